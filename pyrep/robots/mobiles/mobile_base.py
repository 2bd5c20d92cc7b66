"""PyRep's ``MobileBase``: a wheeled base ``name`` with joints ``<name>_m_joint1..n`` and
wheels ``<name>_wheel1..n``; its 2-D pose ``[x (m), y (m), yaw (rad)]``.

Path planning for bases (PyRep's ``get_linear_path`` / ``get_nonlinear_path`` of mobiles) is
not written in simx's ``pyrep`` yet: those raise NotImplementedError.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pyrep.backend import sim
from pyrep.objects.dummy import Dummy
from pyrep.objects.shape import Shape
from pyrep.robots.robot_component import RobotComponent


class MobileBase(RobotComponent):
    """A mobile base (``count``: which copy, as ``RobotComponent``)."""

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
        self.intermediate_target_base.set_parent(None)
        self.target_base.set_parent(None)

    def get_2d_pose(self) -> np.ndarray:
        """``[x, y, yaw]`` (m, m, rad) seen from above."""
        return np.r_[self.get_position()[:2], self.get_orientation()[-1:]]

    def set_2d_pose(self, pose: Any) -> None:
        """Places the base at ``[x, y, yaw]`` on the ground."""
        x, y, yaw = pose
        self.set_position([x, y, self.z_pos])
        self.set_orientation([0.0, 0.0, yaw])

    def assess_collision(self) -> bool:
        """Whether the base's collection collides with anything else."""
        if self._collision_collection is None:
            return False
        result = sim.call("checkCollision", self._collision_collection, sim.sim_handle_all)  # type: ignore[attr-defined]
        return bool(result[0] if isinstance(result, (list, tuple)) else result)

    def set_base_angular_velocites(self, velocity: list[float]) -> None:
        raise NotImplementedError()

    def get_linear_path(self, *args: Any, **kwargs: Any) -> Any:
        raise NotImplementedError("mobile base path planning is not in simx's pyrep yet (docs/PYREP.md)")

    def get_nonlinear_path(self, *args: Any, **kwargs: Any) -> Any:
        raise NotImplementedError("mobile base path planning is not in simx's pyrep yet (docs/PYREP.md)")
