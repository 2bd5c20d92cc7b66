"""CoppeliaSim 4.x's Ruckig objects (``sim.ruckigPos``, ``ruckigVel``, ``ruckigStep``,
``ruckigRemove``) on the ``ruckig`` library CoppeliaSim uses too: jerk-limited online trajectories
a script or a client steps itself, and ``moveToConfig`` / ``moveToPose`` in steps on them
(``_init``, ``_step``, ``_cleanup``). Handles from 4,000,000; at most 256 objects per caller
(a script, or a ZMQ door's clients: :class:`~simx_server.api.context.CallerState`)."""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base.arguments import as_integer as _int, as_number as _num

_FIRST, MAX_OBJECTS, MAX_DOFS, MAX_UPDATES = 4_000_000, 256, 64, 100_000
_SYNC = {0: "Phase", 1: "Time", 3: "No"}  # sim.ruckig_phasesync, timesync, nosync


def _floats(values: Any, n: int, what: str) -> list[float]:
    if not isinstance(values, (list, tuple)) or len(values) < n:
        raise ArgumentError(f"{what} must hold {n} numbers")
    return [_num(v, what) for v in values[:n]]


# Ruckig position and velocity interfaces, stepped by the caller.

def _ruckig_objects(ctx: CallContext) -> dict:
    objs = ctx.state.ruckig
    if objs is None:
        objs = ctx.state.ruckig = {}
    return objs


def _ruckig_new(ctx: CallContext, position: bool, dofs: Any, baseCycleTime: Any, flags: Any, current: Any, limits: Any,  # noqa: N803
                selection: Any, target: Any) -> int:
    from ruckig import ControlInterface, InputParameter, OutputParameter, Ruckig, Synchronization
    n, dt = _int(dofs, "dofs"), _num(baseCycleTime, "baseCycleTime")
    if not 0 < n <= MAX_DOFS or not 0 < dt <= 10:
        raise ArgumentError(f"dofs must lie in 1..{MAX_DOFS} and baseCycleTime in (0, 10] s")
    objs = _ruckig_objects(ctx)
    if len(objs) >= MAX_OBJECTS:
        raise ArgumentError(f"at most {MAX_OBJECTS} Ruckig objects: remove some (sim.ruckigRemove)")
    cur = _floats(current, 3 * n, "currentPosVelAccel")
    inp = InputParameter(n)
    inp.current_position, inp.current_velocity, inp.current_acceleration = cur[:n], cur[n:2 * n], cur[2 * n:]
    lim = _floats(limits, (3 if position else 2) * n, "maxVelAccelJerk" if position else "maxAccelJerk")
    if any(v <= 0 for v in lim):
        raise ArgumentError("the limits must be positive")
    if position:
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = lim[:n], lim[n:2 * n], lim[2 * n:]
        tgt = _floats(target, 2 * n, "targetPosVel")
        inp.target_position, inp.target_velocity = tgt[:n], tgt[n:]
    else:
        inp.control_interface = ControlInterface.Velocity
        inp.max_acceleration, inp.max_jerk = lim[:n], lim[n:]
        inp.target_velocity = _floats(target, n, "targetVel")
    sel = [bool(_int(v, "selection")) for v in (selection or [1] * n)][:n]
    if len(sel) != n:
        raise ArgumentError("selection must hold one value per dof")
    inp.enabled = sel
    inp.synchronization = getattr(Synchronization, _SYNC.get(_int(flags, "flags") & 3, "Phase"))
    h = ctx.state.ruckig_next = (_FIRST - 1 if ctx.state.ruckig_next is None else ctx.state.ruckig_next) + 1  # never given twice
    objs[h] = (Ruckig(n, dt), inp, OutputParameter(n), dt, n)
    return h


@sim_function("ruckigPos")
def ruckigPos(ctx: CallContext, dofs: Any, baseCycleTime: Any, flags: Any, currentPosVelAccel: Any,  # noqa: N802, N803
              maxVelAccelJerk: Any, selection: Any, targetPosVel: Any) -> int:  # noqa: N803
    """A position-interface Ruckig object (current position, velocity, acceleration; limits
    of velocity, acceleration, jerk; target position and velocity, ``dofs`` each); its handle.

    ``sim.ruckigPos``.

    Args:
        dofs: 1..MAX_DOFS.
        baseCycleTime: s, in (0, 10].
        flags: Ruckig's synchronization flags.
        currentPosVelAccel: 3*dofs numbers (m or rad, /s, /s²).
        maxVelAccelJerk: 3*dofs positive numbers.
        selection: dofs numbers (1: the degree of freedom is used).
        targetPosVel: 2*dofs numbers.

    Returns:
        The Ruckig object's handle.

    Raises:
        ArgumentError: counts, lengths or limits out of range, or too many Ruckig objects.
    """
    return _ruckig_new(ctx, True, dofs, baseCycleTime, flags, currentPosVelAccel, maxVelAccelJerk, selection,
                            targetPosVel)


@sim_function("ruckigVel")
def ruckigVel(ctx: CallContext, dofs: Any, baseCycleTime: Any, flags: Any, currentPosVelAccel: Any,  # noqa: N802, N803
              maxAccelJerk: Any, selection: Any, targetVel: Any) -> int:  # noqa: N803
    """A velocity-interface Ruckig object (limits of acceleration and jerk; a target velocity).

    ``sim.ruckigVel``.

    Args:
        dofs: 1..MAX_DOFS.
        baseCycleTime: s, in (0, 10].
        flags: Ruckig's synchronization flags.
        currentPosVelAccel: 3*dofs numbers (m or rad, /s, /s²).
        maxAccelJerk: 2*dofs positive numbers.
        selection: dofs numbers (1: the degree of freedom is used).
        targetVel: 2*dofs numbers (velocity, acceleration).

    Returns:
        The Ruckig object's handle.

    Raises:
        ArgumentError: counts, lengths or limits out of range, or too many Ruckig objects.
    """
    return _ruckig_new(ctx, False, dofs, baseCycleTime, flags, currentPosVelAccel, maxAccelJerk, selection,
                            targetVel)


@sim_function("ruckigStep")
def ruckigStep(ctx: CallContext, handle: Any, cycleTime: Any) -> tuple[int, list[float], float]:  # noqa: N802, N803
    """Advance by ``cycleTime`` (s, a whole number of base cycles): ``result, newPosVelAccel,
    synchronizationTime``; result 0 working, 1 finished, negative a Ruckig error.

    ``sim.ruckigStep``.

    Args:
        handle: from :func:`ruckigPos` / :func:`ruckigVel`.
        cycleTime: s.

    Returns:
        ``(result, newPosVelAccel, synchronizationTime)``: int, 3*dofs floats (``[]`` on an
        error), s.

    Raises:
        UnknownObjectError: no such Ruckig object.
        ArgumentError: ``cycleTime`` over MAX_UPDATES base cycles.
    """
    from ruckig import Result
    obj = _ruckig_objects(ctx).get(_int(handle, "handle"))
    if obj is None:
        raise UnknownObjectError(f"no Ruckig object {handle}")
    otg, inp, out, dt, n = obj
    steps = max(1, round(_num(cycleTime, "cycleTime") / dt))
    if steps > MAX_UPDATES:
        raise ArgumentError(f"cycleTime covers more than {MAX_UPDATES} base cycles")
    result = Result.Working
    for _ in range(steps):
        result = otg.update(inp, out)
        if result not in (Result.Working, Result.Finished):
            return int(result.value) if hasattr(result, "value") else -1, [], 0.0
        out.pass_to_input(inp)
        if result == Result.Finished:
            break
    state = list(out.new_position) + list(out.new_velocity) + list(out.new_acceleration)
    return (1 if result == Result.Finished else 0), state, float(out.trajectory.duration)


@sim_function("ruckigRemove")
def ruckigRemove(ctx: CallContext, handle: Any) -> None:  # noqa: N802
    """``sim.ruckigRemove``: forget a Ruckig object.

    Args:
        handle: from :func:`ruckigPos` / :func:`ruckigVel`.

    Raises:
        UnknownObjectError: no such Ruckig object.

    """
    if _ruckig_objects(ctx).pop(_int(handle, "handle"), None) is None:
        raise UnknownObjectError(f"no Ruckig object {handle}")


@sim_function("moveToConfig_init")
def moveToConfig_init(ctx: CallContext, params: Any) -> dict:  # noqa: N802
    """The state of a joint motion stepped by the caller: ``params`` as ``sim.moveToConfig``'s
    (``joints`` or ``pos``, ``targetPos``, ``maxVel``, ``maxAccel``, ``maxJerk``, optional
    ``vel``, ``accel``, ``targetVel``, ``flags``, ``timeStep``); each
    :func:`moveToConfig_step` advances it one time step and sets the joints' target positions.

    ``sim.moveToConfig_init`` (CoppeliaSim 4.7).

    Args:
        params: the parameter table (positions rad or m, limits per second, /s², /s³).

    Returns:
        The motion's data table for :func:`moveToConfig_step`.

    Raises:
        ArgumentError: not a table, no joints or positions, or lengths that differ.
        UnknownObjectError: no such joint.
    """
    if not isinstance(params, dict):
        raise ArgumentError("moveToConfig_init takes a table of parameters")
    joints = [ctx.world.get(ctx.h(j, "joints[i]")).handle for j in params.get("joints", [])]
    pos = params.get("pos") or [ctx.world.joint_position(j) for j in joints]
    n = len(pos)
    if not n or (joints and len(joints) != n):
        raise ArgumentError("give joints (handles) or pos, one per degree of freedom")

    def field(key: str, default: float) -> list[float]:
        v = params.get(key, default)
        return _floats([v] * n if isinstance(v, (int, float)) else v, n, key)
    dt = _num(params.get("timeStep", ctx.world.dt), "timeStep")
    current = _floats(pos, n, "pos") + field("vel", 0.0) + field("accel", 0.0)
    limits = field("maxVel", 9999.0) + field("maxAccel", 99999.0) + field("maxJerk", 9999999.0)
    target = _floats(params.get("targetPos", []), n, "targetPos") + field("targetVel", 0.0)
    h = ruckigPos(ctx, n, dt, max(0, _int(params.get("flags", 0), "flags")), current, limits, [1] * n, target)
    return {"ruckigObject": h, "joints": joints, "timeStep": dt, "pos": list(pos),
            "vel": current[n:2 * n], "accel": current[2 * n:]}


@sim_function("moveToConfig_step")
def moveToConfig_step(ctx: CallContext, data: Any) -> tuple[int, dict]:  # noqa: N802
    """One time step: ``result, data`` (result 0 moving, 1 arrived); the joints' target positions
    (and ``data.pos``, ``vel``, ``accel``) follow the trajectory.

    ``sim.moveToConfig_step``.

    Args:
        data: the table :func:`moveToConfig_init` returned.

    Returns:
        ``(result, data)``.

    Raises:
        ArgumentError: not that table, or Ruckig found no trajectory.
    """
    if not isinstance(data, dict) or "ruckigObject" not in data:
        raise ArgumentError("moveToConfig_step takes the table moveToConfig_init returned")
    result, state, _ = ruckigStep(ctx, data["ruckigObject"], data["timeStep"])
    if result < 0:
        raise ArgumentError(f"no trajectory for these limits and targets (Ruckig result {result})")
    n = len(state) // 3
    data["pos"], data["vel"], data["accel"] = state[:n], state[n:2 * n], state[2 * n:]
    for j, q in zip(data["joints"], data["pos"]):
        ctx.world.set_joint_target_position(j, q)
    return result, data


@sim_function("moveToConfig_cleanup")
def moveToConfig_cleanup(ctx: CallContext, data: Any) -> None:  # noqa: N802
    """Release the motion's trajectory object.

    ``sim.moveToConfig_cleanup``.

    Args:
        data: the table :func:`moveToConfig_init` returned (anything else: nothing done).
    """
    if isinstance(data, dict) and "ruckigObject" in data:
        _ruckig_objects(ctx).pop(_int(data["ruckigObject"], "ruckigObject"), None)


@sim_function("moveToPose_init")
def moveToPose_init(ctx: CallContext, params: Any) -> dict:  # noqa: N802
    """The state of a pose motion stepped by the caller: ``params`` as ``sim.moveToPose``'s
    (``object`` or ``pose``, ``targetPose``, optional ``relObject``, ``maxVel``, ``maxAccel``,
    ``maxJerk`` of 4 degrees of freedom x, y, z and the rotation angle, or with ``metric``
    (4 weights) of 1 along a straight line; ``flags``, ``timeStep``). Each
    :func:`moveToPose_step` advances it one time step and places the object.

    ``sim.moveToPose_init`` (CoppeliaSim 4.7).

    Args:
        params: the parameter table (poses 7 numbers, m and quaternion).

    Returns:
        The motion's data table for :func:`moveToPose_step`.

    Raises:
        ArgumentError: not a table, no ``targetPose``, or neither ``object`` nor ``pose``.
        UnknownObjectError: no such object.
    """
    if not isinstance(params, dict) or params.get("targetPose") is None:
        raise ArgumentError("moveToPose_init takes a table of parameters with targetPose")
    rel = _int(params.get("relObject", -1), "relObject")
    obj = params.get("object")
    if params.get("pose") is not None:
        start, obj = _floats(params["pose"], 7, "pose"), None
    elif obj is not None:
        obj = ctx.world.get(ctx.h(obj, "object")).handle
        start = list(ctx.sim.getObjectPose(obj, rel))
    else:
        raise ArgumentError("give object (a handle) or pose")
    goal = _floats(params["targetPose"], 7, "targetPose")
    q0 = np.array([start[6], *start[3:6]]) / np.linalg.norm(start[3:7])
    q1 = np.array([goal[6], *goal[3:6]]) / np.linalg.norm(goal[3:7])
    turn = np.empty(4)  # q1 * conj(q0): the rotation from start to goal, about one axis
    mujoco.mju_mulQuat(turn, q1, np.array([q0[0], -q0[1], -q0[2], -q0[3]]))
    if turn[0] < 0:
        turn = -turn
    angle = 2 * math.atan2(float(np.linalg.norm(turn[1:])), float(turn[0]))
    axis = turn[1:] / np.linalg.norm(turn[1:]) if angle > 1e-12 else np.array([0.0, 0.0, 1.0])
    delta = np.array(goal[:3]) - np.array(start[:3])
    metric = params.get("metric")
    dt = _num(params.get("timeStep", ctx.world.dt), "timeStep")

    def field(key: str, default: float, n: int) -> list[float]:
        v = params.get(key, default)
        return _floats([v] * n if isinstance(v, (int, float)) else v, n, key)
    if metric is not None:
        w = _floats(metric, 4, "metric")
        dist = float(np.linalg.norm(np.append(delta * w[:3], angle * w[3])))
        n, target = 1, [dist]
    else:
        n, target = 4, [*delta.tolist(), angle]
    limits = field("maxVel", 9999.0, n) + field("maxAccel", 99999.0, n) + field("maxJerk", 9999999.0, n)
    h = ruckigPos(ctx, n, dt, max(0, _int(params.get("flags", 0), "flags")), [0.0] * 3 * n, limits, [1] * n,
                       target + [0.0] * n)
    return {"ruckigObject": h, "object": obj, "relObject": rel, "timeStep": dt, "startPose": start,
            "targetPose": goal, "axis": axis.tolist(), "angle": angle, "metric": metric is not None,
            "dist": target[0] if metric is not None else 0.0, "pose": list(start)}


@sim_function("moveToPose_step")
def moveToPose_step(ctx: CallContext, data: Any) -> tuple[int, dict]:  # noqa: N802
    """One time step: ``result, data`` (result 0 moving, 1 arrived); ``data.pose`` (x, y, z,
    qx, qy, qz, qw) and the object follow the trajectory.

    ``sim.moveToPose_step``.

    Args:
        data: the table :func:`moveToPose_init` returned.

    Returns:
        ``(result, data)``.

    Raises:
        ArgumentError: not that table, or Ruckig found no trajectory.
    """
    if not isinstance(data, dict) or "ruckigObject" not in data:
        raise ArgumentError("moveToPose_step takes the table moveToPose_init returned")
    result, state, _ = ruckigStep(ctx, data["ruckigObject"], data["timeStep"])
    if result < 0:
        raise ArgumentError(f"no trajectory for these limits and targets (Ruckig result {result})")
    start, goal = data["startPose"], data["targetPose"]
    if data["metric"]:
        f = state[0] / data["dist"] if data["dist"] > 1e-12 else 1.0
        pos = [s + f * (g - s) for s, g in zip(start[:3], goal[:3])]
        angle = f * data["angle"]
    else:
        pos = [s + d for s, d in zip(start[:3], state[:3])]
        angle = state[3]
    turn, q = np.empty(4), np.empty(4)
    mujoco.mju_axisAngle2Quat(turn, np.array(data["axis"], dtype=float), angle)
    mujoco.mju_mulQuat(q, turn, np.array([start[6], *start[3:6]]) / np.linalg.norm(start[3:7]))
    data["pose"] = [*pos, float(q[1]), float(q[2]), float(q[3]), float(q[0])]
    if data.get("object") is not None:
        ctx.sim.setObjectPose(data["object"], data["pose"], data["relObject"])
    return result, data


@sim_function("moveToPose_cleanup")
def moveToPose_cleanup(ctx: CallContext, data: Any) -> None:  # noqa: N802
    """Release the motion's trajectory object.

    ``sim.moveToPose_cleanup``.

    Args:
        data: the table :func:`moveToPose_init` returned (anything else: nothing done).
    """
    if isinstance(data, dict) and "ruckigObject" in data:
        _ruckig_objects(ctx).pop(_int(data["ruckigObject"], "ruckigObject"), None)


