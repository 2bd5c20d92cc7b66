"""PyRep's ``RobotComponent``: a robot model's base and its joints, driven together."""

from __future__ import annotations

from typing import Any

from pyrep.backend import sim
from pyrep.const import JointMode, JointType, ObjectType
from pyrep.objects.joint import Joint
from pyrep.objects.object import Object


class RobotComponent(Object):
    """The ``count``-th copy (0: the first, ``name``; n: ``name#n-1``) of a robot part whose
    joints are ``joint_names``."""

    def __init__(self, count: int, name: str, joint_names: list[str], base_name: str | None = None):
        suffix = "" if count == 0 else f"#{count - 1}"
        super().__init__((name if base_name is None else base_name) + suffix)
        self._num_joints = len(joint_names)
        self.joints = [Joint(jname + suffix) for jname in joint_names]

    def copy(self) -> RobotComponent:
        """A copy of the whole model (a new ``count``)."""
        handle = int(sim.call("copyPasteObjects", [self._handle], 1)[0])
        clone = object.__new__(type(self))
        clone.__dict__.update(self.__dict__)
        clone._handle = handle
        names = [j.get_name() for j in self.joints]
        tree = {o.get_name(): o for o in Object._get_objects_in_tree(handle, ObjectType.JOINT)}
        clone.joints = [Joint(tree[n].get_handle()) if n in tree else j for n, j in zip(names, self.joints)]
        return clone

    def _get_requested_type(self) -> ObjectType:
        return self.get_type()

    def _type_ok(self, actual: ObjectType) -> bool:
        return True

    def get_joint_count(self) -> int:
        return self._num_joints

    def get_joint_types(self) -> list[JointType]:
        return [j.get_joint_type() for j in self.joints]

    def get_joint_positions(self) -> list[float]:
        """Joint positions (rad or m)."""
        return [j.get_joint_position() for j in self.joints]

    def set_joint_positions(self, positions: list[float], disable_dynamics: bool = False) -> None:
        """Places every joint at once (rad or m); their motors' targets follow."""
        self._assert_len(positions)
        with sim.one_change():  # one mj_forward for the arm, not one per joint
            for joint, p in zip(self.joints, positions):
                joint.set_joint_position(float(p), disable_dynamics)

    def get_joint_target_positions(self) -> list[float]:
        return [j.get_joint_target_position() for j in self.joints]

    def set_joint_target_positions(self, positions: list[float]) -> None:
        self._assert_len(positions)
        for joint, p in zip(self.joints, positions):
            joint.set_joint_target_position(float(p))

    def get_joint_target_velocities(self) -> list[float]:
        return [j.get_joint_target_velocity() for j in self.joints]

    def set_joint_target_velocities(self, velocities: list[float]) -> None:
        self._assert_len(velocities)
        for joint, v in zip(self.joints, velocities):
            joint.set_joint_target_velocity(float(v))

    def get_joint_forces(self) -> list[float]:
        return [j.get_joint_force() for j in self.joints]

    def set_joint_forces(self, forces: list[float]) -> None:
        self._assert_len(forces)
        for joint, f in zip(self.joints, forces):
            joint.set_joint_force(float(f))

    def get_joint_velocities(self) -> list[float]:
        return [j.get_joint_velocity() for j in self.joints]

    def get_joint_intervals(self) -> tuple[list[bool], list[list[float]]]:
        """``(cyclic flags, [min, range] each)``."""
        pairs = [j.get_joint_interval() for j in self.joints]
        return [c for c, _ in pairs], [i for _, i in pairs]

    def set_joint_intervals(self, cyclic: list[bool], intervals: list[list[float]]) -> None:
        self._assert_len(cyclic)
        self._assert_len(intervals)
        for joint, c, i in zip(self.joints, cyclic, intervals):
            joint.set_joint_interval(c, i)

    def get_joint_upper_velocity_limits(self) -> list[float]:
        return [j.get_joint_upper_velocity_limit() for j in self.joints]

    def set_control_loop_enabled(self, value: bool) -> None:
        for joint in self.joints:
            joint.set_control_loop_enabled(value)

    def set_motor_locked_at_zero_velocity(self, value: bool) -> None:
        for joint in self.joints:
            joint.set_motor_locked_at_zero_velocity(value)

    def set_joint_mode(self, value: JointMode) -> None:
        for joint in self.joints:
            joint.set_joint_mode(value)

    def get_joint_modes(self) -> list[JointMode]:
        return [j.get_joint_mode() for j in self.joints]

    def get_visuals(self) -> list[Object]:
        """The shapes of the model whose name contains ``visual``."""
        tree = self.get_objects_in_tree(ObjectType.SHAPE, exclude_base=False)
        return [o for o in tree if "visual" in o.get_name()]

    def _assert_len(self, inputs: Any) -> None:
        if len(inputs) != len(self.joints):
            raise ValueError(f"Tried to set values for {len(inputs)} joints, but joint group consists of "
                             f"{len(self.joints)} joints.")
