"""Depth frames of the vision sensors: drawn unlit, without colour, planes as single quads, and
read back into metres in a few numpy passes.

:class:`simx_server.sim.render_thread.SensorRenderer` draws every depth frame through
:func:`draw_depth`; :meth:`simx_server.sim.vision.VisionSensors._draw` calls
:func:`flat_planes` on a depth frame's scene. The depths are ``mujoco.Renderer.render``'s
(mujoco 3.17): on llvmpipe at 640x480 the bundled scene's Kinect depth frame went from about
5 ms of GL work to 1.3 ms, and its read-back and normalisation allocate two arrays where they
allocated eight.
"""

from __future__ import annotations

import ctypes
import math
from typing import Any, Callable

import mujoco
import numpy as np

#: Frames of at most this many pixels keep their read-back buffers between frames (12 bytes a
#: pixel: 12 MB at this size); larger ones allocate them for each frame.
KEEP_PIXELS = 1 << 20


_GL_COLOR_MASK: list[Any] = []  # glColorMask, or None, once looked up


def colour_mask() -> Callable[[int, int, int, int], None] | None:
    """OpenGL's ``glColorMask(r, g, b, a)`` (0/1 each) for the context current on the calling
    thread, or None where it cannot be had (colour is then written, as MuJoCo does).

    A depth frame reads the depth buffer only; MuJoCo's unlit pass writes a colour per pixel
    too: masked, the bundled scene's depth frame takes 1.3 ms of GL work on llvmpipe instead
    of 1.9, with the same depths.

    Taken from the GL library of PyOpenGL's platform (the one mujoco's ``GLContext`` made the
    context with: EGL's libOpenGL, OSMesa, GLX) and called through ctypes: PyOpenGL's own
    wrapper checks ``glGetError`` after the call and would raise on an error that one of
    MuJoCo's calls left pending.

    Returns:
        The function, or None.
    """
    if not _GL_COLOR_MASK:
        try:
            from OpenGL import platform

            proto = ctypes.CFUNCTYPE(None, ctypes.c_ubyte, ctypes.c_ubyte, ctypes.c_ubyte, ctypes.c_ubyte)
            _GL_COLOR_MASK.append(proto(("glColorMask", platform.PLATFORM.GL)))
        except Exception:  # no PyOpenGL platform, no such symbol: colour is written, as before
            _GL_COLOR_MASK.append(None)
    return _GL_COLOR_MASK[0]


def flat_planes(scene: mujoco.MjvScene, model: mujoco.MjModel, data: mujoco.MjData) -> int:
    """Draw the scene's plane geoms as one quad each (16 in all) instead of MuJoCo's grid, for
    a frame that is not lit (depth): the same plane, the same extent.

    MuJoCo draws a plane with a display list of its own (``makePlane`` in MuJoCo's
    ``render_context.c``): a grid of up to ``mjMAXPLANEGRID`` x ``mjMAXPLANEGRID`` quads
    (40,000 for an infinite plane) so that fixed-function lighting, computed per vertex, shows
    highlights on it. A depth frame is drawn unlit (``mjRND_SEGMENT``), where a plane's depth is
    linear across it in screen space: the grid only costs time (on llvmpipe, 640x480, the
    bundled scene's floor was 3.7 ms of a 5 ms depth frame). A geom with ``dataid`` -1 is drawn
    with the list for planes without their own (``numquads`` x ``numquads`` quads over -1..1,
    scaled by the geom's ``size``), so each plane's size is set to its grid's half extent: the
    model's size where it is finite (the grid spans it exactly), else the grid ``makePlane``
    makes, ``mjMAXPLANEGRID / 2`` cells of ``(2.1 zfar + 2 sX) / mjMAXPLANEGRID``, with ``sX``
    from the material's ``texrepeat`` or ``2.1 zfar / (mjMAXPLANEGRID - 2)``.

    An infinite plane is centred under the camera in steps of ``2 sX`` as ``mjv_updateScene``
    does (``addGeomGeoms``), but on the camera of this frame: ``mjv_updateScene`` places the
    geoms before it moves the scene's camera, so it centres them on the previous frame's camera,
    and a frame's depths then depended (in their last bits) on the camera drawn before it.
    Depths equal the grid's to within rounding (5e-6 m at 2.9 m in the bundled scene's Kinect
    frame; the same pixels at the far plane, but for a pixel on a plane's edge seen edge-on).

    Call after ``update_scene`` and before the render; ``update_scene`` makes the geoms anew.

    Args:
        scene: the ``MjvScene`` about to be drawn (its geoms are changed in place).
        model: the model it shows.
        data: the state it shows (the planes' poses).

    Returns:
        The number of planes changed.
    """
    planes = int(np.count_nonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE))
    if not planes:
        return 0
    zfar = model.vis.map.zfar * model.stat.extent
    cells = mujoco.mjMAXPLANEGRID
    head = 0.5 * (np.asarray(scene.camera[0].pos, float) + np.asarray(scene.camera[1].pos, float))
    changed = 0
    for i in range(scene.ngeom):
        if changed == planes:  # each model plane is one geom of the scene at most
            break
        g = scene.geoms[i]
        if g.type != mujoco.mjtGeom.mjGEOM_PLANE or g.dataid < 0 or g.objtype != mujoco.mjtObj.mjOBJ_GEOM:
            continue
        size, matid = model.geom_size[g.objid], model.geom_matid[g.objid]
        pos, axes = data.geom_xpos[g.objid].copy(), data.geom_xmat[g.objid].reshape(3, 3)
        for k in range(2):
            if size[k] > 0:
                g.size[k] = size[k]
                continue
            repeat = model.mat_texrepeat[matid][k] if matid >= 0 else 0.0
            step = 2.0 / repeat if repeat > 0 else 2.1 * zfar / (cells - 2)
            g.size[k] = (2.1 * zfar + 2.0 * step) / cells * (cells // 2)
            along = float(np.dot(head - data.geom_xpos[g.objid], axes[:, k]))
            pos += axes[:, k] * (2.0 * step * math.floor(0.5 * along / step + 0.5))  # mju_round
        g.pos[:] = pos
        g.dataid = -1
        changed += 1
    return changed


def draw_depth(scene: mujoco.MjvScene, rect: mujoco.MjrRect, context: mujoco.MjrContext,
               model: mujoco.MjModel, scratch: dict[str, np.ndarray]) -> np.ndarray:
    """Draw ``scene`` (``update_scene`` done) into ``context``'s bound buffer as a depth frame
    and read it back in metres: ``mujoco.Renderer.render``'s depth frame (mujoco 3.17), value for
    value, with colour writes masked (:func:`colour_mask`; MuJoCo never sets the mask, so it is
    set back to all-on) and its read-back done in place.

    Like ``mujoco.Renderer``, the frame is drawn with ``mjRND_SEGMENT`` and ``mjRND_IDCOLOR`` on
    (unlit, flat colours: more accurate depth far away) and the scene's flags are set back after.
    MuJoCo's reversed-Z window depth ``z`` (``mjDEPTH_ZEROFAR``) becomes metres as the renderer
    does it: coefficients in float32 from the model's ``znear``/``zfar`` times its extent, the
    arithmetic in float64, the result rounded to float32. Orthographic:
    ``zfar - z (zfar - znear)``; perspective: ``d / (z + c)`` with ``c = -0.5 C - 0.5``,
    ``d = -0.5 D``, ``C = -(f + n) / (f - n)``, ``D = -2 f n / (f - n)`` (glFrustum's terms).
    ``mujoco.Renderer`` makes a float64 copy, two more arrays for the two operations, a float32
    copy, and then flips the rows with another copy; here the window depth and the float64
    values live in ``scratch`` (kept for frames up to :data:`KEEP_PIXELS`) and the rows are
    flipped by a view.

    Args:
        scene: the scene to draw (its flags are restored afterwards).
        rect: the viewport, ``width`` x ``height`` pixels.
        context: the ``MjrContext``, its offscreen buffer bound; its GL context current.
        model: the model drawn (near and far planes).
        scratch: the renderer's buffers (empty at first; filled here).

    Returns:
        (height, width) float32 depth in m, top-down rows (a view of a new bottom-up array).
    """
    shape = (rect.height, rect.width)
    window, wide = scratch.get("window"), scratch.get("wide")
    if window is None or window.shape != shape:
        window, wide = np.empty(shape, np.float32), np.empty(shape, np.float64)
        if shape[0] * shape[1] <= KEEP_PIXELS:
            scratch["window"], scratch["wide"] = window, wide
    flags = scene.flags
    saved = flags.copy()
    flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = True
    flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = True
    mask = colour_mask()
    if mask is not None:
        mask(0, 0, 0, 0)  # a depth frame reads the depth buffer only
    try:
        mujoco.mjr_render(rect, scene, context)
        mujoco.mjr_readPixels(None, window, rect, context)
    finally:
        if mask is not None:
            mask(1, 1, 1, 1)
        np.copyto(flags, saved)
    extent = model.stat.extent
    zfar, znear = np.float32(model.vis.map.zfar * extent), np.float32(model.vis.map.znear * extent)
    if scene.camera[0].orthographic:
        np.multiply(window, zfar - znear, out=wide, dtype=np.float64)
        np.subtract(zfar, wide, out=wide, dtype=np.float64)
    else:
        c = -(zfar + znear) / (zfar - znear)
        d = -(np.float32(2) * zfar * znear) / (zfar - znear)
        c, d = np.float32(-0.5) * c - np.float32(0.5), np.float32(-0.5) * d
        np.add(window, c, out=wide, dtype=np.float64)
        np.divide(d, wide, out=wide, dtype=np.float64)
    metres = np.empty(shape, np.float32)
    np.copyto(metres, wide, casting="same_kind")
    return metres[::-1]
