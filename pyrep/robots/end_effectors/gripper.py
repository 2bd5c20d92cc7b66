"""PyRep's ``Gripper``: finger joints opened and closed by velocity, and grasping by attaching.

``grasp(obj)`` attaches a detected object to the gripper's attach point
(``obj.set_parent(attach_point, keep_in_place=True)``, the table's ``sim.setObjectParent``), as
PyRep fakes a grasp; ``release()`` gives it back to its old parent.
"""

from __future__ import annotations

import numpy as np

from pyrep.objects.force_sensor import ForceSensor
from pyrep.objects.object import Object
from pyrep.objects.proximity_sensor import ProximitySensor
from pyrep.robots.robot_component import RobotComponent

POSITION_ERROR = 0.001


class Gripper(RobotComponent):
    """A gripper ``name`` with ``joint_names``, ``<name>_attachProxSensor`` and ``<name>_attachPoint``."""

    def __init__(self, count: int, name: str, joint_names: list[str]):
        super().__init__(count, name, joint_names)
        suffix = "" if count == 0 else f"#{count - 1}"
        self._proximity_sensor = ProximitySensor(f"{name}_attachProxSensor{suffix}")
        self._attach_point = ForceSensor(f"{name}_attachPoint{suffix}")
        self._old_parents: list[Object | None] = []
        self._grasped_objects: list[Object] = []
        self._prev_positions: list[float | None] = [None] * len(joint_names)
        self._prev_vels: list[float | None] = [None] * len(joint_names)
        self._touch_sensors = []
        i = 0
        while ForceSensor.exists(f"{name}_touchSensor{i}{suffix}"):
            self._touch_sensors.append(ForceSensor(f"{name}_touchSensor{i}{suffix}"))
            i += 1

    def grasp(self, obj: Object) -> bool:
        """Attaches ``obj`` to the gripper if its proximity sensor detects it; whether it does."""
        detected = self._proximity_sensor.is_detected(obj)
        if detected and obj not in self._grasped_objects:
            self._grasped_objects.append(obj)
            self._old_parents.append(obj.get_parent())
            obj.set_parent(self._attach_point, keep_in_place=True)
        return detected

    def release(self) -> None:
        """Detaches every grasped object (back to its old parent)."""
        for obj, parent in zip(self._grasped_objects, self._old_parents):
            if obj.still_exists():
                obj.set_parent(parent, keep_in_place=True)
        self._grasped_objects = []
        self._old_parents = []

    def get_grasped_objects(self) -> list[Object]:
        return self._grasped_objects

    def _targets(self, amount: float) -> tuple[np.ndarray, np.ndarray]:
        _, intervals = self.get_joint_intervals()
        lo = np.array([i[0] for i in intervals])
        span = np.array([i[1] for i in intervals])
        return lo, span

    def actuate(self, amount: float, velocity: float) -> bool:
        """One step of opening (1) or closing (0) the gripper to ``amount`` at ``velocity``
        (rad/s or m/s); True once every finger reached it or stopped moving (call it before each
        ``step()`` until then).

        Raises:
            ValueError: ``amount`` out of 0..1.
        """
        if not 0.0 <= amount <= 1.0:
            raise ValueError("'open_amount' should be between 0 and 1.'")
        lo, span = self._targets(amount)
        target = lo + span * amount
        current = self.get_joint_positions()
        done = True
        for i, (joint, goal, cur, prev) in enumerate(zip(self.joints, target, current, self._prev_positions)):
            not_moving = prev is not None and abs(cur - prev) < POSITION_ERROR
            reached = abs(goal - cur) < POSITION_ERROR
            vel = -velocity if cur - goal > 0 else velocity
            oscillating = self._prev_vels[i] is not None and vel != self._prev_vels[i]
            if not_moving or reached or oscillating:
                joint.set_joint_target_velocity(0)
                continue
            done = False
            self._prev_vels[i] = vel
            joint.set_joint_target_velocity(vel)
        self._prev_positions = list(current)
        if done:
            self._prev_positions = [None] * self._num_joints
            self._prev_vels = [None] * self._num_joints
            self.set_joint_target_velocities([0.0] * self._num_joints)
        return done

    def get_open_amount(self) -> list[float]:
        """Per finger joint, 0 (closed) .. 1 (open)."""
        lo, span = self._targets(1.0)
        return list(np.clip((np.array(self.get_joint_positions()) - lo) / span, 0.0, 1.0))

    def get_touch_sensor_forces(self) -> list[list[float]]:
        """Forces (N) of the fingers' touch sensors.

        Raises:
            NotImplementedError: the gripper has none.
        """
        if not self._touch_sensors:
            raise NotImplementedError("No touch sensors for this robot!")
        return [s.read()[0] for s in self._touch_sensors]
