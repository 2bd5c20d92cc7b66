"""A render thread: one worker that owns GL contexts and the renderers made on them.

:class:`simx_server.sim.vision.VisionSensors` uses two, for requests and for streams; each
keeps one ``mujoco.Renderer`` (a GL context and ``MjrContext``) per image size, bound to one
model, at most ``limits.MAX_RENDERERS``.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Iterator

import mujoco

from simx_server.base import limits as L


#: MuJoCo's visualisation flags a sensor keeps on (everything else, rays, contacts, joints...,
#: is off): the scene's own appearance. mjVIS_STATIC draws the world body's geoms.
_SCENE_FLAGS = ("mjVIS_TEXTURE", "mjVIS_STATIC", "mjVIS_SKIN", "mjVIS_FLEXEDGE", "mjVIS_FLEXSKIN")


def sensor_option() -> mujoco.MjvOption:
    """The ``MjvOption`` sensors render with: what a V-REP vision sensor sees, the scene only.

    MuJoCo's defaults with every visualisation extra off (``_SCENE_FLAGS`` kept), no frames
    nor labels, and no sites; geom, skin and flex groups as MuJoCo's defaults (0-2 visible).
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
    GL function pointers again (glad's globals) while the other thread may be calling them (a
    suspect, not a proven cause, when an environment's server went away under load after the
    stream thread came in). Writers go first: a waiting one holds back new frames."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._drawing = 0
        self._making = False
        self._waiting = 0  # threads waiting to make or free a context

    @contextmanager
    def shared(self) -> Iterator[None]:
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


#: The one lock of the process's render threads.
GL_LOCK = GLLock()


def _close(renderer: mujoco.Renderer) -> None:
    try:
        with GL_LOCK.exclusive():
            renderer.close()
    except Exception:  # a context already torn down by the driver
        pass


class RenderThread:
    """A render thread and the state only it touches: the renderers (one GL context and
    ``MjrContext`` per resolution), bound to one model. Shared by the successive VisionSensors
    of a server (scene loads, edits); jobs run in the order they were submitted."""

    def __init__(self, name: str = "simx-render") -> None:
        self.executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix=name)
        # render thread only; most recently used last, at most limits.MAX_RENDERERS
        self.renderers: OrderedDict[tuple[int, int], mujoco.Renderer] = OrderedDict()
        self.model: mujoco.MjModel | None = None  # the model the renderers were made for
        self.newest: mujoco.MjModel | None = None  # set on the simulation thread: the latest scene
        self.option: mujoco.MjvOption | None = None
        self.failure: str | None = None  # why no GL context can be made: not tried again
        self.snapshot: tuple[int, mujoco.MjData] | None = None  # simulation thread: (version, the state it shows)

    def renderer(self, model: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
        """The renderer of this size for ``model``, made now if needed (render thread).

        Raises RuntimeError once a renderer could not be made (no usable GL platform): a
        second attempt after a failed one can abort the process (GLFW without a display)."""
        if self.failure is not None:
            raise RuntimeError(f"vision sensors cannot render here: {self.failure}")
        if model is not self.model:
            self.free()
            self.model = model
        r = self.renderers.get((width, height))
        if r is None:
            while len(self.renderers) >= L.MAX_RENDERERS:  # sizes set at run time: bounded
                _close(self.renderers.popitem(last=False)[1])
            try:
                with GL_LOCK.exclusive():
                    r = mujoco.Renderer(model, height, width)
            except Exception as exc:
                self.failure = f"{type(exc).__name__}: {exc}"
                raise
            self.renderers[(width, height)] = r
        else:
            self.renderers.move_to_end((width, height))
        if self.option is None:
            self.option = sensor_option()
        return r

    def free(self) -> None:
        """Free every GL context (render thread)."""
        for r in self.renderers.values():
            _close(r)
        self.renderers.clear()
        self.model = None
