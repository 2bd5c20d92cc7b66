"""V-REP's joint functions of ``sim`` (``sim.getJointPosition``, ``sim.setJointTargetVelocity``
...): positions in rad (hinge) or m (slide), velocities in rad/s or m/s, forces in N·m or N, on
:class:`simx_server.sim.joints.Joints`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.base.arguments import as_number as _num

if TYPE_CHECKING:
    pass


# Joint positions, motor targets and forces.

@sim_function("getJointPosition")
def getJointPosition(ctx: CallContext, handle: Any) -> float:  # noqa: N802
    """Joint position (rad or m).

    Args:
        handle: a hinge or slide joint's handle.

    Returns:
        rad or m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint, or a spherical one.
    """
    return ctx.world.joint_position(ctx.h(handle))


@sim_function("setJointPosition")
def setJointPosition(ctx: CallContext, handle: Any, position: Any) -> None:  # noqa: N802
    """Teleport a joint to ``position`` (rad or m).

    Args:
        handle: a hinge or slide joint's handle.
        position: rad or m, within ±limits.MAX_JOINT_POSITION.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint, or a spherical one.
        ArgumentError: a position out of bounds.
    """
    ctx.world.set_joint_position(ctx.h(handle), _num(position, "position"))


@sim_function("setJointTargetPosition")
def setJointTargetPosition(ctx: CallContext, handle: Any, position: Any) -> None:  # noqa: N802
    """Target position of the joint's motor (rad or m), stored whatever the mode (2000/2001 decide).

    Args:
        handle: a joint's handle.
        position: rad or m, within ±limits.MAX_JOINT_POSITION.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
        ArgumentError: a position out of bounds.
    """
    ctx.world.set_joint_target_position(ctx.h(handle), _num(position, "position"))


@sim_function("getJointTargetPosition")
def getJointTargetPosition(ctx: CallContext, handle: Any) -> float:  # noqa: N802
    """Target position of a joint's motor (rad or m).

    Args:
        handle: a joint's handle.

    Returns:
        rad or m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
    """
    return float(ctx.world.target_position[ctx.world.motor(ctx.h(handle))])


@sim_function("setJointTargetVelocity")
def setJointTargetVelocity(ctx: CallContext, handle: Any, velocity: Any) -> None:  # noqa: N802
    """Target velocity of the joint's motor (rad/s or m/s), stored whatever the mode (2000/2001 decide).

    Args:
        handle: a joint's handle.
        velocity: rad/s or m/s, within ±limits.MAX_JOINT_VELOCITY.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
        ArgumentError: a velocity out of bounds.
    """
    ctx.world.set_joint_target_velocity(ctx.h(handle), _num(velocity, "velocity"))


@sim_function("getJointTargetVelocity")
def getJointTargetVelocity(ctx: CallContext, handle: Any) -> float:  # noqa: N802
    """Target velocity of a joint's motor (rad/s or m/s).

    Args:
        handle: a joint's handle.

    Returns:
        rad/s or m/s.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
    """
    return float(ctx.world.target_velocity[ctx.world.motor(ctx.h(handle))])


@sim_function("setJointForce", "setJointMaxForce")
def setJointForce(ctx: CallContext, handle: Any, force: Any) -> None:  # noqa: N802
    """Maximum force/torque of the joint's motor (N or N·m).

    Args:
        handle: a joint's handle.
        force: N or N·m (sign ignored), within limits.MAX_JOINT_FORCE.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
        ArgumentError: a force out of bounds.
    """
    ctx.world.set_joint_force(ctx.h(handle), _num(force, "force"))


@sim_function("getJointForce")
def getJointForce(ctx: CallContext, handle: Any) -> float:  # noqa: N802
    """Force/torque the joint's motor applies (N or N·m).

    Args:
        handle: a hinge or slide joint's handle.

    Returns:
        N or N·m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint, or a spherical one.
    """
    return ctx.world.joint_force(ctx.h(handle))


@sim_function("getJointMaxForce")
def getJointMaxForce(ctx: CallContext, handle: Any) -> float:  # noqa: N802
    """Maximum force/torque of the joint's motor (N or N·m).

    Args:
        handle: a joint's handle.

    Returns:
        N or N·m, >= 0.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
    """
    return ctx.world.joint_max_force(ctx.h(handle))


