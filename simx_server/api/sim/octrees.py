"""CoppeliaSim 4.x's octrees kept as data: ``sim.createOctree`` and the calls on octrees. An octree
is a scene object with a frame (as a point cloud, :mod:`simx_server.api.sim.clouds`, whose helpers
these calls share): a set of cubic voxels of one size on a grid aligned with that frame (centres at
``(i + 0.5) * voxelSize``), each with a colour and a tag.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import clouds as _clouds
from simx_server.api.sim import paths as _paths
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.api import cloud_geometry as geo
from simx_server.api.sim.clouds import MAX_POINTS, _colours, _points
from simx_server.sim.objects import SHAPE


# ``sim.createOctree`` and the calls on octrees (the helpers come from :mod:`simx_server.api.sim.clouds`).

@sim_function("createOctree")
def createOctree(ctx: CallContext, voxelSize: Any, options: Any, pointSize: Any) -> int:  # noqa: N802, N803
    """A new, empty octree of ``voxelSize`` (m) voxels at the world origin; its handle.

    ``sim.createOctree``.

    Args:
        voxelSize: m, positive.
        options: kept.
        pointSize: pixels, kept.

    Returns:
        The octree's handle.

    Raises:
        ArgumentError: a size that is not positive, or not numbers.
    """
    size = _num(voxelSize, "voxelSize")
    if not size > 0:
        raise ArgumentError("voxelSize must be positive")
    h = _clouds.new_frame(ctx, "Octree")
    _paths.store_of(ctx, "clouds")[h] = {"kind": "octree", "size": size, "options": _int(options, "options"),
                                "pointSize": _num(pointSize, "pointSize"), "keys": np.empty((0, 3), np.int64),
                                "rgb": np.empty((0, 3)), "tags": np.empty(0, np.int64)}
    return h


def _add_voxels(ctx: CallContext, c: dict, local: np.ndarray, rgb: np.ndarray, tags: np.ndarray) -> int:
    keys = np.vstack([c["keys"], np.floor(local / c["size"]).astype(np.int64)])
    _, first = np.unique(keys, axis=0, return_index=True)  # a voxel already there keeps its colour and tag
    first.sort()
    if len(first) > MAX_POINTS:
        raise ArgumentError(f"an octree holds at most {MAX_POINTS} voxels")
    c["keys"], c["rgb"] = keys[first], np.vstack([c["rgb"], rgb])[first]
    c["tags"] = np.concatenate([c["tags"], tags])[first]
    return len(c["keys"])


@sim_function("insertVoxelsIntoOctree")
def insertVoxelsIntoOctree(ctx: CallContext, octreeHandle: Any, options: Any, points: Any, color: Any = None,  # noqa: N802, N803
                           tag: Any = None) -> int:
    """Occupy the voxels containing ``points`` (world; ``options`` bit 0: relative to the
    octree; bit 1: one colour and tag per point). The octree's voxel count.

    ``sim.insertVoxelsIntoOctree``.

    Args:
        octreeHandle: the octree's handle.
        options: bit 0 relative to the octree, bit 1 one colour and tag per point.
        points: 3n numbers, m.
        color: 3 numbers (3n with bit 1) in 0..1, or None.
        tag: an integer (n with bit 1), or None.

    Returns:
        The voxel count.

    Raises:
        UnknownObjectError: not an octree.
        ArgumentError: points, colours or tags of the wrong length or kind.
    """
    c, opts, h = _clouds.cloud(ctx, octreeHandle, "octree"), _int(options, "options"), ctx.h(octreeHandle, "octreeHandle")
    local = _clouds.to_local(ctx, h, _points(points), bool(opts & 1))
    n = len(local)
    if tag is None:
        tags = np.zeros(n, np.int64)
    else:
        t = [_int(v, "tag") for v in (tag if isinstance(tag, (list, tuple)) else [tag])]
        if len(t) < (n if opts & 2 else 1):
            raise ArgumentError("tag must hold one number per point (options bit 1) or one")
        tags = np.array(t[:n] if opts & 2 else t[:1] * n, np.int64)
    return _add_voxels(ctx, c, local, _colours(color, n, bool(opts & 2)), tags)


@sim_function("removeVoxelsFromOctree")
def removeVoxelsFromOctree(ctx: CallContext, octreeHandle: Any, options: Any, points: Any) -> int:  # noqa: N802, N803
    """Free the voxels containing ``points`` (nil: every voxel). The octree's voxel count.

    ``sim.removeVoxelsFromOctree``.

    Args:
        octreeHandle: the octree's handle.
        options: bit 0: points relative to the octree.
        points: 3n numbers (m), or None.

    Returns:
        The voxel count.

    Raises:
        UnknownObjectError: not an octree.
        ArgumentError: points of the wrong length or kind.
    """
    c, opts, h = _clouds.cloud(ctx, octreeHandle, "octree"), _int(options, "options"), ctx.h(octreeHandle, "octreeHandle")
    if points is None:
        keep = np.zeros(len(c["keys"]), dtype=bool)
    else:
        gone = np.floor(_clouds.to_local(ctx, h, _points(points), bool(opts & 1)) / c["size"]).astype(np.int64)
        keep = ~geo.near_mask(c["keys"].astype(float), gone.astype(float), 0.5)
    c["keys"], c["rgb"], c["tags"] = c["keys"][keep], c["rgb"][keep], c["tags"][keep]
    return len(c["keys"])


@sim_function("getOctreeVoxels")
def getOctreeVoxels(ctx: CallContext, octreeHandle: Any) -> list[float]:  # noqa: N802, N803
    """The voxels' centres relative to the octree's frame (m, x, y, z each).

    ``sim.getOctreeVoxels``.

    Args:
        octreeHandle: the octree's handle.

    Returns:
        3n floats, m.

    Raises:
        UnknownObjectError: not an octree.
    """
    c = _clouds.cloud(ctx, octreeHandle, "octree")
    return ((c["keys"] + 0.5) * c["size"]).reshape(-1).tolist()


@sim_function("checkOctreePointOccupancy")
def checkOctreePointOccupancy(ctx: CallContext, octreeHandle: Any, options: Any, points: Any) -> tuple[int, int, int, int]:  # noqa: N802, N803
    """``result, tag, locationLow, locationHigh``: result 1 when every point (``options`` bit 1:
    any point) lies in an occupied voxel; the tag of the first such voxel and its grid index
    (simx's location code: x, y, z as 21-bit fields offset by 2^20, low and high 32 bits).

    ``sim.checkOctreePointOccupancy``.

    Args:
        octreeHandle: the octree's handle.
        options: bit 0 relative to the octree, bit 1 any point.
        points: 3n numbers, m.

    Returns:
        ``(result, tag, locationLow, locationHigh)``, ints; all 0 when not occupied.

    Raises:
        UnknownObjectError: not an octree.
        ArgumentError: points of the wrong length or kind.
    """
    c, opts, h = _clouds.cloud(ctx, octreeHandle, "octree"), _int(options, "options"), ctx.h(octreeHandle, "octreeHandle")
    idx = np.floor(_clouds.to_local(ctx, h, _points(points), bool(opts & 1)) / c["size"]).astype(np.int64)
    if not len(idx) or not len(c["keys"]):
        return 0, 0, 0, 0
    hit = geo.near_mask(idx.astype(float), c["keys"].astype(float), 0.5)
    ok = hit.any() if opts & 2 else hit.all()
    if not ok:
        return 0, 0, 0, 0
    first = idx[int(np.flatnonzero(hit)[0])]
    v = int(np.flatnonzero((c["keys"] == first).all(axis=1))[0])
    code = sum(((int(first[i]) + (1 << 20)) & 0x1FFFFF) << (21 * i) for i in range(3))
    return 1, int(c["tags"][v]), code & 0xFFFFFFFF, code >> 32


@sim_function("insertObjectIntoOctree")
def insertObjectIntoOctree(ctx: CallContext, octreeHandle: Any, objectHandle: Any, options: Any, color: Any = None,  # noqa: N802, N803
                           tag: Any = 0) -> int:
    """Occupy the voxels an object passes through: a shape's surface, a point cloud's points,
    another octree's voxel centres, a dummy's position. The octree's voxel count.

    ``sim.insertObjectIntoOctree``.

    Args:
        octreeHandle: the octree's handle.
        objectHandle: a shape, point cloud, octree or dummy.
        options: checked, ignored.
        color: 3 numbers in 0..1, or None.
        tag: an integer (None: 0).

    Returns:
        The voxel count.

    Raises:
        UnknownObjectError: not an octree, or no such object.
        ArgumentError: a bad argument.
        UnsupportedError: an object that is no shape, dummy, point cloud or octree.
    """
    c, h = _clouds.cloud(ctx, octreeHandle, "octree"), ctx.h(octreeHandle, "octreeHandle")
    _int(options, "options")
    local = _clouds.to_local(ctx, h, _clouds.object_points(ctx, objectHandle, c["size"] / 2), False)
    n = len(local)
    return _add_voxels(ctx, c, local, _colours(color, n, False), np.full(n, _int(tag or 0, "tag"), np.int64))


@sim_function("subtractObjectFromOctree")
def subtractObjectFromOctree(ctx: CallContext, octreeHandle: Any, objectHandle: Any, options: Any) -> int:  # noqa: N802, N803
    """Free the voxels an object occupies: those it passes through (as
    :func:`insertObjectIntoOctree` marks them) and, for a shape, those whose centre lies in
    its solid. The octree's voxel count.

    ``sim.subtractObjectFromOctree``.

    Args:
        octreeHandle: the octree's handle.
        objectHandle: a shape, point cloud, octree or dummy.
        options: checked, ignored.

    Returns:
        The voxel count.

    Raises:
        UnknownObjectError: not an octree, or no such object.
        ArgumentError: a bad argument.
        UnsupportedError: an object that is no shape, dummy, point cloud or octree.
    """
    c, h = _clouds.cloud(ctx, octreeHandle, "octree"), ctx.h(octreeHandle, "octreeHandle")
    _int(options, "options")
    if not len(c["keys"]):
        return 0
    crossed = np.floor(_clouds.to_local(ctx, h, _clouds.object_points(ctx, objectHandle, c["size"] / 2), False)
                       / c["size"]).astype(float)
    gone = geo.near_mask(c["keys"].astype(float), crossed, 0.5)
    obj = ctx.world.get(ctx.h(objectHandle, "objectHandle"))
    if obj.type == SHAPE and ctx.h(objectHandle, "objectHandle") not in _paths.store_of(ctx, "clouds"):
        gone |= _clouds.inside_of(ctx, objectHandle, _clouds.to_world(ctx, h, (c["keys"] + 0.5) * c["size"]), 0.0)
    c["keys"], c["rgb"], c["tags"] = c["keys"][~gone], c["rgb"][~gone], c["tags"][~gone]
    return len(c["keys"])


