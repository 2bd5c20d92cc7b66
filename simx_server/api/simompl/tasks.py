"""simOMPL's state spaces and tasks: what a task is made of before ``setup`` (its state spaces,
algorithm, collision pairs, start and goal states, validation callback), and the handles that
name them (strings, as the plug-in's). The state space types are
:mod:`simx_server.sim.ompl_spaces`'s."""

from __future__ import annotations

import dataclasses
from typing import Any, Callable

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import SIMOMPL, simompl_function
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text
from simx_server.sim import motion_planning as mp, ompl_spaces as spaces
from simx_server.sim.objects import JOINT
from simx_wire.protocol import ArgumentError, UnsupportedError

#: ``simOMPL.Algorithm`` (the plug-in's enum, from 30001) and ``simOMPL.StateSpaceType`` (from 50001).
ALGORITHM = {name: 30001 + i for i, name in enumerate(mp.ALGORITHMS)}
STATE_SPACE_TYPE = {name: 50001 + i for i, name in enumerate(spaces.TYPES)}
JOINT_POSITION, CYCLIC = STATE_SPACE_TYPE["joint_position"], STATE_SPACE_TYPE["cyclic_joint_position"]
SIMOMPL.constants.update({"Algorithm": ALGORITHM, "StateSpaceType": STATE_SPACE_TYPE})
#: The most tasks and state spaces one caller may hold at once.
MAX_OBJECTS = 1024
#: Bytes the set-up tasks of every caller may keep beyond the scene (their collision checks'
#: scratch data, and the scene's model of their setup once it was edited:
#: ``motion_planning.kept_bytes``); a door's client's ``setup`` past it is refused. 25 kept tasks
#: took a server from 777 to 5,139 MB (issue 84).
MAX_KEPT_BYTES = 1 << 30
#: The finest state validity checking resolution (a fraction of the space's extent): OMPL checks a
#: motion state by state without looking at the planning time, 1/resolution states at most.
MIN_RESOLUTION = 1e-5


@dataclasses.dataclass
class StateSpace:
    name: str
    kind: str  #: a name of ompl_spaces.TYPES
    object: int  #: the joint, or the shape that a pose or position moves
    low: tuple[float, ...]
    high: tuple[float, ...]
    projection: bool
    ref: int = -1  #: the reference frame's object of positions and angles (-1: the world)
    turning_radius: float = 0.05  #: a dubins space's (simOMPL's default)
    symmetric: bool = False  #: a dubins space's (simOMPL's default)

    def subspace(self) -> spaces.Subspace:
        return spaces.Subspace(self.kind, self.low, self.high, self.projection, self.turning_radius, self.symmetric)


@dataclasses.dataclass
class Task:
    name: str
    spaces: list[str] = dataclasses.field(default_factory=list)
    dim: int = 0  #: the values of a state: its spaces' together
    algorithm: str = "KPIECE1"  # the plug-in's default
    pairs: list[int] = dataclasses.field(default_factory=list)
    start: list[float] | None = None
    goals: list[list[float]] = dataclasses.field(default_factory=list)
    resolution: float = 0.01
    verbose: int = 0
    callback: Callable[[list[float]], Any] | None = None
    problem: mp.Problem | None = None
    checker: mp.ScratchCollisions | None = None
    busy: bool = False  #: a solve, simplification or compute runs off the simulation thread (long_calls)


def _store(ctx: CallContext) -> dict[str, Any]:
    if ctx.state.ompl is None:
        ctx.state.ompl = {"next": 0}
    return ctx.state.ompl


def _add(ctx: CallContext, kind: str, obj: Any) -> str:
    store = _store(ctx)
    if len(store) > MAX_OBJECTS:
        raise ArgumentError(f"too many simOMPL tasks and state spaces ({MAX_OBJECTS}); destroy some first")
    store["next"] += 1
    handle = f"simOMPL.{kind}:{store['next']}"
    store[handle] = obj
    return handle


def _get(ctx: CallContext, handle: Any, kind: type, what: str) -> Any:
    h = _text(handle, what)
    obj = _store(ctx).get(h)
    if not isinstance(obj, kind):
        raise ArgumentError(f"{what}: no simOMPL {kind.__name__[0].lower() + kind.__name__[1:]} {h!r}")
    return obj


def task_of(ctx: CallContext, handle: Any, set_up: bool = False) -> Task:
    """The task ``handle`` names.

    Raises:
        ArgumentError: no such task; not set up (``set_up``); its planning runs now (off the
            simulation thread, :mod:`simx_server.api.long_calls`: OMPL's objects are not shared).
    """
    task: Task = _get(ctx, handle, Task, "taskHandle")
    if task.busy:
        raise ArgumentError("the task is busy: its planning (simOMPL.solve, simplifyPath or compute) runs now; "
                            "call again once that call has answered")
    if set_up and task.problem is None:
        raise ArgumentError("simOMPL.setup(taskHandle) has not been called")
    return task


def as_state(task: Task, value: Any, what: str = "state") -> list[float]:
    """A state of the task's dimension (simOMPL's ``validateStateSize``)."""
    dim = task.dim
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or not value:
        raise ArgumentError(f"{what} is empty." if isinstance(value, (list, tuple)) else f"{what} must be a table")
    if len(value) != dim:
        hint = " Did you forget to set the state space for this task?" if dim == 0 else ""
        raise ArgumentError(f"{what} is of incorrect size. Expected {dim}, got {len(value)}.{hint}")
    return [_num(v, f"{what}[{i + 1}]") for i, v in enumerate(value)]


def as_states(task: Task, value: Any, what: str = "states") -> np.ndarray:
    """A flat table of states (k * dim) as (k, dim)."""
    dim = max(task.dim, 1)
    if not isinstance(value, (list, tuple, np.ndarray)) or len(value) % dim:
        raise ArgumentError(f"{what} must be a flat table of states of {dim} values each")
    return np.asarray([_num(v, f"{what}[{i + 1}]") for i, v in enumerate(value)], dtype=float).reshape(-1, dim)


def spaces_of(ctx: CallContext, task: Task) -> list[StateSpace]:
    return [_get(ctx, h, StateSpace, "stateSpaceHandles") for h in task.spaces]


# ---------------------------------------------------------------- state spaces
@simompl_function()
def createStateSpace(ctx: CallContext, name: Any, type: Any, objectHandle: Any, boundsLow: Any, boundsHigh: Any,  # noqa: N802, N803
                     useForProjection: Any, weight: Any = 1.0, refObjectHandle: Any = -1) -> str:
    """A state space (``simOMPL.StateSpaceType``): ``joint_position`` a revolute or prismatic
    joint's position (one bound each, rad or m), ``cyclic_joint_position`` a cyclic revolute
    joint's (no bounds), ``position2d`` / ``position3d`` a shape's position (2 or 3 bounds, m),
    ``pose2d`` / ``dubins`` its position and yaw (bounds of x and y; ``dubins`` turns no tighter
    than :func:`setDubinsParams`'s radius), ``pose3d`` its position and quaternion (bounds of x,
    y, z). Positions and angles are relative to ``refObjectHandle`` (-1: the world); the shape
    must move freely (a dynamic shape, a model's base): simx places it in a scratch copy of the
    state to check collisions. ``useForProjection`` non-zero: projection-based planners
    (KPIECE...) project onto it (a pose: onto its position).

    Returns:
        the state space's handle (a string).

    Raises:
        ArgumentError: an unknown type, bounds of another length, a low bound not below the high
            one, a weight not positive, an object of the wrong kind.
        UnsupportedError: a weight other than 1.
    """
    text, kind = _text(name, "name"), _int(type, "type")
    names = {v: k for k, v in STATE_SPACE_TYPE.items()}
    if kind not in names:
        raise ArgumentError(f"type: no simOMPL.StateSpaceType {kind}")
    kind_name = names[kind]
    if not isinstance(boundsLow, (list, tuple)) or not isinstance(boundsHigh, (list, tuple)) \
            or len(boundsLow) != len(boundsHigh):
        raise ArgumentError("Lower and upper bounds must have the same length.")
    count = spaces.BOUNDS[kind_name]
    if kind_name == "cyclic_joint_position":
        boundsLow = boundsHigh = ()  # the plug-in warns and ignores them: a cyclic joint has none
    elif len(boundsLow) != count:
        what = "of its position " if kind_name in ("pose2d", "dubins", "pose3d") else ""
        raise ArgumentError(f"a {kind_name} state space has {count} lower and {count} upper bound(s) {what}"
                            f"(got {len(boundsLow)})")
    low = tuple(_num(v, f"boundsLow[{i + 1}]") for i, v in enumerate(boundsLow))
    high = tuple(_num(v, f"boundsHigh[{i + 1}]") for i, v in enumerate(boundsHigh))
    for lo, hi in zip(low, high):
        if not lo < hi:
            raise ArgumentError(f"boundsLow ({lo}) must be below boundsHigh ({hi})")
    w = _num(weight, "weight")
    if w <= 0:
        raise ArgumentError("State component weight must be positive.")
    if w != 1.0:
        raise UnsupportedError("weights other than 1 are not supported by simx")
    ref = _int(refObjectHandle, "refObjectHandle")
    if ref != -1:
        ref = ctx.world.get(ctx.h(refObjectHandle, "refObjectHandle")).handle
    handle = ctx.h(objectHandle, "objectHandle")
    if kind_name in spaces.JOINT_TYPES:
        obj = ctx.world.get(handle, JOINT)
        types = {"joint_position": (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE),
                 "cyclic_joint_position": (mujoco.mjtJoint.mjJNT_HINGE,)}[kind_name]
        if int(ctx.world.model.jnt_type[obj.mj_id]) not in [int(t) for t in types]:
            raise ArgumentError(f"objectHandle: joint {obj.name!r} is not "
                                f"{'revolute nor prismatic' if len(types) == 2 else 'revolute'}")
    else:
        try:  # what setup will place: checked now
            spaces.Placement(ctx.world, kind_name, handle, ref)
        except ValueError as exc:
            raise ArgumentError(f"objectHandle: {exc}") from None
    space = StateSpace(text, kind_name, handle, low, high, _int(useForProjection, "useForProjection") > 0, ref)
    return _add(ctx, "stateSpace", space)


@simompl_function()
def setDubinsParams(ctx: CallContext, stateSpaceHandle: Any, turningRadius: Any, isSymmetric: Any) -> None:  # noqa: N802, N803
    """A ``dubins`` state space's turning radius (m, > 0) and whether its distance is symmetric
    (OMPL's ``DubinsStateSpace``); the other types keep them unused, as the plug-in does."""
    space: StateSpace = _get(ctx, stateSpaceHandle, StateSpace, "stateSpaceHandle")
    radius = _num(turningRadius, "turningRadius")
    if not radius > 0:
        raise ArgumentError(f"turningRadius must be positive (m), got {radius}")
    space.turning_radius, space.symmetric = radius, bool(isSymmetric)


@simompl_function()
def createStateSpaceForJoint(ctx: CallContext, name: Any, jointHandle: Any, useForProjection: Any = 0,  # noqa: N802, N803
                             weight: Any = 1.0) -> str:
    """simOMPL.lua's helper: :func:`createStateSpace` of a joint within its interval
    (``sim.getJointInterval``), a ``cyclic_joint_position`` space for a cyclic joint."""
    cyclic, interval = ctx.sim.getJointInterval(jointHandle)
    if cyclic:
        return createStateSpace(ctx, name, CYCLIC, jointHandle, [], [], useForProjection, weight)
    return createStateSpace(ctx, name, JOINT_POSITION, jointHandle, [interval[0]], [interval[0] + interval[1]],
                            useForProjection, weight)


@simompl_function()
def destroyStateSpace(ctx: CallContext, stateSpaceHandle: Any) -> None:  # noqa: N802, N803
    """Forgets a state space."""
    _get(ctx, stateSpaceHandle, StateSpace, "stateSpaceHandle")
    del _store(ctx)[_text(stateSpaceHandle, "stateSpaceHandle")]


# ------------------------------------------------------------------- tasks
@simompl_function()
def createTask(ctx: CallContext, name: Any) -> str:  # noqa: N802
    """A new task (algorithm KPIECE1, as the plug-in's default); returns its handle (a string)."""
    return _add(ctx, "task", Task(_text(name, "name")))


@simompl_function()
def destroyTask(ctx: CallContext, taskHandle: Any) -> None:  # noqa: N802, N803
    """Forgets a task."""
    task_of(ctx, taskHandle)
    del _store(ctx)[_text(taskHandle, "taskHandle")]


@simompl_function()
def printTaskInfo(ctx: CallContext, taskHandle: Any) -> None:  # noqa: N802, N803
    """Writes the task's settings to the log (INFO)."""
    import logging

    t = task_of(ctx, taskHandle)
    logging.getLogger(__name__).info("simOMPL task %r: algorithm %s, state spaces %s, collision pairs %s, start %s, "
                                     "goals %s", t.name, t.algorithm, t.spaces, t.pairs, t.start, t.goals)


@simompl_function()
def setVerboseLevel(ctx: CallContext, taskHandle: Any, verboseLevel: Any) -> None:  # noqa: N802, N803
    """Kept; simx's planner writes nothing to the log while planning."""
    task_of(ctx, taskHandle).verbose = _int(verboseLevel, "verboseLevel")


@simompl_function()
def setStateValidityCheckingResolution(ctx: CallContext, taskHandle: Any, resolution: Any) -> None:  # noqa: N802, N803
    """How finely motions are checked: a fraction of the space's extent (default 0.01)."""
    r = _num(resolution, "resolution")
    if not MIN_RESOLUTION <= r <= 1:
        raise ArgumentError(f"resolution must be in [{MIN_RESOLUTION:g}, 1]: a fraction of the state space's extent "
                            "(finer, one motion's check would run for minutes inside OMPL, out of the planning "
                            "time's reach; tasks.MIN_RESOLUTION)")
    task_of(ctx, taskHandle).resolution = r


@simompl_function()
def setStateSpace(ctx: CallContext, taskHandle: Any, stateSpaceHandles: Any) -> None:  # noqa: N802, N803
    """The task's state: the values of these state spaces, in this order."""
    task = task_of(ctx, taskHandle)
    if not isinstance(stateSpaceHandles, (list, tuple)):
        raise ArgumentError("stateSpaceHandles must be a table of state space handles")
    found = [_get(ctx, h, StateSpace, "stateSpaceHandles") for h in stateSpaceHandles]
    task.spaces = [_text(h, "stateSpaceHandles") for h in stateSpaceHandles]
    task.dim = sum(spaces.DIMENSION[s.kind] for s in found)


@simompl_function()
def setStateSpaceForJoints(ctx: CallContext, taskHandle: Any, jointHandles: Any, useForProjection: Any = (),  # noqa: N802, N803
                           weights: Any = ()) -> None:
    """simOMPL.lua's helper: one :func:`createStateSpaceForJoint` per joint, as the task's state."""
    if not isinstance(jointHandles, (list, tuple)):
        raise ArgumentError("jointHandles must be a table of joint handles")
    proj, w = list(useForProjection or ()), list(weights or ())
    spaces = [createStateSpaceForJoint(ctx, f"j{i + 1}", j, proj[i] if i < len(proj) else 0, w[i] if i < len(w) else 1.0)
              for i, j in enumerate(jointHandles)]
    setStateSpace(ctx, taskHandle, spaces)


@simompl_function()
def getStateSpaceDimension(ctx: CallContext, taskHandle: Any) -> int:  # noqa: N802, N803
    """The number of values of the task's state (a ``pose2d`` has 3, a ``pose3d`` 7...)."""
    return task_of(ctx, taskHandle).dim


@simompl_function()
def setAlgorithm(ctx: CallContext, taskHandle: Any, algorithm: Any) -> None:  # noqa: N802, N803
    """The planner (``simOMPL.Algorithm.RRTConnect``...).

    Raises:
        ArgumentError: not a ``simOMPL.Algorithm`` value.
        UnsupportedError: an algorithm that OMPL's Python bindings lack (they have BITstar,
            BKPIECE1, FMT, KPIECE1, LBKPIECE1, PRM, PRMstar, RRT, RRTConnect, RRTstar).
    """
    task = task_of(ctx, taskHandle)
    value = _int(algorithm, "algorithm")
    names = {v: k for k, v in ALGORITHM.items()}
    if value not in names:
        raise ArgumentError(f"Invalid motion planning algorithm: {value} (simOMPL.Algorithm has "
                            f"{min(names)}..{max(names)})")
    if names[value] not in mp.available():
        if mp.IMPORT_ERROR:
            raise UnsupportedError(mp.IMPORT_ERROR)
        raise UnsupportedError(f"OMPL's Python bindings have no {names[value]} planner; "
                               f"they have {', '.join(mp.available())}")
    task.algorithm = names[value]


@simompl_function()
def setCollisionPairs(ctx: CallContext, taskHandle: Any, collisionPairHandles: Any) -> None:  # noqa: N802, N803
    """Entity pairs ``{e1, e2, e1', e2', ...}`` (shapes, collections, ``sim.handle_all``) that
    must not collide along the path (an odd last one is dropped, as the plug-in does)."""
    task = task_of(ctx, taskHandle)
    if not isinstance(collisionPairHandles, (list, tuple)):
        raise ArgumentError("collisionPairHandles must be a table of entity handles")
    handles = [ctx.h(h, "collisionPairHandles") for h in collisionPairHandles]
    task.pairs = handles[:len(handles) // 2 * 2]


@simompl_function()
def setStartState(ctx: CallContext, taskHandle: Any, state: Any) -> None:  # noqa: N802, N803
    """The start state (one value per state space)."""
    task = task_of(ctx, taskHandle)
    task.start = as_state(task, state)


@simompl_function()
def setGoalState(ctx: CallContext, taskHandle: Any, state: Any) -> None:  # noqa: N802, N803
    """The goal state (replaces the goals)."""
    task = task_of(ctx, taskHandle)
    task.goals = [as_state(task, state)]


@simompl_function()
def addGoalState(ctx: CallContext, taskHandle: Any, state: Any) -> None:  # noqa: N802, N803
    """One more goal state: a path to any goal solves the task."""
    task = task_of(ctx, taskHandle)
    task.goals.append(as_state(task, state))


@simompl_function()
def setGoalStates(ctx: CallContext, taskHandle: Any, states: Any) -> None:  # noqa: N802, N803
    """simOMPL.lua's helper: :func:`setGoalState` of the first, :func:`addGoalState` of the others."""
    if not isinstance(states, (list, tuple)) or not states:
        raise ArgumentError("states must be a table of states")
    setGoalState(ctx, taskHandle, states[0])
    for s in states[1:]:
        addGoalState(ctx, taskHandle, s)


@simompl_function()
def setStateValidationCallback(ctx: CallContext, taskHandle: Any, callback: Any) -> None:  # noqa: N802, N803
    """A function ``callback(state) -> bool`` that decides which states are valid, instead of
    the collision pairs (a Python script's or an in-process caller's function).

    Raises:
        ArgumentError: not callable (a ZMQ client cannot pass a function).
    """
    task = task_of(ctx, taskHandle)
    if not callable(callback):
        raise ArgumentError("callback must be a function (a ZMQ client cannot pass one; use setCollisionPairs)")
    task.callback = callback


