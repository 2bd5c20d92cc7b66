"""CoppeliaSim 4.x's joint intervals, modes and dependencies on MuJoCo (``sim.getJointInterval``,
``sim.setJointMode``, ``sim.getJointDependency`` ...): intervals are MuJoCo's ``jnt_range``; modes
map onto simx's motors and kinematic joints (:mod:`simx_server.sim.kinematic`); dependencies are
MJCF joint equalities.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_vector as _vector
from simx_server.sim import kinematic, mechanisms
from simx_server.sim.objects import JOINT

#: CoppeliaSim's ``sim.jointmode_kinematic`` (0), ``dependent`` (4), ``dynamic`` (5).
JOINTMODE_KINEMATIC, JOINTMODE_DEPENDENT, JOINTMODE_DYNAMIC = 0, 4, 5
_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)  # an int: comparing with MuJoCo's enum costs 1.4 us


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
    lo, hi = m.jnt_range[obj.mj_id].tolist()
    if not m.jnt_limited[obj.mj_id]:
        if int(m.jnt_type[obj.mj_id]) == _HINGE:
            return True, [-np.pi, 2 * np.pi]
        return False, [-1e6, 2e6]
    return False, [lo, hi - lo]


@sim_function("setJointInterval")
def setJointInterval(ctx: CallContext, objectHandle: Any, cyclic: Any, interval: Any) -> None:  # noqa: N802, N803
    """Set the joint's limits ``[min, range]`` (rad or m); ``cyclic`` true removes them (a
    hinge). Written to the model and the scene's MjSpec (kept by later edits). A hinge or slide
    outside its new limits is put at the nearest one, as coppeliaSimLib's
    ``simSetJointInterval_internal`` puts the joint back at its position through
    ``CJoint::setPosition``, which clamps it to the interval: RLBench's ``ERJointViaIK`` narrows
    a joint's interval around the angle it commands, so that the IK that follows
    (``sim.checkIkGroup``, which holds that joint) solves the other joints around it.

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
    ctx.world.refresh_cyclic()
    if not cyclic and int(m.jnt_type[obj.mj_id]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
        q = ctx.world.joint_position(obj.handle)
        if not lo <= q <= lo + span:
            i = ctx.world.motor_index.get(obj.handle)
            target = None if i is None else float(ctx.world.motors.target_position[i])
            ctx.world.set_joint_position(obj.handle, min(max(q, lo), lo + span))  # (calls changed())
            if target is not None:  # CJoint::setPosition leaves the motor's target as it was
                ctx.world.motors.target_position[i] = target
            return
    ctx.world.changed()


@sim_function("getJointMode")
def getJointMode(ctx: CallContext, jointHandle: Any) -> tuple[int, int]:  # noqa: N802, N803
    """``jointMode, options``: the mode :func:`setJointMode` gave a joint with a motor
    (``sim.jointmode_dynamic``, 5, unless set), ``sim.jointmode_kinematic`` (0) for a joint
    without one; options 0 (coppeliaSimLib ``simGetJointMode_internal``).

    Args:
        jointHandle: a joint's handle.

    Returns:
        ``(mode, 0)``.
    """
    obj = _joint(ctx, jointHandle)
    i = ctx.world.motor_index.get(obj.handle)
    return (JOINTMODE_KINEMATIC if i is None else int(ctx.world.motors.joint_mode[i])), 0


@sim_function("setJointMode")
def setJointMode(ctx: CallContext, jointHandle: Any, jointMode: Any, options: Any = 0) -> None:  # noqa: N802, N803
    """A joint with a motor in force/torque mode (``sim.jointmode_dynamic`` / 4.1's
    ``sim_jointmode_force``, 5: driven by physics) or in a kinematic mode (4.1's
    ``sim_jointmode_passive`` 0 / ``sim.jointmode_kinematic``, ``sim_jointmode_ik`` 2): held
    where ``sim.setJointPosition`` puts it, carrying its bodies as a rigid link, no motor force
    (:mod:`simx_server.sim.kinematic`; the first kinematic joint of a scene adds the equalities
    that hold them: one recompile). Stopping the simulation gives every joint its mode at the
    start, as CoppeliaSim's ``CJoint::simulationEnded``. coppeliaSimLib
    ``simSetJointMode_internal`` -> ``CJoint::setJointMode``.

    Args:
        jointHandle: a joint's handle.
        jointMode: 5, 0 or 2.
        options: checked (bit 0, V-REP's "hybrid" operation, has no meaning in simx).

    Raises:
        ObjectTypeError: a joint without a motor of its own (spherical, tendon-driven).
        UnsupportedError: the dependent modes (3, 4: use ``sim.setJointDependency``), 1, or a
            scene that cannot be edited.
    """
    obj = _joint(ctx, jointHandle)
    mode = _int(jointMode, "jointMode")
    _int(options, "options")
    world = ctx.world
    i = world.motor(obj.handle)
    if mode == JOINTMODE_DYNAMIC:
        world.motors.set_joint_mode(i, mode)
        kinematic.release(world, i)
        return
    if mode not in kinematic.KINEMATIC_MODES:
        raise UnsupportedError(f"setJointMode {mode}: simx's joint modes are 5 (force/torque), 0 (passive, "
                               "kinematic) and 2 (IK); a dependent joint is made with setJointDependency")
    if kinematic.equalities(world)[i] < 0:  # the scene's first kinematic joint: the equalities
        sim = ctx.simulation("setJointMode")
        m = world.model
        names = [n for a in world.motors.act
                 if (n := mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.actuator_trnid[a, 0])))]
        name = obj.name
        sim.editor._edit(lambda spec: kinematic.add_equalities(spec, names))
        world = ctx.world
        i = world.motor(world.by_name[name].handle)
    world.motors.set_joint_mode(i, mode)


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


