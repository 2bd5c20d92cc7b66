"""PyRep's ``NonHolonomicBase``: a differential-drive base (left wheel first)."""

from __future__ import annotations

from pyrep.robots.mobiles.mobile_base import MobileBase


class NonHolonomicBase(MobileBase):
    """A two-wheeled base driven by its wheels' velocities."""

    def __init__(self, count: int, num_wheels: int, name: str):
        super().__init__(count, num_wheels, name)
        self.cummulative_error = 0.0
        self.prev_error = 0.0
        self.Kp, self.Ki, self.Kd = 1.0, 0.01, 0.1
        self.desired_velocity = 0.05

    def set_base_angular_velocites(self, velocity: list[float]) -> None:
        """Sets the wheels' target velocities (rad/s), left then right."""
        self.set_joint_target_velocities(list(velocity))

    def get_base_velocities(self) -> list[float]:
        """``[linear (m/s), angular (rad/s)]`` of the base from its wheels' velocities."""
        wv = self.get_joint_velocities()
        linear = sum(wv) * self.wheel_radius / 2.0
        angular = self.wheel_radius * (wv[1] - wv[0]) / self.wheel_distance
        return [linear, angular]
