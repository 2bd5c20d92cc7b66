"""CoppeliaSim 4.x's ``sim`` functions that child scripts and remote programs call alike: removing
objects and models, handles and children, joint types, velocities and force limits, vision
sensors' depth as a buffer.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import sensors as _sensors
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_vector as _vector
from simx_server.sim import dyn_ctrl, object_params
from simx_server.sim.objects import JOINT, WORLD

# mjtJoint free -> (none: no V-REP joint); ball -> spherical, slide -> prismatic, hinge -> revolute
_JOINT_TYPES = {0: None, 1: 12, 2: 11, 3: 10}


@sim_function("removeObject")
def removeObject(ctx: CallContext, objectHandle: Any) -> None:  # noqa: N802, N803
    """Remove an object (a shape with its body subtree), as ``simxRemoveObject``.

    ``sim.removeObject``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: the world (-1).
        UnsupportedError: an object simx cannot remove, or no simulation behind the script.
    """
    ctx.simulation("removeObject").editor.remove_object(ctx.h(objectHandle))


@sim_function("removeObjects")
def removeObjects(ctx: CallContext, objectHandles: Any, delayedRemoval: Any = False) -> None:  # noqa: N802, N803
    """Remove several objects (each as :func:`removeObject`; ``delayedRemoval`` ignored).

    ``sim.removeObjects``.

    Args:
        objectHandles: list of handles (ones already removed with a parent are skipped).
        delayedRemoval: ignored.

    Raises:
        ArgumentError: not a list of integers.
        UnknownObjectError: no such object.
        UnsupportedError: an object simx cannot remove, or no simulation behind the script.
    """
    if not isinstance(objectHandles, list):
        raise ArgumentError("objectHandles must be a list of handles")
    for h in objectHandles:
        if ctx.h(h, "objectHandle") in ctx.world.objects:  # already gone with a removed parent: skip
            removeObject(ctx, h)


@sim_function("removeModel")
def removeModel(ctx: CallContext, objectHandle: Any, delayedRemoval: Any = False) -> int:  # noqa: N802, N803
    """Remove a model: its base and every object below it in V-REP's tree, with their scripts
    and the assets only they used (``Editor.remove_model``); returns how many objects went.

    ``sim.removeModel`` (``simRemoveModel_internal``).

    Args:
        objectHandle: the model's base object (a shape that is no model base: its own tree), or
            ``sim.handle_self``.
        delayedRemoval: ignored.

    Returns:
        The number of objects removed.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: an object other than a shape that is no model base.
        UnsupportedError: an object simx cannot remove, or no simulation behind the script.
    """
    before = len(ctx.world.objects)
    ctx.simulation("removeModel").editor.remove_model(ctx.h(objectHandle))
    return before - len(ctx.world.objects)


@sim_function("isHandle")
def isHandle(ctx: CallContext, objectHandle: Any) -> bool:  # noqa: N802, N803
    """Whether an object has this handle.

    ``sim.isHandle``.

    Args:
        objectHandle: an integer.

    Returns:
        True or False.

    Raises:
        ArgumentError: not an integer.
    """
    return ctx.h(objectHandle, "objectHandle") in ctx.world.objects


@sim_function("getObjectChild")
def getObjectChild(ctx: CallContext, objectHandle: Any, index: Any) -> int:  # noqa: N802, N803
    """The ``index``-th (0-based) child of an object (-1: of the world), or -1.

    ``sim.getObjectChild``.

    Args:
        objectHandle: the parent's handle, -1 (the world) or ``sim.handle_self``.
        index: 0-based.

    Returns:
        The child's handle, or -1.

    Raises:
        UnknownObjectError: no such object.
    """
    h, i = ctx.h(objectHandle), _int(index, "index")
    if h != WORLD:
        ctx.world.get(h)
    children = [o.handle for o in ctx.world.objects.values() if o.parent == h]
    return children[i] if 0 <= i < len(children) else -1


@sim_function("getJointType")
def getJointType(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """``sim.joint_revolute_subtype`` (10), ``sim.joint_prismatic_subtype`` (11) or
    ``sim.joint_spherical_subtype`` (12: a MuJoCo ball joint).

    ``sim.getJointType``.

    Args:
        objectHandle: a joint's handle, or ``sim.handle_self``.

    Returns:
        10, 11 or 12.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint.
        UnsupportedError: a MuJoCo free joint.
    """
    obj = ctx.world.get(ctx.h(objectHandle), JOINT)
    kind = _JOINT_TYPES.get(int(ctx.world.model.jnt_type[obj.mj_id]))
    if kind is None:
        raise UnsupportedError(f"joint {obj.name!r} is a MuJoCo free joint, which V-REP's joint types do "
                               "not describe")
    return kind


@sim_function("getJointVelocity")
def getJointVelocity(ctx: CallContext, jointHandle: Any) -> float:  # noqa: N802, N803
    """Joint velocity (rad/s or m/s).

    ``sim.getJointVelocity``.

    Args:
        jointHandle: a joint's handle, or ``sim.handle_self``.

    Returns:
        rad/s or m/s.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint.
        UnsupportedError: no simulation behind the script.
    """
    return object_params.joint_velocity(ctx.simulation("getJointVelocity").world, ctx.h(jointHandle))


@sim_function("setJointTargetForce")
def setJointTargetForce(ctx: CallContext, objectHandle: Any, forceOrTorque: Any, signedValue: Any = True) -> None:  # noqa: N802, N803
    """The joint's target force/torque (N or N·m): what its motor applies in force mode, and its
    magnitude the most it applies in the other modes (``sim.jointintparam_dynctrlmode``,
    :mod:`simx_server.sim.dyn_ctrl`). ``signedValue`` true (the default): the value's sign is kept,
    and a target velocity of the other sign turns round; false: a negative value is 0, and the
    force takes the target velocity's sign (coppeliaSimLib ``CJoint::setTargetForce``).

    ``sim.setJointTargetForce``.

    Args:
        objectHandle: a joint's handle, or ``sim.handle_self``.
        forceOrTorque: N or N·m, within limits.MAX_JOINT_FORCE.
        signedValue: keep the sign.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
        ArgumentError: not a number, or out of bounds.
    """
    force = _num(forceOrTorque, "forceOrTorque")
    signed = bool(signedValue) if signedValue is not None else True
    ctx.world.set_joint_force(ctx.h(objectHandle), force if signed else max(force, 0.0), signed)


@sim_function("getJointTargetForce")
def getJointTargetForce(ctx: CallContext, jointHandle: Any) -> float:  # noqa: N802, N803
    """The joint's signed target force/torque (N or N·m; coppeliaSimLib ``CJoint::getTargetForce``):
    what :func:`setJointTargetForce` set, its sign the target velocity's when both are nonzero.

    ``sim.getJointTargetForce``.

    Args:
        jointHandle: a joint's handle, or ``sim.handle_self``.

    Returns:
        N or N·m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint with a motor of its own.
    """
    world = ctx.world
    return dyn_ctrl.target_force(world.motors, world.motor(ctx.h(jointHandle)))


@sim_function("getVisionSensorDepth")
def getVisionSensorDepth(ctx: CallContext, sensorHandle: Any, options: Any = 0, pos: Any = None,  # noqa: N802, N803
                         size: Any = None) -> tuple[bytes, list[int]]:
    """``depth, resolution``: the depth buffer as float32 bytes, rows bottom-up; values 0..1
    from near to far clipping plane, or (``options`` bit 0) distances in m. ``pos``/``size``
    cut a window as in ``getVisionSensorImg``.

    ``sim.getVisionSensorDepth``.

    Args:
        sensorHandle: a vision sensor's handle.
        options: bit 0: metres.
        pos: ``[x, y]`` pixels, or None.
        size: ``[w, h]`` pixels (0: to the edge), or None.

    Returns:
        ``(depth, resolution)``: w*h float32 bytes and ``[w, h]``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
        UnsupportedError: options beyond bit 0, or no simulation behind the script.
        ArgumentError: a window outside the image.
    """
    opts = _int(options, "options")
    if opts & ~1:
        raise UnsupportedError(f"getVisionSensorDepth options {opts}: only bit 0 (metres) is supported")
    px, py = (0, 0) if pos is None else _vector(pos, 2, "pos")
    sx, sy = (0, 0) if size is None else _vector(size, 2, "size")
    job = _sensors.depth_job(ctx, "getVisionSensorDepth", ctx.h(sensorHandle), bool(opts & 1))

    def finish() -> tuple[bytes, list[int]]:
        depth = _sensors.crop(job(), int(px), int(py), int(sx), int(sy))
        return depth.astype(np.float32, copy=False).tobytes(), [int(depth.shape[1]), int(depth.shape[0])]

    return _sensors.rendered(ctx, "getVisionSensorDepth", finish)


