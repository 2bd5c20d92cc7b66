"""PyRep's ``Joint``: positions in rad (revolute) or m (prismatic), velocities per s, forces in
N or N·m."""

from __future__ import annotations

from typing import Union

from pyrep.backend import sim
from pyrep.const import JointMode, JointType, ObjectType
from pyrep.errors import CoppeliaSimError
from pyrep.objects.object import Object, object_type_to_class

_UPPER_VELOCITY = 2017  # sim_jointfloatparam_upper_limit
_CTRL_ENABLED = 2001  # sim_jointintparam_ctrl_enabled
_MOTOR_ENABLED = 2000  # sim_jointintparam_motor_enabled
_VELOCITY_LOCK = 2030  # sim_jointintparam_velocity_lock


class Joint(Object):
    """A joint."""

    def __init__(self, name_or_handle: Union[str, int]):
        super().__init__(name_or_handle)

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.JOINT

    def get_joint_type(self) -> JointType:
        """Revolute, prismatic or spherical."""
        return JointType(sim.call("getJointType", self._handle))

    def get_joint_position(self) -> float:
        """Position: rad or m; 0.0 for a spherical joint, as PyRep gives on CoppeliaSim 4.1 (its
        ``simGetJointPosition`` refuses a spherical joint, and PyRep's binding does not check the
        return code: the zeroed buffer comes back; RLBench's low-dimensional state reads ropes'
        spherical joints so)."""
        try:
            return float(sim.call("getJointPosition", self._handle))
        except CoppeliaSimError:
            if self.get_joint_type() == JointType.SPHERICAL:
                return 0.0
            raise

    def set_joint_position(self, position: float, disable_dynamics: bool = False) -> None:
        """Sets the position (rad or m) at once; the motor's target follows, so that a joint in
        position control stays there. ``disable_dynamics`` is accepted (the set is immediate)."""
        sim.call("setJointPosition", self._handle, float(position))
        if self.is_control_loop_enabled():
            sim.call("setJointTargetPosition", self._handle, float(position))

    def get_joint_target_position(self) -> float:
        """The position controller's target (rad or m)."""
        return float(sim.call("getJointTargetPosition", self._handle))

    def set_joint_target_position(self, position: float) -> None:
        """Sets the position controller's target (rad or m)."""
        sim.call("setJointTargetPosition", self._handle, float(position))

    def get_joint_target_velocity(self) -> float:
        """The motor's target velocity (rad/s or m/s)."""
        return float(sim.call("getJointTargetVelocity", self._handle))

    def set_joint_target_velocity(self, velocity: float) -> None:
        """Sets the motor's target velocity (rad/s or m/s)."""
        sim.call("setJointTargetVelocity", self._handle, float(velocity))

    def get_joint_force(self) -> float:
        """The force (N) or torque (N·m) on the joint, with CoppeliaSim 4.1's sign: the opposite
        of the force the motor applies (``sim.getJointForce`` of 4.2+, which simx follows)."""
        return -float(sim.call("getJointForce", self._handle))

    def set_joint_force(self, force: float) -> None:
        """Sets the motor's maximum force (N) or torque (N·m)."""
        sim.call("setJointMaxForce", self._handle, float(force))

    def get_joint_velocity(self) -> float:
        """The joint's velocity (rad/s or m/s)."""
        return float(sim.call("getJointVelocity", self._handle))

    def get_joint_interval(self) -> tuple[bool, list[float]]:
        """``(cyclic, [min, range])`` (rad or m)."""
        cyclic, interval = sim.call("getJointInterval", self._handle)
        return bool(cyclic), [float(v) for v in interval]

    def set_joint_interval(self, cyclic: bool, interval: list[float]) -> None:
        """Sets the limits: ``interval`` is ``[min, range]`` (rad or m)."""
        sim.call("setJointInterval", self._handle, bool(cyclic), [float(v) for v in interval])

    def get_joint_upper_velocity_limit(self) -> float:
        """The motor's velocity limit (rad/s or m/s)."""
        return float(sim.call("getObjectFloatParam", self._handle, _UPPER_VELOCITY))

    def is_control_loop_enabled(self) -> bool:
        """Whether the motor runs a position controller."""
        return bool(sim.call("getObjectInt32Param", self._handle, _CTRL_ENABLED))

    def set_control_loop_enabled(self, value: bool) -> None:
        sim.call("setObjectInt32Param", self._handle, _CTRL_ENABLED, int(value))

    def is_motor_enabled(self) -> bool:
        """Whether the motor is on."""
        return bool(sim.call("getObjectInt32Param", self._handle, _MOTOR_ENABLED))

    def set_motor_enabled(self, value: bool) -> None:
        sim.call("setObjectInt32Param", self._handle, _MOTOR_ENABLED, int(value))

    def is_motor_locked_at_zero_velocity(self) -> bool:
        """Whether the motor holds its position at zero target velocity."""
        return bool(sim.call("getObjectInt32Param", self._handle, _VELOCITY_LOCK))

    def set_motor_locked_at_zero_velocity(self, value: bool) -> None:
        sim.call("setObjectInt32Param", self._handle, _VELOCITY_LOCK, int(value))

    def get_joint_mode(self) -> JointMode:
        """The joint's mode (passive, IK, dependent, force/torque)."""
        mode = sim.call("getJointMode", self._handle)
        return JointMode(int(mode[0] if isinstance(mode, (list, tuple)) else mode))

    def set_joint_mode(self, value: JointMode) -> None:
        """Sets the joint's mode."""
        sim.call("setJointMode", self._handle, value.value, 0)


object_type_to_class[ObjectType.JOINT] = Joint
