"""CoppeliaSim 4.x's dynamic control mode of a joint (``sim.jointintparam_dynctrlmode``, 2039) and
its target force, on :class:`~simx_server.sim.motors.Motors`.

CoppeliaSim 4.x gives a joint in dynamic mode one control mode (coppeliaSimLib ``CJoint::
setDynCtrlMode``, ``CJoint::handleDynJoint``), where V-REP 3.x had two flags (motor enabled,
control loop enabled; simx keeps both, :mod:`simx_server.sim.motors`):

==========  =====  ==========================================================================
mode        value  what the motor does (each substep)
==========  =====  ==========================================================================
free        0      nothing (motor off)
force       1      applies the signed target force (``sim.setJointTargetForce``), whatever the
                   joint does: torque control
velocity    4      runs at the target velocity with at most the target force's magnitude
position    8      V-REP's position loop toward the target position (upper velocity, P gain)
spring      12     a spring-damper ``K e + C de/dt`` about the target position (K, C:
                   ``sim.jointfloatparam_kc_k`` / ``_kc_c``; :mod:`simx_server.sim.joint_springs`)
callback    16     the scripts' joint callback decides, at each substep
                   (:mod:`simx_server.scripts.dynamics`): 0 force until one answers
==========  =====  ==========================================================================

A change of mode sets the target velocity as ``CJoint::setDynCtrlMode`` does: 1000 for force and
spring (so that the spring is a force, never a speed limit), pi/2 rad/s (0.1 m/s prismatic) for
velocity; position and callback keep it. The legacy flags read as CoppeliaSim 4.x reads them
(``simGetObjectInt32Param``: motor enabled = mode != free, control loop = mode >= position).

The target force is signed (``CJoint::setTargetForce``): a signed force of the other sign than the
target velocity turns the target velocity round, an unsigned one (``signedValue`` false, V-REP's
``simxSetJointForce``) takes the target velocity's sign; a target velocity of the other sign
turns the force round (``CJoint::setTargetVelocity``). Its magnitude is the maximum force the
other modes use. A stop gives every joint the mode it started with (``CJoint::simulationEnded``).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import quote
from simx_server.sim.joint_springs import Springs

#: ``sim.jointdynctrl_free``, ``_force``, ``_velocity``, ``_position``, ``_spring``, ``_callback``.
FREE, FORCE, VELOCITY, POSITION, SPRING, CALLBACK = 0, 1, 4, 8, 12, 16
MODES = {FREE: "free", FORCE: "force", VELOCITY: "velocity", POSITION: "position", SPRING: "spring",
         CALLBACK: "callback"}
#: The target velocity ``CJoint::setDynCtrlMode`` gives force and spring modes (``just a very high value``).
HIGH_VELOCITY = 1000.0
#: ... and velocity mode: rad/s for revolute joints, m/s for prismatic ones.
VELOCITY_REVOLUTE, VELOCITY_PRISMATIC = math.pi / 2, 0.1


def joints(m, ids: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The motors' joint ids and which are hinges (those that can be cyclic).

    Args:
        m: the MjModel.
        ids: the motors' joint ids.

    Returns:
        ``(ids, hinge)``, each (n,).
    """
    hinge = np.array([int(m.jnt_type[j]) == int(mujoco.mjtJoint.mjJNT_HINGE) for j in ids], dtype=bool)
    return np.array(ids, dtype=int), hinge


def reset(motors) -> None:
    """The motors' state of this module as the scene starts (``CJoint::simulationEnded``): each
    motor's force and callback modes as the scene says (``mode=force``, ``mode=callback``), the
    target force's sign the target velocity's, no callback answer.

    Args:
        motors: the Motors (after their target velocities are reset).
    """
    n = len(motors.act)
    motors.force_sign = np.where(motors.target_velocity < 0, -1.0, 1.0)
    motors.force_mode = motors.initial_force_mode.copy()
    motors.callback_mode = motors.initial_callback_mode.copy()
    motors.callback_velocity, motors.callback_force = np.zeros(n), np.zeros(n)
    motors.callback_pure = np.zeros(n, dtype=bool)


def mode(motors, i: int) -> int:
    """CoppeliaSim 4.x's dynamic control mode of motor ``i`` (``CJoint::getDynCtrlMode``).

    Args:
        motors: the world's :class:`~simx_server.sim.motors.Motors`.
        i: a motor number.

    Returns:
        One of FREE, FORCE, VELOCITY, POSITION, SPRING, CALLBACK.
    """
    if not motors.enabled[i]:
        return FREE
    if motors.force_mode[i]:
        return FORCE
    if motors.callback_mode[i]:
        return CALLBACK
    if not motors.loop[i]:
        return VELOCITY
    springs = motors.springs
    return SPRING if springs is not None and springs.mask[i] else POSITION


def set_mode(world, handle: int, value: int, name: str) -> None:
    """Put joint ``handle``'s motor in CoppeliaSim 4.x's dynamic control mode ``value``
    (``CJoint::setDynCtrlMode``); the same mode again changes nothing.

    Args:
        world: the World.
        handle: a joint's handle.
        value: FREE, FORCE, VELOCITY, POSITION, SPRING or CALLBACK.
        name: the parameter's name, for messages.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
        ArgumentError: another value.
    """
    i = world.motor(handle)
    if value not in MODES:
        raise ArgumentError(f"{name}: {quote(value)} is not a joint control mode (sim.jointdynctrl_free 0, "
                            "_force 1, _velocity 4, _position 8, _spring 12, _callback 16)")
    mo = world.motors
    if value == mode(mo, i):
        return
    mo.enabled[i] = value != FREE
    mo.loop[i] = value in (POSITION, SPRING, CALLBACK)
    mo.force_mode[i] = value == FORCE
    mo.callback_mode[i] = value == CALLBACK
    mo.callback_velocity[i] = mo.callback_force[i] = 0.0
    mo.callback_pure[i] = False
    if value == SPRING or (mo.springs is not None and mo.springs.mask[i]):
        springs(mo).mask[i] = value == SPRING
    if value in (FORCE, SPRING):
        set_target_velocity(mo, i, HIGH_VELOCITY)
    elif value == VELOCITY:
        prismatic = not mo._hinge[i]
        set_target_velocity(mo, i, VELOCITY_PRISMATIC if prismatic else VELOCITY_REVOLUTE)
    mo.refresh_flags()
    mo.write_force_limits(world.model)  # a force or callback mode's own ranges go


def apply_forced(motors, views, forced: np.ndarray, scripted: np.ndarray) -> None:
    """The motors of CoppeliaSim 4.x's force mode, and those its callback mode drives
    (``CJoint::handleDynJoint``): a motor in force mode (or whose callback gave a force only)
    applies its signed force, ``tau = f`` (the engine's velocity motor at +-10000 with that force,
    always at its limit); one whose callback gave a velocity runs the motors' velocity law at
    that velocity with at most the callback's force (after :meth:`~simx_server.sim.motors.Motors.apply`, which wrote the rest).

    Args:
        motors: the Motors.
        views: the model's and data's arrays (``motor_views.Views``).
        forced: (n,) the motors that apply a force.
        scripted: (n,) the callback motors with a velocity.
    """
    fr = views.forcerange
    if np.count_nonzero(scripted):
        a = motors.act[scripted]
        limit = np.abs(motors.callback_force[scripted] / motors.gear[scripted])
        fr[a, 0], fr[a, 1] = -limit, limit
    if np.count_nonzero(forced):
        a = motors.act[forced]
        f = np.where(motors.callback_mode, motors.callback_force, motors.force_sign * motors.max_force)[forced]
        g = motors.gear[forced]
        views.gainprm[a, 0] = 0.0
        views.biasprm[a, 0] = f / g
        views.biasprm[a, 1] = 0.0
        views.biasprm[a, 2] = 0.0
        views.ctrl[a] = 0.0
        fr[a, 0], fr[a, 1] = -np.abs(f / g), np.abs(f / g)



def position_error(motors, jnt_limited: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The position laws' goals and errors: target minus position, a cyclic joint's (a hinge
    without limits) taken the shortest way round, in [-pi, pi] (simDyn's ``getAngleMinusAlpha``
    in ``_handleMotorControl``: V-REP's cyclic joints never turn more than half a turn to a target).

    Args:
        motors: the Motors.
        jnt_limited: the model's ``jnt_limited`` (limits change at run time: ``sim.setJointInterval``).
        q: (n,) the joints' positions.

    Returns:
        ``(goal, error)``, each (n,): the goal is ``q + error`` (the target itself, or the same
        angle the shortest way round).
    """
    goal = motors.target_position
    err = goal - q
    key, cyclic, any_cyclic = motors.cyclic_kept
    limited = jnt_limited.tobytes()
    if key != limited:  # the joints' limits changed (kept while they are the same)
        cyclic = motors._hinge & (jnt_limited[motors.jnt] == 0)
        any_cyclic = bool(np.count_nonzero(cyclic))
        motors.cyclic_kept = (limited, cyclic, any_cyclic)
    if any_cyclic:
        err = np.where(cyclic, np.remainder(err + np.pi, 2 * np.pi) - np.pi, err)
        goal = q + err
    return goal, err


def split(motors, on: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The motors in force mode, or whose callback gave a force alone (``forced``), and those a
    callback gives a velocity (``scripted``), out of the motors that are on.

    Args:
        motors: the Motors.
        on: (n,) the motors that are on (enabled, in dynamic mode).

    Returns:
        ``(on, forced, scripted)``: ``on`` without the forced ones.
    """
    forced = on & (motors.force_mode | (motors.callback_mode & motors.callback_pure))
    scripted = on & motors.callback_mode & ~motors.callback_pure
    return on & ~forced, forced, scripted


def springs(motors) -> Springs:
    """The spring-damper settings of every motor, made when a program first puts a motor in the
    mode or sets its K or C (none is in the mode then).

    Args:
        motors: the Motors.

    Returns:
        The :class:`~simx_server.sim.joint_springs.Springs`.
    """
    if motors.springs is None:
        motors.springs = Springs(np.zeros(len(motors.act), bool), *motors._spring_parameters)
    return motors.springs


def set_target_velocity(motors, i: int, velocity: float) -> None:
    """Motor ``i``'s target velocity (rad/s or m/s), its target force turned to the same sign
    (``CJoint::setTargetVelocity``).

    Args:
        motors: the Motors.
        i: a motor number.
        velocity: rad/s or m/s.
    """
    motors.target_velocity[i] = velocity
    if velocity * motors.force_sign[i] < 0:
        motors.force_sign[i] = -motors.force_sign[i]


def set_target_force(motors, i: int, force: float, signed: bool) -> None:
    """Motor ``i``'s target force (N or N·m; ``CJoint::setTargetForce``): ``signed``, its sign is
    kept and a target velocity of the other sign turned round; unsigned, a negative force is 0 and
    the force takes the target velocity's sign.

    Args:
        motors: the Motors.
        i: a motor number.
        force: N or N·m.
        signed: keep the force's sign.
    """
    velocity = float(motors.target_velocity[i])
    if not signed:
        force = max(force, 0.0)
        if velocity < 0:
            force = -force
    motors.max_force[i] = abs(force)
    if force != 0:
        motors.force_sign[i] = 1.0 if force > 0 else -1.0
    if force * velocity < 0:
        motors.target_velocity[i] = -velocity


def target_force(motors, i: int) -> float:
    """Motor ``i``'s signed target force (``CJoint::getTargetForce(true)``), N or N·m.

    Args:
        motors: the Motors.
        i: a motor number.

    Returns:
        N or N·m.
    """
    return float(motors.force_sign[i] * motors.max_force[i])
