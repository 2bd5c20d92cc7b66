"""simOMPL's planning calls on a task: ``setup`` (OMPL's problem, the scratch collision check),
``solve``, ``simplifyPath``, ``interpolatePath``, ``getPath``, ``compute``, the solution's state,
and the calls on single states and flat paths."""

from __future__ import annotations

import inspect
from typing import Any, Callable, Generator

import numpy as np

from simx_server.api import long_calls
from simx_server.api.mesh_waits import door_client
from simx_server.api.context import CallContext
from simx_server.api.registry import simompl_function
from simx_server.api.simompl import tasks
from simx_server.api.simompl.tasks import Task, as_state, as_states, spaces_of, task_of
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.sim import motion_planning as mp, ompl_spaces
from simx_wire.protocol import BUSY, ArgumentError, RemoteError, UnsupportedError


@simompl_function()
def setup(ctx: CallContext, taskHandle: Any) -> None:
    """Makes the planner of the task's state spaces, start, goals and algorithm; reads the
    scene's state for the collision checks.

    Raises:
        ArgumentError: no state space, start state or goal state.
        UnsupportedError: OMPL's Python bindings are not installed.
    """
    task = task_of(ctx, taskHandle)
    spaces = spaces_of(ctx, task)
    if not spaces:
        raise ArgumentError("the task has no state space (simOMPL.setStateSpace)")
    if task.start is None:
        raise ArgumentError("Start state is empty.")
    if not task.goals:
        raise ArgumentError("No goal state specified.")
    if mp.IMPORT_ERROR:
        raise UnsupportedError(mp.IMPORT_ERROR)
    try:
        placements = [ompl_spaces.Placement(ctx.world, s.kind, s.object, s.ref) for s in spaces]
    except ValueError as exc:
        raise ArgumentError(str(exc)) from None
    if door_client(ctx):  # what the tasks keep, this one's new copy of the scene's data with them
        data = ctx.world.data
        kept = mp.kept_bytes(ctx.world.model, task.checker) + int(data.nbuffer) + int(data.narena)
        if kept > tasks.MAX_KEPT_BYTES:
            raise RemoteError(f"{BUSY}: the simOMPL tasks set up would keep {kept:,} bytes of copies of the scene, "
                              f"more than {tasks.MAX_KEPT_BYTES:,} (tasks.MAX_KEPT_BYTES); destroy some tasks "
                              "(simOMPL.destroyTask)")
    task.checker = mp.ScratchCollisions(ctx.world, placements, list(zip(task.pairs[::2], task.pairs[1::2])),
                                        bounded=door_client(ctx))
    callback = task.callback
    if callback is not None:
        def valid(q: np.ndarray) -> bool:
            try:
                return bool(callback(q.tolist()))
            except Exception as exc:  # the caller's code: its error, named, ends the planning call
                raise ArgumentError(f"the state validation callback failed: {exc}") from exc
    else:
        checker = task.checker

        def valid(q: np.ndarray) -> bool:
            return not checker(q)
    try:
        task.problem = mp.Problem(ompl_spaces.Space([s.subspace() for s in spaces]), long_calls.stoppable(valid),
                                  task.resolution)
        task.problem.setup(np.array(task.start), [np.array(g) for g in task.goals], task.algorithm)
    except ValueError as exc:
        task.problem = None
        raise ArgumentError(str(exc)) from None


def _max_time(value: Any) -> float:
    t = _num(value, "maxTime")
    if not t > 0:
        raise ArgumentError("maxTime must be positive (s)")
    return t


def _planned(ctx: CallContext, task: Task, work: Callable[[mp.Problem], Any]) -> Any:
    """``work(problem)`` on the task's problem, its collision checks on a copy of the scene's
    state now; for a ZMQ client off the simulation thread (:func:`long_calls.later`: a
    Deferred), the task refusing other calls meanwhile (``Task.busy``). ValueError (a bound of
    the path) is an ArgumentError."""
    problem = _fresh(ctx, task)
    checker = task.checker
    assert checker is not None

    def run() -> Generator[None, None, Any]:  # a solve's steps run in slices off the thread
        checker.defer = False  # a planner's thread builds the trees its checks need
        try:
            result = work(problem)
            if inspect.isgenerator(result):
                result = yield from result
            return result
        except ValueError as exc:
            raise ArgumentError(str(exc)) from None

    def done() -> None:
        checker.defer = True
        task.busy = False

    task.busy = True
    return long_calls.later(ctx, run, done=done)


@simompl_function()
def solve(ctx: CallContext, taskHandle: Any, maxTime: Any) -> bool:  # noqa: N803
    """Runs the planner for at most ``maxTime`` s (and at most
    :data:`~simx_server.sim.motion_planning.MAX_SECONDS`); True when it found a path (exact or
    approximate). A ZMQ client's runs off the simulation thread (:mod:`simx_server.api.long_calls`)."""
    task = task_of(ctx, taskHandle, True)
    t = _max_time(maxTime)
    step = _step(ctx, t)
    return _planned(ctx, task, lambda problem: problem.solve_in_steps(t, step))  # type: ignore[no-any-return]


def _step(ctx: CallContext, max_time: float) -> float:
    """s a solve runs between two yields: off the simulation thread a slice of the long calls'
    turns (long_calls.SLICE_SECONDS: others are served between), at once all of it."""
    return long_calls.SLICE_SECONDS if long_calls.off_thread(ctx) else max_time


def _fresh(ctx: CallContext, task: Task) -> mp.Problem:
    """The task's problem, its collision checks on a copy of the scene's state now."""
    assert task.problem is not None and task.checker is not None
    if task.checker.model is not ctx.world.model:
        raise ArgumentError("the scene's model changed since simOMPL.setup: call setup again")
    task.checker.refresh()
    return task.problem


def _solved(ctx: CallContext, taskHandle: Any) -> mp.Problem:
    task = task_of(ctx, taskHandle, True)
    assert task.problem is not None
    if task.problem.path is None:
        raise ArgumentError("the task has no solution path (simOMPL.solve first)")
    return task.problem


@simompl_function()
def simplifyPath(ctx: CallContext, taskHandle: Any, maxSimplificationTime: Any = -1.0) -> None:  # noqa: N802, N803
    """OMPL's path simplifier on the solution: as much as it can when ``maxSimplificationTime``
    < 0, else for at most that many s (10 s at most either way). A ZMQ client's runs off the
    simulation thread (:mod:`simx_server.api.long_calls`)."""
    _solved(ctx, taskHandle)
    seconds = _num(maxSimplificationTime, "maxSimplificationTime")
    return _planned(ctx, task_of(ctx, taskHandle), lambda problem: problem.simplify(seconds))  # type: ignore[no-any-return]


@simompl_function()
def interpolatePath(ctx: CallContext, taskHandle: Any, stateCnt: Any = 0) -> None:  # noqa: N802, N803
    """Interpolates the solution to ``stateCnt`` states (0: at OMPL's checking resolution).

    Raises:
        ArgumentError: the path would hold more than
            :data:`~simx_server.sim.motion_planning.MAX_PATH_VALUES` values (checked first).
    """
    count = _state_count(ctx, taskHandle, stateCnt)
    try:
        _solved(ctx, taskHandle).interpolate(count)
    except ValueError as exc:
        raise ArgumentError(str(exc)) from None


def _state_count(ctx: CallContext, taskHandle: Any, stateCnt: Any) -> int:  # noqa: N803
    """``stateCnt`` checked: >= 0, and its states within MAX_PATH_VALUES values."""
    count = _int(stateCnt, "stateCnt")
    if count < 0:
        raise ArgumentError("stateCnt must be >= 0")
    dim = max(task_of(ctx, taskHandle).dim, 1)
    if count * dim > mp.MAX_PATH_VALUES:
        raise ArgumentError(f"stateCnt {count}: {count} states of {dim} values would pass {mp.MAX_PATH_VALUES} "
                            "values (motion_planning.MAX_PATH_VALUES); ask for fewer states")
    return count


@simompl_function()
def hasSolution(ctx: CallContext, taskHandle: Any) -> bool:  # noqa: N802, N803
    """Whether a path (exact or approximate) was found."""
    p = task_of(ctx, taskHandle, True).problem
    return p is not None and (p.exact() or p.approximate())


@simompl_function()
def hasExactSolution(ctx: CallContext, taskHandle: Any) -> bool:  # noqa: N802, N803
    """Whether the path found reaches a goal."""
    p = task_of(ctx, taskHandle, True).problem
    return p is not None and p.exact()


@simompl_function()
def hasApproximateSolution(ctx: CallContext, taskHandle: Any) -> bool:  # noqa: N802, N803
    """Whether the path found stops short of the goals."""
    p = task_of(ctx, taskHandle, True).problem
    return p is not None and p.approximate()


@simompl_function()
def getGoalDistance(ctx: CallContext, taskHandle: Any) -> float:  # noqa: N802, N803
    """How far the path found ends from the goals (0: exact)."""
    p = task_of(ctx, taskHandle, True).problem
    assert p is not None
    return p.goal_distance()


@simompl_function()
def getPath(ctx: CallContext, taskHandle: Any) -> list[float]:  # noqa: N802, N803
    """The solution's states, flat (state count * dimension)."""
    return _solved(ctx, taskHandle).path_values().reshape(-1).tolist()


@simompl_function()
def compute(ctx: CallContext, taskHandle: Any, maxTime: Any, maxSimplificationTime: Any = -1.0,  # noqa: N803
            stateCnt: Any = 0) -> tuple[bool, list[float]]:
    """:func:`solve`, then :func:`simplifyPath`, :func:`interpolatePath` and :func:`getPath`:
    ``(solved, states)`` (``states`` empty when not solved). A ZMQ client's runs off the
    simulation thread, in one job (:mod:`simx_server.api.long_calls`).

    Raises:
        ArgumentError: ``stateCnt`` (or, with 0, the checking resolution) would make a path of
            more than :data:`~simx_server.sim.motion_planning.MAX_PATH_VALUES` values: before
            planning, or once the path is found (then nothing is interpolated).
    """
    task = task_of(ctx, taskHandle, True)
    t = _max_time(maxTime)
    seconds = _num(maxSimplificationTime, "maxSimplificationTime")
    count = _state_count(ctx, taskHandle, stateCnt)

    step = _step(ctx, t)

    def work(problem: mp.Problem) -> Generator[None, None, tuple[bool, list[float]]]:
        if not (yield from problem.solve_in_steps(t, step)):  # in slices off the simulation thread
            return False, []
        problem.simplify(seconds)
        problem.interpolate(count)
        return True, problem.path_values().reshape(-1).tolist()

    return _planned(ctx, task, work)  # type: ignore[no-any-return]


# ------------------------------------------------------------------ states
@simompl_function()
def readState(ctx: CallContext, taskHandle: Any) -> list[float]:  # noqa: N802, N803
    """The scene's current values of the task's state spaces: joint positions, objects'
    positions, yaws (V-REP's third Euler angle) and quaternions relative to each space's
    reference (the plug-in's ``readState``)."""
    state: list[float] = []
    for s in spaces_of(ctx, task_of(ctx, taskHandle)):
        if s.kind in ompl_spaces.JOINT_TYPES:
            state.append(float(ctx.sim.getJointPosition(s.object)))
            continue
        pos = [float(v) for v in ctx.sim.getObjectPosition(s.object, s.ref)]
        if s.kind in ("pose2d", "dubins"):
            state += [*pos[:2], float(ctx.sim.getObjectOrientation(s.object, s.ref)[2])]
        elif s.kind == "pose3d":
            state += [*pos, *(float(v) for v in ctx.sim.getObjectQuaternion(s.object, s.ref))]
        else:
            state += pos[:ompl_spaces.DIMENSION[s.kind]]
    return state


@simompl_function()
def writeState(ctx: CallContext, taskHandle: Any, state: Any) -> None:  # noqa: N802, N803
    """Moves the scene to ``state`` (the plug-in's ``writeState``): joints with
    ``sim.setJointPosition``, objects with ``sim.setObjectPosition`` (a 2-D position keeps the
    object's z) and ``sim.setObjectOrientation`` (a yaw keeps the first two Euler angles) or
    ``sim.setObjectQuaternion``."""
    task = task_of(ctx, taskHandle)
    values = as_state(task, state)
    i = 0
    for s in spaces_of(ctx, task):
        v = values[i:i + ompl_spaces.DIMENSION[s.kind]]
        i += len(v)
        if s.kind in ompl_spaces.JOINT_TYPES:
            ctx.sim.setJointPosition(s.object, v[0])
            continue
        pos = [float(c) for c in ctx.sim.getObjectPosition(s.object, s.ref)]
        n = ompl_spaces.BOUNDS[s.kind]  # the position's values
        pos[:n] = v[:n]
        if s.kind in ("pose2d", "dubins"):
            euler = [float(c) for c in ctx.sim.getObjectOrientation(s.object, s.ref)]
            ctx.sim.setObjectOrientation(s.object, s.ref, [euler[0], euler[1], v[2]])
        elif s.kind == "pose3d":
            ctx.sim.setObjectQuaternion(s.object, s.ref, v[3:7])
        ctx.sim.setObjectPosition(s.object, s.ref, pos)


def _space(ctx: CallContext, task: Task) -> ompl_spaces.Space:
    """OMPL's space of the task (bounds, angles, metric), without a setup."""
    found = spaces_of(ctx, task)
    if not found:
        raise ArgumentError("the task has no state space (simOMPL.setStateSpace)")
    if mp.IMPORT_ERROR:
        raise UnsupportedError(mp.IMPORT_ERROR)
    return ompl_spaces.Space([s.subspace() for s in found])


@simompl_function()
def isStateValid(ctx: CallContext, taskHandle: Any, state: Any) -> bool:  # noqa: N802, N803
    """The task's validity check of one state (the scene's current state otherwise)."""
    task = task_of(ctx, taskHandle, True)
    problem, q = _fresh(ctx, task), as_state(task, state)
    if task.callback is None and task.checker is not None:
        # OMPL's check is the collision check alone (of the state as OMPL holds it), called here
        # so that its errors (a mesh's tree being built for a client) reach the door unchanged
        return not task.checker(problem.codec.values(problem.state(q)))
    return problem.is_valid(q)


@simompl_function()
def isStateWithinBounds(ctx: CallContext, taskHandle: Any, state: Any) -> bool:  # noqa: N802, N803
    """Whether the state lies within its state spaces' bounds (OMPL's ``satisfiesBounds``)."""
    task = task_of(ctx, taskHandle)
    return _space(ctx, task).within_bounds(as_state(task, state))


@simompl_function()
def enforceBounds(ctx: CallContext, taskHandle: Any, state: Any) -> list[float]:  # noqa: N802, N803
    """The state brought within its bounds (OMPL's ``enforceBounds``: positions and joint values
    clipped, angles wrapped to [-pi, pi])."""
    task = task_of(ctx, taskHandle)
    return _space(ctx, task).enforce_bounds(as_state(task, state)).tolist()


@simompl_function()
def stateDistance(ctx: CallContext, taskHandle: Any, a: Any, b: Any) -> float:  # noqa: N802
    """The distance between two states in the task's space (OMPL's: the spaces' distances
    summed, as the plug-in's compound space, so several joints' absolute differences; a pose's
    position and angle distances summed, a dubins space's shortest Dubins curve)."""
    task = task_of(ctx, taskHandle)
    return _space(ctx, task).distance(as_state(task, a, "a"), as_state(task, b, "b"))


@simompl_function()
def getPathStateCount(ctx: CallContext, taskHandle: Any, path: Any) -> int:  # noqa: N802, N803
    """simOMPL.lua's helper: the number of states in a flat path."""
    return len(as_states(task_of(ctx, taskHandle), path, "path"))


@simompl_function()
def getPathState(ctx: CallContext, taskHandle: Any, path: Any, index: Any) -> list[float]:  # noqa: N802, N803
    """simOMPL.lua's helper: the state at ``index`` (from 1; negative from the end) of a flat path."""
    states = as_states(task_of(ctx, taskHandle), path, "path")
    i = _int(index, "index")
    if i == 0 or abs(i) > len(states):
        raise ArgumentError("invalid index")
    return states[i - 1 if i > 0 else i].tolist()


@simompl_function()
def getReversedPath(ctx: CallContext, taskHandle: Any, path: Any) -> list[float]:  # noqa: N802, N803
    """simOMPL.lua's helper: the flat path's states in reverse order."""
    return as_states(task_of(ctx, taskHandle), path, "path")[::-1].reshape(-1).tolist()
