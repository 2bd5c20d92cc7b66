"""PyRep's ``HolonomicBase``: a base on four omni-wheels (mecanum), driven forward, sideways
and round together; its front is its y axis."""

from __future__ import annotations

import math
from typing import Any

from pyrep.const import ConfigurationPathAlgorithms as Algos
from pyrep.errors import ConfigurationPathError
from pyrep.objects.joint import Joint
from pyrep.robots.configuration_paths.holonomic_configuration_path import HolonomicConfigurationPath
from pyrep.robots.mobiles.mobile_base import MobileBase, box_adjusted_matrix_and_facing_angle


class HolonomicBase(MobileBase):
    """A holonomic base: ``distance_from_target`` (m) is how far short of a linear path's goal
    it stops; ``max_velocity`` (rad/s of the wheels) bounds its forward and sideways speed,
    ``max_velocity_rotation`` its turning, ``max_acceleration`` the change per step (a fraction
    of those bounds), as PyRep's controller.

    The wheels are omni-wheels only while the model's scripts run (they put each roller joint
    back at 45 degrees every step): they come with the model, in a scene that holds it or added
    with ``import_model``.
    """

    def __init__(self, count: int, num_wheels: int, distance_from_target: float, name: str,
                 max_velocity: float = 4, max_velocity_rotation: float = 6, max_acceleration: float = 0.035):
        super().__init__(count, num_wheels, name)
        suffix = "" if count == 0 else f"#{count - 1}"
        self.paramP = 20
        self.paramO = 10
        self.previous_forw_back_vel = 0.0
        self.previous_left_right_vel = 0.0
        self.previous_rot_vel = 0.0
        self.accelF = max_acceleration
        self.maxV = max_velocity
        self.max_v_rot = max_velocity_rotation
        self.dist1 = distance_from_target
        self.joints_slipping = [Joint(f"{name}_slipping_m_joint{i + 1}{suffix}") for i in range(self.num_wheels)]

    def set_base_angular_velocites(self, velocity: Any) -> None:
        """The wheels' target velocities (rad/s) for ``[forward, sideways, rotation]`` (rad/s of
        the wheels: a positive rotation turns the base clockwise seen from above)."""
        fb, lr, rot = (float(v) for v in velocity[:3])
        self.set_joint_target_velocities([-fb - lr - rot, -fb + lr - rot, -fb - lr + rot, -fb + lr + rot])

    def get_linear_path(self, position: Any, angle: float = 0) -> HolonomicConfigurationPath:
        """A straight path to ``position`` (x, y; m): the goal's yaw is the heading of the target
        axis most aligned with the way there, less pi/2 (PyRep's box-adjusted facing angle, not
        ``angle`` itself); the base stops ``distance_from_target`` short of it.

        Raises:
            ConfigurationPathError: the base collides somewhere along the line.
        """
        position_base = self.get_position()
        angle_base = float(self.get_orientation()[-1])
        self._aim(position, angle)
        m, angle = box_adjusted_matrix_and_facing_angle(self, self.target_base)
        self.intermediate_target_base.set_position([m[3] - m[0] * self.dist1, m[7] - m[4] * self.dist1, self.target_z])
        self.intermediate_target_base.set_orientation([0.0, 0.0, angle])
        self.target_base.set_orientation([0.0, 0.0, angle])
        path = [[float(position_base[0]), float(position_base[1]), angle_base],
                [float(position[0]), float(position[1]), angle]]
        if self._check_collision_linear_path(path):
            raise ConfigurationPathError("Could not create path. An object was detected on the linear path.")
        return HolonomicConfigurationPath(self, path)

    def get_nonlinear_path(self, position: Any, angle: float = 0, boundaries: float = 2, path_pts: int = 600,
                           ignore_collisions: bool = False,
                           algorithm: Any = Algos.RRTConnect) -> HolonomicConfigurationPath:
        """A planned path to ``position`` (x, y; m) with yaw ``angle`` (rad), within
        ±``boundaries`` m (:meth:`MobileBase._get_nonlinear_path_points`).

        Raises:
            ConfigurationPathError: no path was found.
        """
        path = self._get_nonlinear_path_points(position, angle, boundaries, path_pts, ignore_collisions, algorithm)
        return HolonomicConfigurationPath(self, path)

    def get_base_actuation(self) -> tuple[list[float], bool]:
        """PyRep's proportional controller: ``([forward, sideways, rotation], done)``, velocities
        (rad/s of the wheels) towards the intermediate target, bounded and ramped; done (the last
        velocities kept) once the target is within 1 mm (less ``distance_from_target``) and its
        yaw, seen from the base, below 0.1 degree."""
        pos_v = self.target_base.get_position(relative_to=self)
        or_v = self.target_base.get_orientation(relative_to=self)
        pos_inter = self.intermediate_target_base.get_position(relative_to=self)
        or_inter = self.intermediate_target_base.get_orientation(relative_to=self)
        if math.hypot(pos_v[0], pos_v[1]) - self.dist1 < 0.001 and or_v[-1] < 0.1 * math.pi / 180:
            return [self.previous_forw_back_vel, self.previous_left_right_vel, self.previous_rot_vel], True
        fb, lr, rot = pos_inter[1] * self.paramP, pos_inter[0] * self.paramP, -or_inter[2] * self.paramO
        v = math.hypot(fb, lr)
        if v > self.maxV:
            fb, lr = fb * self.maxV / v, lr * self.maxV / v
        if abs(rot) > self.max_v_rot:
            rot = math.copysign(self.max_v_rot, rot)
        step_v, step_rot = self.maxV * self.accelF, self.max_v_rot * self.accelF

        def ramp(new: float, old: float, most: float) -> float:
            return old + max(-most, min(most, new - old))

        fb = ramp(fb, self.previous_forw_back_vel, step_v)
        lr = ramp(lr, self.previous_left_right_vel, step_v)
        rot = ramp(rot, self.previous_rot_vel, step_rot)
        self.previous_forw_back_vel, self.previous_left_right_vel, self.previous_rot_vel = fb, lr, rot
        return [fb, lr, rot], False
