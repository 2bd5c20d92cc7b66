"""CoppeliaSim's ``sim.moveToConfig`` and ``sim.moveToPose``: jerk-limited, time-optimal motions
from the Ruckig library (the ``ruckig`` package; CoppeliaSim uses the same library),
phase-synchronised across degrees of freedom unless ``flags`` say otherwise, one increment per
simulation step. ``moveToConfig`` moves joints through their target positions (their position
control follows) or, for joints without an active motor, their positions; ``moveToPose`` moves an
``object`` (4 degrees of freedom x, y, z and the rotation angle, or one along a straight line
with a ``metric``). Both also take CoppeliaSim 4.3-4.5's positional form, whose ``callback``
gets each step's state instead of anything being moved.

One implementation for every caller: :func:`config_motion` and :func:`pose_motion` build a motion as a generator that
yields ``None`` when it wants a simulation step and a :class:`CallbackCall` when it wants the
caller's callback run (the driver sends it the callback's return values), and returns the call's
return values. Drivers: :func:`moveToConfig` / :func:`moveToPose` here, in a Python script's
thread (the callback a Python callable, a step a thread switch); a Lua script's thread
(``THREADS_LUA`` of :mod:`simx_server.scripts.threads`, through :func:`lua_motion`: the callback a
Lua function, a step a coroutine yield); for ZMQ clients a :class:`~simx_server.api.sim.stepped.Stepped`
that :mod:`simx_server.zmq.service` drives (the callback the client's ``"NAME@func"``, a step a
``_*wait*_``). The 4.6 map's ``callback`` and ``ik`` fields are not supported (an error says so).
"""

from __future__ import annotations

import math
from typing import Any, Callable, Generator

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import threads as _threads
from simx_server.api.sim.stepped import MAX_MOTION_STEPS, CallbackCall, Stepped, zmq_callback
from simx_wire.protocol import ArgumentError, RemoteError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_vector as _vector
from simx_server.sim.objects import JOINT
from simx_server.sim.rotations import matrix_from_quaternion, quaternion_from_matrix, rotation_angle

#: CoppeliaSim's sim.ruckig_* flags used here.
RUCKIG_PHASESYNC, RUCKIG_TIMESYNC, RUCKIG_NOSYNC = 0, 1, 3
#: Longest motion in simulation steps (a bound on one call's work: 100,000 steps = 83 min at 50 ms).
MAX_DOFS = 64


def positional_config(args: tuple) -> tuple[dict, Any, Any]:
    """CoppeliaSim 4.3-4.5's ``sim.moveToConfig(flags, currentPos, currentVel, currentAccel,
    maxVel, maxAccel, maxJerk, targetPos, targetVel, callback, auxData, cyclicJoints, timeStep)``
    as the map form's fields (nil ones left out), its ``callback`` and ``auxData``.

    Args:
        args: the 8 to 13 positional arguments.

    Returns:
        ``(params, callback, auxData)``.

    Raises:
        ArgumentError: a count out of 8..13.
    """
    if not 8 <= len(args) <= 13:
        raise ArgumentError(
            "sim.moveToConfig takes one map of parameters (4.6) or 8 to 13 arguments (4.3-4.5: flags, "
            "currentPos, currentVel, currentAccel, maxVel, maxAccel, maxJerk, targetPos, targetVel, "
            "callback, auxData, cyclicJoints, timeStep)"
        )
    keys = ("flags", "pos", "vel", "accel", "maxVel", "maxAccel", "maxJerk", "targetPos", "targetVel")
    params = {k: v for k, v in zip(keys, args) if v is not None}
    rest = list(args[9:]) + [None] * (13 - len(args))
    callback, aux, cyclic, time_step = rest
    if not isinstance(params.get("pos"), list):
        raise ArgumentError("invalid 'currentPos' argument: a list of numbers")
    params.update({k: v for k, v in (("cyclicJoints", cyclic), ("timeStep", time_step)) if v is not None})
    return params, callback, aux


def positional_pose(args: tuple) -> tuple[dict, Any, Any]:
    """CoppeliaSim 4.3-4.5's ``sim.moveToPose(flags, currentPose, maxVel, maxAccel, maxJerk,
    targetPose, callback, auxData, metric, timeStep)`` as the map form's fields, its ``callback``
    and ``auxData``. Poses are 7 numbers (x, y, z, qx, qy, qz, qw) or 12 (a matrix).

    Args:
        args: the 6 to 10 positional arguments.

    Returns:
        ``(params, callback, auxData)``.

    Raises:
        ArgumentError: a count out of 6..10, or a pose of the wrong length.
    """
    if not 6 <= len(args) <= 10:
        raise ArgumentError(
            "sim.moveToPose takes one map of parameters (4.6) or 6 to 10 arguments (4.3-4.5: flags, "
            "currentPose, maxVel, maxAccel, maxJerk, targetPose, callback, auxData, metric, timeStep)"
        )
    keys = ("flags", "pose", "maxVel", "maxAccel", "maxJerk", "targetPose")
    params = {k: v for k, v in zip(keys, args) if v is not None}
    callback, aux, metric, time_step = list(args[6:]) + [None] * (10 - len(args))
    params.update({k: v for k, v in (("metric", metric), ("timeStep", time_step)) if v is not None})
    return params, callback, aux


def _limits(params: dict, key: str, dim: int, default: float) -> list[float]:
    value = params.get(key, default)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value] * dim
    if not isinstance(value, list) or len(value) < dim:
        raise ArgumentError(f"invalid '{key}' field: {dim} numbers")
    return [_num(v, key) for v in value[:dim]]


def _trajectory(dim: int, dt: float, params: dict, current: list[float], target: list[float]):
    """A Ruckig generator and its input for ``dim`` degrees of freedom, from CoppeliaSim's fields."""
    try:
        from ruckig import InputParameter, OutputParameter, Ruckig, Synchronization
    except ImportError:  # pragma: no cover - a dependency of simx
        raise UnsupportedError("sim.moveToConfig/moveToPose need the ruckig package (pip install ruckig)") from None
    if not 0 < dim <= MAX_DOFS:
        raise ArgumentError(f"a motion has 1 to {MAX_DOFS} degrees of freedom, got {dim}")
    inp = InputParameter(dim)
    inp.current_position = current
    inp.current_velocity = _limits(params, "vel", dim, 0.0)
    inp.current_acceleration = _limits(params, "accel", dim, 0.0)
    inp.target_position = target
    inp.target_velocity = _limits(params, "targetVel", dim, 0.0)
    inp.max_velocity = _limits(params, "maxVel", dim, 9999.0)
    inp.max_acceleration = _limits(params, "maxAccel", dim, 99999.0)
    inp.max_jerk = _limits(params, "maxJerk", dim, 9999999.0)
    inp.min_velocity = _limits(params, "minVel", dim, 0.0) if "minVel" in params else [-v for v in inp.max_velocity]
    inp.min_acceleration = (
        _limits(params, "minAccel", dim, 0.0) if "minAccel" in params else [-a for a in inp.max_acceleration]
    )
    flags = _int(params.get("flags", -1), "flags")
    sync = flags & 3 if flags >= 0 else RUCKIG_PHASESYNC
    inp.synchronization = {
        RUCKIG_PHASESYNC: Synchronization.Phase,
        RUCKIG_TIMESYNC: Synchronization.Time,
        RUCKIG_NOSYNC: Synchronization.No,
    }.get(sync, Synchronization.Phase)
    if any(v <= 0 for v in inp.max_velocity + inp.max_acceleration + inp.max_jerk):
        raise ArgumentError("maxVel, maxAccel and maxJerk must be positive")
    return Ruckig(dim, dt), inp, OutputParameter(dim)


def _run(otg, inp, out) -> Generator[tuple[list, list, list, bool], None, None]:
    """Ruckig's increments: (position, velocity, acceleration, last) per step."""
    from ruckig import Result

    for _ in range(MAX_MOTION_STEPS):
        result = otg.update(inp, out)
        if result not in (Result.Working, Result.Finished):
            raise ArgumentError(f"no trajectory for these limits and targets (Ruckig: {result.name})")
        out.pass_to_input(inp)
        yield list(out.new_position), list(out.new_velocity), list(out.new_acceleration), result == Result.Finished
        if result == Result.Finished:
            return
    raise ArgumentError(f"the motion would last more than {MAX_MOTION_STEPS} steps")


def _no_callbacks(params: Any, name: str) -> dict:
    if not isinstance(params, dict):
        raise ArgumentError(f"sim.{name} takes one map of parameters")
    for key in ("callback", "ik"):
        if params.get(key) is not None:
            raise UnsupportedError(f"sim.{name}: '{key}' is not supported by simx")
    return params


Motion = Generator["CallbackCall | None", Any, list]
#: A driver's check of a 4.3-4.5 callback: returns the form its CallbackCall carries, or raises.
Accept = Callable[[Any], Any]


# The motions as generators (:data:`Motion`; the drivers below and in the callers run them).

def config_motion(ctx: CallContext, params: Any, legacy: tuple, accept: Accept) -> Motion:
    """``sim.moveToConfig``'s motion: move joints along a jerk-limited trajectory, one increment per simulation step
    (CoppeliaSim 4.6's map form: ``joints``, ``targetPos``, ``maxVel``, ``maxAccel``,
    ``maxJerk``, optional ``pos``, ``vel``, ``accel``, ``minVel``, ``minAccel``,
    ``targetVel``, ``flags``, ``cyclicJoints``, ``timeStep``). Returns the parameters with
    the final ``pos``, ``vel``, ``accel`` and ``timeLeft``.

    4.3-4.5's form ``(flags, currentPos, currentVel, currentAccel, maxVel, maxAccel, maxJerk,
    targetPos, targetVel, callback, auxData [, cyclicJoints, timeStep])`` runs the same
    motion from ``currentPos`` and calls ``callback(pos, vel, accel, auxData)`` each step
    instead of moving joints; returns ``pos, vel, accel, timeLeft`` (rad, rad/s, rad/s², s)."""
    callback = aux = None
    if legacy or not isinstance(params, dict):
        p, callback, aux = positional_config((params, *legacy))
        callback = accept(callback)
    else:
        p = _no_callbacks(params, "moveToConfig")
    joints = p.get("joints")
    if joints is not None:
        if not isinstance(joints, list) or not joints:
            raise ArgumentError("invalid 'joints' field: a list of joint handles")
        joints = [ctx.world.get(ctx.h(h, "joint handle"), JOINT).handle for h in joints]
    if "pos" in p:
        pos = _vector(p["pos"], len(p["pos"]) if isinstance(p["pos"], list) else 0, "pos")
    elif joints is not None:
        pos = [ctx.world.joint_position(h) for h in joints]
    else:
        raise ArgumentError("missing field: either 'pos' or 'joints' is required")
    dim = len(pos)
    if joints is not None and len(joints) != dim:
        raise ArgumentError("'joints' and 'pos' differ in length")
    target = _vector(p.get("targetPos"), dim, "targetPos")
    cyclic = p.get("cyclicJoints") or []
    for i, flag in enumerate(cyclic[:dim] if isinstance(cyclic, list) else []):
        if flag:  # the shorter way round
            target[i] = pos[i] + math.remainder(target[i] - pos[i], 2 * math.pi)
    dt = _num(p.get("timeStep", 0), "timeStep") or ctx.world.dt
    otg, inp, out = _trajectory(dim, dt, p, pos, target)

    motored = [_has_motor(ctx, h) for h in joints] if joints is not None else []

    def motion() -> Generator[CallbackCall | None, Any, list]:
        steps = 0
        for q, v, a, last in _run(otg, inp, out):
            if callback is not None:
                yield CallbackCall(callback, [q, v, a, aux])
            for h, value, by_motor in zip(joints or (), q, motored):
                if by_motor:  # its position control follows (CoppeliaSim: a dynamically enabled joint)
                    ctx.world.set_joint_target_position(h, value)
                else:
                    ctx.world.set_joint_position(h, value)
            steps += 1
            yield
            if last:
                break
        time_left = max(0.0, steps * dt - out.trajectory.duration)
        if callback is not None:
            return [q, v, a, time_left]
        return [{**_plain(p), "pos": q, "vel": v, "accel": a, "targetPos": target, "timeLeft": time_left}]

    return motion()


def _has_motor(ctx: CallContext, handle: int) -> bool:
    try:
        ctx.world.motor(handle)
        return True
    except RemoteError:  # a joint moved only through a tendon: placed instead
        return False


def pose_motion(ctx: CallContext, params: Any, legacy: tuple, accept: Accept) -> Motion:
    """``sim.moveToPose``'s motion: move an ``object`` (or just a ``pose``) to ``targetPose`` along a jerk-limited
    trajectory, one increment per simulation step (CoppeliaSim 4.6's map form: ``object``
    or ``pose``, ``targetPose``, ``relObject``, ``maxVel``, ``maxAccel``, ``maxJerk`` of 4
    degrees of freedom x, y, z, angle; with ``metric`` (4 weights) 1 degree along a straight
    line). Returns the parameters with the final ``pose``, ``matrix`` and ``timeLeft``.

    4.3-4.5's form ``(flags, currentPose, maxVel, maxAccel, maxJerk, targetPose, callback,
    auxData [, metric, timeStep])`` runs the same motion from ``currentPose`` and calls
    ``callback(pose, vel, accel, auxData)`` each step (the pose as given: 7 numbers or a
    12-number matrix; vel and accel the Ruckig degrees of freedom, a number along the line
    with a metric); returns ``pose, timeLeft``."""
    callback = aux = None
    matrices = False
    if legacy or not isinstance(params, dict):
        p, callback, aux = positional_pose((params, *legacy))
        callback = accept(callback)
        for key in ("pose", "targetPose"):
            if isinstance(p.get(key), list) and len(p[key]) == 12:
                p[key], matrices = ctx.sim.matrixToPose(p[key]), True
    else:
        p = _no_callbacks(params, "moveToPose")
    rel = _int(p.get("relObject", -1), "relObject")
    obj = p.get("object")
    if "pose" in p and p["pose"] is not None:
        start = _vector(p["pose"], 7, "pose")
        obj, rel = None, -1
    elif obj is not None:
        obj = ctx.h(obj)
        start = ctx.sim.getObjectPose(obj, rel)
    else:
        raise ArgumentError("missing field: either 'pose' or 'object' is required")
    goal = _vector(p.get("targetPose"), 7, "targetPose")
    p0, r0 = np.array(start[:3]), matrix_from_quaternion(*start[3:])
    p1, r1 = np.array(goal[:3]), matrix_from_quaternion(*goal[3:])
    rot = r1 @ r0.T  # the turn from start to goal, about one axis
    angle = rotation_angle(rot)
    axis = _rotation_axis(rot, angle)
    metric = p.get("metric")
    dt = _num(p.get("timeStep", 0), "timeStep") or ctx.world.dt
    if metric is not None:
        w = _vector(metric, 4, "metric")
        dist = float(np.linalg.norm(np.append((p1 - p0) * w[:3], angle * w[3])))
        otg, inp, out = _trajectory(1, dt, p, [0.0], [dist]) if dist > 1e-6 else (None, None, None)
    else:
        dist = 0.0
        otg, inp, out = _trajectory(4, dt, p, [0.0] * 4, [*(p1 - p0), angle])

    def pose_at(progress: list[float]) -> tuple[np.ndarray, np.ndarray]:
        if metric is not None:
            t = progress[0] / dist
            return p0 + t * (p1 - p0), _turn(axis, t * angle) @ r0
        t = progress[3] / angle if abs(angle) > math.pi * 1e-5 else 0.0
        return p0 + np.array(progress[:3]), _turn(axis, t * angle) @ r0

    def call(pos: np.ndarray, r: np.ndarray, v: Any, a: Any) -> CallbackCall:
        """The callback's call with the pose (or matrix), velocity and acceleration."""
        pose = [*map(float, pos), *quaternion_from_matrix(r)]
        return CallbackCall(callback, [ctx.sim.poseToMatrix(pose) if matrices else pose, v, a, aux])

    def motion() -> Generator[CallbackCall | None, Any, list]:
        pos, r = p0, r0
        if otg is not None:
            for q, v, a, last in _run(otg, inp, out):
                pos, r = pose_at(q)
                if callback is not None:
                    yield call(pos, r, *((v[0], a[0]) if metric is not None else (v, a)))
                if obj is not None:
                    ctx.sim.setObjectPose(obj, [*pos, *quaternion_from_matrix(r)], rel)
                yield
                if last:
                    break
        else:  # already there: one step, one callback with the pose
            if callback is not None:
                yield call(pos, r, *((0.0, 0.0) if metric is not None else ([0.0] * 4, [0.0] * 4)))
            yield
        pose = [*map(float, pos), *quaternion_from_matrix(r)]
        if callback is not None:
            return [ctx.sim.poseToMatrix(pose) if matrices else pose, 0.0]
        return [{**_plain(p), "pose": pose, "matrix": ctx.sim.poseToMatrix(pose), "timeLeft": 0.0}]

    return motion()




# ``sim.moveToConfig`` and ``sim.moveToPose``: a Python script's calls drive the motion here in its
# thread; a ZMQ client's get a Stepped the service drives; a Lua script's go through ``THREADS_LUA``,
# which runs its Lua callback and yields its coroutine (:func:`lua_motion`).

@sim_function("moveToConfig")
def moveToConfig(ctx: CallContext, params: Any, *legacy: Any) -> Any:  # noqa: N802 (CoppeliaSim's names)
    """Move joints along a jerk-limited trajectory, one increment per simulation step; in a
    threaded script only (it yields at each step, as CoppeliaSim's ``sim.step()`` inside).

    CoppeliaSim 4.6's map form (``joints``, ``targetPos``, ``maxVel``, ``maxAccel``,
    ``maxJerk``, optional ``pos``, ``vel``, ``accel``, ``minVel``, ``minAccel``,
    ``targetVel``, ``flags``, ``cyclicJoints``, ``timeStep``; rad, rad/s, rad/s², rad/s³, s)
    returns the map with the final ``pos``, ``vel``, ``accel`` and ``timeLeft``. 4.3-4.5's
    ``(flags, currentPos, currentVel, currentAccel, maxVel, maxAccel, maxJerk, targetPos,
    targetVel, callback, auxData [, cyclicJoints, timeStep])`` calls ``callback(pos, vel,
    accel, auxData)`` each step instead of moving joints and returns ``pos, vel, accel,
    timeLeft``. Raises ArgumentError outside a thread and for bad arguments.

    Args:
        params: the map (4.6), or ``flags`` (4.3-4.5).
        *legacy: the other 4.3-4.5 arguments.

    Returns:
        The map, or ``(pos, vel, accel, timeLeft)``.
    """
    if ctx.remote:  # a ZMQ client: one increment per step, its callback "NAME@func"
        return Stepped(config_motion(ctx, params, legacy, zmq_callback))
    thread = _threads.py_thread(ctx, "moveToConfig")
    return _drive(thread, config_motion(ctx, params, legacy, _python_callback))


@sim_function("moveToPose")
def moveToPose(ctx: CallContext, params: Any, *legacy: Any) -> Any:  # noqa: N802
    """Move an ``object`` (or a ``pose``) to ``targetPose`` along a jerk-limited trajectory,
    one increment per simulation step; in a threaded script only. The 4.6 map form
    (``object`` or ``pose``, ``targetPose``, ``relObject``, ``maxVel``, ``maxAccel``,
    ``maxJerk`` of x, y, z and the angle, or along a line with ``metric``; m, rad, s)
    returns the map with the final ``pose``, ``matrix`` and ``timeLeft``; 4.3-4.5's
    ``(flags, currentPose, maxVel, maxAccel, maxJerk, targetPose, callback, auxData [,
    metric, timeStep])`` calls ``callback(pose, vel, accel, auxData)`` each step and returns
    ``pose, timeLeft``.

    Args:
        params: the map (4.6), or ``flags`` (4.3-4.5).
        *legacy: the other 4.3-4.5 arguments.

    Returns:
        The map, or ``(pose, timeLeft)``.

    Raises:
        ArgumentError: outside a threaded Python script, or bad arguments.
    """
    if ctx.remote:
        return Stepped(pose_motion(ctx, params, legacy, zmq_callback))
    thread = _threads.py_thread(ctx, "moveToPose")
    return _drive(thread, pose_motion(ctx, params, legacy, _python_callback))


def lua_motion(ctx: CallContext, name: str, args: list) -> Motion:
    """A Lua thread's motion: its 4.3-4.5 callback stays in Lua (``True`` stands for it)."""
    if not args:
        raise ArgumentError(f"sim.{name} takes one map of parameters or CoppeliaSim 4.3-4.5's arguments")
    build = config_motion if name == "moveToConfig" else pose_motion
    return build(ctx, args[0], tuple(args[1:]), _lua_callback)




def _python_callback(callback: Any) -> Any:
    if not callable(callback):
        raise ArgumentError(f"the 4.3-4.5 form's callback must be a function, got {type(callback).__name__}")
    return callback


def _lua_callback(callback: Any) -> bool:
    if callback is not True:
        raise ArgumentError(f"the 4.3-4.5 form's callback must be a function, got {type(callback).__name__}")
    return True


def _drive(thread: Any, motion: Motion) -> Any:
    """Run a motion in a Python script's thread: its callback called, a thread switch per step."""
    value = None
    try:
        while True:
            try:
                item = motion.send(value)
            except StopIteration as done:
                values = done.value or []
                return values[0] if len(values) == 1 else tuple(values)
            value = None
            if isinstance(item, CallbackCall):
                value = item.callback(*item.args)
            else:
                thread.switch()
    finally:
        motion.close()


def _plain(params: dict) -> dict:
    """The caller's parameters without what cannot go back (callbacks, auxData as it came)."""
    return {k: v for k, v in params.items() if k not in ("callback",)}


def _rotation_axis(rot: np.ndarray, angle: float) -> np.ndarray:
    if angle < 1e-9:
        return np.array([0.0, 0.0, 1.0])
    if abs(angle - math.pi) < 1e-6:  # half a turn: the axis from the symmetric part
        m = (rot + np.eye(3)) / 2
        axis = m[:, int(np.argmax(np.diag(m)))]
        return axis / np.linalg.norm(axis)
    axis = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]]) / (2 * math.sin(angle))
    return axis / np.linalg.norm(axis)


def _turn(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)
