"""CoppeliaSim's ``sim`` calls on dynamics: ``sim.addForce``, ``sim.addForceAndTorque``,
``sim.resetDynamicObject``.

Forces accumulate in MuJoCo's ``xfrc_applied`` and are reset after the next simulation step, as
CoppeliaSim resets them after ``sim.handleDynamics`` (:class:`AppliedForces`, cleared by
:meth:`simx_server.scripts.scene_scripts.Scripts.sensing`).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ObjectTypeError
from simx_server.base import limits as L
from simx_server.api.sim.core import _vector
from simx_server.sim import surfaces
from simx_server.sim.world import SHAPE, World

class AppliedForces:
    """Forces and torques added by scripts for the next simulation step.

    ``add`` accumulates a wrench (world frame, at the body's centre of mass) in MuJoCo's
    ``xfrc_applied``; ``clear`` zeroes the rows it wrote, once the step that applied them is
    over. One per :class:`~simx_server.scripts.scene_scripts.Scripts`, shared by its scripts' contexts.
    """

    def __init__(self) -> None:
        self._data: mujoco.MjData | None = None
        self._bodies: set[int] = set()

    def add(self, world: World, body: int, force: np.ndarray, torque: np.ndarray) -> None:
        """Add ``force`` (N) and ``torque`` (N·m), world axes, at body ``body``'s centre of mass.

        Raises ArgumentError, adding nothing, when a component of the sum would exceed
        ``limits.MAX_SCRIPT_FORCE``.

        Args:
            world: the scene.
            body: MuJoCo body id.
            force: 3 floats, N.
            torque: 3 floats, N·m.

        Raises:
            ArgumentError: the sum would exceed ``limits.MAX_SCRIPT_FORCE``.
        """
        if self._data is not world.data:  # a new MjData (scene edit, new scene): nothing pending there
            self._data, self._bodies = world.data, set()
        total = world.data.xfrc_applied[body] + np.concatenate([force, torque])
        if not np.all(np.abs(total) <= L.MAX_SCRIPT_FORCE):
            raise ArgumentError(f"the forces and torques added to one body for a step must stay within "
                                f"+/-{L.MAX_SCRIPT_FORCE:g} N or N m (simx_server.base.limits.MAX_SCRIPT_FORCE)")
        world.data.xfrc_applied[body] = total
        self._bodies.add(body)

    def clear(self, world: World) -> None:
        """Zero what :meth:`add` wrote (after the step that applied it).

        Args:
            world: the scene.
        """
        if self._bodies and self._data is world.data:
            world.data.xfrc_applied[sorted(self._bodies)] = 0.0
        self._data, self._bodies = None, set()

    def __bool__(self) -> bool:
        return bool(self._bodies)


@sim_function("resetDynamicObject")
def resetDynamicObject(ctx: CallContext, handle: Any) -> None:  # noqa: N802
    """CoppeliaSim's ``sim.resetDynamicObject`` (V-REP 3.x ``simResetDynamicObject``), called
    before a script teleports a robot: the object's tree (its body and every body below it;
    ``sim.handle_all``: the whole scene) stops, every degree of freedom of those bodies'
    joints, free joints included, at zero velocity (a dynamic shape given an initial velocity,
    ``sim.shapefloatparam_init_velocity_x`` ...: at that velocity, :mod:`simx_server.sim.surfaces`),
    and the contacts are rebuilt for the current poses (``mj_forward``). Errors: an unknown handle.

    Args:
        handle: the object's handle, or ``sim.handle_all``.

    Raises:
        UnknownObjectError: no such object.
    """
    world = ctx.world
    m, d = world.model, world.data
    h = ctx.h(handle, "objectHandle")
    if h == C.sim_handle_all:
        d.qvel[:] = 0
        d.qacc_warmstart[:] = 0
        tree = np.ones(m.nbody, bool)
    else:
        root = world.get(ctx.h(h)).body
        bodies = np.arange(m.nbody)
        tree = np.zeros(m.nbody, bool)
        tree[root] = True
        for b in bodies[root + 1:]:  # MuJoCo orders bodies so that a parent comes first
            tree[b] = tree[m.body_parentid[b]]
        dofs = tree[m.dof_bodyid]
        d.qvel[dofs] = 0
        d.qacc_warmstart[dofs] = 0
    if world.init_velocities:  # a dynamic shape starts again with its initial velocity
        surfaces.start_free(world, tree)  # (reads body orientations: the poses did not change)
    world.changed()


def _dynamic_body(ctx: CallContext, handle: Any) -> int:
    obj = ctx.world.get(ctx.h(handle, "shapeHandle"), SHAPE)
    if ctx.world.model.body_weldid[obj.mj_id] == 0:
        raise ObjectTypeError(f"shape {obj.name!r} is static (welded to the world): forces do not move it")
    return obj.mj_id


@sim_function("addForce")
def addForce(ctx: CallContext, handle: Any, position: Any, force: Any) -> None:  # noqa: N802
    """Add ``force`` (N, world axes) at ``position`` (m, in the shape's frame) for the next
    simulation step; forces add up and are reset after that step (CoppeliaSim: after
    ``sim.handleDynamics``). Errors: not a shape, a static shape.

    ``sim.addForce``.

    Args:
        handle: a dynamic shape's handle.
        position: 3 numbers, m (shape frame).
        force: 3 numbers, N (world frame).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape, or a static one.
        ArgumentError: not 3 numbers, or a sum over ``limits.MAX_SCRIPT_FORCE``.
    """
    body = _dynamic_body(ctx, handle)
    p = np.array(_vector(position, 3, "position"))
    f = np.array(_vector(force, 3, "force"))
    d = ctx.world.data
    at = d.xpos[body] + d.xmat[body].reshape(3, 3) @ p
    ctx.forces.add(ctx.world, body, f, np.cross(at - d.xipos[body], f))


@sim_function("addForceAndTorque")
def addForceAndTorque(ctx: CallContext, handle: Any, force: Any = None, torque: Any = None) -> None:  # noqa: N802
    """Add ``force`` (N) and ``torque`` (N·m), world axes, at the shape's centre of mass for
    the next simulation step (nil: none); reset after it, as :func:`addForce`.

    ``sim.addForceAndTorque``.

    Args:
        handle: a dynamic shape's handle.
        force: 3 numbers (N), or None.
        torque: 3 numbers (N·m), or None.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape, or a static one.
        ArgumentError: not 3 numbers, or a sum over ``limits.MAX_SCRIPT_FORCE``.
    """
    body = _dynamic_body(ctx, handle)
    f = np.zeros(3) if force is None else np.array(_vector(force, 3, "force"))
    t = np.zeros(3) if torque is None else np.array(_vector(torque, 3, "torque"))
    ctx.forces.add(ctx.world, body, f, t)


