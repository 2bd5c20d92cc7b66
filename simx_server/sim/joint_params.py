"""Joint motors' object parameters (``simxGetObjectIntParameter`` / ``simxSetObjectFloatParameter``
on a joint): 2000 motor enabled, 2001 control loop enabled, 2030 motor locked at zero velocity,
2002-2004 PID gains, 2017 upper velocity, read from and written to the world's
:class:`~simx_server.sim.motors.Motors`.
"""

from __future__ import annotations

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base import limits as L
from simx_server.base.arguments import quote
from simx_server.sim.world import World

#: Joint object parameters this module answers (legacy ids): 2000 motor enabled, 2001 control
#: loop enabled, 2030 ``sim_jointintparam_velocity_lock`` (ints); 2002-2004 PID gains, 2017 upper
#: velocity (floats).
INT_PARAMS = {2000, 2001, 2030}
FLOAT_PARAMS = {2002, 2003, 2004, 2017}
FLOAT_SETTABLE = {2002, 2017}


def get_param(world: World, handle: int, pid: int) -> float | int:
    """Value of joint parameter ``pid`` (INT_PARAMS or FLOAT_PARAMS) of joint ``handle``.

    2000: 1 when the motor is enabled; 2001: 1 when its position control loop is enabled
    (V-REP reports the flag whatever the motor); 2030: 1 when the motor locks its joint where a
    zero target velocity stopped it (coppeliaSimLib ``CJoint::getMotorLock``); 2002: P gain (V-REP's units: the loop asks
    P * error / 5 ms); 2003/2004: I and D gains, always 0 (simx's loop is proportional);
    2017: upper velocity (rad/s or m/s). 2000/2001 read 0 on a joint without a motor of its
    own (spherical, tendon-driven); the float ids raise ObjectTypeError there.

    Args:
        world: the world.
        handle: a joint's handle.
        pid: a ``sim_jointintparam_*`` / ``sim_jointfloatparam_*`` id (INT_PARAMS, FLOAT_PARAMS).

    Returns:
        An int for 2000/2001/2030, else a float (gains; velocity in rad/s or m/s).

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
    if pid == 2002:
        return float(mo.pid_p[i])
    if pid == 2017:
        return float(mo.max_velocity[i])
    return 0.0


def set_param(world: World, handle: int, pid: int, value: float | int, name: str) -> None:
    """Set joint parameter ``pid`` (``name`` is its legacy name, for messages).

    2000 / 2001: 0 or 1 (motor on/off, control loop on/off; the targets are kept, as V-REP
    keeps them); 2030: 0 or 1, lock the joint where a zero target velocity stops it (any
    nonzero value is 1, as ``CJoint::setMotorLock(parameter != 0)``); 2002: P gain > 0 and at most limits.MAX_PID_P (V-REP's units; the loop's
    gain is P / 5 ms, at most 1/dt); 2017: upper velocity > 0 and at most
    limits.MAX_JOINT_VELOCITY. Others and values out of range: ArgumentError /
    UnsupportedError naming the parameter and quoting the value.

    Args:
        world: the world.
        handle: a joint's handle.
        pid: 2000, 2001, 2030, 2002 or 2017.
        value: the new value (0/1, gain, or velocity in rad/s or m/s).
        name: the parameter's legacy name, for messages.

    Raises:
        ObjectTypeError: not a joint with a motor of its own.
        ArgumentError: a value out of range.
        UnsupportedError: any other id (the I and D gains).
    """
    i = world.motor(handle)
    if pid == 2030:
        world.motors.set_locked(i, value != 0)
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
