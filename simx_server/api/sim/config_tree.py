"""``sim.getConfigurationTree`` / ``sim.setConfigurationTree``: save and restore the
configuration of a hierarchy tree (poses relative to the parents, joint positions).

CoppeliaSim's ``CSceneObjectContainer::getConfigurationTree`` writes, for each object of the
tree, its handle, its local transformation and (joints) its position, as an opaque buffer that
``setConfigurationTree`` applies back. Here the buffer is that too: a magic tag, then per
object its handle (int32), its pose relative to its parent (7 doubles: x y z qx qy qz qw, m)
and its joint position (a double, NaN for other objects), little-endian. Restoring re-creates
moving objects in the physics at their saved pose (``sim.resetDynamicObject``), so they
restart at rest.
"""

from __future__ import annotations

import math
import struct
from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.sim.objects import JOINT
from simx_wire.protocol import ArgumentError

_MAGIC = b"SIMXCFG1"
_ITEM = struct.Struct("<i8d")
_HANDLE_PARENT = -11  # sim.handle_parent
_HANDLE_SCENE = -12  # sim.handle_scene


@sim_function("getConfigurationTree")
def getConfigurationTree(ctx: CallContext, objectHandle: Any) -> bytes:  # noqa: N802, N803
    """The configuration of the tree based at ``objectHandle`` (``sim.handle_scene``: every object).

    ``sim.getConfigurationTree``.

    Args:
        objectHandle: the tree's base, or ``sim.handle_scene``.

    Returns:
        An opaque buffer for ``sim.setConfigurationTree``.

    Raises:
        UnknownObjectError: no such object.
    """
    handles = ctx.sim.getObjectsInTree(objectHandle, -2, 0)
    out = [_MAGIC]
    for h in handles:
        pose = ctx.sim.getObjectPose(h, _HANDLE_PARENT)
        joint = float(ctx.sim.getJointPosition(h)) if ctx.world.get(h).type == JOINT else math.nan
        out.append(_ITEM.pack(int(h), *[float(v) for v in pose], joint))
    return b"".join(out)


@sim_function("setConfigurationTree")
def setConfigurationTree(ctx: CallContext, data: Any) -> None:  # noqa: N802
    """Restore a configuration saved by ``sim.getConfigurationTree`` (objects removed since are skipped).

    ``sim.setConfigurationTree``.

    Args:
        data: the buffer.

    Raises:
        ArgumentError: not such a buffer.
    """
    if not isinstance(data, (bytes, bytearray)) or not bytes(data).startswith(_MAGIC) \
            or (len(data) - len(_MAGIC)) % _ITEM.size:
        raise ArgumentError("data must be a buffer of sim.getConfigurationTree")
    items = [_ITEM.unpack_from(data, off) for off in range(len(_MAGIC), len(data), _ITEM.size)]
    world = ctx.world
    present = [item for item in items if item[0] in world.objects]
    for h, *rest in present:
        pose, joint = rest[:7], rest[7]
        if not math.isnan(joint):
            ctx.sim.setJointPosition(h, joint)
        ctx.sim.setObjectPose(h, _HANDLE_PARENT, list(pose))
    for h, *_ in present:
        ctx.sim.resetDynamicObject(h)
