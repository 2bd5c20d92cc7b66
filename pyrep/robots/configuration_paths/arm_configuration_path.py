"""PyRep's ``ArmConfigurationPath``: joint configurations an arm follows, one per ``step()``.

``step()`` hands the next configuration of the path to the joints' position controllers (their
target positions); the physics then moves the arm there during the simulation step. The planner
spaces configurations so that no joint moves more than the arm's ``max_velocity`` times the
simulation step between two of them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyrep.robots.configuration_paths.configuration_path import ConfigurationPath


class ArmConfigurationPath(ConfigurationPath):
    """``path_points``: the configurations, flat (n * joints)."""

    def __init__(self, arm: Any, path_points: Any):
        self._arm = arm
        self._num_joints = arm.get_joint_count()
        self._path_points = np.asarray(path_points, dtype=np.float64).reshape(-1)
        self._index = 0
        self._path_done = False
        self._joint_position_action: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self._path_points) // self._num_joints

    def __getitem__(self, i: Any) -> ArmConfigurationPath:
        points = self._path_points.reshape(-1, self._num_joints)[i]
        return self.__class__(self._arm, points)

    def _config(self, i: int) -> np.ndarray:
        return self._path_points[i * self._num_joints:(i + 1) * self._num_joints]

    def step(self) -> bool:
        """Targets the next configuration; True once the last one was handed over."""
        if self._path_done or len(self) == 0:
            self._path_done = True
            return True
        config = self._config(self._index)
        self._joint_position_action = config.copy()
        self._arm.set_joint_target_positions(config.tolist())
        self._index += 1
        self._path_done = self._index >= len(self)
        return self._path_done

    def get_executed_joint_position_action(self) -> np.ndarray | None:
        """The configuration the last ``step()`` targeted."""
        return self._joint_position_action

    def set_to_start(self, disable_dynamics: bool = False) -> None:
        """Places the arm at the path's first configuration."""
        self._arm.set_joint_positions(self._config(0).tolist(), disable_dynamics=disable_dynamics)
        self._index = 0
        self._path_done = False

    def set_to_end(self, disable_dynamics: bool = False) -> None:
        """Places the arm at the path's last configuration."""
        self._arm.set_joint_positions(self._config(len(self) - 1).tolist(), disable_dynamics=disable_dynamics)

    def visualize(self) -> None:
        """Nothing to draw headless."""

    def clear_visualization(self) -> None:
        """Nothing to clear headless."""
