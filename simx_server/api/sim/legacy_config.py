"""V-REP 3.x's configuration trees: ``sim.getConfigurationTree`` / ``sim.setConfigurationTree``
(deprecated in CoppeliaSim 4.2, still used by old scene scripts to put a robot back as it was).

As coppeliaSimLib ``simGetConfigurationTree_internal`` / ``simSetConfigurationTree_internal``
and ``CMemorizedConf_old``: each object of the tree (``sim.handle_all``: the scene) is kept with
its parent and its pose relative to that parent, a joint also with its position (a spherical
joint with its rotation, as ``CMemorizedConf_old`` keeps ``getSphericalTransformation``);
restoring goes parents first, sets each object still under the same parent back to its local
pose (an object whose pose follows from its joints is already there once they are) and each
joint to its position, and stops the moved objects (``resetDynamicObject``).

The buffer is simx's own (a client only hands back what it got): ``SIMXCT2``, then per object
i32 handle, i32 parent handle (-1: the world), 7 f64 (x y z qx qy qz qw, m), f64 joint position
(NaN for other objects) and 4 f64, a spherical joint's quaternion (w x y z, MuJoCo's; NaN for
other objects).
"""

from __future__ import annotations

import math
import struct
from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ObjectTypeError
from simx_server.sim.objects import JOINT, WORLD

_MAGIC = b"SIMXCT2"
_ITEM = struct.Struct("<ii7dd4d")
_BALL = int(mujoco.mjtJoint.mjJNT_BALL)
_NO_QUAT = (math.nan,) * 4


def _tree(ctx: CallContext, root: int) -> list[int]:
    """``root`` and every object below it, parents first (the scene for ``sim.handle_all``)."""
    w = ctx.world
    if root in (C.sim_handle_all, -12):  # sim.handle_all, sim.handle_scene (4.x)
        return list(w.objects)
    out, todo = [], [w.get(root).handle]
    while todo:
        h = todo.pop(0)
        out.append(h)
        todo.extend(o.handle for o in w.objects.values() if o.parent == h)
    return out


@sim_function("getConfigurationTree")
def getConfigurationTree(ctx: CallContext, objectHandle: Any) -> bytes:  # noqa: N802, N803
    """The configuration of an object's tree (``sim.handle_all``: the whole scene) as a buffer
    for :func:`setConfigurationTree` (V-REP 3.x ``simGetConfigurationTree``).

    Args:
        objectHandle: the tree's base, or ``sim.handle_all``.

    Returns:
        The buffer (simx's layout, see the module).

    Raises:
        UnknownObjectError: no such object.
    """
    w = ctx.world
    parts = [_MAGIC]
    for h in _tree(ctx, ctx.h(objectHandle, "objectHandle")):
        obj = w.objects[h]
        pose = ctx.sim.getObjectPose(h, obj.parent)
        jtype = int(w.model.jnt_type[obj.mj_id]) if obj.type == JOINT else -1
        q = w.joint_position(h) if jtype in (2, 3) else math.nan
        quat = _NO_QUAT
        if jtype == _BALL:
            a = int(w.model.jnt_qposadr[obj.mj_id])
            quat = tuple(float(x) for x in w.data.qpos[a:a + 4])
        parts.append(_ITEM.pack(h, obj.parent, *pose, q, *quat))
    return b"".join(parts)


@sim_function("setConfigurationTree")
def setConfigurationTree(ctx: CallContext, rawBufferHandle: Any) -> int:  # noqa: N802, N803
    """Put back what :func:`getConfigurationTree` kept (V-REP 3.x ``simSetConfigurationTree``):
    objects gone since are skipped, an object under another parent keeps its pose, joints
    return to their positions; what moved is stopped. Returns 1.

    Args:
        rawBufferHandle: the buffer :func:`getConfigurationTree` answered.

    Returns:
        1.

    Raises:
        ArgumentError: not such a buffer.
    """
    raw = rawBufferHandle.encode("latin-1") if isinstance(rawBufferHandle, str) else rawBufferHandle
    if not isinstance(raw, (bytes, bytearray)) or not bytes(raw).startswith(_MAGIC) or \
            (len(raw) - len(_MAGIC)) % _ITEM.size:
        raise ArgumentError("setConfigurationTree: not a buffer of sim.getConfigurationTree")
    w = ctx.world
    items = [_ITEM.unpack_from(raw, len(_MAGIC) + k * _ITEM.size) for k in range((len(raw) - len(_MAGIC)) // _ITEM.size)]

    def depth(h: int) -> int:
        n = 0
        while h != WORLD and h in w.objects and n <= len(w.objects):
            h, n = w.objects[h].parent, n + 1
        return n

    moved = []
    for h, parent, *rest in sorted(items, key=lambda item: depth(item[0])):
        obj = w.objects.get(h)
        if obj is None or obj.parent != parent:
            continue
        pose, q, quat = rest[:7], rest[7], rest[8:12]
        if obj.type == JOINT:
            if not math.isnan(q) and abs(w.joint_position(h) - q) > 1e-12:
                ctx.sim.setJointPosition(h, q)
                moved.append(h)
            elif not math.isnan(quat[0]) and int(w.model.jnt_type[obj.mj_id]) == _BALL:
                a, v = int(w.model.jnt_qposadr[obj.mj_id]), int(w.model.jnt_dofadr[obj.mj_id])
                if not np.allclose(w.data.qpos[a:a + 4], quat, atol=1e-12):
                    w.data.qpos[a:a + 4] = quat
                    w.data.qvel[v:v + 3] = 0.0
                    w.changed()
                    moved.append(h)
        elif not np.allclose(ctx.sim.getObjectPose(h, parent), pose, atol=1e-9):
            try:
                ctx.sim.setObjectPose(h, parent, list(pose))
            except ObjectTypeError:  # moved by its joints (a spherical one): there once they are
                continue
            moved.append(h)
    for h in moved:
        ctx.sim.resetDynamicObject(h)
    return 1
