"""PyRep's ``ArmConfigurationPath``: joint configurations an arm follows, timed as PyRep times them.

PyRep (``ArmConfigurationPath._get_rml_handle`` and ``_step_motion``) moves along the path by
its length in joint space (the Euclidean distance between consecutive configurations, summed):
a one-dimensional motion from 0 to that length, limited to the arm's ``max_velocity`` (times a
correction, below), ``max_acceleration`` and ``max_jerk``, made by the Reflexxes library
(``sim.rmlPos``) and advanced one simulation step per ``step()``. The configuration at the
distance reached is interpolated linearly between its two path points and handed to the
joints' position controllers (their target positions); the physics moves the arm there during
the simulation step. Before the first step the whole motion is sampled once: where some joint
would exceed its upper velocity limit, the velocity limit is divided by the largest excess and
the motion sampled again. A short path is thus done in a few steps and a long one is followed
at the arm's speed, whatever the number of its points. The motion is computed with ``ruckig``
(the jerk-limited successor of Reflexxes, which simx's ``sim.ruckigPos`` uses too).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyrep.backend import sim
from pyrep.robots.configuration_paths.configuration_path import ConfigurationPath

#: PyRep's tolerance on the joints' velocity limits (``rMax > 1.001``), and how many times the
#: velocity is corrected at most (each correction divides it by the largest excess; one or
#: two are enough for any path whose points interpolate linearly).
_VELOCITY_SLACK = 1.001
_MAX_CORRECTIONS = 20


class ArmConfigurationPath(ConfigurationPath):
    """``path_points``: the configurations, flat (n * joints), rad (m for prismatic joints)."""

    def __init__(self, arm: Any, path_points: Any):
        self._bind_world()
        self._arm = arm
        self._num_joints = arm.get_joint_count()
        self._path_points = np.asarray(path_points, dtype=np.float64).reshape(-1)
        self._path_done = False
        self._joint_position_action: np.ndarray | None = None
        self._motion: Any = None  # ruckig's Trajectory, made at the first step
        self._time = 0.0          # s into the motion
        self._cumulative = np.zeros(0)  # each point's distance along the path, made with the motion

    def __len__(self) -> int:
        return len(self._path_points) // self._num_joints

    def __getitem__(self, i: Any) -> ArmConfigurationPath:
        points = self._path_points.reshape(-1, self._num_joints)[i]
        return self.__class__(self._arm, points)

    def _config(self, i: int) -> np.ndarray:
        return self._path_points[i * self._num_joints:(i + 1) * self._num_joints]

    def _lengths(self) -> np.ndarray:
        """The distance along the path of each point (PyRep's ``_get_path_point_lengths``)."""
        points = self._path_points.reshape(-1, self._num_joints)
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])

    def _at(self, distances: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """The configurations (k, joints) at ``distances`` along the path, linear between two
        points (a distance past the end: the last segment's line, as PyRep's last-segment rule)."""
        points = self._path_points.reshape(-1, self._num_joints)
        i = np.clip(np.searchsorted(lengths, distances, side="right") - 1, 0, len(points) - 2)
        span = lengths[i + 1] - lengths[i]
        t = np.where(span > 0, (distances - lengths[i]) / np.where(span > 0, span, 1.0), 1.0)
        return points[i] + (points[i + 1] - points[i]) * t[:, None]

    def _plan_motion(self, dt: float, lengths: np.ndarray) -> Any:
        """The motion along the path (a ruckig ``Trajectory`` of one degree of freedom) whose
        points lie at ``lengths`` along it, its velocity corrected so that no joint exceeds its
        upper velocity limit between two steps."""
        from ruckig import InputParameter, Result, Ruckig, Trajectory

        limits = np.asarray(self._arm.get_joint_upper_velocity_limits(), dtype=np.float64)
        limits = np.where(limits > 0, limits, np.inf)
        correction = 1.0
        for _ in range(_MAX_CORRECTIONS):
            inp = InputParameter(1)
            inp.current_position, inp.current_velocity, inp.current_acceleration = [0.0], [0.0], [0.0]
            inp.target_position, inp.target_velocity, inp.target_acceleration = [float(lengths[-1])], [0.0], [0.0]
            inp.max_velocity = [self._arm.max_velocity * correction]
            inp.max_acceleration = [float(self._arm.max_acceleration)]
            inp.max_jerk = [float(self._arm.max_jerk)]
            motion = Trajectory(1)
            if Ruckig(1).calculate(inp, motion) not in (Result.Working, Result.Finished):
                raise RuntimeError("the path's motion could not be computed")
            times = dt * np.arange(1, int(np.ceil(motion.duration / dt - 1e-9)) + 1)
            if len(times) == 0:
                return motion
            reached = np.array([motion.at_time(min(t, motion.duration))[0][0] for t in times])
            qs = self._at(reached, lengths)
            dq = np.diff(np.vstack([self._config(0), qs]), axis=0)
            excess = float(np.max(np.abs(dq / dt) / limits))
            if excess <= _VELOCITY_SLACK:
                return motion
            correction /= excess
        return motion

    def step(self) -> bool:
        """Advance the motion along the path by one simulation step and target the joints at
        the configuration reached (PyRep's ``step`` with ``sim.rmlStep``).

        Returns:
            True once the end of the path was targeted (the motion's final state reached).
        """
        if self._path_done or len(self) == 0:
            self._path_done = True
            return True
        dt = float(sim.call("getSimulationTimeStep"))
        if self._motion is None:
            self._cumulative = self._lengths()
            self._motion = self._plan_motion(dt, self._cumulative) if len(self) > 1 else None
            self._time = 0.0
        self._time += dt
        if self._motion is None or self._time >= self._motion.duration - 1e-9:
            config = self._config(len(self) - 1)
            self._path_done = True
        else:
            reached = self._motion.at_time(self._time)[0][0]
            config = self._at(np.array([reached]), self._cumulative)[0]
        self._joint_position_action = config.copy()
        self._arm.set_joint_target_positions(config.tolist())
        return self._path_done

    def get_executed_joint_position_action(self) -> np.ndarray | None:
        """The configuration the last ``step()`` targeted."""
        return self._joint_position_action

    def set_to_start(self, disable_dynamics: bool = False) -> None:
        """Places the arm at the path's first configuration; the next ``step()`` starts the
        motion anew."""
        self._arm.set_joint_positions(self._config(0).tolist(), disable_dynamics=disable_dynamics)
        self._motion = None
        self._path_done = False

    def set_to_end(self, disable_dynamics: bool = False) -> None:
        """Places the arm at the path's last configuration."""
        self._arm.set_joint_positions(self._config(len(self) - 1).tolist(), disable_dynamics=disable_dynamics)

    def visualize(self) -> None:
        """Nothing to draw headless."""

    def clear_visualization(self) -> None:
        """Nothing to clear headless."""
