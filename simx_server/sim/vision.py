"""Vision sensors: MuJoCo cameras rendered offscreen, in V-REP's image and depth formats.

A vision sensor is a MuJoCo camera. Its resolution is the camera's ``resolution`` attribute
(256x256 when the MJCF leaves it at 1x1; at most limits.MAX_RESOLUTION a side, or the scene is
refused when it loads), its field of view the camera's ``fovy``, and its
near/far clipping planes and image kind come from the ``simx:NAME`` custom text
(``near=0.01 far=10 image=rgb|depth``). A sensor with ``image=depth`` shows its depth as grey
in all three channels (near dark, far bright), as a V-REP depth sensor with a
"depth to image" filter does. ``render_mode=handles`` (or ``sim_visionintparam_render_mode`` set
to 2) makes the image V-REP's colour-coded handles (simx_server.sim.handle_render). A sensor
with a ``background=`` colour (every sensor of a ``.ttt``) is drawn as V-REP drew it: no sky
box, that colour where no object is, nothing outside its near and far planes; its filter chain
and options ("ignore RGB", ...) are :mod:`simx_server.sim.vision_chain`, and a sensor whose
scripts have a vision callback (``sysCall_vision``) is handled each simulation pass as
CoppeliaSim handles it (:mod:`simx_server.sim.vision_handled`).

Like V-REP's default vision-sensor renderer (plain OpenGL), sensors draw neither shadows nor
reflections, whatever the scene's lights and materials say; ``shadows=true`` and
``reflections=true`` in the custom text turn them on for one sensor (as V-REP's OpenGL3 render
mode did). On a software renderer shadows are most of the cost of a frame (llvmpipe, 640x480:
about 15 ms of 20 for the UR5 scene's sun).

A V-REP vision sensor sees the scene's shapes only: sensors render with MuJoCo's
visualisation extras off (rangefinder rays, contact points and forces, joints, actuators,
tendons, lights, cameras, frames, labels, centres of mass, inertia boxes, constraints,
perturbation markers, bounding volumes) and without sites (simx's dummies, which V-REP's sensors
do not see either). Geoms of groups 0-2 (MuJoCo's default visible groups), textures, skins,
flexes, the skybox and haze stay as the scene's author set them.

Frames are rendered on demand and cached until the world changes (one render per
simulation step per sensor, however many clients ask); a sensor with explicit handling shows
the state of its last handling until the next (:mod:`simx_server.sim.vision_handled`).
Rendering runs on threads of their own, which own the GL contexts, from a copy of ``MjData``
taken on the simulation thread: a slow software renderer delays the image, not the physics nor
the other clients. Requests render on
the *request* render thread; large streamed images (``limits.STREAM_THREAD_PIXELS``, set by the
stream publisher through :attr:`VisionSensors.for_streams`) on a *stream* render thread made on
the first of them, once its renderers are warm: a client's streams of huge images (a 4096x4096
frame takes 1.5 s on llvmpipe) never queue ahead of another client's image request, which waits
for its own frame only. Images leave here as ``bytes`` in V-REP's layout: rows bottom-up, RGB,
8 bits; depth as float32 in 0..1 (linear between near and far). A sensor's static properties
(resolution, clipping, image kind) are :mod:`simx_server.sim.sensor_spec`.

V-REP rendered every sensor every step, so a program's first streamed image came at once. Here
the renderers (MuJoCo's ``MjrContext`` in the render thread's one GL context: about 1 s for the
first on a software renderer, 0.2 s for each further one)
and one warm-up frame per sensor are made on the request render thread as soon as a scene loads
or its model changes (an edit), not on the first request: the first streamed image is in the
client's inbox within a step or two of the streaming call (streams use that thread until the
stream thread's own renderers are warm). The render threads and their contexts live as long as
the server; a new scene or an edit hands them over (``previous=``) and they are rebuilt for the
new model in submission order. The simulation thread waits for them
(:meth:`VisionSensors.wait_ready`) only while the simulation is stopped: before the server
starts it, and on a scene load or an edit made while stopped. An edit while it runs does not
wait; images asked for meanwhile come once the renderers are rebuilt (0.1-0.45 s on llvmpipe).
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import threading
import time
from concurrent.futures import Future
from typing import Any, Callable

import mujoco
import numpy as np

from simx_server.base import limits as L
from simx_server.sim import handle_render, vision_look
from simx_server.sim.physics import check_resolution
from simx_server.sim.depth_frames import flat_planes
from simx_server.sim.render_thread import RenderThread, render_bands, wait_for
from simx_server.sim.sensor_spec import SensorSpec, sensor_spec
from simx_server.sim.vision_chain import VisionChain, clip_planes
from simx_server.sim.vision_handled import VisionHandling
from simx_server.sim.vision_results import Deferred, VisionResults
from simx_server.sim.world import VISION_SENSOR, World

log = logging.getLogger("simx.vision")

class VisionSensors(VisionHandling, VisionChain, VisionResults):
    """The scene's vision sensors.

    Methods are called on the simulation thread; rendering happens on render threads (each a
    single-worker executor, so its jobs run in the order they were submitted): the request
    render thread, and the stream render thread while :attr:`for_streams` is set. The renderers
    for the scene's sensors are made at once on the request thread (see :meth:`wait_ready`), on
    the stream thread when it is first needed. ``previous`` is the VisionSensors of the scene
    this one replaces (a load, an edit): its render threads and contexts are taken over, and
    ``previous`` must not be used afterwards (its ``at_load`` is kept). ``at_load`` False: no renderer is
    made before a frame is asked for (server ``--renderers on-demand``). Call close() when done.

    Attributes:
        for_streams: set by the stream publisher while it executes streamed commands: their
            frames of ``limits.STREAM_THREAD_PIXELS`` or more render on the stream render thread
            (once it is warm; before, on the request thread, so that the first streamed image
            is not late).
    """

    def __init__(self, world: World, previous: VisionSensors | None = None, at_load: bool = True):
        self.world = world
        self.at_load = previous.at_load if previous is not None else at_load
        self._streaming: RenderThread | None = None  # the stream render thread, made on demand
        self._streaming_ready: Future | None = None  # its renderers are warm
        carried = {}  # the frames of explicitly handled sensors' handlings (see _keep)
        if previous is not None and previous._owner:
            self._thread, previous._owner = previous._thread, False  # its pending jobs still run
            self._streaming = previous._streaming
            carried = {k: v for k, v in previous._cache.items() if k[0] in previous.pins}
            previous._cache.clear()
        else:
            self._thread = RenderThread()
        self._owner = True  # closes the render threads (unless it hands them over)
        self.for_streams = False
        self._cache: dict[tuple[int, str], tuple[int, Future, RenderThread]] = {}
        self._colours: np.ndarray | None = None  # geom id -> packed handle colour (handle_render)
        self._filter_states: dict = {}  # handle -> its work image and buffers (vision_filters.FilterState)
        self._init_handling()  # records of sensors handled with callbacks (vision_handled)
        self.renders = 0  # number of frames actually rendered (for tests and benchmarks)
        self.reset()
        edit = previous is not None and previous.world is world
        if edit:  # run-time settings stay
            self._keep(previous, carried)
        self._ready = self._prepare(self._thread, warm=not edit)
        if self._streaming is not None:
            self._streaming_ready = self._prepare(self._streaming)

    def reset(self) -> None:
        """(Re)read every sensor's properties from the scene (undoing run-time changes; the
        disabled light components, not a scene value, stay: ``CViewableBase``)."""
        world = self.world
        disabled = {h: s.disabled_light_components for h, s in getattr(self, "specs", {}).items()}
        self.specs: dict[int, SensorSpec] = {}
        self._cache.clear()
        self._colours = None
        self._filter_states.clear()
        self._reset_handling()
        m = world.model
        vision_look.scene_look(m)  # a look it cannot give refuses the scene (ValueError)
        for obj in world.objects.values():
            if obj.type == VISION_SENSOR:
                self.specs[obj.handle] = sensor_spec(m, obj)
                self.specs[obj.handle].disabled_light_components = disabled.get(obj.handle, 0)
                if obj.settings.get("explicit") == "true":  # saved with explicit handling (vision_handled)
                    self.explicit.add(obj.handle)
        if self.specs:
            m.vis.global_.offwidth = max(m.vis.global_.offwidth, *(s.width for s in self.specs.values()))
            m.vis.global_.offheight = max(m.vis.global_.offheight, *(s.height for s in self.specs.values()))

    def _keep(self, previous: VisionSensors, frames: dict) -> None:
        """Keep what commands set on the sensors that an edit left in the scene (render mode,
        resolution, clipping, explicit handling and its last handling, with ``frames``, its
        frames drawn...), as CoppeliaSim keeps an object's properties when other objects are
        added or removed; the camera's index is the new model's. An
        edit used to reread them from the scene file: RLBench's mask cameras, made
        colour-coded, turned back to RGB at the next object created or renamed."""
        for handle, spec in previous.specs.items():
            now = self.specs.get(handle)
            if now is not None:
                self.specs[handle] = dataclasses.replace(spec, camera=now.camera)
        self.explicit |= {h for h in previous.explicit if h in self.specs}
        self.pins.update((h, pin) for h, pin in previous.pins.items() if h in self.specs)
        self._cache.update((k, v) for k, v in frames.items() if k[0] in self.pins)
        if self.specs:
            g = self.world.model.vis.global_
            g.offwidth = max(g.offwidth, *(s.width for s in self.specs.values()))
            g.offheight = max(g.offheight, *(s.height for s in self.specs.values()))

    def set_resolution(self, handle: int, width: int | None = None, height: int | None = None) -> None:
        """``sim_visionintparam_resolution_x``/``_y`` (1002/1003) set at run time, as V-REP
        allowed: the sensor renders at the new size from the next image on (a renderer per
        size, at most limits.MAX_RENDERERS kept). The field of view keeps V-REP's rule (the
        perspective angle spans the larger side). Undone when the simulation stops, like the
        other run-time sensor changes. Raises ArgumentError outside 1..MAX_RESOLUTION.

        Args:
            handle: a vision sensor's handle.
            width: pixels, or None to keep it.
            height: pixels, or None to keep it.
        """
        spec = self.spec(handle)
        w = spec.width if width is None else int(width)
        h = spec.height if height is None else int(height)
        check_resolution(w, h, f"vision sensor {self.world.get(handle).name!r}")
        if (w, h) == (spec.width, spec.height):
            return
        # A new spec object: jobs already queued keep the size they were asked for.
        self.specs[handle] = dataclasses.replace(spec, width=w, height=h)
        g = self.world.model.vis.global_
        g.offwidth, g.offheight = max(g.offwidth, w), max(g.offheight, h)
        self.world.version += 1  # cached frames are of the old size
        if handle in self.explicit:  # buffers made anew, cleared (CVisionSensor::setResolution)
            self.unpin(handle)
        self._warm(w, h)

    def _warm(self, width: int, height: int) -> None:
        """Make the request thread's renderer of a new size now (its ``MjrContext``: 0.2 s on
        llvmpipe, a second on a loaded machine), while the client goes
        on with its set-up, rather than in its first image call (which would make that call, and a
        synchronous step waiting for it, seconds slower than the next ones)."""
        thread, model = self._thread, self.world.model

        def warm() -> None:
            if thread.newest is model:  # else a newer scene is queued: it prepares its own
                try:
                    thread.renderer(model, width, height)
                except Exception as exc:  # the first image of that size says it again
                    log.warning("vision sensors: cannot make a %dx%d renderer: %s", width, height, exc)

        thread.executor.submit(warm)

    def spec(self, handle: int) -> SensorSpec:
        """The sensor's properties; raises UnknownObjectError/ObjectTypeError for other handles.

        Args:
            handle: a vision sensor's handle.

        Returns:
            Its :class:`~simx_server.sim.sensor_spec.SensorSpec`.
        """
        self.world.get(handle, VISION_SENSOR)
        return self.specs[handle]

    def after(self, job: Callable[[], Any]) -> Future:
        """Run ``job`` on the request render thread once every render submitted to it so far
        is done.

        Args:
            job: a callable of no argument.

        Returns:
            The future of ``job()``.
        """
        return self._thread.executor.submit(job)

    def after_all(self, renders: list[Deferred], job: Callable[[], Any]) -> Future:
        """A future of ``job()``, run once every render of ``renders`` is done, on the stream
        render thread if one of them is drawn there, else on the request thread; the wait holds
        no thread (frames may come from either thread: the cache shares them).

        Args:
            renders: the Deferred renders to wait for.
            job: a callable of no argument.

        Returns:
            The future of ``job()``.
        """
        streaming = self._streaming is not None and any(d.thread is self._streaming for d in renders)
        executor, result = (self._streaming if streaming else self._thread).executor, Future()
        futures = [d.future for d in renders]
        left, lock = [len(futures)], threading.Lock()

        def run() -> None:
            nonlocal job
            try:
                result.set_result(job())
            except BaseException as exc:  # handed to whoever waits for the result
                result.set_exception(exc)
            finally:
                # A future keeps its callbacks: one_done -> submit -> run -> job -> (the job's
                # frames) -> one_done was a cycle that kept every frame, 50-117 MB each at
                # 4096x4096, until the cyclic collector ran (3 GB in 15 s).
                job = None

        def submit() -> None:
            try:
                executor.submit(run)
            except RuntimeError:  # shut down meanwhile: run here
                run()

        def one_done(_f: Future) -> None:
            with lock:
                left[0] -= 1
                last = left[0] == 0
            if last:
                submit()

        if not futures:
            submit()
        for f in futures:
            f.add_done_callback(one_done)
        return result

    def _target(self, spec: SensorSpec | None = None) -> RenderThread:
        """The render thread of a frame of ``spec`` for the command being executed (simulation
        thread): the stream thread for streamed frames of at least ``limits.STREAM_THREAD_PIXELS``
        (once its renderers are warm), else the request thread."""
        if not self.for_streams or spec is None or spec.width * spec.height < L.STREAM_THREAD_PIXELS:
            return self._thread
        if self._streaming is None:  # the first large streamed image: warm a thread for streams
            self._streaming = RenderThread("simx-render-streams", L.STREAM_BAND_PIXELS)
            self._streaming_ready = self._prepare(self._streaming)
        return self._streaming if self._streaming_ready.done() else self._thread

    # ------------------------------------------------------------ render threads
    @staticmethod
    def _draw(thread: RenderThread, model: mujoco.MjModel, data: mujoco.MjData, spec: SensorSpec,
              kind: str) -> np.ndarray:
        """One frame on ``thread`` (the calling render thread), top-down rows: RGB (h, w, 3)
        uint8, depth (h, w) float32 in m, or ("handles") MuJoCo's segmentation (h, w, 2) int32
        (object id, type)."""
        r = thread.renderer(model, spec.width, thread.band_rows(spec.width, spec.height))
        if kind == "depth":
            r.enable_depth_rendering()
        elif kind == "handles":
            r.enable_segmentation_rendering()
        try:
            r.update_scene(data, camera=spec.camera, scene_option=thread.option)
            r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = spec.shadows
            r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = spec.reflections
            # V-REP clears a sensor's image to its background colour: no sky box behind the scene
            r.scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = spec.background is None
            if spec.background is not None and kind != "depth":
                clip_planes(r.scene, spec.near, spec.far)  # and nothing outside its planes
            if kind == "rgb":  # (after the planes: it moves an orthographic camera back, planes too)
                vision_look.apply(r.scene, model, spec.disabled_light_components)  # V-REP's lighting
            elif kind == "depth":
                flat_planes(r.scene, model, data)  # unlit: a plane needs no grid (most of the frame's time)
            return render_bands(r, spec.height)
        finally:
            if kind == "depth":
                r.disable_depth_rendering()
            elif kind == "handles":
                r.disable_segmentation_rendering()

    def _render(self, thread: RenderThread, model: mujoco.MjModel, data: mujoco.MjData, spec: SensorSpec,
                kind: str) -> np.ndarray:
        """Rendered frame of a request or stream (counted in ``renders``; on the stream thread,
        its time in the thread's share, see :meth:`streams_over_share`)."""
        started = time.monotonic()
        frame = self._draw(thread, model, data, spec, kind)
        self.renders += 1
        if thread is self._streaming:
            thread.charge(time.monotonic() - started, L.STREAM_RENDER_SHARE)
        return frame

    def streams_over_share(self) -> bool:
        """Whether the stream render thread drew more than ``limits.STREAM_RENDER_SHARE`` of the
        time lately (``limits.STREAM_RENDER_DEBT_SECONDS`` ahead): streams of its large frames then
        skip steps.

        Returns:
            True when streams should skip steps.
        """
        s = self._streaming
        return s is not None and s.debt(L.STREAM_RENDER_SHARE) > L.STREAM_RENDER_DEBT_SECONDS

    def _prepare(self, thread: RenderThread, warm: bool = True) -> Future:
        """Make the renderers of this scene's sensors on ``thread`` and draw one frame of each
        (the first frame of a renderer costs several later ones); a failure is logged once and
        the renderers are then made on the first request. ``warm`` False (an edit of the scene:
        PyRep's ``Shape.create``, an imported model; a program makes tens in a row, each a new
        model): only the old model's contexts are freed, the new ones are made on the first
        request, once for the whole series."""
        model = self.world.model
        thread.newest = model
        if not self.specs or not self.at_load or not warm:
            return thread.executor.submit(thread.free)  # the old scene's contexts are not needed
        data, specs = copy.copy(self.world.data), list(self.specs.values())

        def prepare() -> None:
            if thread.newest is not model:
                return  # a newer scene is queued: it prepares its own
            try:
                for spec in specs:
                    self._draw(thread, model, data, spec, self._image_kind(spec))
                for size in {(s.width, s.height): s for s in specs}.values():  # depth from any sensor
                    self._draw(thread, model, data, size, "depth")
            except Exception as exc:
                log.warning("vision sensors: cannot prepare the renderers: %s: %s", type(exc).__name__, exc)

        return thread.executor.submit(prepare)

    def wait_ready(self, timeout: float | None = None) -> bool:
        """Wait until the renderers made at load are ready: whether they are (False on timeout).

        The server waits for them before it starts the simulation, so that a fresh server's
        first streamed image comes within a step or two of the streaming call.

        Args:
            timeout: s, or None (no limit).

        Returns:
            True when ready.
        """
        try:
            self._ready.result(timeout)
        except TimeoutError:
            return False
        return True

    # -------------------------------------------------------- simulation thread
    def _cached(self, key: tuple[int, str]) -> tuple[Future, RenderThread] | None:
        """The cached future of ``key`` for the world's current state and its render thread, if
        this command may use it: a request never waits for a frame still queued on the stream
        render thread (it renders its own: streams of huge images must not hold it up); a
        stream may share one."""
        cached = self._cache.get(key)
        if cached is None or cached[0] != self.shown(key[0]):
            return None
        _, future, thread = cached
        if not self.for_streams and thread is not self._thread and not future.done():
            return None
        return future, thread

    def _frame(self, handle: int, kind: str) -> Future:
        """The frame of the state the sensor shows (a future), rendered once per state: the
        world's current state, or an explicitly handled sensor's last handling's (vision_handled)."""
        version = self.shown(handle)
        cached = self._cached((handle, kind))
        if cached is not None:
            return cached[0]
        spec, model, pin = self.spec(handle), self.world.model, self.pins.get(handle)
        thread = self._target(spec)
        if pin is not None and version != self.world.version:  # the world moved on: its handling's state
            spec, model, state = pin.spec, pin.model, pin.data
        else:
            state = thread.state(version, model, self.world.data)  # one copy per thread: each reads its own
        future = thread.executor.submit(self._render, thread, model, state, spec, kind)
        thread.reading(state, future)
        self._cache[(handle, kind)] = (version, future, thread)
        return future

    def _rendered_depth_job(self, handle: int) -> Callable[[], np.ndarray]:
        """The sensor's depth frame of the world's current state submitted (simulation thread);
        the job returned gives it, run on the request render thread after it (:meth:`after`),
        normalised to 0..1 between near and far, (h, w) float32, rows bottom-up (before the
        sensor's options and filters: see :meth:`depth_job`). Raises
        UnknownObjectError/ObjectTypeError for other handles.

        Args:
            handle: a vision sensor's handle.

        Returns:
            The job.
        """
        spec, raw = self.spec(handle), self._frame(handle, "depth")
        near, far = spec.near, spec.far  # as they are now, even if changed before the render

        def normalised() -> np.ndarray:
            # The frame's top-down rows are a view of bottom-up ones (depth_frames.draw_depth):
            # flipped back, they are contiguous, and so is the buffer made from them.
            norm = wait_for(raw, "vision sensor depth")[::-1] - near
            norm /= far - near
            return np.clip(norm, 0.0, 1.0, out=norm).astype(np.float32, copy=False)

        return normalised

    @staticmethod
    def _image_kind(spec: SensorSpec) -> str:
        """The frame an image of this sensor is made from."""
        if spec.render_mode == handle_render.COLOR_CODED:
            return "handles"
        return "depth" if spec.depth_image else "rgb"

    def _rendered_image_job(self, handle: int) -> Callable[[], np.ndarray]:
        """As :meth:`_rendered_depth_job`, for the sensor's rendered image: (h, w, 3) uint8 RGB,
        rows bottom-up (before the sensor's options and filters: see :meth:`image_job`).

        Args:
            handle: a vision sensor's handle.

        Returns:
            The job.
        """
        kind = self._image_kind(self.spec(handle))
        if kind == "handles":  # V-REP's colour-coded handles (render mode 2)
            if self._colours is None:
                self._colours = handle_render.geom_colours(self.world)
            seg, colours = self._frame(handle, "handles"), self._colours
            return lambda: handle_render.coded_image(wait_for(seg, "vision sensor image"), colours)[::-1]
        if kind == "depth":
            depth = self._raw_depth_job(handle)

            def from_depth() -> np.ndarray:
                g = np.rint(depth() * 255.0).astype(np.uint8)
                return np.repeat(g[:, :, None], 3, axis=2)

            return from_depth
        raw = self._frame(handle, "rgb")
        return lambda: wait_for(raw, "vision sensor image")[::-1]

    def close(self) -> None:
        """Finish pending jobs, free every GL context (on its thread) and stop, waiting at most
        ``limits.RENDER_WAIT_SECONDS`` for each render thread; idempotent. A VisionSensors whose
        render thread was handed over has nothing to close."""
        owner, self._owner = self._owner, False
        self._cache.clear()
        if owner:
            threads = [t for t in (self._thread, self._streaming) if t is not None]
            closing = []
            for thread in threads:
                thread.newest = None  # a preparation not started yet is skipped
                closing.append(thread.executor.submit(thread.close))
            for thread, closed in zip(threads, closing):
                try:  # its pending jobs, then its contexts freed; bounded: a stuck thread is left
                    closed.result(L.RENDER_WAIT_SECONDS)
                except Exception as exc:
                    log.warning("vision sensors: the render thread did not end within RENDER_WAIT_SECONDS = %g s "
                                "(%s): left running", L.RENDER_WAIT_SECONDS, type(exc).__name__)
                thread.executor.shutdown(wait=False)
