"""V-REP's joint calls of the ``sim`` facade (``sim.getJointPosition``, ``sim.setJointTargetVelocity``
...), a mixin of :class:`simx_server.scripts.facade_core.SimFacade`: positions in rad (hinge) or
m (slide), velocities in rad/s or m/s, forces in N·m or N, on
:class:`simx_server.sim.joints.Joints`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from simx_server.base.arguments import as_number as _num

if TYPE_CHECKING:
    from simx_server.sim.world import World


class JointCalls:
    """Joint positions, motor targets and forces (mixin of the facade)."""

    def getJointPosition(self, handle: Any) -> float:  # noqa: N802
        """Joint position (rad or m).

        Args:
            handle: a hinge or slide joint's handle.

        Returns:
            rad or m.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint, or a spherical one.
        """
        return self._world.joint_position(self._h(handle))

    def setJointPosition(self, handle: Any, position: Any) -> None:  # noqa: N802
        """Teleport a joint to ``position`` (rad or m).

        Args:
            handle: a hinge or slide joint's handle.
            position: rad or m, within ±limits.MAX_JOINT_POSITION.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint, or a spherical one.
            ArgumentError: a position out of bounds.
        """
        self._world.set_joint_position(self._h(handle), _num(position, "position"))

    def setJointTargetPosition(self, handle: Any, position: Any) -> None:  # noqa: N802
        """Target position of the joint's motor (rad or m), stored whatever the mode (2000/2001 decide).

        Args:
            handle: a joint's handle.
            position: rad or m, within ±limits.MAX_JOINT_POSITION.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
            ArgumentError: a position out of bounds.
        """
        self._world.set_joint_target_position(self._h(handle), _num(position, "position"))

    def getJointTargetPosition(self, handle: Any) -> float:  # noqa: N802
        """Target position of a joint's motor (rad or m).

        Args:
            handle: a joint's handle.

        Returns:
            rad or m.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
        """
        return float(self._world.target_position[self._world.motor(self._h(handle))])

    def setJointTargetVelocity(self, handle: Any, velocity: Any) -> None:  # noqa: N802
        """Target velocity of the joint's motor (rad/s or m/s), stored whatever the mode (2000/2001 decide).

        Args:
            handle: a joint's handle.
            velocity: rad/s or m/s, within ±limits.MAX_JOINT_VELOCITY.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
            ArgumentError: a velocity out of bounds.
        """
        self._world.set_joint_target_velocity(self._h(handle), _num(velocity, "velocity"))

    def getJointTargetVelocity(self, handle: Any) -> float:  # noqa: N802
        """Target velocity of a joint's motor (rad/s or m/s).

        Args:
            handle: a joint's handle.

        Returns:
            rad/s or m/s.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
        """
        return float(self._world.target_velocity[self._world.motor(self._h(handle))])

    def setJointForce(self, handle: Any, force: Any) -> None:  # noqa: N802
        """Maximum force/torque of the joint's motor (N or N·m).

        Args:
            handle: a joint's handle.
            force: N or N·m (sign ignored), within limits.MAX_JOINT_FORCE.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
            ArgumentError: a force out of bounds.
        """
        self._world.set_joint_force(self._h(handle), _num(force, "force"))

    setJointMaxForce = setJointForce  # noqa: N815 (CoppeliaSim 4 name)

    def getJointForce(self, handle: Any) -> float:  # noqa: N802
        """Force/torque the joint's motor applies (N or N·m).

        Args:
            handle: a hinge or slide joint's handle.

        Returns:
            N or N·m.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint, or a spherical one.
        """
        return self._world.joint_force(self._h(handle))

    def getJointMaxForce(self, handle: Any) -> float:  # noqa: N802
        """Maximum force/torque of the joint's motor (N or N·m).

        Args:
            handle: a joint's handle.

        Returns:
            N or N·m, >= 0.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint with a motor of its own.
        """
        return self._world.joint_max_force(self._h(handle))

    if TYPE_CHECKING:  # provided by the facade
        _world: World

        def _h(self, handle: Any, what: str = "object handle") -> int: ...
