"""A render thread: one worker that owns a GL context and the renderers made in it.

:class:`simx_server.sim.vision.VisionSensors` uses two, for requests and for streams; each
keeps one GL context and, in it, one renderer (a ``mujoco.Renderer`` with its own
``MjrContext`` and offscreen buffer) per image size, bound to one model, at most
``limits.MAX_RENDERERS``.
"""

from __future__ import annotations

import copy
import threading
import time
from collections import OrderedDict
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from typing import Any, Callable, Iterator

import mujoco
import numpy as np

from simx_server.base import limits as L
from simx_server.sim import depth_frames, texture_motion, vision_look
from simx_wire.protocol import RemoteError, SimxError


class RenderError(RemoteError):
    """A frame that could not be had: its render failed (no GL context could be made, the
    driver failed: the message names the error), or its render thread did not answer within
    ``limits.RENDER_WAIT_SECONDS``."""


def wait_for(future: Future, what: str = "vision sensor") -> Any:
    """``future.result()`` of a render thread's job, waited for at most
    ``limits.RENDER_WAIT_SECONDS``: no caller waits for ever on a render thread.

    Args:
        future: the job's future.
        what: names the call in errors.

    Returns:
        The job's value.

    Raises:
        RenderError: the job raised something else than simx's own errors (a GL or driver
            error: its type and message kept), or no answer within the bound.
        SimxError: the job's own (an argument, an object), unchanged.
    """
    try:
        return future.result(L.RENDER_WAIT_SECONDS)
    except SimxError:
        raise
    except Exception as exc:
        if not future.done():  # (the wait's TimeoutError, not a job's)
            raise RenderError(f"{what}: no frame within RENDER_WAIT_SECONDS = {L.RENDER_WAIT_SECONDS:g} s: "
                              "the render thread does not answer") from None
        raise RenderError(f"{what}: the render failed: {type(exc).__name__}: {exc}") from exc


#: MuJoCo's visualisation flags a sensor keeps on (everything else, rays, contacts, joints...,
#: is off): the scene's own appearance. mjVIS_STATIC draws the world body's geoms.
_SCENE_FLAGS = ("mjVIS_TEXTURE", "mjVIS_STATIC", "mjVIS_SKIN", "mjVIS_FLEXEDGE", "mjVIS_FLEXSKIN")


def sensor_option() -> mujoco.MjvOption:
    """The ``MjvOption`` sensors render with: what a V-REP vision sensor sees, the scene only.

    MuJoCo's defaults with every visualisation extra off (``_SCENE_FLAGS`` kept), no frames
    nor labels, and no sites; geom, skin and flex groups as MuJoCo's defaults (0-2 visible).

    Returns:
        A new ``MjvOption``.
    """
    option = mujoco.MjvOption()
    for name in dir(mujoco.mjtVisFlag):
        if name.startswith("mjVIS_"):
            option.flags[getattr(mujoco.mjtVisFlag, name)] = name in _SCENE_FLAGS
    option.frame = mujoco.mjtFrame.mjFRAME_NONE
    option.label = mujoco.mjtLabel.mjLABEL_NONE
    option.sitegroup[:] = 0
    for groups in (option.jointgroup, option.tendongroup, option.actuatorgroup):
        groups[:] = 0
    return option


class GLLock:
    """Frames are drawn on both render threads at once (:meth:`shared`), but a GL context is
    made or freed alone (:meth:`exclusive`): MuJoCo's ``mjr_makeContext`` loads the process's
    GL function pointers again (glad's globals) while the other thread may be calling them.
    Writers go first: a waiting one holds back new frames."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._drawing = 0
        self._making = False
        self._waiting = 0  # threads waiting to make or free a context

    @contextmanager
    def shared(self) -> Iterator[None]:
        """Draw a frame: waits while a context is made or a maker waits; frames run together.

        Yields:
            None, while the frame may be drawn.
        """
        with self._cond:
            self._cond.wait_for(lambda: not self._making and not self._waiting)
            self._drawing += 1
        try:
            yield
        finally:
            with self._cond:
                self._drawing -= 1
                self._cond.notify_all()

    @contextmanager
    def exclusive(self) -> Iterator[None]:
        """Make or free a GL context: waits until no frame is drawn; one at a time.

        Yields:
            None, while the context may be made or freed.
        """
        with self._cond:
            self._waiting += 1
            self._cond.wait_for(lambda: not self._making and not self._drawing)
            self._waiting -= 1
            self._making = True
        try:
            yield
        finally:
            with self._cond:
                self._making = False
                self._cond.notify_all()


#: Copies of the world's state a render thread keeps for its frames (RenderThread.state): the
#: state being drawn, the newest, and one more for a frame still queued.
STATE_COPIES = 3

#: The one lock of the process's render threads.
GL_LOCK = GLLock()


def _free_gl(free: Callable[[], None]) -> None:
    """Run ``free`` (a renderer's ``close``, a GL context's ``free``) alone (GL_LOCK); a
    context already torn down by the driver is no error."""
    try:
        with GL_LOCK.exclusive():
            free()
    except Exception:
        pass


class SensorRenderer(mujoco.Renderer):
    """A ``mujoco.Renderer`` drawn in a GL context it shares with the other renderers of its
    render thread: its own ``MjrContext``, whose offscreen buffer is ``width`` x ``height``.

    ``mujoco.Renderer`` makes a GL context per renderer. On Mesa's llvmpipe a fresh context's
    first ``MjrContext`` costs 1-1.5 s (4 s and more on a loaded machine), a further one in the
    same context 0.2 s: a sensor set to a new resolution, or a scene loaded, would make the
    first image, and the synchronous step whose streams wait for it, seconds late. Frames are the
    same, pixel for pixel, as a renderer's of its own context.

    ``MjrContext`` sizes its offscreen buffers by the model's ``offwidth`` x ``offheight``,
    which is the largest sensor's size: once a sensor was set to 4096x4096, every renderer made
    after it (a 640x480 one, a 4096x256 band) took a 4096x4096 buffer, about 300 MB on
    llvmpipe. The model's size is set to the renderer's for the time it is made (the caller
    holds GL_LOCK exclusively: the other render thread makes none meanwhile).

    The offscreen buffer is not multisampled (``offsamples`` 0 while it is made): V-REP's and
    CoppeliaSim's vision sensors draw into a plain framebuffer object (coppeliaSimLib 4.1
    ``CFrameBufferObject``: ``glRenderbufferStorage``, a ``QOpenGLFramebufferObject`` without
    samples), so their images are not anti-aliased, and a colour-coded image holds only the
    handles' own colours at edges. On llvmpipe MuJoCo's default 4 samples doubled the time of
    an RGB frame (an RLBench scene of 70,000 triangles at 128x128: 33 ms, 15 ms without).

    The attributes set are those ``mujoco.Renderer.__init__`` sets (mujoco 3.17), less the GL
    context it would make; ``tests/sim/test_render_threads.py`` compares the frames.

    Args:
        model: the model drawn.
        width: pixels.
        height: pixels.
        context: the render thread's ``mujoco.GLContext``, current on the calling thread.
    """

    def __init__(self, model: mujoco.MjModel, width: int, height: int, context: mujoco.GLContext) -> None:
        self._gl_context = None
        self._mjr_context = None
        self._width, self._height, self._model = width, height, model
        self._scene = mujoco.MjvScene(model=model, maxgeom=10000)
        self._scene_option = mujoco.MjvOption()
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._depth_rendering = False
        self._segmentation_rendering = False
        self._depth_scratch: dict[str, np.ndarray] = {}  # depth_frames.draw_depth's buffers
        context.make_current()
        g, q = model.vis.global_, model.vis.quality
        saved = g.offwidth, g.offheight, q.offsamples
        g.offwidth, g.offheight, q.offsamples = width, height, 0
        try:
            self._mjr_context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
        finally:
            g.offwidth, g.offheight, q.offsamples = saved
        self._mjr_context.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self._gl_context = context
        self.mesh_version = texture_motion.uploads(model)[0]  # the texture coordinates it was made with
        # V-REP's look: geoms drawn with OpenGL's distant viewer, as V-REP's sensors draw them
        self._viewer_lists = vision_look.distant_viewer(self._mjr_context) if vision_look.asks_vrep(model) else []

    def render(self, *, out: np.ndarray | None = None) -> np.ndarray:
        """``mujoco.Renderer.render`` into this renderer's own offscreen buffer (the context's
        other renderers bind theirs). The render thread's context is current on it from the
        first renderer made to :meth:`RenderThread.close` (the thread makes no other current),
        so the buffer is bound here and ``mujoco.Renderer.render`` makes it current once.

        Args:
            out: as ``mujoco.Renderer.render``.

        A depth frame (no ``out``) is :func:`simx_server.sim.depth_frames.draw_depth`'s:
        the same depths, without colour writes, in fewer passes.

        Returns:
            The frame, top-down rows (``mujoco.Renderer`` flips MuJoCo's bottom-up read; a
            depth frame is a top-down view of bottom-up rows):
            (height, width, 3) uint8 RGB, (height, width) float32 depth in m, or
            (height, width, 2) int32 segmentation.
        """
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._mjr_context)
        if not self._depth_rendering or out is not None:
            return super().render(out=out)
        if self._mjr_context is None:
            raise RuntimeError("render cannot be called after close.")
        if self._gl_context:
            self._gl_context.make_current()
        return depth_frames.draw_depth(self._scene, self._rect, self._mjr_context, self._model, self._depth_scratch)

    def close(self) -> None:
        """Free this renderer's ``MjrContext`` (on its render thread); the shared GL context stays."""
        if self._mjr_context:
            vision_look.restore(self._mjr_context, self._viewer_lists)  # MuJoCo frees its own lists
            self._viewer_lists = []
            self._mjr_context.free()
        self._mjr_context = None
        self._gl_context = None

    def __del__(self) -> None:
        """Nothing: GL objects are freed on the render thread, where its context is current
        (:meth:`RenderThread.free`, :meth:`RenderThread.close`). ``mujoco.Renderer.__del__``
        closes; the garbage collector runs it on any thread, and on a renderer still open when
        the interpreter ends (a program that never called ``PyRep.shutdown``), after imports
        have stopped: the process's end frees the context."""


class RenderThread:
    """A render thread and the state only it touches: its GL context and the renderers in it
    (an ``MjrContext`` per resolution), bound to one model. Shared by the successive VisionSensors
    of a server (scene loads, edits); jobs run in the order they were submitted."""

    def __init__(self, name: str = "simx-render", band_pixels: int | None = None) -> None:
        self.executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix=name)
        self.band_pixels = band_pixels  # frames drawn in bands of at most this many pixels (None: whole)
        self._busy, self._busy_at = 0.0, time.monotonic()  # drawing time owed (charge, debt)
        # render thread only; most recently used last, at most limits.MAX_RENDERERS
        self.renderers: OrderedDict[tuple[int, int], mujoco.Renderer] = OrderedDict()
        self.model: mujoco.MjModel | None = None  # the model the renderers were made for
        self.newest: mujoco.MjModel | None = None  # set on the simulation thread: the latest scene
        self.option: mujoco.MjvOption | None = None
        self.failure: str | None = None  # why no GL context can be made: not tried again
        self.context: mujoco.GLContext | None = None  # render thread: the renderers' one GL context
        # simulation thread: (version, model, the copy of the state frames of that version read)
        self.snapshot: tuple[int, mujoco.MjModel, mujoco.MjData] | None = None
        # simulation thread: [MjData, the last job that reads it, how many hold it (see hold)]
        self._copies: list[list] = []

    def renderer(self, model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
        """The renderer of this size for ``model``, made now if needed (render thread), with the
        meshes whose texture coordinates moved since its last frame uploaded again.

        Raises RenderError once a renderer could not be made (no usable GL platform): a
        second attempt after a failed one can abort the process (GLFW without a display).

        Args:
            model: the model to render.
            width: pixels.
            height: pixels (rows of the renderer; a taller frame is drawn in bands).

        Returns:
            The renderer.
        """
        if self.failure is not None:
            raise RenderError(f"vision sensors cannot render here: {self.failure}")
        if model is not self.model:
            self.free()
            self.model = model
        r = self.renderers.get((width, height))
        if r is None:
            while len(self.renderers) >= L.MAX_RENDERERS:  # sizes set at run time: bounded
                _free_gl(self.renderers.popitem(last=False)[1].close)
            try:
                with GL_LOCK.exclusive():
                    if self.context is None:
                        self.context = mujoco.GLContext(width, height)
                    r = SensorRenderer(model, width, height, self.context)
            except Exception as exc:
                self.failure = f"{type(exc).__name__}: {exc}"
                raise
            self.renderers[(width, height)] = r
        else:
            self.renderers.move_to_end((width, height))
        version, meshes = texture_motion.uploads(model)
        if getattr(r, "mesh_version", version) < version and r._mjr_context is not None:
            for mesh in meshes:  # texture coordinates moved since its last frame (sim/texture_motion.py)
                mujoco.mjr_uploadMesh(model, r._mjr_context, mesh)
        r.mesh_version = version
        if self.option is None:
            self.option = sensor_option()
        return r

    def state(self, version: int, model: mujoco.MjModel, data: mujoco.MjData) -> mujoco.MjData:
        """The copy of ``data`` (the world's state ``version`` of ``model``) that this thread's
        frames of that state read (simulation thread): the copy made for ``version``, else a
        new one, so that the simulation goes on while frames are drawn. Call :meth:`reading`
        with each job that reads it.

        A copy no job reads any more (its last job done: the thread runs its jobs in order) is
        filled again with ``mj_copyData``, which copies the fields only; ``copy.copy`` allocates
        and clears a whole ``MjData`` (the bundled scene's: 20 MB of buffer and arena, 0.35 ms
        against 0.01). At most ``STATE_COPIES`` are kept; more at once are made and dropped.

        Args:
            version: the world's version (``World.version``).
            model: the world's model.
            data: the world's state.

        Returns:
            The copy.
        """
        snap = self.snapshot
        if snap is not None and snap[0] == version and snap[1] is model:
            return snap[2]
        current = snap[2] if snap is not None and snap[1] is model else None
        if snap is not None and snap[1] is not model:
            self._copies = []  # copies of another model: their sizes differ
        spare = next((c for c in self._copies
                      if c[0] is not current and not c[2] and (c[1] is None or c[1].done())), None)
        if spare is None:
            copied = copy.copy(data)
            if len(self._copies) < STATE_COPIES:
                self._copies.append([copied, None, 0])
        else:
            copied, spare[1] = spare[0], None
            mujoco.mj_copyData(copied, model, data)
        self.snapshot = (version, model, copied)
        return copied

    def hold(self, state: mujoco.MjData, holds: int = 1) -> None:
        """Keep ``state``, a copy :meth:`state` gave, from being filled again while it is held
        (simulation thread): an explicitly handled sensor's frames are drawn from the state of
        its handling, however late they are read (:mod:`simx_server.sim.vision_handled`).

        Args:
            state: the copy.
            holds: 1 to hold it, -1 to let it go (a copy no longer kept is left alone).
        """
        for c in self._copies:
            if c[0] is state:
                c[2] = max(0, c[2] + holds)

    def reading(self, state: mujoco.MjData, job: Future) -> None:
        """Note ``job`` (submitted to this thread) as the last that reads ``state``, a copy
        :meth:`state` gave (simulation thread).

        Args:
            state: the copy.
            job: the job's future.
        """
        for c in self._copies:
            if c[0] is state:
                c[1] = job

    def charge(self, seconds: float, share: float) -> None:
        """Count ``seconds`` of drawing (render thread); what is owed falls by ``share`` s per s.

        Args:
            seconds: drawing time just spent, s.
            share: the share of wall time drawing may take, s per s.
        """
        now = time.monotonic()
        self._busy, self._busy_at = self.debt(share, now) + seconds, now

    def debt(self, share: float, now: float | None = None) -> float:
        """Drawing time owed: the time charged less ``share`` s per s since (any thread).

        Args:
            share: the share of wall time drawing may take, s per s.
            now: ``time.monotonic()``, if the caller has it.

        Returns:
            Seconds owed, >= 0.
        """
        now = time.monotonic() if now is None else now
        return max(0.0, self._busy - (now - self._busy_at) * share)

    def band_rows(self, width: int, height: int) -> int:
        """Rows of the renderer a ``width`` x ``height`` frame is drawn with: ``height``, or with
        ``band_pixels`` the rows of one band (see :func:`render_bands`).

        Args:
            width: the frame's width, pixels.
            height: its height, pixels.

        Returns:
            Rows.
        """
        return height if not self.band_pixels else max(1, min(height, self.band_pixels // width))

    def free(self) -> None:
        """Free every renderer (render thread); the GL context stays for the next scene's."""
        for r in self.renderers.values():
            _free_gl(r.close)
        self.renderers.clear()
        self.model = None

    def close(self) -> None:
        """Free every renderer and the GL context (render thread; before the thread ends)."""
        self.free()
        context, self.context = self.context, None
        if context is not None:
            _free_gl(context.free)


def render_bands(r: mujoco.Renderer, height: int) -> np.ndarray:
    """``r.render()`` of the scene ``r`` holds (``update_scene`` done), top-down rows, under the
    GL lock; ``height``: the frame's rows, ``r.height`` or more.

    A frame taller than the renderer is drawn in horizontal bands of ``r.height`` rows, each with
    the camera's frustum cut to its rows (MuJoCo computes the frustum's width from the viewport,
    so each band has the whole frame's projection): the bands equal the whole frame to within 2
    of 255 (RGB) and 1e-4 m (depth) but for a pixel or two on a silhouette, which the cut frustum's
    rounding puts on the other side. Rows past the top of the last band are drawn and dropped.
    Each band is its own render, so on Mesa's llvmpipe, whose one rasteriser queue serves every
    GL context of the process, another thread's frame waits for one band, not the whole frame.

    Args:
        r: a renderer whose scene is updated.
        height: the frame's height in pixels.

    Returns:
        The frame: (height, width, 3) uint8 RGB, or (height, width) float32 depth, top-down.
    """
    rows = r.height
    if rows >= height:
        with GL_LOCK.shared():  # not while the other render thread makes a context
            return r.render()
    cameras = r.scene.camera  # mjvGLCamera: left and right eye (the same for a mono view)
    bottom, top = cameras[0].frustum_bottom, cameras[0].frustum_top
    out = None
    for first in range(0, height, rows):  # the band's first row, counted from the bottom
        for c in cameras:
            c.frustum_bottom = bottom + (top - bottom) * first / height
            c.frustum_top = bottom + (top - bottom) * (first + rows) / height
        with GL_LOCK.shared():
            band = r.render()
        if out is None:
            out = np.empty((height,) + band.shape[1:], band.dtype)
        n = min(rows, height - first)
        out[height - first - n: height - first] = band[rows - n:]
    return out
