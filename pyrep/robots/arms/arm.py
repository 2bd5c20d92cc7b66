"""PyRep's ``Arm``: joints, a tip and a target dummy; inverse kinematics and motion planning.

Inverse kinematics is damped least squares on the geometric Jacobian (joint axes and positions
read from the scene through the API table), from the arm's current configuration; the scene is
restored afterwards (PyRep's ``solve_ik_via_jacobian`` does not move the arm either). Paths:
``get_linear_path`` follows a straight line of the tip, ``get_nonlinear_path`` a joint-space
path to IK solutions planned by OMPL through the table's ``simOMPL`` (as PyRep's add-on script
plans with CoppeliaSim's simOMPL), collisions of the arm's collection (``<name>_arm``) against
the scene checked by MuJoCo on a scratch copy of the state.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyrep.backend import sim
from pyrep.const import ConfigurationPathAlgorithms as Algos
from pyrep.errors import CoppeliaSimError, ConfigurationError, ConfigurationPathError, IKError
from pyrep.objects.dummy import Dummy
from pyrep.objects.object import Object
from pyrep.robots.arms import planning, sampling
from pyrep.robots.configuration_paths.arm_configuration_path import ArmConfigurationPath
from pyrep.robots.robot_component import RobotComponent


class Arm(RobotComponent):
    """An arm ``name`` with joints ``<name>_joint1..n``, ``<name>_tip`` and ``<name>_target``."""

    def __init__(self, count: int, name: str, num_joints: int, base_name: str | None = None,
                 max_velocity: float = 1.0, max_acceleration: float = 4.0, max_jerk: float = 1000):
        joint_names = [f"{name}_joint{i + 1}" for i in range(num_joints)]
        super().__init__(count, name, joint_names, base_name)
        suffix = "" if count == 0 else f"#{count - 1}"
        self.max_velocity = max_velocity
        self.max_acceleration = max_acceleration
        self.max_jerk = max_jerk
        self._ik_target = Dummy(f"{name}_target{suffix}")
        self._ik_tip = Dummy(f"{name}_tip{suffix}")
        try:
            self._collision_collection: int | None = int(sim.call("getCollectionHandle", f"{name}_arm{suffix}"))
        except RuntimeError:
            self._collision_collection = None
        self._constraints = np.ones(6, dtype=bool)  # x y z, alpha-beta (2), gamma
        self._max_iterations = 200
        self._damping = 0.05
        # the model's own IK group (PyRep's arms carry "<name>_ik"): solve_ik_via_jacobian is
        # CoppeliaSim's simCheckIkGroup on it, with the group's method, iterations and precision
        try:
            self._ik_group: int | None = int(sim.call("getIkGroupHandle", f"{name}_ik{suffix}"))
        except RuntimeError:
            self._ik_group = None

    # ------------------------------------------------------ IK settings
    def set_ik_element_properties(self, constraint_x: bool = True, constraint_y: bool = True,
                                  constraint_z: bool = True, constraint_alpha_beta: bool = True,
                                  constraint_gamma: bool = True) -> None:
        """Which of the tip's coordinates IK must reach (the arm's IK group's element: PyRep's
        ``simSetIkElementProperties``)."""
        if self._ik_group is not None:
            bits = sum(b for b, on in zip((1, 2, 4, 8, 16), (constraint_x, constraint_y, constraint_z,
                                                              constraint_alpha_beta, constraint_gamma)) if on)
            sim.call("setIkElementProperties", self._ik_group, self._ik_tip.get_handle(), bits)
        self._constraints = np.array([constraint_x, constraint_y, constraint_z, constraint_alpha_beta,
                                      constraint_alpha_beta, constraint_gamma])

    def set_ik_group_properties(self, resolution_method: str = "pseudo_inverse", max_iterations: int = 6,
                                dls_damping: float = 0.1) -> None:
        """IK's method (``pseudo_inverse``, ``damped_least_squares``, ``jacobian_transpose``),
        iterations and damping (the arm's IK group's: PyRep's ``simSetIkGroupProperties``).

        Raises:
            Exception: an unknown method.
        """
        methods = ("pseudo_inverse", "damped_least_squares", "jacobian_transpose")
        if resolution_method not in methods:
            raise Exception(f"Invalid resolution method: {resolution_method}")
        if self._ik_group is not None:
            sim.call("setIkGroupProperties", self._ik_group, methods.index(resolution_method), int(max_iterations),
                     float(dls_damping))
        self._max_iterations = max(int(max_iterations), 50)
        self._damping = 0.01 if resolution_method == "pseudo_inverse" else float(dls_damping)

    # ---------------------------------------------------------- poses
    def get_tip(self) -> Dummy:
        """The tip dummy: the point that IK and paths place."""
        return self._ik_tip

    def _target_matrix(self, position: Any, euler: Any, quaternion: Any, relative_to: Object | None) -> np.ndarray:
        """The world pose (4, 4) to reach (the target dummy is moved there, as PyRep does)."""
        self._ik_target.set_position(position, relative_to)
        if euler is not None:
            self._ik_target.set_orientation(euler, relative_to)
        elif quaternion is not None:
            self._ik_target.set_quaternion(quaternion, relative_to)
        return self._ik_target.get_matrix()

    def get_jacobian(self) -> np.ndarray:
        """The (6, n) geometric Jacobian of the tip (linear rows, then angular), world frame."""
        return self._jacobian()

    def _prismatic(self) -> list[bool]:
        """Which joints slide (the others turn), in the order of ``joints``."""
        return [joint.get_joint_type().name == "PRISMATIC" for joint in self.joints]

    def _jacobian(self, prismatic: list[bool] | None = None) -> np.ndarray:
        """(6, n) Jacobian; ``prismatic``: :meth:`_prismatic`, if the caller has it (a solve
        reads the joints' types once, not at every iteration)."""
        tip = self._ik_tip.get_position()
        cols = []
        for joint, slides in zip(self.joints, self._prismatic() if prismatic is None else prismatic):
            m = joint.get_matrix()
            axis, origin = m[:3, 2], m[:3, 3]
            if slides:
                cols.append(np.concatenate([axis, np.zeros(3)]))
            else:
                r = tip - origin  # axis x r, as np.cross computes it (np.cross costs 80 us a call)
                cols.append(np.array([axis[1] * r[2] - axis[2] * r[1], axis[2] * r[0] - axis[0] * r[2],
                                      axis[0] * r[1] - axis[1] * r[0], axis[0], axis[1], axis[2]]))
        return np.array(cols).T

    def _limits(self) -> tuple[np.ndarray, np.ndarray]:
        cyclic, intervals = self.get_joint_intervals()
        lo = np.array([-np.inf if c else i[0] for c, i in zip(cyclic, intervals)])
        hi = np.array([np.inf if c else i[0] + i[1] for c, i in zip(cyclic, intervals)])
        return lo, hi

    def _error(self, goal: np.ndarray) -> np.ndarray:
        m = self._ik_tip.get_matrix()
        dp = goal[:3, 3] - m[:3, 3]
        # the rotation vector from the tip to the goal (world frame, rad), a half turn's included
        axis, angle = sim.call("getRotationAxis", planning.table_matrix(m), planning.table_matrix(goal))
        err = np.concatenate([dp, float(angle) * np.asarray(axis, dtype=float)])
        err[~self._constraints] = 0.0
        return err

    def _solve(self, goal: np.ndarray, start: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray | None:
        """Joint values reaching ``goal`` from ``start``, or None (the arm left at the last try)."""
        q = start.copy()
        prismatic = self._prismatic()
        for _ in range(self._max_iterations):
            self.set_joint_positions(q.tolist())
            err = self._error(goal)
            if np.linalg.norm(err[:3]) < 1e-3 and np.linalg.norm(err[3:]) < 1e-2:
                return q
            jac = self._jacobian(prismatic)
            jac[~self._constraints] = 0.0
            step = jac.T @ np.linalg.solve(jac @ jac.T + self._damping ** 2 * np.eye(6), err)
            norm = np.linalg.norm(step)
            if norm > 0.3:
                step *= 0.3 / norm
            q = np.clip(q + step, lo, hi)
        return None

    def solve_ik_via_jacobian(self, position: Any, euler: Any = None, quaternion: Any = None,
                              relative_to: Object | None = None, locked_joints: list[int] | None = None) -> np.ndarray:
        """Joint values (n,) that put the tip at the pose, from the current configuration (the arm
        is not moved; the target dummy is). With the arm's IK group (``<name>_ik``) this is
        PyRep's ``simCheckIkGroup`` on it: its own method, iterations, damping and precision
        decide, so a pose too far for them fails as on CoppeliaSim; ``locked_joints`` (indices)
        are held. Without one, damped least squares of :meth:`set_ik_group_properties`.

        Raises:
            IKError: no solution from here.
        """
        goal = self._target_matrix(position, euler, quaternion, relative_to)
        if self._ik_group is not None:
            locked = set(locked_joints or [])
            joints = [j for i, j in enumerate(self.joints) if i not in locked]
            result, values = sim.call("checkIkGroup", self._ik_group, [j.get_handle() for j in joints])
            if int(result) == 2:  # sim_ikresult_fail
                raise IKError("IK failed. Perhaps the distance was between the tip  and target was too large.")
            if int(result) == 0:
                raise IKError("IK not performed.")
            return np.array(values, float)
        start = np.array(self.get_joint_positions())
        lo, hi = self._limits()
        try:
            found = self._solve(goal, start, lo, hi)
        finally:
            self.set_joint_positions(start.tolist())
        if found is None:
            raise IKError("IK failed. Perhaps the distance was between the tip and target was too large.")
        return found

    def solve_ik(self, position: Any, euler: Any = None, quaternion: Any = None,
                 relative_to: Object | None = None) -> list[float]:
        """PyRep's older name of :meth:`solve_ik_via_jacobian` (a list)."""
        return self.solve_ik_via_jacobian(position, euler, quaternion, relative_to).tolist()

    def solve_ik_via_sampling(self, position: Any, euler: Any = None, quaternion: Any = None,
                              ignore_collisions: bool = False, trials: int = 300, max_configs: int = 1,
                              distance_threshold: float = 0.65, max_time_ms: int = 10,
                              relative_to: Object | None = None) -> np.ndarray:
        """Up to ``max_configs`` configurations (m, n) reaching the pose, from random starts,
        collision-free unless ``ignore_collisions``, nearest to the current one first.

        As PyRep's (``trials`` calls of ``sim.getConfigForTipPose``, ``max_time_ms`` each): at
        most ``trials`` tries of ``max_time_ms`` ms each, so a pose out of reach fails after
        ``trials * max_time_ms`` (:mod:`pyrep.robots.arms.sampling`).

        Raises:
            ConfigurationError: none found in ``trials`` tries.
        """
        prev_pose = self._ik_target.get_pose()  # as PyRep: the target dummy is put back afterwards
        try:
            self._target_matrix(position, euler, quaternion, relative_to)  # IK pulls the tip onto the target
            found = sampling.sample_configs(self, trials, max_configs, distance_threshold, max_time_ms,
                                            ignore_collisions)
        finally:
            self._ik_target.set_pose(prev_pose)
        if not found:
            raise ConfigurationError("Could not find a valid joint configuration for desired end effector pose.")
        start = np.array(self.get_joint_positions())
        found.sort(key=lambda q: float(np.linalg.norm(q - start)))
        return np.array(found)

    def get_configs_for_tip_pose(self, position: Any, euler: Any = None, quaternion: Any = None,
                                 ignore_collisions: bool = False, trials: int = 300, max_configs: int = 60,
                                 relative_to: Object | None = None) -> list[list[float]]:
        """PyRep's older interface of :meth:`solve_ik_via_sampling` (lists)."""
        return self.solve_ik_via_sampling(position, euler, quaternion, ignore_collisions, trials,
                                          max_configs, relative_to=relative_to).tolist()

    # ------------------------------------------------------- collisions
    def check_arm_collision(self, obj: Object | None = None) -> bool:
        """Whether the arm's collection collides with ``obj`` (None: anything else)."""
        if self._collision_collection is None:
            return False
        other = sim.sim_handle_all if obj is None else obj.get_handle()  # type: ignore[attr-defined]
        result = sim.call("checkCollision", self._collision_collection, other)
        return bool(result[0] if isinstance(result, (list, tuple)) else result)

    def _collides(self, q: np.ndarray) -> bool:
        self.set_joint_positions(q.tolist())
        return self.check_arm_collision()

    # ------------------------------------------------------------ paths
    def _step_size(self) -> float:
        dt = float(sim.call("getSimulationTimeStep"))
        return max(self.max_velocity * dt, 1e-3)

    def get_linear_path(self, position: Any, euler: Any = None, quaternion: Any = None, steps: int = 50,
                        ignore_collisions: bool = False, relative_to: Object | None = None) -> ArmConfigurationPath:
        """A path moving the tip along the straight line to the pose (``steps`` poses on it).
        With the arm's IK group this is PyRep's: ``sim.generateIkPath`` on it (the group's own
        method, iterations, damping and precision; collisions of the arm's collection with
        the scene unless ``ignore_collisions``); without one, damped least squares.

        Raises:
            ConfigurationPathError: a pose of the line cannot be reached, or collides.
        """
        prev = self._ik_target.get_pose()  # as PyRep: the target dummy is put back afterwards
        try:
            goal = self._target_matrix(position, euler, quaternion, relative_to)
            if self._ik_group is not None:
                pairs = [] if ignore_collisions or self._collision_collection is None else \
                    [self._collision_collection, sim.sim_handle_all]  # type: ignore[attr-defined]
                flat = sim.call("generateIkPath", self._ik_group, self._handles(), max(int(steps), 2), pairs)
                if not flat:
                    raise ConfigurationPathError("Could not create path.")
                return self._path(np.reshape(flat, (-1, len(self.joints))))
        finally:
            self._ik_target.set_pose(prev)
        start = np.array(self.get_joint_positions())
        lo, hi = self._limits()
        poses = planning.interpolate_poses(self._ik_tip.get_matrix(), goal, max(int(steps), 1))
        configs = [start]
        try:
            for pose in poses:
                q = self._solve(pose, configs[-1], lo, hi)
                if q is None or (not ignore_collisions and self._collides(q)):
                    raise ConfigurationPathError("Could not create path.")
                configs.append(q)
        finally:
            self.set_joint_positions(start.tolist())
        return self._path(np.array(configs))

    def get_nonlinear_path(self, position: Any, euler: Any = None, quaternion: Any = None,
                           ignore_collisions: bool = False, trials: int = 300, max_configs: int = 1,
                           distance_threshold: float = 0.65, max_time_ms: int = 10, trials_per_goal: int = 1,
                           algorithm: Any = Algos.SBL, relative_to: Object | None = None) -> ArmConfigurationPath:
        """A collision-free joint-space path to a configuration reaching the pose, planned by OMPL.

        PyRep's add-on (``getNonlinearPath`` and ``_findPath`` of ``simAddOnScript_PyRep.lua``),
        through the table's ``simOMPL``: goal configurations from :meth:`solve_ik_via_sampling`
        (``max_configs`` of them, all goals of one task), one ``joint_position`` state space per
        joint (the first three used for projections, bounds clipped to ±6.28 rad), collision pairs
        ``{<arm collection>, sim.handle_all}`` unless ``ignore_collisions`` (checked by MuJoCo on a
        scratch copy of the scene), ``algorithm``'s planner, 4 s per search, ``trials_per_goal``
        searches, the shortest valid path kept. A failing call ends within PyRep's bounds: the
        goals' search ``trials * max_time_ms`` ms, then ``trials_per_goal`` searches of 4 s, each
        a new planner (``simOMPL.compute(task, 4, -1, 300)``: solved, simplified, interpolated to
        300 configurations), motions checked at simOMPL's default resolution (1% of the joints'
        summed ranges), a path that reaches no goal exactly left out. ``step()`` moves along it
        by its length in joint space, timed as PyRep's Reflexxes motion
        (:class:`~pyrep.robots.configuration_paths.arm_configuration_path.ArmConfigurationPath`).

        Args:
            algorithm: a :class:`pyrep.const.ConfigurationPathAlgorithms`. Those OMPL's Python
                bindings lack (``ompl`` 2.0.1 has BITstar, BKPIECE1, FMT, KPIECE1, LBKPIECE1,
                PRM, PRMstar, RRT, RRTConnect, RRTstar; PyRep's default SBL is not among them)
                plan with RRTConnect, with a warning logged once per algorithm.

        Raises:
            ConfigurationPathError: no such path was found.
            AttributeError: ``algorithm`` is not a ``ConfigurationPathAlgorithms`` (PyRep reads
                ``algorithm.value``).
            CoppeliaSimError: an algorithm that CoppeliaSim's simOMPL does not have (``pRRT``,
                ``pSBL``: PyRep's script call fails on them), or OMPL is not installed.
        """
        name = algorithm.value
        if name not in sim.ompl_constants("Algorithm"):  # before the IK search, as PyRep's add-on fails
            raise CoppeliaSimError(f"The call failed on the V-REP side: simOMPL has no algorithm {name!r}")
        try:
            goals = self.solve_ik_via_sampling(position, euler, quaternion, ignore_collisions, trials,
                                               max(max_configs, 1), distance_threshold, max_time_ms,
                                               relative_to=relative_to)
        except ConfigurationError as exc:
            raise ConfigurationPathError("Could not create path.") from exc
        lo, hi = self._limits()
        lo, hi = np.maximum(lo, -6.28), np.minimum(hi, 6.28)
        start = np.clip(self.get_joint_positions(), lo, hi)
        pairs = [] if ignore_collisions or self._collision_collection is None else \
            [self._collision_collection, sim.sim_handle_all]  # type: ignore[attr-defined]
        path = _plan(self, name, start, goals, lo, hi, pairs, trials_per_goal)
        if path is None:
            raise ConfigurationPathError("Could not create path.")
        return ArmConfigurationPath(self, path)

    def get_path(self, position: Any, euler: Any = None, quaternion: Any = None, ignore_collisions: bool = False,
                 trials: int = 300, max_configs: int = 1, distance_threshold: float = 0.65,
                 max_time_ms: int = 10, trials_per_goal: int = 1, algorithm: Any = Algos.SBL,
                 relative_to: Object | None = None) -> ArmConfigurationPath:
        """A linear path when one exists, else a nonlinear one (:meth:`get_nonlinear_path`).

        Raises:
            ConfigurationPathError: neither was found.
        """
        try:
            return self.get_linear_path(position, euler, quaternion, ignore_collisions=ignore_collisions,
                                        relative_to=relative_to)
        except ConfigurationPathError:
            return self.get_nonlinear_path(position, euler, quaternion, ignore_collisions, trials, max_configs,
                                           distance_threshold, max_time_ms, trials_per_goal, algorithm,
                                           relative_to)

    def get_path_from_cartesian_path(self, path: Any) -> ArmConfigurationPath:
        """A path through the poses of a ``CartesianPath``. With the arm's IK group as PyRep's
        add-on (``getPathFromCartesianPath`` of ``simAddOnScript_PyRep.lua``): from the current
        configuration, for relative distances 0.05, 0.10, ... while <= 1.0 (summed in floating
        point, as Lua does: the last is 0.95) the target is put at the path's pose and
        ``sim.generateIkPath`` gives 20 configurations to it, without collision checks; the
        scene and the target are left as they were. Without an IK group, damped least squares
        to 50 poses along it.

        Raises:
            ConfigurationPathError: a pose of the path cannot be reached.
        """
        start = np.array(self.get_joint_positions())
        configs = [start[None, :]]
        prev = self._ik_target.get_pose()
        lo, hi = self._limits()
        try:
            if self._ik_group is not None:
                t = 0.05
                while t <= 1.0:
                    pos, ori = path.get_pose_on_path(t)
                    self._target_matrix(pos, ori, None, None)
                    flat = sim.call("generateIkPath", self._ik_group, self._handles(), 20, [])
                    if not flat:
                        raise ConfigurationPathError("Could not create a path from cartesian path.")
                    configs.append(np.reshape(flat, (-1, len(self.joints))))
                    self.set_joint_positions(configs[-1][-1].tolist())
                    t += 0.05
            else:
                for t in np.linspace(0.0, 1.0, 50):
                    pos, ori = path.get_pose_on_path(float(t))
                    q = self._solve(self._target_matrix(pos, ori, None, None), configs[-1][-1], lo, hi)
                    if q is None:
                        raise ConfigurationPathError("Could not create a path from cartesian path.")
                    configs.append(q[None, :])
        finally:
            self.set_joint_positions(start.tolist())
            self._ik_target.set_pose(prev)
        return self._path(np.vstack(configs))

    def _handles(self) -> list[int]:
        return [j.get_handle() for j in self.joints]

    def _path(self, configs: np.ndarray) -> ArmConfigurationPath:
        """The path through ``configs`` (m, n), no joint moving more than one step's worth between two."""
        return ArmConfigurationPath(self, planning.densify(configs, self._step_size()))


def _plan(arm: Arm, algorithm: str, start: np.ndarray, goals: np.ndarray, lo: np.ndarray, hi: np.ndarray,
          pairs: list[int], searches: int) -> np.ndarray | None:
    """PyRep's ``_findPath`` (``simAddOnScript_PyRep.lua``) with ``simOMPL``: ``searches`` times
    ``simOMPL.compute(task, 4, -1, 300)`` (CoppeliaSim 4.1's ``compute`` sets the task up
    afresh first: each search is a new planner), at simOMPL's default checking resolution (1% of
    the joints' summed ranges); of the paths whose states are all valid, the shortest (Euclidean
    in joint space), flat (300 configurations), or None."""
    task = sim.ompl_call("createTask", "task")
    spaces: list[str] = []
    try:
        sim.ompl_call("setVerboseLevel", task, 0)
        sim.ompl_set_algorithm(task, algorithm, "get_nonlinear_path")
        joint_position = sim.ompl_constants("StateSpaceType")["joint_position"]
        for i, joint in enumerate(arm.joints):
            spaces.append(sim.ompl_call("createStateSpace", f"j_space{i + 1}", joint_position, joint.get_handle(),
                                        [float(lo[i])], [float(hi[i])], i + 1 if i < 3 else 0))
        sim.ompl_call("setStateSpace", task, spaces)
        if pairs:
            sim.ompl_call("setCollisionPairs", task, pairs)
        sim.ompl_call("setStartState", task, start.tolist())
        sim.ompl_call("setGoalStates", task, [g.tolist() for g in goals])
        best, best_length = None, np.inf
        for _ in range(max(int(searches), 1)):
            sim.ompl_call("setup", task)
            solved, flat = sim.ompl_call("compute", task, 4.0, -1.0, 300)
            # OMPL 2's RRTConnect also reports a path that stops short of every goal (approximate)
            if not solved or not flat or not sim.ompl_call("hasExactSolution", task):
                continue
            path = np.asarray(flat, dtype=float).reshape(-1, len(spaces))
            # as PyRep: a simplified path can touch an invalid state; keep only valid ones
            if not all(sim.ompl_call("isStateValid", task, q.tolist()) for q in path[:-1]):
                continue
            length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
            if length < best_length:
                best, best_length = path.reshape(-1), length
        return best
    finally:
        sim.ompl_call("destroyTask", task)
        for space in spaces:
            sim.ompl_call("destroyStateSpace", space)
