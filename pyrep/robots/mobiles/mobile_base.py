"""PyRep's ``MobileBase``: a wheeled base ``name`` with joints ``<name>_m_joint1..n``, wheels
``<name>_wheel1..n``, the dummies ``<name>_target_base`` and ``<name>_intermediate_target_base``
that its controllers drive to, and the collection ``<name>_base`` whose collisions paths avoid;
its 2-D pose ``[x (m), y (m), yaw (rad)]``.

Paths (PyRep's ``MobileBase`` and its add-on script's ``getNonlinearPathMobile``): a linear path
is checked at 50 poses along the line, a nonlinear one planned by OMPL through the table's
``simOMPL`` in a ``dubins`` state space of the base (turning radius 0.1 m, symmetric), both with
the collision pair ``{<name>_base, sim.handle_all}`` checked by MuJoCo on a scratch copy of the
state: planning never moves the base (PyRep's linear check puts it at each pose in turn).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from pyrep.backend import sim
from pyrep.const import ConfigurationPathAlgorithms as Algos
from pyrep.errors import ConfigurationPathError
from pyrep.objects.dummy import Dummy
from pyrep.objects.object import Object
from pyrep.objects.shape import Shape
from pyrep.robots.robot_component import RobotComponent

#: Poses a linear path is checked at (PyRep's ``_check_collision_linear_path``: 50, the last four
#: with the goal's yaw).
LINEAR_CHECKS = 50
#: Motions of a nonlinear path are checked every 0.2% of the state space's extent (about 1.5 cm
#: at PyRep's 2 m bounds; simOMPL's default 1%, which PyRep's add-on keeps, lets a base cut a
#: corner between two checks).
RESOLUTION = 0.002


class MobileBase(RobotComponent):
    """A mobile base (``count``: which copy, as ``RobotComponent``).

    Raises:
        CoppeliaSimError: (a RuntimeError, as PyRep's) the scene lacks the model's objects.
    """

    def __init__(self, count: int, num_wheels: int, name: str):
        super().__init__(count, name, [f"{name}_m_joint{i + 1}" for i in range(num_wheels)])
        suffix = "" if count == 0 else f"#{count - 1}"
        self.num_wheels = num_wheels
        self.wheels = [Shape(f"{name}_wheel{i + 1}{suffix}") for i in range(num_wheels)]
        self.intermediate_target_base = Dummy(f"{name}_intermediate_target_base{suffix}")
        self.target_base = Dummy(f"{name}_target_base{suffix}")
        try:
            self._collision_collection: int | None = int(sim.call("getCollectionHandle", f"{name}_base{suffix}"))
        except RuntimeError:
            self._collision_collection = None
        self.z_pos = float(self.get_position()[2])
        self.target_z = float(self.target_base.get_position()[-1])
        self.wheel_radius = float(self.wheels[0].get_bounding_box()[5])
        self.wheel_distance = float(np.linalg.norm(self.wheels[0].get_position() - self.wheels[1].get_position()))
        self.intermediate_target_base.set_parent(None)  # orphans, as PyRep leaves them after a .ttm load
        self.target_base.set_parent(None)

    def get_2d_pose(self) -> np.ndarray:
        """``[x, y, yaw]`` (m, m, rad) seen from above."""
        return np.r_[self.get_position()[:2], self.get_orientation()[-1:]]

    def set_2d_pose(self, pose: Any) -> None:
        """Places the base at ``[x, y, yaw]`` on the ground (its height when it was made)."""
        x, y, yaw = pose
        self.set_position([x, y, self.z_pos])
        self.set_orientation([0.0, 0.0, yaw])

    def assess_collision(self) -> bool:
        """Whether the base's collection collides with anything else."""
        if self._collision_collection is None:
            return False
        result = sim.call("checkCollision", self._collision_collection, sim.sim_handle_all)  # type: ignore[attr-defined]
        return bool(result[0] if isinstance(result, (list, tuple)) else result)

    def set_cartesian_position(self, position: Any) -> None:
        """PyRep's delta move ``[x (m), y (m), angle]`` as wheel velocities over one 0.05 s step
        (holonomic bases only)."""
        vel = [0.0, 0.0, float(position[-1])]
        for i in range(2):
            vel[i] = float(position[i]) / (0.05 * self.wheel_radius / 2)
        self.set_base_angular_velocites(vel)

    def set_base_angular_velocites(self, velocity: Any) -> None:
        """The wheels' velocities from the base's (the subclass's kinematics)."""
        raise NotImplementedError()

    def get_base_actuation(self) -> Any:
        """The controller driving the base to its target (the subclass's)."""
        raise NotImplementedError()

    def copy(self) -> RobotComponent:
        """A copy of the model, its target dummies with it (left orphans, as PyRep's)."""
        self.intermediate_target_base.set_parent(self)
        self.target_base.set_parent(self)
        try:
            return super().copy()
        finally:
            self.intermediate_target_base.set_parent(None)
            self.target_base.set_parent(None)

    # ------------------------------------------------------------ paths
    def _aim(self, position: Any, angle: float) -> None:
        """Puts the target dummy at the goal: ``position``'s x, y, yaw ``angle``."""
        self.target_base.set_position([position[0], position[1], self.target_z])
        self.target_base.set_orientation([0.0, 0.0, angle])

    def _check_collision_linear_path(self, path: Any) -> bool:
        """Whether the base collides at one of :data:`LINEAR_CHECKS` poses of the straight line
        from ``path[0]`` to ``path[1]`` (``[x, y, yaw]`` each; the start's yaw, the goal's at the
        last four, as PyRep), checked on a scratch copy of the state (the base stays)."""
        if self._collision_collection is None:
            return False
        start, end = np.asarray(path[0], dtype=float), np.asarray(path[1], dtype=float)
        poses = [np.r_[start[:2] + (k + 1) / LINEAR_CHECKS * (end[:2] - start[:2]), start[2] if k < LINEAR_CHECKS - 4 else end[2]]
                 for k in range(LINEAR_CHECKS)]
        task, space = self._task("pose2d", 2.0 * max(np.max(np.abs(np.r_[start[:2], end[:2]])), 1.0), False)
        try:
            sim.ompl_call("setStartState", task, poses[0].tolist())
            sim.ompl_call("setGoalState", task, poses[-1].tolist())
            sim.ompl_call("setup", task)
            return not all(sim.ompl_call("isStateValid", task, p.tolist()) for p in poses)
        finally:
            sim.ompl_call("destroyTask", task)
            sim.ompl_call("destroyStateSpace", space)

    def _task(self, kind: str, bounds: float, ignore_collisions: bool) -> tuple[str, str]:
        """A simOMPL task of the base's pose: a ``kind`` space (``pose2d``, ``dubins``: turning
        radius 0.1 m, symmetric, as PyRep's add-on) within ±``bounds`` m, the base's collision
        pair unless ``ignore_collisions``."""
        task = sim.ompl_call("createTask", "t")
        try:
            space = sim.ompl_call("createStateSpace", "2d", sim.ompl_constants("StateSpaceType")[kind],
                                  self.get_handle(), [-bounds, -bounds], [bounds, bounds], 1)
        except Exception:
            sim.ompl_call("destroyTask", task)
            raise
        sim.ompl_call("setVerboseLevel", task, 0)
        if kind == "dubins":
            sim.ompl_call("setDubinsParams", space, 0.1, True)
        sim.ompl_call("setStateSpace", task, [space])
        if not ignore_collisions and self._collision_collection is not None:
            sim.ompl_call("setCollisionPairs", task, [self._collision_collection, sim.sim_handle_all])  # type: ignore[attr-defined]
        return task, space

    def _get_nonlinear_path_points(self, position: Any, angle: float = 0, boundaries: float = 2,
                                   path_pts: int = 600, ignore_collisions: bool = False,
                                   algorithm: Any = Algos.RRTConnect) -> list[list[float]]:
        """A planned path to ``position`` (x, y) with yaw ``angle``: ``path_pts`` points
        ``[x, y, yaw, distance from the previous point]`` (m, m, rad, m).

        PyRep's ``getNonlinearPathMobile``: ``simOMPL``, a ``dubins`` state space of the base
        bounded to ±``boundaries`` m in x and y (the world's, not around the base), ``algorithm``'s
        planner (one OMPL's Python bindings lack plans with RRTConnect, with a warning), 4 s of
        search, the path simplified and interpolated to ``path_pts`` states. Motions are checked
        every :data:`RESOLUTION` of the space's extent.

        Raises:
            ConfigurationPathError: no path reaching the goal was found (PyRep's add-on could
                also return one that stops short of it: OMPL's approximate solution).
            AttributeError: ``algorithm`` is not a ``ConfigurationPathAlgorithms``.
            CoppeliaSimError: ``pRRT`` or ``pSBL``, or OMPL is not installed.
        """
        name = algorithm.value
        self._aim(position, angle)
        task, space = self._task("dubins", float(boundaries), ignore_collisions)
        try:
            sim.ompl_set_algorithm(task, name, "get_nonlinear_path")
            sim.ompl_call("setStateValidityCheckingResolution", task, RESOLUTION)
            x, y, _ = self.get_position()
            sim.ompl_call("setStartState", task, [float(x), float(y), float(self.get_orientation()[2])])
            sim.ompl_call("setGoalState", task, [float(position[0]), float(position[1]), float(angle)])
            sim.ompl_call("setup", task)
            solved, states = sim.ompl_call("compute", task, 4.0, -1.0, int(path_pts))
            if not solved or not sim.ompl_call("hasExactSolution", task):  # (a start or goal that collides too)
                raise ConfigurationPathError("Could not create path.")
        finally:
            sim.ompl_call("destroyTask", task)
            sim.ompl_call("destroyStateSpace", space)
        points = np.asarray(states, dtype=float).reshape(-1, 3)
        steps = np.r_[0.0, np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1)]
        return [[*p.tolist(), float(d)] for p, d in zip(points, steps)]


def box_adjusted_matrix_and_facing_angle(base: Object, target: Object) -> tuple[list[float], float]:
    """PyRep's add-on ``getBoxAdjustedMatrixAndFacingAngle``: of the target's three axes, the one
    most aligned (either way) with the direction from the base to the target gives a heading;
    the matrix (12 values, 3 x 4, rows) at the target's position turned to that heading about z,
    and the heading less pi/2 (the yaw that points a base's y axis, its front, along it)."""
    p2, p1 = target.get_position(), base.get_position()
    d = p2 - p1
    norm = float(np.linalg.norm(d))
    d = d / norm if norm > 0 else d
    axes = target.get_matrix()[:3, :3].T  # the target's x, y, z axes (world)
    scores = axes @ d
    best = int(np.argmax(np.abs(scores)))
    v = axes[best] * (1.0 if scores[best] >= 0 else -1.0)
    heading = math.atan2(v[1], v[0])
    c, s = math.cos(heading), math.sin(heading)
    m = [c, -s, 0.0, float(p2[0]), s, c, 0.0, float(p2[1]), 0.0, 0.0, 1.0, float(p2[2])]
    return m, heading - math.pi / 2
