"""PyRep's ``NonHolonomicBase``: a differential-drive base (left wheel first), its front its x
axis."""

from __future__ import annotations

import math
from typing import Any

from pyrep.const import ConfigurationPathAlgorithms as Algos
from pyrep.errors import ConfigurationPathError
from pyrep.robots.configuration_paths.nonholonomic_configuration_path import NonHolonomicConfigurationPath
from pyrep.robots.mobiles.mobile_base import MobileBase


class NonHolonomicBase(MobileBase):
    """A two-wheeled base driven by its wheels' velocities, steered by PyRep's PID controller
    (``Kp``, ``Ki``, ``Kd``) at ``desired_velocity`` (m/s)."""

    def __init__(self, count: int, num_wheels: int, name: str):
        super().__init__(count, num_wheels, name)
        self.cummulative_error = 0.0
        self.prev_error = 0.0
        self.Kp, self.Ki, self.Kd = 1.0, 0.01, 0.1
        self.desired_velocity = 0.05

    def set_base_angular_velocites(self, velocity: Any) -> None:
        """Sets the wheels' target velocities (rad/s), left then right."""
        self.set_joint_target_velocities(list(velocity))

    def get_base_velocities(self) -> list[float]:
        """``[linear (m/s), angular (rad/s)]`` of the base from its wheels' velocities."""
        wv = self.get_joint_velocities()
        linear = sum(wv) * self.wheel_radius / 2.0
        angular = self.wheel_radius * (wv[1] - wv[0]) / self.wheel_distance
        return [linear, angular]

    def get_linear_path(self, position: Any, angle: float = 0) -> NonHolonomicConfigurationPath:
        """A straight path to ``position`` (x, y; m) with yaw ``angle`` (rad; the controller
        steers towards the position and leaves the yaw as it comes).

        Raises:
            ConfigurationPathError: the base collides somewhere along the line.
        """
        position_base = self.get_position()
        angle_base = float(self.get_orientation()[-1])
        self._aim(position, angle)
        self.intermediate_target_base.set_position([position[0], position[1], self.target_z])
        self.intermediate_target_base.set_orientation([0.0, 0.0, angle])
        path = [[float(position_base[0]), float(position_base[1]), angle_base],
                [float(position[0]), float(position[1]), float(angle)]]
        if self._check_collision_linear_path(path):
            raise ConfigurationPathError("Could not create path. An object was detected on the linear path.")
        return NonHolonomicConfigurationPath(self, path)

    def get_nonlinear_path(self, position: Any, angle: float = 0, boundaries: float = 2, path_pts: int = 600,
                           ignore_collisions: bool = False,
                           algorithm: Any = Algos.RRTConnect) -> NonHolonomicConfigurationPath:
        """A planned path to ``position`` (x, y; m) with yaw ``angle`` (rad), within
        ±``boundaries`` m (:meth:`MobileBase._get_nonlinear_path_points`).

        Raises:
            ConfigurationPathError: no path was found.
        """
        path = self._get_nonlinear_path_points(position, angle, boundaries, path_pts, ignore_collisions, algorithm)
        return NonHolonomicConfigurationPath(self, path)

    def get_base_actuation(self) -> tuple[list[float], bool]:
        """PyRep's PID controller: ``([left, right] wheel velocities (rad/s), done)``, steering
        towards the intermediate target at ``desired_velocity``; done (the wheels stopped) once
        the target is within 0.1 m."""
        d_x, d_y, _ = self.intermediate_target_base.get_position(relative_to=self)
        d_x_final, d_y_final, _ = self.target_base.get_position(relative_to=self)
        if math.hypot(d_x_final, d_y_final) < 0.1:
            return [0.0, 0.0], True
        alpha = math.atan2(d_y, d_x)
        e = math.atan2(math.sin(alpha), math.cos(alpha))
        e_i = self.cummulative_error + e
        e_d = e - self.prev_error
        w = self.Kp * e + self.Ki * e_i + self.Kd * e_d
        w = math.atan2(math.sin(w), math.cos(w))
        self.cummulative_error += e
        self.prev_error = e
        vr = (2.0 * self.desired_velocity + w * self.wheel_distance) / (2.0 * self.wheel_radius)
        vl = (2.0 * self.desired_velocity - w * self.wheel_distance) / (2.0 * self.wheel_radius)
        return [vl, vr], False
