"""PyRep's ``Robotiq85Gripper``: fully open or closed only, as PyRep's."""

from pyrep.objects.joint import Joint
from pyrep.robots.end_effectors.gripper import Gripper

POSITION_ERROR = 0.00001


class Robotiq85Gripper(Gripper):
    def __init__(self, count: int = 0):
        super().__init__(count, "ROBOTIQ_85", ["ROBOTIQ_85_active1", "ROBOTIQ_85_active2"])
        self._open_amount_query_joints = [Joint(n) for n in ("ROBOTIQ_85_Rjoint1", "ROBOTIQ_85_Ljoint1")]

    def actuate(self, amount: float, velocity: float) -> bool:
        """Opens (1) or closes (0) fully; True once the fingers stopped.

        Raises:
            ValueError: another amount.
        """
        if amount not in (0.0, 1.0):
            raise ValueError("This gripper currently only supports fully open or closed.")
        vel = velocity if amount == 1.0 else -velocity
        current = self.get_joint_positions()
        done = True
        for i, (joint, cur, prev) in enumerate(zip(self.joints, current, self._prev_positions)):
            if prev is not None and abs(cur - prev) < POSITION_ERROR:
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
        """0 closed .. 1 open, from the finger joints."""
        amounts = []
        for joint in self._open_amount_query_joints:
            _, (lo, span) = joint.get_joint_interval()
            amounts.append(1.0 - min(max((joint.get_joint_position() - lo) / span, 0.0), 1.0))
        return amounts
