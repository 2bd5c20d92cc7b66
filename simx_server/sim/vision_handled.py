"""Vision sensors handled as CoppeliaSim 4.2+ handles them (a mixin of
:class:`simx_server.sim.vision.VisionSensors`): rendered, measured (V-REP's default packet), then
processed by the ``sysCall_vision`` callbacks of the scripts attached to the sensor
(:mod:`simx_server.scripts.vision_callbacks`), which work with ``simVision`` on the sensor's work
image and may write its image and depth buffer back, and return a trigger and packets
(``CVisionSensor::handleSensor`` -> ``detectEntity`` -> ``_computeDefaultReturnValuesAndApplyFilters``
in coppeliaSimLib).

What a handling leaves is a :class:`Handled` record: the sensor's image, depth buffer, trigger and
packets, which every read returns (``simxGetVisionSensorImage``, ``sim.getVisionSensorImg``,
``sim.readVisionSensor`` ..., :mod:`simx_server.sim.vision_chain`) until the sensor is handled
again (each simulation pass, a ``sim.handleVisionSensor``, a passive sensor's new image), as
CoppeliaSim's sensor buffers keep the last handling's result. Sensors without a vision callback
have no record and stay rendered when read (nothing is done for them each pass). A record that
a ``simVision.workImgToSensorImg`` made outside any callback shows that image while the world's
state stays the same (the sensor is rendered anew after a change). Records go when the
simulation stops (:meth:`VisionSensors.reset`).

A sensor's ``filters=`` chain (:mod:`simx_server.sim.vision_filters`; CoppeliaSim turns a 3.x
chain into a customization script's ``sysCall_vision``) runs after the scripts' callbacks, on
what they wrote. Then, if triggered, the scripts' ``sysCall_trigger`` callbacks.

A sensor with explicit handling (``sim.setExplicitHandling``, a scene's ``explicit=true``) is
handled only by ``sim.handleVisionSensor`` (``simHandleVisionSensor_internal``: the main script's
``sim_handle_all_except_explicit`` leaves it out), and its reads show that handling until the
next, however the world moved since: CoppeliaSim's ``CVisionSensor::handleSensor`` renders into
the sensor's ``_rgbBuffer`` and ``_depthBuffer``, which ``simGetVisionSensorImg_internal``,
``simGetVisionSensorDepth_internal`` and ``simReadVisionSensor_internal`` only read. Here the
handling is a :class:`Pin`, the world's state it saw: frames are still drawn when first read,
and from that state once the world moved on (kept, from the render thread's copies). Before its
first handling the sensor shows its cleared buffers (``CVisionSensor::_clearBuffers``: its
background colour, depth 1), and a new resolution clears them again (``setResolution`` ->
``_reserveBuffers``).
"""

from __future__ import annotations

import contextlib
import dataclasses
from typing import TYPE_CHECKING, Any, Callable, Iterator, Protocol

import numpy as np

from simx_server.sim import vision_filters as VF
from simx_server.sim.render_thread import wait_for

if TYPE_CHECKING:
    from concurrent.futures import Future

    import mujoco

    from simx_server.sim.render_thread import RenderThread
    from simx_server.sim.sensor_spec import SensorSpec
    from simx_server.sim.world import World


@dataclasses.dataclass
class Handled:
    """A sensor's buffers after a handling.

    Attributes:
        rgb: (h, w, 3) uint8, rows bottom-up (replaced, never changed in place: render
            threads may be reading the previous one).
        depth: (h, w) float32 in 0..1 between the clipping planes, rows bottom-up.
        packets: V-REP's default packet, then each packet the callbacks and the chain returned.
        trigger: whether the sensor triggered.
        version: the world's state it shows; None: until the sensor is handled again.
    """

    rgb: np.ndarray
    depth: np.ndarray
    packets: list[list[float]]
    trigger: bool = False
    version: int | None = None


@dataclasses.dataclass
class Pin:
    """An explicitly handled sensor's last handling: the state its reads show.

    Attributes:
        version: the world's version handled (``World.version``).
        model: the model of that state.
        data: a copy of that state, held on ``thread`` (:meth:`RenderThread.hold`).
        spec: the sensor's properties then.
        thread: the render thread whose copy ``data`` is.
    """

    version: int
    model: mujoco.MjModel
    data: mujoco.MjData
    spec: SensorSpec
    thread: RenderThread


class VisionHooks(Protocol):
    """The scripts' callbacks of one sensor's handling (:mod:`simx_server.scripts.vision_callbacks`)."""

    def vision(self, handle: int, record: Handled) -> None:
        """Run the ``sysCall_vision`` callbacks: they may write ``record``'s image and depth
        (through ``simVision``), and set its trigger and add packets.

        Args:
            handle: the vision sensor's handle.
            record: what the handling made so far, written by the callbacks.
        """

    def trigger(self, handle: int, record: Handled) -> None:
        """Run the ``sysCall_trigger`` callbacks of a triggered sensor (they may clear its trigger).

        Args:
            handle: the vision sensor's handle.
            record: its handling's result, whose trigger the callbacks may clear.
        """


class VisionHandling:
    """The records of handled sensors (a VisionSensors mixin; :meth:`_init_handling` in its
    constructor)."""

    def _init_handling(self) -> None:
        self.handled: dict[int, Handled] = {}
        #: Sensors with explicit handling (``sim.setExplicitHandling``): not handled each pass.
        self.explicit: set[int] = set()
        self._busy: dict[int, Handled] = {}  # sensors whose callbacks run now, and their record
        self.pins: dict[int, Pin] = {}  # explicitly handled sensors' last handling

    def _reset_handling(self) -> None:
        self.handled.clear()
        self.explicit.clear()
        self._busy.clear()
        for handle in list(self.pins):
            self.unpin(handle)

    def set_explicit(self, handle: int, explicit: bool) -> None:
        """``sim.setExplicitHandling`` of a vision sensor: with explicit handling it keeps what
        it shows now (the last pass's handling) until ``sim.handleVisionSensor``; without, it
        shows each pass's state again.

        Args:
            handle: a vision sensor's handle.
            explicit: bit 0 of the flags.
        """
        if explicit and handle not in self.explicit:
            self.explicit.add(handle)
            self.pin(handle)
        elif not explicit:
            self.explicit.discard(handle)
            self.unpin(handle)

    def pin(self, handle: int) -> None:
        """Handle an explicitly handled sensor's buffers (``sim.handleVisionSensor``): its reads
        show the world's state now until it is handled again (see the module's text).

        Args:
            handle: a vision sensor's handle.
        """
        world, thread, spec = self.world, self._thread, self.spec(handle)
        state = thread.state(world.version, world.model, world.data)  # the copy its frames read
        self.unpin(handle)
        thread.hold(state)
        self.pins[handle] = Pin(world.version, world.model, state, spec, thread)

    def unpin(self, handle: int) -> None:
        """Forget the sensor's last explicit handling (its copy of the state let go).

        Args:
            handle: a vision sensor's handle.
        """
        pin = self.pins.pop(handle, None)
        if pin is not None:
            pin.thread.hold(pin.data, -1)

    @contextlib.contextmanager
    def current(self, handle: int) -> Iterator[None]:
        """Reads made inside show the world's state now, not the sensor's last explicit handling,
        which stays for the reads after (``sim.checkVisionSensor``, ``checkVisionSensorEx``:
        ``CVisionSensor::checkSensor`` renders, then puts the sensor's buffers back).

        Args:
            handle: a vision sensor's handle.

        Yields:
            None, while reads show the current state.
        """
        pin, explicit = self.pins.pop(handle, None), handle in self.explicit
        self.explicit.discard(handle)
        try:
            yield
        finally:
            if pin is not None:
                self.pins[handle] = pin
            if explicit:
                self.explicit.add(handle)

    def shown(self, handle: int) -> int:
        """The world's version the sensor's reads show: its explicit handling's, else the current.

        Args:
            handle: a vision sensor's handle.

        Returns:
            A ``World.version``.
        """
        pin = self.pins.get(handle)
        return self.world.version if pin is None else pin.version

    def cleared(self, handle: int) -> bool:
        """Whether the sensor shows its cleared buffers: explicit handling, not handled yet.

        Args:
            handle: a vision sensor's handle.

        Returns:
            True when cleared.
        """
        return handle in self.explicit and handle not in self.pins

    def record(self, handle: int) -> Handled | None:
        """The record reads of ``handle`` return now, or None (the sensor is rendered).

        Args:
            handle: a vision sensor's handle.

        Returns:
            Its :class:`Handled`, or None.
        """
        busy = self._busy.get(handle)
        if busy is not None:
            return busy
        rec = self.handled.get(handle)
        if rec is None or (rec.version is not None and rec.version != self.world.version):
            return None
        return rec

    def work_state(self, handle: int, create: bool = False) -> VF.FilterState | None:
        """The sensor's work image and buffers (``simVision``'s, shared with its ``filters=``
        chain), made when ``create``; None when it has none.

        Args:
            handle: a vision sensor's handle.
            create: make an empty one if it has none.

        Returns:
            Its :class:`~simx_server.sim.vision_filters.FilterState`, or None.
        """
        if create:
            return self._filter_states.setdefault(handle, VF.FilterState())
        return self._filter_states.get(handle)

    def drop_work_state(self, handle: int) -> None:
        """Forget the sensor's work image and buffers (``workImgToSensorImg`` with ``removeBuffer``).

        Args:
            handle: a vision sensor's handle.
        """
        self._filter_states.pop(handle, None)

    def in_callback(self, handle: int) -> Handled | None:
        """The record being made while ``handle``'s vision callbacks run.

        Args:
            handle: a vision sensor's handle.

        Returns:
            That :class:`Handled`, or None when its callbacks are not running.
        """
        return self._busy.get(handle)

    def handle(self, handle: int, hooks: VisionHooks | None = None, image: np.ndarray | None = None) -> Handled:
        """Handle the sensor now (simulation thread; it waits for the frames): its image (the
        rendering, or ``image``), depth buffer and default packet, then ``hooks``' vision
        callbacks, the ``filters=`` chain, and the trigger callbacks if it triggered.

        A sensor whose callbacks are running (a callback that handles its own sensor) is not
        handled again: its record so far is returned (CoppeliaSim's ``_inApplyFilterRoutine``).

        Args:
            handle: a vision sensor's handle.
            hooks: the scripts' callbacks (None: none; the record then lasts while the world's
                state does).
            image: the image to handle instead of a rendering, (h, w, 3) uint8, rows bottom-up
                (a passive sensor's, or one a script wrote).

        Returns:
            The new record (kept: reads return it).

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a vision sensor.
        """
        busy = self._busy.get(handle)
        if busy is not None:
            return busy
        spec = self.spec(handle)
        rec = self._fresh(handle, image)
        self._busy[handle] = rec
        try:
            if hooks is not None:
                hooks.vision(handle, rec)
            if spec.filters:
                self._chain(handle, spec, rec)
            if rec.trigger and hooks is not None:
                hooks.trigger(handle, rec)
        finally:
            del self._busy[handle]
        rec.version = None if hooks is not None else self.world.version
        self.handled[handle] = rec
        self._forget(handle)
        return rec

    def _fresh(self, handle: int, image: np.ndarray | None) -> Handled:
        """A record of the sensor's image (rendered now, or ``image``), depth and default packet."""
        spec = self.spec(handle)
        raw = (lambda: image) if image is not None else self.raw_image_job(handle)
        depth = self._raw_depth_job(handle)

        def job() -> tuple[np.ndarray, np.ndarray, list[float]]:
            img = np.ascontiguousarray(raw())
            d = depth()
            return img, d, self.default_packet_of(spec, img, d)

        img, d, packet = wait_for(self.after(job), "handleVisionSensor")
        return Handled(img, d, [packet])

    def _chain(self, handle: int, spec: SensorSpec, rec: Handled) -> None:
        """The sensor's ``filters=`` chain on the record (after the callbacks)."""
        state = self._filter_states.setdefault(handle, VF.FilterState())
        res = VF.apply_chain(spec.filters, rec.rgb, rec.depth, state)
        if res.image is not None:
            rec.rgb = res.image
        if res.depth is not None:
            rec.depth = res.depth
        rec.trigger = rec.trigger or res.trigger
        rec.packets += [list(p) for p in res.packets]

    def write(self, handle: int, rgb: np.ndarray | None = None, depth: np.ndarray | None = None,
              hooks: VisionHooks | None = None) -> None:
        """A script writes the sensor's image or depth buffer (``simVision.workImgToSensorImg`` /
        ``workImgToSensorDepthMap``) outside the sensor's callbacks: as CoppeliaSim's
        ``simSetVisionSensorImg``, the image is handled (default packet, ``hooks``' callbacks,
        chain), and without callbacks reads return it while the world's state stays; a depth
        buffer replaces the current record's.

        Args:
            handle: a vision sensor's handle.
            rgb: (h, w, 3) uint8, rows bottom-up, or None.
            depth: (h, w) float32 in 0..1, rows bottom-up, or None.
            hooks: the sensor's scripts' callbacks, or None.
        """
        if rgb is not None:
            self.handle(handle, hooks, rgb)
        if depth is not None:
            rec = self.record(handle)
            if rec is None:
                rec = self._fresh(handle, None)
                rec.version = self.world.version
                self.handled[handle] = rec
            rec.depth = depth
            self._forget(handle)

    def _forget(self, handle: int) -> None:
        """Drop the cached payloads and chain results of ``handle`` (its record replaced them);
        its rendered frames stay."""
        for key in [k for k in self._cache if k[0] == handle and k[1] not in ("rgb", "depth", "handles")]:
            del self._cache[key]

    if TYPE_CHECKING:  # provided by VisionSensors
        world: World
        _cache: dict
        _filter_states: dict
        _thread: RenderThread

        def spec(self, handle: int) -> SensorSpec: ...

        def after(self, job: Callable[[], Any]) -> Future: ...

        def raw_image_job(self, handle: int) -> Callable[[], np.ndarray]: ...

        def _raw_depth_job(self, handle: int) -> Callable[[], np.ndarray]: ...

        def default_packet_of(self, spec: SensorSpec, img: np.ndarray, depth: np.ndarray) -> list[float]: ...
