"""V-REP's old path objects (``sim_object_path_type``, deprecated in CoppeliaSim 4.2 and still
served by its ``sim1`` table): ``sim.getPositionOnPath``, ``sim.getOrientationOnPath``,
``sim.getPathPosition`` / ``sim.setPathPosition``, ``sim.getPathLength``,
``sim.getClosestPositionOnPath``,
``sim.insertPathCtrlPoints``, ``sim.cutPathCtrlPoints`` and ``sim.createPath``'s old form
(:func:`create_old_path`, which :func:`simx_server.api.sim.paths.createPath` calls when its first
argument is a number, as CoppeliaSim's ``sim.createPath`` does).

The path's data and the Bezier points, lengths and poses derived from them are
:mod:`simx_server.sim.old_paths`' (coppeliaSimLib ``CPathCont_old``); a path of a ``.ttt`` keeps
what the file stored, a created one starts empty. Nothing follows a path by itself in simx
(V-REP's path-following dummies and ``sim.followPath`` are not carried over).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.sim import kept_objects
from simx_server.sim.old_paths import POINT_SIZE, matrix_to_quat, quat_to_matrix
from simx_server.sim.rotations import euler_from_matrix, matrix_from_euler
from simx_server.sim.spec_tools import _names, vrep_suffix


def _path(ctx: CallContext, handle: Any, what: str = "pathHandle"):
    return kept_objects.store(ctx.world).path(ctx.h(handle, what))


def _world_pose(ctx: CallContext, handle: int, relative: Any) -> tuple[np.ndarray, np.ndarray]:
    pos, quat = _path(ctx, handle).pose_at(_num(relative, "relativeDistance"))
    p, r = ctx.world.frame(ctx.h(handle, "pathHandle"))
    return p + r @ pos, r @ quat_to_matrix(quat)


@sim_function("getPositionOnPath")
def getPositionOnPath(ctx: CallContext, pathHandle: Any, relativeDistance: Any) -> list[float]:  # noqa: N802, N803
    """The world position (m) on the path at ``relativeDistance`` (0..1 of its virtual length;
    -1 - i: control point i). coppeliaSimLib ``simGetPositionOnPath_internal``.

    Args:
        pathHandle: an old path.
        relativeDistance: 0..1 (wrapped on a closed path, clamped on an open one), or <= -0.5.

    Returns:
        ``[x, y, z]``, m.

    Raises:
        ObjectTypeError: not a path. ArgumentError: an empty path, or no such control point.
    """
    return [float(v) for v in _world_pose(ctx, pathHandle, relativeDistance)[0]]


@sim_function("getOrientationOnPath")
def getOrientationOnPath(ctx: CallContext, pathHandle: Any, relativeDistance: Any) -> list[float]:  # noqa: N802, N803
    """The world orientation (Euler angles alpha, beta, gamma, rad) on the path at
    ``relativeDistance`` (as :func:`getPositionOnPath`). coppeliaSimLib
    ``simGetOrientationOnPath_internal``.

    Returns:
        ``[alpha, beta, gamma]``, rad.
    """
    return [float(v) for v in euler_from_matrix(_world_pose(ctx, pathHandle, relativeDistance)[1])]


@sim_function("getClosestPositionOnPath")
def getClosestPositionOnPath(ctx: CallContext, pathHandle: Any, position: Any) -> float:  # noqa: N802, N803
    """The relative position (0..1 of the virtual length) on the path closest to ``position``
    (m, in the path's frame, as coppeliaSimLib takes it). ``simGetClosestPositionOnPath_internal``.

    Args:
        pathHandle: an old path.
        position: 3 numbers, m.

    Returns:
        0..1.

    Raises:
        ObjectTypeError: not a path. ArgumentError: an empty path, or not 3 numbers.
    """
    if not isinstance(position, (list, tuple)) or len(position) < 3:
        raise ArgumentError("position must hold 3 numbers")
    path = _path(ctx, pathHandle)
    where = path.closest(np.array([_num(v, "position[i]") for v in position[:3]]))
    total = path.length()
    return float(where / total) if total != 0 else float(where)


@sim_function("getPathPosition")
def getPathPosition(ctx: CallContext, pathHandle: Any) -> float:  # noqa: N802, N803
    """The path's position along itself (m of virtual length). ``simGetPathPosition_internal``."""
    return float(_path(ctx, pathHandle).position)


@sim_function("setPathPosition")
def setPathPosition(ctx: CallContext, pathHandle: Any, position: Any) -> None:  # noqa: N802, N803
    """Set the path's position (m of virtual length; wrapped on a closed path, clamped to 0..length
    on an open one). ``simSetPathPosition_internal`` / ``CPathCont_old::setPosition``."""
    _path(ctx, pathHandle).set_position(_num(position, "position"))


@sim_function("getPathLength")
def getPathLength(ctx: CallContext, pathHandle: Any) -> float:  # noqa: N802, N803
    """The path's virtual length (m; its length calculation method's, by default the linear
    length where the points move). ``simGetPathLength_internal``."""
    return float(_path(ctx, pathHandle).length())


@sim_function("insertPathCtrlPoints")
def insertPathCtrlPoints(ctx: CallContext, pathHandle: Any, options: Any, startIndex: Any, ptCnt: Any,  # noqa: N802, N803
                         ptData: Any) -> int:  # noqa: N803
    """Insert ``ptCnt`` control points at ``startIndex``: 11 numbers each (x y z m, alpha beta
    gamma rad in the path's frame, max relative velocity, on-spot distance, Bezier point count,
    Bezier factors before and after), 16 with ``options`` bit 1 (then aux flags and 4 aux
    channels); ``options`` bit 0: the path is closed. ``simInsertPathCtrlPoints_internal``.

    Returns:
        1.

    Raises:
        ArgumentError: ``ptData`` shorter than ``ptCnt`` points, or not numbers.
    """
    opts, n = _int(options, "options"), _int(ptCnt, "ptCnt")
    per = 16 if opts & 2 else 11
    if not isinstance(ptData, (list, tuple)) or n < 0 or len(ptData) < n * per:
        raise ArgumentError(f"ptData must hold ptCnt x {per} numbers")
    raw = np.array([_num(v, "ptData[i]") for v in ptData[:n * per]], dtype=float).reshape(n, per)
    pts = np.zeros((n, POINT_SIZE))
    for i, r in enumerate(raw):
        pts[i, :3] = r[:3]
        pts[i, 3:7] = matrix_to_quat(matrix_from_euler(*r[3:6]))
        pts[i, 7:9], pts[i, 9] = r[9:11], np.floor(r[8] + 0.5)
        pts[i, 10], pts[i, 11] = r[6], r[7]
        if per == 16:
            pts[i, 12], pts[i, 13:17] = np.floor(r[11] + 0.5), r[12:16]
    _path(ctx, pathHandle).insert(_int(startIndex, "startIndex"), pts, bool(opts & 1))
    return 1


@sim_function("cutPathCtrlPoints")
def cutPathCtrlPoints(ctx: CallContext, pathHandle: Any, startIndex: Any, ptCnt: Any) -> int:  # noqa: N802, N803
    """Remove ``ptCnt`` control points from ``startIndex`` (every point when either is negative).
    ``simCutPathCtrlPoints_internal``. Returns 1."""
    _path(ctx, pathHandle).cut(_int(startIndex, "startIndex"), _int(ptCnt, "ptCnt"))
    return 1


def create_old_path(ctx: CallContext, attributes: Any, intParams: Any = None, floatParams: Any = None,  # noqa: N803
                    color: Any = None) -> int:
    """``sim.createPath(attributes, intParams, floatParams, color)`` (``simCreatePath_internal``):
    an empty old path at the world origin named ``Path`` (a site of type 8); ``attributes`` -1:
    the default ones; ``intParams`` line size, length calculation method; ``floatParams``
    control point size, angle-to-distance and on-spot-distance coefficients. Its handle.

    Raises:
        ArgumentError: malformed parameters. UnsupportedError: no simulation behind the caller.
    """
    attrib = _int(attributes, "attributes")
    ints = [_int(v, "intParams[i]") for v in (intParams or [])[:2]] if isinstance(intParams, (list, tuple)) else []
    floats = [_num(v, "floatParams[i]") for v in (floatParams or [])[:3]] if isinstance(floatParams, (list, tuple)) else []
    sim = ctx.simulation("createPath")

    def change(spec: mujoco.MjSpec):
        name = "Path" + vrep_suffix({"Path"}, _names(spec) | set(sim.world.by_name))
        site = spec.worldbody.add_site(name=name)
        site.size, site.group = [1e-3, 0, 0], 5
        spec.add_text(name=f"simx:{name}", data="object_type=8")
        return lambda: sim.world.resolve(name).handle

    handle = sim.editor._edit(change)
    path = kept_objects.store(sim.world).path(handle)
    if attrib != -1:
        path.attributes = attrib
    if len(ints) > 1:
        path.length_method = ints[1]
    if len(floats) > 2:
        path.angle_coeff, path.on_spot_coeff = floats[1], floats[2]
    path.actualize()
    return handle
