"""CoppeliaSim 4.x's point clouds and octrees kept as data (``sim.createPointCloud`` and the calls on
point clouds; the octree calls are in :mod:`simx_server.api.sim.octrees`, on this module's helpers).

Each is a scene object with a frame: a MuJoCo site (so ``sim.getObjectType`` answers
``sim.object_dummy_type``; poses, parents and removal work as for any dummy) whose points or
voxels simx keeps, relative to that frame, in the simulation's store. Nothing is drawn
headless and MuJoCo does not collide with them. A point cloud is a list of points with an
insertion tolerance; an octree is a set of cubic voxels of one size on a grid aligned with its
frame (centres at ``(i + 0.5) * voxelSize``), each with a colour and a tag. Objects go in or out
as their geometry: shapes as the solid MuJoCo collides with (primitives and mesh hulls,
:mod:`simx_server.api.cloud_geometry`), point clouds and octrees as their points and voxel
centres, dummies as their position.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import core as _core
from simx_server.api.sim import paths as _paths
from simx_wire.protocol import ArgumentError, UnknownObjectError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.api import cloud_geometry as geo
from simx_server.sim.objects import DUMMY, SHAPE
from simx_server.sim.spec_tools import _names, vrep_suffix

#: At most this many points in a point cloud, voxels in an octree.
MAX_POINTS = 1_000_000


def _points(values: Any, what: str = "points") -> np.ndarray:
    if isinstance(values, (bytes, bytearray)):
        values = np.frombuffer(values, dtype=np.float32)
    if not isinstance(values, (list, tuple, np.ndarray)) or len(values) % 3:
        raise ArgumentError(f"{what} must be a flat table of x, y, z coordinates (m)")
    arr = np.array([_num(v, what) for v in values] if not isinstance(values, np.ndarray) else values, dtype=float)
    if not np.isfinite(arr).all():
        raise ArgumentError(f"{what} must be finite numbers")
    if len(arr) // 3 > MAX_POINTS:
        raise ArgumentError(f"at most {MAX_POINTS} points per call")
    return arr.reshape(-1, 3)


def _colours(color: Any, n: int, per_point: bool) -> np.ndarray:
    """(n, 3) colours: one RGB for all, or (``per_point``) one per point; nil: grey."""
    if color is None:
        return np.full((n, 3), 0.5)
    c = np.array([_num(v, "color") for v in color], dtype=float)
    need = 3 * n if per_point else 3
    if len(c) < need:
        raise ArgumentError(f"color must hold {need} numbers ({'one RGB per point' if per_point else 'one RGB'})")
    return c[:need].reshape(-1, 3) if per_point else np.tile(c[:3], (n, 1))


# ``sim.createPointCloud``, ``createOctree`` and the calls on them.

def cloud(ctx: CallContext, handle: Any, kind: str) -> dict:
    h = ctx.h(handle, f"{kind}Handle")
    rec = _paths.store_of(ctx, "clouds").get(h)
    if rec is None or rec["kind"] != kind:
        raise UnknownObjectError(f"object {h} is not a {'point cloud' if kind == 'pointCloud' else 'octree'}")
    ctx.world.get(h)  # still in the scene
    return rec


def to_local(ctx: CallContext, handle: int, pts: np.ndarray, relative: bool) -> np.ndarray:
    if relative:
        return pts
    rot, pos = _core.frame_of(ctx, handle)
    return (pts - pos) @ rot


def to_world(ctx: CallContext, handle: int, pts: np.ndarray) -> np.ndarray:
    rot, pos = _core.frame_of(ctx, handle)
    return pts @ rot.T + pos


def new_frame(ctx: CallContext, base: str) -> int:
    sim = ctx.simulation(f"create{base}")

    def change(spec: mujoco.MjSpec):
        name = base + vrep_suffix({base}, _names(spec) | set(sim.world.by_name))
        spec.worldbody.add_site(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.005, 0.005, 0.005],
                                rgba=[0.5, 0.5, 0.5, 0.0])
        return lambda: sim.world.resolve(name).handle

    return sim.editor._edit(change)


def object_points(ctx: CallContext, handle: Any, spacing: float) -> np.ndarray:
    """World points of an object: a shape's surface (``spacing`` m apart), a point cloud's
    points, an octree's voxel centres, a dummy's position."""
    h = ctx.h(handle, "objectHandle")
    rec = _paths.store_of(ctx, "clouds").get(h)
    if rec is not None:
        ctx.world.get(h)
        local = rec["pts"] if rec["kind"] == "pointCloud" else (rec["keys"] + 0.5) * rec["size"]
        return to_world(ctx, h, local)
    obj = ctx.world.get(h)
    if obj.type == SHAPE:
        geoms = np.flatnonzero(ctx.world.model.geom_bodyid == obj.mj_id)
        return geo.surface_points(ctx.world.model, ctx.world.data, geoms, spacing)
    if obj.type == DUMMY:
        return _core.frame_of(ctx, h)[1][None, :]
    raise UnsupportedError(f"object {h} is not a shape, dummy, point cloud or octree")


def inside_of(ctx: CallContext, handle: Any, pts: np.ndarray, tol: float) -> np.ndarray:
    """Which world points collide with an object (within ``tol`` m of it)."""
    h = ctx.h(handle, "objectHandle")
    rec = _paths.store_of(ctx, "clouds").get(h)
    if rec is not None and rec["kind"] == "octree":
        ctx.world.get(h)
        local = to_local(ctx, h, pts, False)
        idx = np.floor(local / rec["size"]).astype(np.int64).astype(float)
        inside = geo.near_mask(idx, rec["keys"].astype(float), 0.5)  # same grid index
        return inside | geo.near_mask(pts, object_points(ctx, h, 0), tol) if tol > 0 else inside
    obj = ctx.world.get(h) if rec is None else None
    if obj is not None and obj.type == SHAPE:
        geoms = np.flatnonzero(ctx.world.model.geom_bodyid == obj.mj_id)
        return geo.shape_sdf(ctx.world.model, ctx.world.data, geoms, pts) <= tol
    return geo.near_mask(pts, object_points(ctx, h, 0), tol)


@sim_function("createPointCloud")
def createPointCloud(ctx: CallContext, maxVoxelSize: Any, maxPtCntPerVoxel: Any, options: Any,  # noqa: N802, N803
                     pointSize: Any) -> int:  # noqa: N803
    """A new, empty point cloud at the world origin; its handle. ``maxVoxelSize`` (m) and
    ``maxPtCntPerVoxel`` describe CoppeliaSim's calculation structure and are kept
    (:func:`getPointCloudOptions`); ``options`` and ``pointSize`` (pixels) likewise.

    ``sim.createPointCloud``.

    Args:
        maxVoxelSize: m, positive.
        maxPtCntPerVoxel: at least 1.
        options: kept.
        pointSize: pixels, kept.

    Returns:
        The point cloud's handle.

    Raises:
        ArgumentError: a size or count out of range, or not numbers.
    """
    size, per, opts, psize = (_num(maxVoxelSize, "maxVoxelSize"), _int(maxPtCntPerVoxel, "maxPtCntPerVoxel"),
                              _int(options, "options"), _num(pointSize, "pointSize"))
    if not size > 0 or per < 1:
        raise ArgumentError("maxVoxelSize must be positive and maxPtCntPerVoxel at least 1")
    h = new_frame(ctx, "Point_cloud")
    _paths.store_of(ctx, "clouds")[h] = {"kind": "pointCloud", "size": size, "per": per, "options": opts,
                                "pointSize": psize, "pts": np.empty((0, 3)), "rgb": np.empty((0, 3))}
    return h


@sim_function("getPointCloudOptions")
def getPointCloudOptions(ctx: CallContext, pointCloudHandle: Any) -> tuple[float, int, int, float]:  # noqa: N802, N803
    """``maxVoxelSize, maxPtCntPerVoxel, options, pointSize``.

    ``sim.getPointCloudOptions``.

    Args:
        pointCloudHandle: the point cloud's handle.

    Returns:
        ``(maxVoxelSize, maxPtCntPerVoxel, options, pointSize)``: m, int, int, pixels.

    Raises:
        UnknownObjectError: not a point cloud.
    """
    c = cloud(ctx, pointCloudHandle, "pointCloud")
    return c["size"], c["per"], c["options"], c["pointSize"]


@sim_function("setPointCloudOptions")
def setPointCloudOptions(ctx: CallContext, pointCloudHandle: Any, maxVoxelSize: Any, maxPtCntPerVoxel: Any,  # noqa: N802, N803
                         options: Any, pointSize: Any) -> None:  # noqa: N803
    """``sim.setPointCloudOptions``: the values :func:`getPointCloudOptions` answers.

    Args:
        pointCloudHandle: the point cloud's handle.
        maxVoxelSize: m, positive.
        maxPtCntPerVoxel: at least 1.
        options: kept.
        pointSize: pixels, kept.

    Raises:
        UnknownObjectError: not a point cloud.
        ArgumentError: a size or count out of range, or not numbers.

    """
    c = cloud(ctx, pointCloudHandle, "pointCloud")
    size, per = _num(maxVoxelSize, "maxVoxelSize"), _int(maxPtCntPerVoxel, "maxPtCntPerVoxel")
    if not size > 0 or per < 1:
        raise ArgumentError("maxVoxelSize must be positive and maxPtCntPerVoxel at least 1")
    c.update(size=size, per=per, options=_int(options, "options"), pointSize=_num(pointSize, "pointSize"))


@sim_function("getPointCloudPoints")
def getPointCloudPoints(ctx: CallContext, pointCloudHandle: Any) -> list[float]:  # noqa: N802, N803
    """The points, relative to the point cloud's frame (m, x, y, z each).

    ``sim.getPointCloudPoints``.

    Args:
        pointCloudHandle: the point cloud's handle.

    Returns:
        3n floats, m.

    Raises:
        UnknownObjectError: not a point cloud.
    """
    return cloud(ctx, pointCloudHandle, "pointCloud")["pts"].reshape(-1).tolist()


def _add_points(ctx: CallContext, h: int, c: dict, local: np.ndarray, rgb: np.ndarray, tol: Any) -> int:
    if tol is not None and _num(tol, "duplicateTolerance") > 0:
        keep = geo.dedupe(local, _num(tol, "duplicateTolerance"), c["pts"])
        local, rgb = local[keep], rgb[keep]
    if len(c["pts"]) + len(local) > MAX_POINTS:
        raise ArgumentError(f"a point cloud holds at most {MAX_POINTS} points")
    c["pts"], c["rgb"] = np.vstack([c["pts"], local]), np.vstack([c["rgb"], rgb])
    return len(c["pts"])


@sim_function("insertPointsIntoPointCloud")
def insertPointsIntoPointCloud(ctx: CallContext, pointCloudHandle: Any, options: Any, points: Any,  # noqa: N802, N803
                               color: Any = None, duplicateTolerance: Any = None) -> int:  # noqa: N803
    """Add points (world coordinates; ``options`` bit 0: relative to the cloud's frame; bit 1:
    ``color`` holds one RGB per point). With ``duplicateTolerance`` (m), a point within it of
    one already in the cloud (or inserted before it) is left out. The cloud's point count.

    ``sim.insertPointsIntoPointCloud``.

    Args:
        pointCloudHandle: the point cloud's handle.
        options: bit 0 relative to the cloud, bit 1 one colour per point.
        points: 3n numbers, m.
        color: 3 numbers (3n with bit 1) in 0..1, or None.
        duplicateTolerance: m, or None.

    Returns:
        The point count.

    Raises:
        UnknownObjectError: not a point cloud.
        ArgumentError: points or colours of the wrong length or kind.
    """
    c, opts = cloud(ctx, pointCloudHandle, "pointCloud"), _int(options, "options")
    h = ctx.h(pointCloudHandle, "pointCloudHandle")
    local = to_local(ctx, h, _points(points), bool(opts & 1))
    return _add_points(ctx, h, c, local, _colours(color, len(local), bool(opts & 2)), duplicateTolerance)


def _keep(ctx: CallContext, c: dict, mask: np.ndarray) -> int:
    c["pts"], c["rgb"] = c["pts"][mask], c["rgb"][mask]
    return len(c["pts"])


@sim_function("removePointsFromPointCloud")
def removePointsFromPointCloud(ctx: CallContext, pointCloudHandle: Any, options: Any, points: Any,  # noqa: N802, N803
                               tolerance: Any) -> int:  # noqa: N803
    """Remove the cloud's points within ``tolerance`` (m) of any of ``points`` (world; bit 0 of
    ``options``: relative to the cloud); nil points: all of them. The cloud's point count.

    ``sim.removePointsFromPointCloud``.

    Args:
        pointCloudHandle: the point cloud's handle.
        options: bit 0: points relative to the cloud.
        points: 3n numbers (m), or None.
        tolerance: m.

    Returns:
        The point count.

    Raises:
        UnknownObjectError: not a point cloud.
        ArgumentError: points of the wrong length or kind.
    """
    c, opts = cloud(ctx, pointCloudHandle, "pointCloud"), _int(options, "options")
    if points is None:
        return _keep(ctx, c, np.zeros(len(c["pts"]), dtype=bool))
    local = to_local(ctx, ctx.h(pointCloudHandle, "h"), _points(points), bool(opts & 1))
    return _keep(ctx, c, ~geo.near_mask(c["pts"], local, _num(tolerance, "tolerance")))


@sim_function("intersectPointsWithPointCloud")
def intersectPointsWithPointCloud(ctx: CallContext, pointCloudHandle: Any, options: Any, points: Any,  # noqa: N802, N803
                                  tolerance: Any) -> int:  # noqa: N803
    """Keep only the cloud's points within ``tolerance`` (m) of one of ``points``. The count.

    ``sim.intersectPointsWithPointCloud``.

    Args:
        pointCloudHandle: the point cloud's handle.
        options: bit 0: points relative to the cloud.
        points: 3n numbers, m.
        tolerance: m.

    Returns:
        The point count.

    Raises:
        UnknownObjectError: not a point cloud.
        ArgumentError: points of the wrong length or kind.
    """
    c, opts = cloud(ctx, pointCloudHandle, "pointCloud"), _int(options, "options")
    local = to_local(ctx, ctx.h(pointCloudHandle, "h"), _points(points), bool(opts & 1))
    return _keep(ctx, c, geo.near_mask(c["pts"], local, _num(tolerance, "tolerance")))


@sim_function("insertObjectIntoPointCloud")
def insertObjectIntoPointCloud(ctx: CallContext, pointCloudHandle: Any, objectHandle: Any, options: Any,  # noqa: N802, N803
                               gridSize: Any, color: Any = None, duplicateTolerance: Any = None) -> int:  # noqa: N803
    """Add an object's points: a shape's surface sampled ``gridSize`` m apart, a point cloud's
    points, an octree's voxel centres, a dummy's position. The cloud's point count.

    ``sim.insertObjectIntoPointCloud``.

    Args:
        pointCloudHandle: the point cloud's handle.
        objectHandle: a shape, point cloud, octree or dummy.
        options: checked, ignored.
        gridSize: m, the sampling step on a shape.
        color: 3 numbers in 0..1, or None.
        duplicateTolerance: m, or None.

    Returns:
        The point count.

    Raises:
        UnknownObjectError: not a point cloud, or no such object.
        ArgumentError: a bad argument.
        UnsupportedError: an object that is no shape, dummy, point cloud or octree.
    """
    c, h = cloud(ctx, pointCloudHandle, "pointCloud"), ctx.h(pointCloudHandle, "pointCloudHandle")
    _int(options, "options")
    world = object_points(ctx, objectHandle, _num(gridSize, "gridSize"))
    local = to_local(ctx, h, world, False)
    return _add_points(ctx, h, c, local, _colours(color, len(local), False), duplicateTolerance)


@sim_function("subtractObjectFromPointCloud")
def subtractObjectFromPointCloud(ctx: CallContext, pointCloudHandle: Any, objectHandle: Any, options: Any,  # noqa: N802, N803
                                 tolerance: Any) -> int:  # noqa: N803
    """Remove the cloud's points that collide with an object (inside a shape's solid, an
    octree's voxels, or within ``tolerance`` m of it). The cloud's point count.

    ``sim.subtractObjectFromPointCloud``.

    Args:
        pointCloudHandle: the point cloud's handle.
        objectHandle: a shape, point cloud, octree or dummy.
        options: checked, ignored.
        tolerance: m.

    Returns:
        The point count.

    Raises:
        UnknownObjectError: not a point cloud, or no such object.
        ArgumentError: a bad argument.
        UnsupportedError: an object that is no shape, dummy, point cloud or octree.
    """
    c, h = cloud(ctx, pointCloudHandle, "pointCloud"), ctx.h(pointCloudHandle, "pointCloudHandle")
    _int(options, "options")
    if not len(c["pts"]):
        return 0
    return _keep(ctx, c, ~inside_of(ctx, objectHandle, to_world(ctx, h, c["pts"]), _num(tolerance, "tolerance")))


