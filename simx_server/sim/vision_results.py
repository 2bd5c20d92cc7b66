"""What the vision sensors answer commands with (a mixin of
:class:`simx_server.sim.vision.VisionSensors`): frames as :class:`Deferred` results that a render
thread completes, and V-REP's ``[[resX, resY], bytes]`` payloads of images and depth buffers,
made once per world state and shared by every client that asks.
"""

from __future__ import annotations

from concurrent.futures import Future
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from simx_wire.protocol import ArgumentError
from simx_server.sim.render_thread import RenderThread, wait_for

if TYPE_CHECKING:
    from simx_server.sim.sensor_spec import SensorSpec
    from simx_server.sim.world import World


class Deferred:
    """A command result that another thread completes (the server replies once it is done);
    ``thread`` is the render thread that does (None: unknown, or another kind of thread), and
    ``seconds`` the time its work took, once done (:mod:`simx_server.api.long_calls`)."""

    __slots__ = ("future", "thread", "seconds")

    def __init__(self, future: Future, thread: RenderThread | None = None):
        self.future, self.thread = future, thread
        self.seconds = 0.0

class VisionResults:
    """Deferred results, images and depth buffers of the vision sensors (a VisionSensors mixin)."""

    def rendered(self, job: Callable[[], Any]) -> Deferred:
        """``job()`` on the request render thread once every render submitted to it so far is
        done (the frames of :meth:`image_job` and :meth:`depth_job`), as a Deferred: the
        simulation thread goes on, the caller replies when its future is done.

        Args:
            job: a callable of no argument.

        Returns:
            The Deferred of ``job()``.
        """
        return Deferred(self.after(job), self._thread)

    def rendered_with(self, handle: int, job: Callable[[], Any]) -> Deferred:
        """As :meth:`rendered`, on the render thread that draws ``handle``'s frames for the
        command being executed (the stream thread for a large streamed sensor, see
        :meth:`_target`), so that a job waiting for a large frame holds no other thread.

        Args:
            handle: a vision sensor's handle.
            job: a callable of no argument.

        Returns:
            The Deferred of ``job()``.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a vision sensor.
        """
        thread = self._target(self.spec(handle))
        return Deferred(thread.executor.submit(job), thread)

    def depth(self, handle: int) -> np.ndarray:
        """Depth normalised to 0..1 between near and far, (h, w) float32, rows bottom-up.

        Args:
            handle: a vision sensor's handle.

        Returns:
            Array (h, w) float32.
        """
        return wait_for(self.after(self.depth_job(handle)), "vision sensor depth")

    def image(self, handle: int, grey: bool) -> np.ndarray:
        """The sensor's image, rows bottom-up: (h, w, 3) uint8 RGB, or (h, w) uint8 when ``grey``.

        ``grey`` is V-REP's options bit 0: one byte per pixel, (R + G + B) / 3.

        Args:
            handle: a vision sensor's handle.
            grey: one byte per pixel.

        Returns:
            Array (h, w, 3) or (h, w) uint8.
        """
        return wait_for(self.after(self.image_job(handle, grey)), "vision sensor image")

    def _payload(self, handle: int, kind: str, job: Callable[[], Callable[[], np.ndarray]]) -> Deferred:
        """``[[resX, resY], bytes]`` of a frame, made once per state and shared (see :meth:`_cached`)."""
        cached = self._cached((handle, kind))
        if cached is None:
            spec, frame = self.spec(handle), job()
            thread = self._target(spec)
            cached = thread.executor.submit(
                lambda: [[spec.width, spec.height], np.asarray(frame()).tobytes()]), thread  # one copy, flipped or not
            self._cache[(handle, kind)] = (self.shown(handle), *cached)
        return Deferred(*cached)

    def image_deferred(self, handle: int, options: int) -> Deferred:
        """``simxGetVisionSensorImage``: a Deferred ``[[resX, resY], bytes]`` (options bit 0: grey).

        Args:
            handle: a vision sensor's handle.
            options: bit 0: grey.

        Raises:
            ArgumentError: ``options`` is not an int.

        Returns:
            The Deferred payload.
        """
        if not isinstance(options, int):
            raise ArgumentError(f"options must be an int, got {type(options).__name__}")
        grey = bool(options & 1)
        return self._payload(handle, f"image{int(grey)}", lambda: self.image_job(handle, grey))

    def depth_deferred(self, handle: int) -> Deferred:
        """``simxGetVisionSensorDepthBuffer``: a Deferred ``[[resX, resY], float32 bytes]``.

        Args:
            handle: a vision sensor's handle.

        Returns:
            The Deferred payload.
        """
        return self._payload(handle, "depth buffer", lambda: self.depth_job(handle))

    def image_bytes(self, handle: int, options: int) -> tuple[list[int], bytes]:
        """:meth:`image_deferred`, waited for: ``([resX, resY], bytes)``.

        Args:
            handle: a vision sensor's handle.
            options: bit 0: grey.

        Returns:
            ``([resX, resY], bytes)``: pixels, and w*h*3 (grey: w*h) bytes, rows bottom-up.

        Raises:
            ArgumentError: ``options`` is not an int.
            UnknownObjectError: no such object.
            ObjectTypeError: not a vision sensor.
        """
        return tuple(wait_for(self.image_deferred(handle, options).future, "vision sensor image"))

    def depth_bytes(self, handle: int) -> tuple[list[int], bytes]:
        """:meth:`depth_deferred`, waited for: ``([resX, resY], float32 bytes)``.

        Args:
            handle: a vision sensor's handle.

        Returns:
            ``([resX, resY], bytes)``: pixels, and w*h float32 (0..1), rows bottom-up.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a vision sensor.
        """
        return tuple(wait_for(self.depth_deferred(handle).future, "vision sensor depth"))

    if TYPE_CHECKING:  # provided by VisionSensors
        world: World
        _thread: RenderThread
        _cache: dict

        def after(self, job: Callable[[], Any]) -> Future: ...

        def spec(self, handle: int) -> SensorSpec: ...

        def _target(self, spec: SensorSpec | None = None) -> RenderThread: ...

        def _cached(self, key: tuple[int, str]) -> tuple[Future, RenderThread] | None: ...

        def image_job(self, handle: int, grey: bool) -> Callable[[], np.ndarray]: ...

        def depth_job(self, handle: int) -> Callable[[], np.ndarray]: ...

        def shown(self, handle: int) -> int: ...
