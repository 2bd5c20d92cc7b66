"""Motion planning with OMPL (the ``ompl`` package's Python bindings) for ``simOMPL``.

:class:`Problem` is one planning query in a task's state space (joint positions, object
positions and poses: :mod:`simx_server.sim.ompl_spaces`): OMPL's ``SpaceInformation`` with a
Python state-validity checker, a start state, one goal state (``GoalState``) or several
(``GoalStates``), and one of OMPL's planners by its ``simOMPL`` name. After a solve, the
solution path is simplified with OMPL's ``PathSimplifier`` (``simplifyMax``, or ``simplify``
within a time) and interpolated with ``PathGeometric.interpolate``, as the simOMPL plug-in's
``solve``, ``simplifyPath``, ``interpolatePath`` and ``compute`` do (CoppeliaRobotics/simOMPL,
``sourceCode/plugin.cpp``).

:class:`ScratchCollisions` is the default validity check of a simOMPL task (its collision
pairs): a state is written into a scratch ``MjData`` (a copy of the world's state: joint
positions, free bodies' poses; a grasped part put where its holder carries it, as a child object
moves with its parent in CoppeliaSim), its poses computed with ``mj_kinematics``, and the pairs' geoms
tested there (:func:`simx_server.sim.collisions.pairs_collide`: a mesh on its triangles, with
coal), so that planning never moves the simulation. simOMPL writes each state into the scene and reads
CoppeliaSim's collision check instead.
"""

from __future__ import annotations

import time
import weakref
from collections.abc import Iterator
from typing import Any, Callable

import mujoco
import numpy as np

from simx_server.sim import collisions, grasps, ompl_spaces
from simx_server.sim.mesh_geometry import UNBOUNDED, Work
from simx_server.sim.ompl_spaces import JOINT_TYPES, Placement, Space
from simx_server.sim.world import World
from simx_wire.protocol import MAX_REQUEST_ITEMS

# OMPL's modules, imported when a planning call first needs them (:func:`_load`); without the
# bindings every planning call says so (``IMPORT_ERROR``).
ob: Any = None
og: Any = None


def _load() -> None:
    """Imports OMPL's bindings on first use (:func:`~simx_server.sim.ompl_spaces.load`).

    Raises:
        RuntimeError: they are not installed.
    """
    global ob, og
    ob, og, _ = ompl_spaces.load()


def __getattr__(name: str) -> Any:
    """``IMPORT_ERROR``: why OMPL's bindings cannot be imported (imported now if not yet), or None."""
    if name == "IMPORT_ERROR":
        return ompl_spaces.import_error()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

#: s one solve or simplification may take at most (the caller's thread waits for it: a script's;
#: a ZMQ client's runs off the simulation thread, :mod:`simx_server.api.long_calls`).
MAX_SECONDS = 10.0
#: The most values (states x the state's dimension) a path may hold once interpolated (37,449
#: states of a 7-joint arm; a reply of 2.4 MiB). ``simOMPL.compute(task, 1e9, 1e9, 1e7)`` made
#: 10^7 states and grew the server from 240 MB to 7 GB; a count past this is refused before it is
#: made. Bound tighter than a reply's values (``protocol.MAX_REQUEST_ITEMS``): OMPL's bindings
#: hold the GIL while they list a path's states (2 million: 5 s, every other thread waiting).
MAX_PATH_VALUES = MAX_REQUEST_ITEMS // 8
#: simOMPL's ``Algorithm`` enum (callbacks.xml, from 30001, in this order; the plug-in leaves out
#: the parallel pRRT and pSBL).
ALGORITHMS: tuple[str, ...] = (
    "BiTRRT", "BITstar", "BKPIECE1", "CForest", "EST", "FMT", "KPIECE1", "LazyPRM", "LazyPRMstar", "LazyRRT",
    "LBKPIECE1", "LBTRRT", "PDST", "PRM", "PRMstar", "RRT", "RRTConnect", "RRTstar", "SBL", "SPARS", "SPARStwo",
    "STRIDE", "TRRT")


def available() -> tuple[str, ...]:
    """The algorithms the installed OMPL bindings have a planner class for.

    Returns:
        Names of :data:`ALGORITHMS` (``ompl`` 2.0.1: BITstar, BKPIECE1, FMT, KPIECE1, LBKPIECE1,
        PRM, PRMstar, RRT, RRTConnect, RRTstar); empty without the bindings.
    """
    try:
        _load()
    except RuntimeError:
        return ()
    return tuple(a for a in ALGORITHMS if hasattr(og, a))


class ScratchCollisions:
    """Whether a state collides, tested on a scratch copy of the scene's state.

    Args:
        world: the scene (its model and current state are copied once, here).
        placements: what each state space's values move (:class:`~simx_server.sim.ompl_spaces.Placement`:
            a joint's ``qpos``, a free body's pose), in the state's order.
        pairs: the entities to test, ``[(entity1, entity2), ...]`` (shapes, collections,
            ``sim_handle_all`` as entity2), as ``sim.checkCollision`` takes them.
        bounded: a door's client's task: each check is a client's query, bounded
            (``mesh_geometry.MAX_QUERY_SECONDS``); while :attr:`defer` (a check on the simulation
            thread) a mesh's tree is not built there (``TreesPending``), on a planner's thread it is.

    Raises:
        UnknownObjectError, ObjectTypeError, ArgumentError: an entity as ``sim.checkCollision``.
    """

    def __init__(self, world: World, placements: list[Placement], pairs: list[tuple[int, int]],
                 bounded: bool = False):
        self.world = world
        self.bounded, self.defer = bounded, True
        self.model = world.model
        self._model_only = _ModelOnly(self.model)  # what the checks read of the scene: its model then
        self.data = mujoco.MjData(world.model)
        self.placements = placements
        offsets = np.cumsum([0] + [p.width for p in placements]).tolist()
        spans = list(zip(placements, offsets, offsets[1:]))
        # joints are written in one store per state; poses (a base's, a free body's) one by one
        self.joint_qpos = np.array([p.address for p, _, _ in spans if p.kind in JOINT_TYPES], dtype=int)
        self.joint_values = np.array([start for p, start, _ in spans if p.kind in JOINT_TYPES], dtype=int)
        self.poses = [(p, start, end) for p, start, end in spans if p.kind not in JOINT_TYPES]
        self.refresh()
        found = [collisions.collision_pairs(world, e1, e2) for e1, e2 in pairs]
        self.a = np.concatenate([a for a, _ in found]) if found else np.zeros(0, dtype=int)
        self.b = np.concatenate([b for _, b in found]) if found else np.zeros(0, dtype=int)
        _CHECKERS.add(self)

    def refresh(self) -> None:
        """Copies the world's state again (the scene may have moved since), the poses that
        states leave unchanged (a base's height...), and the grasped parts held now (they move
        with their holder in each state, as a child object does in CoppeliaSim)."""
        m = self.model
        placed = {p.address for p in self.placements if p.kind not in JOINT_TYPES and p.address >= 0}
        self.held = [h for h in grasps.held_parts(self.world)  # a part a state places is the state's
                     if int(m.jnt_qposadr[m.body_jntadr[h[0]]]) not in placed]
        self.data.qpos[:] = self.world.data.qpos
        self.data.mocap_pos[:], self.data.mocap_quat[:] = self.world.data.mocap_pos, self.world.data.mocap_quat
        for p in self.placements:
            p.refresh(self.world)

    def __call__(self, q: np.ndarray) -> bool:
        """True when the state ``q`` (its values, the placements' in order) collides."""
        if self.a.size == 0:
            return False
        if self.joint_qpos.size:
            self.data.qpos[self.joint_qpos] = q[self.joint_values]
        for p, start, end in self.poses:
            p.write(self.data, q[start:end])
        if self.held:  # grasped parts where their holders put them
            grasps.place_held(self.model, self.data, self.held)
        mujoco.mj_kinematics(self.model, self.data)
        # the model of setup, not world.model: a check may run off the simulation thread while
        # an edit recompiles the scene (its new model would not fit this MjData)
        work = Work.client(self.defer) if self.bounded else UNBOUNDED
        return collisions.pairs_collide(self._model_only, self.a, self.b, self.data, work)


_CHECKERS: weakref.WeakSet[ScratchCollisions] = weakref.WeakSet()  # every one alive (kept by a task)


def kept_bytes(live: mujoco.MjModel, besides: ScratchCollisions | None = None) -> int:
    """Bytes the collision checks alive keep beyond the scene (the planning tasks' copies):
    each one's scratch ``MjData`` (its buffer and arena), and each model other than ``live``
    once (a task set up before an edit keeps the scene's model of then). The meshes' trees are
    :data:`~simx_server.sim.mesh_geometry.TREES`' (bounded there).

    Args:
        live: the scene's model now.
        besides: a check not to count (one about to be replaced).

    Returns:
        Bytes.
    """
    total, models = 0, {}
    for checker in list(_CHECKERS):
        if checker is besides:
            continue
        total += int(checker.data.nbuffer) + int(checker.data.narena)
        if checker.model is not live:
            models[id(checker.model)] = int(checker.model.nbuffer)
    return total + sum(models.values())


class _ModelOnly:
    """A world as :func:`simx_server.sim.collisions.pairs_collide` reads it with a scratch MjData:
    its model only."""

    __slots__ = ("model",)

    def __init__(self, model: mujoco.MjModel):
        self.model = model


class Problem:
    """One query of OMPL in a task's state space.

    Args:
        space: the task's state space (:class:`~simx_server.sim.ompl_spaces.Space`: its
            values, bounds, projection).
        valid: ``valid(q) -> bool`` for a state's values (``space.dim``,); called from inside
            OMPL's planner.
        resolution: the state validity checking resolution, a fraction of the space's extent
            (simOMPL's default 0.01).

    Raises:
        RuntimeError: OMPL's bindings are not installed (:data:`IMPORT_ERROR`).
    """

    def __init__(self, space: Space, valid: Callable[[np.ndarray], bool], resolution: float = 0.01):
        _load()
        self.dim = space.dim
        self.codec, self.space = space, space.space
        self.si = ob.SpaceInformation(self.space)
        self.si.setStateValidityChecker(lambda s: bool(valid(space.values(s))))
        self.si.setStateValidityCheckingResolution(float(resolution))
        self.si.setup()
        self.pdef: Any = None
        self.planner: Any = None
        self.path: Any = None  # the solution path, simplified and interpolated in place

    def state(self, values: Any) -> Any:
        """An OMPL state.

        Args:
            values: (n,) its values.

        Returns:
            The state (OMPL's, for this problem's space).
        """
        s = self.si.allocState()
        self.codec.write(s, values)
        return s

    def setup(self, start: np.ndarray, goals: list[np.ndarray], algorithm: str) -> None:
        """The query: from ``start`` to any of ``goals``, with the planner ``algorithm``.

        Args:
            start: (n,) the start configuration.
            goals: the goal configurations, (n,) each (several: OMPL's ``GoalStates``).
            algorithm: a name of :func:`available`.

        Raises:
            ValueError: an algorithm that the installed bindings lack, or no goal.
        """
        if algorithm not in available():
            raise ValueError(f"OMPL's Python bindings (ompl {_version()}) have no planner {algorithm}; "
                             f"they have {', '.join(available())}")
        if not goals:
            raise ValueError("no goal state")
        self.pdef = ob.ProblemDefinition(self.si)
        self.pdef.addStartState(self.state(start))
        if len(goals) == 1:
            goal = ob.GoalState(self.si)
            goal.setState(self.state(goals[0]))
        else:
            goal = ob.GoalStates(self.si)
            for g in goals:
                goal.addState(self.state(g))
        self.pdef.setGoal(goal)
        self.goal = goal
        self.planner = getattr(og, algorithm)(self.si)
        self.planner.setProblemDefinition(self.pdef)
        self.planner.setup()
        self.path = None

    def solve(self, max_time: float) -> bool:
        """Runs the planner (it goes on from what it built in earlier solves).

        Args:
            max_time: s at most (and at most :data:`MAX_SECONDS`).

        Returns:
            True when it found a path, exact or approximate (as OMPL's ``PlannerStatus``
            converts to a bool).
        """
        solved = bool(self.planner.solve(min(float(max_time), MAX_SECONDS)))
        self.path = og.PathGeometric(self.pdef.getSolutionPath()) if self.pdef.hasSolution() else None
        return solved

    def solve_in_steps(self, max_time: float, step: float) -> Iterator[None]:
        """:meth:`solve` as a generator: the planner runs ``step`` s at a time (it goes on from
        what it built: OMPL's planners keep their trees and roadmaps between solves), yielding
        between, until it returns before its step is spent (a solution found, for a planner that
        then stops) or ``max_time`` (at most :data:`MAX_SECONDS`) is spent; the generator returns
        :meth:`solve`'s value. With ``step`` >= ``max_time`` it is :meth:`solve`. What
        :mod:`simx_server.api.long_calls` runs in slices, in turns.

        Args:
            max_time: s in all (at most :data:`MAX_SECONDS`).
            step: s of one run of the planner.

        Returns:
            A generator whose value is True when it found a path, exact or approximate.
        """
        left = min(float(max_time), MAX_SECONDS)
        while True:
            spent, began = min(left, step), time.monotonic()
            solved = bool(self.planner.solve(spent))
            took = time.monotonic() - began
            left -= took
            if left <= 0 or took < 0.9 * spent:  # out of time, or it stopped by itself
                break
            yield
        self.path = og.PathGeometric(self.pdef.getSolutionPath()) if self.pdef.hasSolution() else None
        return solved

    def simplify(self, max_time: float = -1.0) -> None:
        """OMPL's ``PathSimplifier`` on the path (simOMPL's ``simplifyPath``).

        Args:
            max_time: < 0: as ``simplifyMax`` (until nothing improves, which is ``simplify``
                without a time limit), but within :data:`MAX_SECONDS`; else ``simplify`` for at
                most that many s (and at most :data:`MAX_SECONDS`).
        """
        simplifier = og.PathSimplifier(self.si, self.goal)
        simplifier.simplify(self.path, MAX_SECONDS if max_time < 0 else min(float(max_time), MAX_SECONDS))

    def interpolated_count(self, count: int = 0) -> int:
        """The states the path would hold after :meth:`interpolate` with ``count`` (OMPL's
        ``PathGeometric::interpolate``: ``count`` when above the path's states; 0: each segment's
        ``validSegmentCount`` states), without making them.

        Args:
            count: as :meth:`interpolate`'s.

        Returns:
            The count; 0 without a path.
        """
        if self.path is None:
            return 0
        states = list(self.path.getStates())
        if count > 0:
            return max(count, len(states))
        return 1 + sum(max(1, int(self.space.validSegmentCount(a, b))) for a, b in zip(states, states[1:]))

    def interpolate(self, count: int = 0) -> None:
        """``PathGeometric.interpolate`` of the path.

        Args:
            count: the states along the path; 0: at the validity checking resolution (the
                states the motion checks tested).

        Raises:
            ValueError: the path would hold more than :data:`MAX_PATH_VALUES` values (the
                count is worked out first; nothing is made).
        """
        states = self.interpolated_count(count)
        if states * self.dim > MAX_PATH_VALUES:
            raise ValueError(f"the path would hold {states} states of {self.dim} values, more than {MAX_PATH_VALUES} "
                             "values (motion_planning.MAX_PATH_VALUES); ask for fewer states"
                             + ("" if count > 0 else " (stateCnt, or a coarser setStateValidityCheckingResolution)"))
        if count > 0:
            self.path.interpolate(int(count))
        else:
            self.path.interpolate()

    def path_values(self) -> np.ndarray:
        """The path's states.

        Returns:
            (m, n); (0, n) without a path.
        """
        if self.path is None:
            return np.zeros((0, self.dim))
        return np.array([self.codec.values(s) for s in self.path.getStates()], dtype=float).reshape(-1, self.dim)

    def exact(self) -> bool:
        """Whether the solution reaches a goal.

        Returns:
            True for an exact solution.
        """
        return self.pdef is not None and bool(self.pdef.hasExactSolution())

    def approximate(self) -> bool:
        """Whether the solution stops short of the goals.

        Returns:
            True for an approximate solution.
        """
        return self.pdef is not None and bool(self.pdef.hasApproximateSolution())

    def goal_distance(self) -> float:
        """How far the solution ends from the goals.

        Returns:
            OMPL's solution difference (0 for an exact solution, -1 before a query).
        """
        return float(self.pdef.getSolutionDifference()) if self.pdef is not None else -1.0

    def is_valid(self, values: Any) -> bool:
        """The validity check of one configuration.

        Args:
            values: (n,) the configuration.

        Returns:
            What the problem's ``valid`` says of it.
        """
        return bool(self.si.isValid(self.state(values)))


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("ompl")
    except metadata.PackageNotFoundError:  # pragma: no cover
        return "?"
