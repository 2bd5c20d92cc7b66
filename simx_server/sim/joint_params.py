"""Joint motors' object parameters (``simxGetObjectIntParameter`` / ``simxSetObjectFloatParameter``
on a joint): 2000 motor enabled, 2001 control loop enabled, 2030 motor locked at zero velocity,
2039 CoppeliaSim 4.x's dynamic control mode (:mod:`simx_server.sim.dyn_ctrl`), 2002-2004 PID
gains, 2017 upper velocity, 2018/2019 the spring-damper mode's K and C, read from and written to
the world's :class:`~simx_server.sim.motors.Motors`.
"""

from __future__ import annotations

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base import limits as L
from simx_server.base.arguments import quote
from simx_server.sim import dyn_ctrl
from simx_server.sim.world import World

#: Joint object parameters this module answers (legacy ids): 2000 motor enabled, 2001 control
#: loop enabled, 2030 ``sim_jointintparam_velocity_lock``, 2039 ``sim.jointintparam_dynctrlmode``
#: (ints); 2002-2004 PID gains, 2017 upper velocity, 2018/2019 ``sim.jointfloatparam_kc_k`` /
#: ``_kc_c`` (floats).
DYN_CTRL_MODE, KC_K, KC_C = 2039, 2018, 2019
INT_PARAMS = {2000, 2001, 2030, DYN_CTRL_MODE}
FLOAT_PARAMS = {2002, 2003, 2004, 2017, KC_K, KC_C}
FLOAT_SETTABLE = {2002, 2017, KC_K, KC_C}


def get_param(world: World, handle: int, pid: int) -> float | int:
    """Value of joint parameter ``pid`` (INT_PARAMS or FLOAT_PARAMS) of joint ``handle``.

    2000: 1 when the motor is enabled; 2001: 1 when its position control loop is enabled
    (V-REP reports the flag whatever the motor); 2030: 1 when the motor locks its joint where a
    zero target velocity stopped it (coppeliaSimLib ``CJoint::getMotorLock``); 2039: the dynamic
    control mode (``CJoint::getDynCtrlMode``: 0 free, 1 force, 4 velocity, 8 position, 12
    spring, 16 callback); 2002: P gain (V-REP's units: the loop asks
    P * error / 5 ms); 2003/2004: I and D gains, always 0 (simx's loop is proportional);
    2017: upper velocity (rad/s or m/s); 2018/2019: the spring-damper mode's K (N/m, N·m/rad)
    and C (N·s/m, N·m·s/rad). 2000/2001/2039 read 0 on a joint without a motor of its
    own (spherical, tendon-driven); the float ids raise ObjectTypeError there.

    Args:
        world: the world.
        handle: a joint's handle.
        pid: a ``sim_jointintparam_*`` / ``sim_jointfloatparam_*`` id (INT_PARAMS, FLOAT_PARAMS).

    Returns:
        An int for 2000/2001/2030/2039, else a float (gains; velocity in rad/s or m/s).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint, or a float id of a joint without a motor of its own.
    """
    mo = world.motors
    if pid in INT_PARAMS and handle not in mo.index:
        world.get(handle)
        return 0  # a spherical joint or one moved through a tendon: no motor of its own
    i = world.motor(handle)
    if pid == 2000:
        return int(mo.enabled[i])
    if pid == 2001:
        return int(mo.loop[i])
    if pid == 2030:
        return int(mo.locked[i])
    if pid == DYN_CTRL_MODE:
        return dyn_ctrl.mode(mo, i)
    if pid in (KC_K, KC_C):
        springs = mo.springs
        k, c = (springs.k, springs.c) if springs is not None else mo._spring_parameters
        return float((k if pid == KC_K else c)[i])
    if pid == 2002:
        return float(mo.pid_p[i])
    if pid == 2017:
        return float(mo.max_velocity[i])
    return 0.0


def set_param(world: World, handle: int, pid: int, value: float | int, name: str) -> None:
    """Set joint parameter ``pid`` (``name`` is its legacy name, for messages).

    2000 / 2001: 0 or 1 (motor on/off, control loop on/off; the targets are kept, as V-REP
    keeps them); 2039: a dynamic control mode (:func:`simx_server.sim.dyn_ctrl.set_mode`);
    2018/2019: the spring-damper mode's K and C, finite (``CJoint::setKc``: at most 1e10,
    1e11 for revolute joints); 2030: 0 or 1, lock the joint where a zero target velocity stops it (any
    nonzero value is 1, as ``CJoint::setMotorLock(parameter != 0)``); 2002: P gain > 0 and at most limits.MAX_PID_P (V-REP's units; the loop's
    gain is P / 5 ms, at most 1/dt); 2017: upper velocity > 0 and at most
    limits.MAX_JOINT_VELOCITY. Others and values out of range: ArgumentError /
    UnsupportedError naming the parameter and quoting the value.

    Args:
        world: the world.
        handle: a joint's handle.
        pid: 2000, 2001, 2030, 2039, 2002, 2017, 2018 or 2019.
        value: the new value (0/1, a mode, gain, velocity in rad/s or m/s, K or C).
        name: the parameter's legacy name, for messages.

    Raises:
        ObjectTypeError: not a joint with a motor of its own.
        ArgumentError: a value out of range.
        UnsupportedError: any other id (the I and D gains).
    """
    i = world.motor(handle)
    if pid == 2030:
        world.motors.set_locked(i, value != 0)
    elif pid == DYN_CTRL_MODE:
        dyn_ctrl.set_mode(world, handle, int(value), name)
    elif pid in (KC_K, KC_C):
        bound = 1e11 if world.motors._hinge[i] else 1e10
        if not -bound <= value <= bound:
            raise ArgumentError(f"{name}: value must be finite and within +-{bound:g}, got {quote(value)}")
        springs = dyn_ctrl.springs(world.motors)
        (springs.k if pid == KC_K else springs.c)[i] = value
    elif pid in INT_PARAMS:
        if value not in (0, 1):
            raise ArgumentError(f"{name}: value must be 0 or 1, got {quote(value)}")
        world.set_motor_flags(handle, **{("enabled" if pid == 2000 else "loop"): bool(value)})
    elif pid == 2002:
        if not 0 < value <= L.MAX_PID_P:
            raise ArgumentError(f"{name}: the proportional gain must be > 0 and at most {L.MAX_PID_P:g} "
                                f"(simx_server.base.limits.MAX_PID_P), got {quote(value)}")
        world.motors.pid_p[i] = value
    elif pid == 2017:
        if not 0 < value <= L.MAX_JOINT_VELOCITY:
            raise ArgumentError(f"{name}: the velocity limit must be > 0 and at most "
                                f"{L.MAX_JOINT_VELOCITY:g} rad/s or m/s (simx_server.base.limits.MAX_JOINT_VELOCITY), "
                                f"got {quote(value)}")
        world.motors.max_velocity[i] = value
    else:
        raise UnsupportedError(f"{name}: simx's position loop is proportional (sim_jointfloatparam_pid_p, "
                               "2002) with the joint's static load compensated; I and D gains cannot be set")
