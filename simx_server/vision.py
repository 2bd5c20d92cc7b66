"""Vision sensors: MuJoCo cameras rendered offscreen, in V-REP's image and depth formats.

A vision sensor is a MuJoCo camera. Its resolution is the camera's ``resolution`` attribute
(256x256 when the MJCF leaves it at 1x1; at most limits.MAX_RESOLUTION a side, or the scene is
refused when it loads), its field of view the camera's ``fovy``, and its
near/far clipping planes and image kind come from the ``simx:NAME`` custom text
(``near=0.01 far=10 image=rgb|depth``). A sensor with ``image=depth`` shows its depth as grey
in all three channels (near dark, far bright), as a V-REP depth sensor with a
"depth to image" filter does.

Like V-REP's default vision-sensor renderer (plain OpenGL), sensors draw neither shadows nor
reflections, whatever the scene's lights and materials say; ``shadows=true`` and
``reflections=true`` in the custom text turn them on for one sensor (as V-REP's OpenGL3 render
mode did). On a software renderer shadows are most of the cost of a frame (llvmpipe, 640x480:
about 15 ms of 20 for the UR5 scene's sun).

Frames are rendered on demand and cached until the world changes (one render per
simulation step per sensor, however many clients ask). Rendering runs on a thread of its own,
which owns the GL contexts, from a copy of ``MjData`` taken on the simulation thread: a slow
software renderer delays the image, not the physics nor the other clients. Images leave here
as ``bytes`` in V-REP's layout: rows bottom-up, RGB, 8 bits; depth as float32 in 0..1 (linear
between near and far).
"""

from __future__ import annotations

import copy
import dataclasses
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable

import mujoco
import numpy as np

from simx_client.protocol import ArgumentError
from simx_server.physics import check_resolution
from simx_server.world import VISION_SENSOR, World

DEFAULT_RESOLUTION = (256, 256)
DEFAULT_NEAR, DEFAULT_FAR = 0.01, 10.0


@dataclasses.dataclass
class SensorSpec:
    """Static properties of one vision sensor."""

    camera: int
    width: int
    height: int
    near: float  # m
    far: float  # m
    depth_image: bool
    shadows: bool = False
    reflections: bool = False


def _flag(settings: dict[str, str], key: str, sensor: str) -> bool:
    """A ``true``/``false`` custom-text setting (default false); ValueError names the sensor."""
    value = settings.get(key, "false").lower()
    if value not in ("true", "false"):
        raise ValueError(f"vision sensor {sensor!r}: {key}={value!r} must be true or false")
    return value == "true"


class Deferred:
    """A command result that the render thread completes (the server replies once it is done)."""

    __slots__ = ("future",)

    def __init__(self, future: Future):
        self.future = future


class VisionSensors:
    """The scene's vision sensors.

    Methods are called on the simulation thread; rendering happens on one render thread (a
    single-worker executor, so jobs run in the order they were submitted). Call close() when done.
    """

    def __init__(self, world: World):
        self.world = world
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="simx-render")
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}  # render thread only
        self._cache: dict[tuple[int, str], tuple[int, Future]] = {}
        self._snapshot: tuple[int, mujoco.MjData] | None = None
        self.renders = 0  # number of frames actually rendered (for tests and benchmarks)
        self.reset()

    def reset(self) -> None:
        """(Re)read every sensor's properties from the scene (undoing run-time changes)."""
        world = self.world
        self.specs: dict[int, SensorSpec] = {}
        self._cache.clear()
        m = world.model
        for obj in world.objects.values():
            if obj.type != VISION_SENSOR:
                continue
            w, h = (int(x) for x in m.cam_resolution[obj.mj_id])
            if (w, h) == (1, 1):
                w, h = DEFAULT_RESOLUTION
            check_resolution(w, h, f"vision sensor {obj.name!r}")  # World checked it at load too
            s = obj.settings
            self.specs[obj.handle] = SensorSpec(
                obj.mj_id, w, h, float(s.get("near", DEFAULT_NEAR)), float(s.get("far", DEFAULT_FAR)),
                s.get("image", "rgb") == "depth",
                shadows=_flag(s, "shadows", obj.name), reflections=_flag(s, "reflections", obj.name))
        if self.specs:
            m.vis.global_.offwidth = max(m.vis.global_.offwidth, *(s.width for s in self.specs.values()))
            m.vis.global_.offheight = max(m.vis.global_.offheight, *(s.height for s in self.specs.values()))

    def spec(self, handle: int) -> SensorSpec:
        """The sensor's properties; raises UnknownObjectError/ObjectTypeError for other handles."""
        self.world.get(handle, VISION_SENSOR)
        return self.specs[handle]

    def after(self, job: Callable[[], Any]) -> Future:
        """Run ``job`` on the render thread once every render submitted so far is done."""
        return self._executor.submit(job)

    # ------------------------------------------------------------ render thread
    def _render(self, model: mujoco.MjModel, data: mujoco.MjData, spec: SensorSpec, kind: str) -> np.ndarray:
        """Rendered frame, top-down rows: RGB (h, w, 3) uint8, or depth (h, w) float32 in m."""
        key = (spec.width, spec.height)
        if key not in self._renderers:
            self._renderers[key] = mujoco.Renderer(model, spec.height, spec.width)
        r = self._renderers[key]
        if kind == "depth":
            r.enable_depth_rendering()
        try:
            r.update_scene(data, camera=spec.camera)
            r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = spec.shadows
            r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = spec.reflections
            frame = r.render()
        finally:
            if kind == "depth":
                r.disable_depth_rendering()
        self.renders += 1
        return frame

    # -------------------------------------------------------- simulation thread
    def _frame(self, handle: int, kind: str) -> Future:
        """The frame of the world's current state (a future), rendered once per state."""
        version = self.world.version
        cached = self._cache.get((handle, kind))
        if cached is not None and cached[0] == version:
            return cached[1]
        spec = self.spec(handle)
        if self._snapshot is None or self._snapshot[0] != version:
            self._snapshot = (version, copy.copy(self.world.data))  # the state this version shows
        future = self._executor.submit(self._render, self.world.model, self._snapshot[1], spec, kind)
        self._cache[(handle, kind)] = (version, future)
        return future

    def _depth_job(self, handle: int) -> Callable[[], np.ndarray]:
        spec, raw = self.spec(handle), self._frame(handle, "depth")
        near, far = spec.near, spec.far  # as they are now, even if changed before the render

        def normalised() -> np.ndarray:
            norm = (raw.result() - near) / (far - near)
            return np.clip(norm, 0.0, 1.0, out=norm).astype(np.float32, copy=False)[::-1]

        return normalised

    def _image_job(self, handle: int, grey: bool) -> Callable[[], np.ndarray]:
        if self.spec(handle).depth_image:
            depth = self._depth_job(handle)

            def from_depth() -> np.ndarray:
                g = np.rint(depth() * 255.0).astype(np.uint8)
                return g if grey else np.repeat(g[:, :, None], 3, axis=2)

            return from_depth
        raw = self._frame(handle, "rgb")

        def rgb() -> np.ndarray:
            img = raw.result()[::-1]
            return (img.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8) if grey else img

        return rgb

    def depth(self, handle: int) -> np.ndarray:
        """Depth normalised to 0..1 between near and far, (h, w) float32, rows bottom-up."""
        return self.after(self._depth_job(handle)).result()

    def image(self, handle: int, grey: bool) -> np.ndarray:
        """The sensor's image, rows bottom-up: (h, w, 3) uint8 RGB, or (h, w) uint8 when ``grey``.

        ``grey`` is V-REP's options bit 0: one byte per pixel, (R + G + B) / 3.
        """
        return self.after(self._image_job(handle, grey)).result()

    def _payload(self, handle: int, kind: str, job: Callable[[], Callable[[], np.ndarray]]) -> Deferred:
        """``[[resX, resY], bytes]`` of a frame, made once per state and shared."""
        cached = self._cache.get((handle, kind))
        if cached is None or cached[0] != self.world.version:
            spec, frame = self.spec(handle), job()
            cached = (self.world.version, self.after(
                lambda: [[spec.width, spec.height], np.ascontiguousarray(frame()).tobytes()]))
            self._cache[(handle, kind)] = cached
        return Deferred(cached[1])

    def image_deferred(self, handle: int, options: int) -> Deferred:
        """``simxGetVisionSensorImage``: a Deferred ``[[resX, resY], bytes]`` (options bit 0: grey)."""
        if not isinstance(options, int):
            raise ArgumentError(f"options must be an int, got {type(options).__name__}")
        grey = bool(options & 1)
        return self._payload(handle, f"image{int(grey)}", lambda: self._image_job(handle, grey))

    def depth_deferred(self, handle: int) -> Deferred:
        """``simxGetVisionSensorDepthBuffer``: a Deferred ``[[resX, resY], float32 bytes]``."""
        return self._payload(handle, "depth buffer", lambda: self._depth_job(handle))

    def image_bytes(self, handle: int, options: int) -> tuple[list[int], bytes]:
        """:meth:`image_deferred`, waited for: ``([resX, resY], bytes)``."""
        return tuple(self.image_deferred(handle, options).future.result())

    def depth_bytes(self, handle: int) -> tuple[list[int], bytes]:
        """:meth:`depth_deferred`, waited for: ``([resX, resY], float32 bytes)``."""
        return tuple(self.depth_deferred(handle).future.result())

    def close(self) -> None:
        """Finish pending jobs, free every GL context (on its thread) and stop; idempotent."""
        if self._executor is None:
            return
        self._executor.submit(self._close_renderers)
        self._executor.shutdown(wait=True)
        self._executor = None
        self._cache.clear()

    def _close_renderers(self) -> None:
        for r in self._renderers.values():
            try:
                r.close()
            except Exception:  # a context already torn down by the driver
                pass
        self._renderers.clear()
