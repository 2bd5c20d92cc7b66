"""CoppeliaSim 4.x's joint intervals, modes and dependencies on MuJoCo (``sim.getJointInterval``,
``sim.setJointMode``, ``sim.getJointDependency`` ...): intervals are MuJoCo's ``jnt_range``; modes
map onto simx's motors; dependencies are MJCF joint equalities.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_vector as _vector
from simx_server.sim import mechanisms
from simx_server.sim.objects import JOINT

#: CoppeliaSim's ``sim.jointmode_kinematic`` (0), ``dependent`` (4), ``dynamic`` (5).
JOINTMODE_KINEMATIC, JOINTMODE_DEPENDENT, JOINTMODE_DYNAMIC = 0, 4, 5


# Joint intervals, modes and dependencies.

def _joint(ctx: CallContext, handle: Any) -> Any:
    return ctx.world.get(ctx.h(handle, "jointHandle"), JOINT)


@sim_function("getJointInterval")
def getJointInterval(ctx: CallContext, objectHandle: Any) -> tuple[bool, list[float]]:  # noqa: N802, N803
    """``cyclic, interval``: interval = ``[min, range]`` (rad or m, MuJoCo's ``jnt_range``);
    a hinge without limits is cyclic (``[-pi, 2 pi]``).

    Args:
        objectHandle: a joint's handle.

    Returns:
        ``(cyclic, [min, range])``.
    """
    obj = _joint(ctx, objectHandle)
    m = ctx.world.model
    lo, hi = (float(v) for v in m.jnt_range[obj.mj_id])
    if not m.jnt_limited[obj.mj_id]:
        if int(m.jnt_type[obj.mj_id]) == mujoco.mjtJoint.mjJNT_HINGE:
            return True, [-np.pi, 2 * np.pi]
        return False, [-1e6, 2e6]
    return False, [lo, hi - lo]


@sim_function("setJointInterval")
def setJointInterval(ctx: CallContext, objectHandle: Any, cyclic: Any, interval: Any) -> None:  # noqa: N802, N803
    """Set the joint's limits ``[min, range]`` (rad or m); ``cyclic`` true removes them (a
    hinge). Written to the model and the scene's MjSpec (kept by later edits).

    Args:
        objectHandle: a joint's handle.
        cyclic: true to remove the limits.
        interval: ``[min, range]``, rad or m.

    Raises:
        ArgumentError: a negative range.
    """
    obj = _joint(ctx, objectHandle)
    lo, span = _vector(interval, 2, "interval")
    if span < 0:
        raise ArgumentError("interval's range must not be negative")
    m = ctx.world.model
    m.jnt_range[obj.mj_id] = [lo, lo + span]
    m.jnt_limited[obj.mj_id] = not cyclic
    sim = ctx.view
    try:
        el = sim.editor._live_spec().joint(obj.name) if sim is not None else None
    except UnsupportedError:
        el = None
    if el is not None:
        el.range = [lo, lo + span]
        el.limited = mujoco.mjtLimited.mjLIMITED_FALSE if cyclic else mujoco.mjtLimited.mjLIMITED_TRUE
    ctx.world.changed()


@sim_function("getJointMode")
def getJointMode(ctx: CallContext, jointHandle: Any) -> tuple[int, int]:  # noqa: N802, N803
    """``jointMode, options``: ``sim.jointmode_dynamic`` (5) for a joint with a motor, else
    ``sim.jointmode_kinematic`` (0); options 0.

    Args:
        jointHandle: a joint's handle.

    Returns:
        ``(mode, 0)``.
    """
    obj = _joint(ctx, jointHandle)
    return (JOINTMODE_DYNAMIC if obj.handle in ctx.world.motor_index else JOINTMODE_KINEMATIC), 0


@sim_function("setJointMode")
def setJointMode(ctx: CallContext, jointHandle: Any, jointMode: Any, options: Any = 0) -> None:  # noqa: N802, N803
    """Only ``sim.jointmode_dynamic`` (5, or its ``jointmode_force`` alias) for a joint with a
    motor: simx's joints are all simulated by MuJoCo (kinematic and dependent modes are not).

    Args:
        jointHandle: a joint's handle.
        jointMode: 5.
        options: ignored.

    Raises:
        UnsupportedError: another mode, or a joint without a motor.
    """
    obj = _joint(ctx, jointHandle)
    mode = _int(jointMode, "jointMode")
    if mode != JOINTMODE_DYNAMIC or obj.handle not in ctx.world.motor_index:
        raise UnsupportedError(f"setJointMode {mode}: simx's joints are dynamic (MuJoCo); kinematic, IK and "
                               "dependent modes do not exist (use setJointPosition to place a joint)")


@sim_function("getJointDependency")
def getJointDependency(ctx: CallContext, jointHandle: Any) -> tuple[int, float, float]:  # noqa: N802, N803
    """``masterJointHandle, offset, multCoeff`` of an MJCF joint equality (``<joint joint1
    joint2 polycoef>``), in V-REP's terms: q1 = offset + coeff·q2 on the joints' positions
    (MuJoCo's polycoef is relative to their ``ref``), or ``-1, 0, 1`` without one.

    Args:
        jointHandle: a joint's handle.

    Returns:
        ``(masterHandle, offset, coefficient)``.
    """
    obj = _joint(ctx, jointHandle)
    found = mechanisms.dependency(ctx.world.model, obj.mj_id)
    if found is None:
        return -1, 0.0, 1.0
    by_id = {o.mj_id: o.handle for o in ctx.world.objects.values() if o.type == JOINT}
    return by_id.get(found[0], -1), found[1], found[2]


