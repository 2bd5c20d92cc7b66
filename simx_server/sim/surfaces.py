"""A shape's initial velocity (``sim.shapefloatparam_init_velocity_x/y/z``, 3000-3002, and
``sim.shapefloatparam_init_ang_velocity_x/y/z``, 3020-3022: world axes, m/s and rad/s), and what
it does: the moving surface of V-REP's conveyors.

V-REP's conveyor models (the "ConveyorBelt" of its model library and the conveyors made from it)
keep a static respondable pad, the *forwarder*, and at each pass reset it
(``sim.resetDynamicObject``) and set its initial velocity to the belt's: the dynamics engine gives
the static body that velocity, it does not move (static bodies are not integrated), and its
contacts see a surface moving at that velocity, so what lies on the pad is carried at the belt's
speed by friction (Bullet's and ODE's solvers take a body's velocity at the contact point as it
is, static or not; coppeliaSimLib ``CShape::setInitialDynamicLinearVelocity``, kept per shape,
restored at the simulation's end by ``CShape::simulationEnded``).

MuJoCo has no surface velocity, so simx gives the contacts one: for every contact of a shape
that is not a free body (a V-REP static shape, fixed to the world or to a body that carries it)
and has an initial velocity, the rows of the contact's constraint get the reference acceleration
they would have if that shape's surface moved at ``v + w x (p - c)`` (``p`` the contact point,
``c`` the shape's centre of mass): between ``mj_step1`` and ``mj_step2`` of each substep, MuJoCo's
``efc_aref = -B·(J·qvel) - K·I·r`` gets ``+B·(J_row·v_surface)`` (the relative velocity the
constraint drives to zero is then the velocity relative to the moving surface; sign by which
side of the contact the shape is). The pad stays where it is, what it carries accelerates at up
to the friction's limit until it moves at the belt's speed, and what lies beside the pad is
untouched. No degree of freedom is added, the model is not recompiled, and a scene without such
a velocity steps inside MuJoCo as before (the substeps go through Python only while a surface
moves).

A free body (a dynamic shape) takes its initial velocity when it is reset
(``sim.resetDynamicObject``: CoppeliaSim creates the rigid body again, with that velocity). The
values set during a run are forgotten when the simulation stops, as CoppeliaSim restores them.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError
from simx_server.sim import friction
from simx_server.sim.objects import SHAPE

__all__ = ["IDS", "MovingSurfaces", "get", "moving", "set_value", "start_free", "substep"]

#: Parameter id -> index in the (6,) initial velocity (linear x y z, angular x y z).
IDS = {3000: 0, 3001: 1, 3002: 2, 3020: 3, 3021: 4, 3022: 5}
_FREE = int(mujoco.mjtJoint.mjJNT_FREE)
_ELLIPTIC = int(mujoco.mjtCone.mjCONE_ELLIPTIC)
#: A speed past which a value is refused (m/s or rad/s): a conveyor or a throw, not a blow-up.
MAX_SPEED = 1.0e4


def _is_free(m: mujoco.MjModel, body: int) -> bool:
    return body > 0 and int(m.body_jntnum[body]) == 1 and int(m.jnt_type[m.body_jntadr[body]]) == _FREE


def get(world, name: str, pid: int) -> float:
    """A shape's initial velocity component.

    Args:
        world: the World.
        name: the shape's name.
        pid: 3000-3002 (m/s) or 3020-3022 (rad/s).

    Returns:
        The value (0 unless set during this run).
    """
    v = world.init_velocities.get(name)
    return 0.0 if v is None else float(v[IDS[pid]])


def set_value(world, name: str, pid: int, value: float) -> None:
    """Set a shape's initial velocity component (world axes).

    Args:
        world: the World.
        name: the shape's name.
        pid: 3000-3002 (m/s) or 3020-3022 (rad/s).
        value: the component.

    Raises:
        ArgumentError: not finite, or faster than :data:`MAX_SPEED`.
    """
    if not math.isfinite(value) or abs(value) > MAX_SPEED:
        raise ArgumentError(f"an initial velocity must be finite and at most {MAX_SPEED:g} in size, got {value!r}")
    v = world.init_velocities.setdefault(name, np.zeros(6))
    v[IDS[pid]] = value
    if not v.any():
        del world.init_velocities[name]


def start_free(world, bodies: np.ndarray) -> None:
    """Give the free bodies among ``bodies`` (a mask over the model's bodies, or all) their
    initial velocity: a dynamic shape reset by ``sim.resetDynamicObject``.

    Args:
        world: the World.
        bodies: (nbody,) bool mask of the bodies reset.
    """
    m, d = world.model, world.data
    for name, v in world.init_velocities.items():
        obj = world.by_name.get(name)
        if obj is None or not _is_free(m, obj.mj_id) or not bodies[obj.mj_id]:
            continue
        dof = int(m.jnt_dofadr[m.body_jntadr[obj.mj_id]])
        d.qvel[dof:dof + 3] = v[:3]  # a free joint: linear velocity in world axes,
        d.qvel[dof + 3:dof + 6] = d.xmat[obj.mj_id].reshape(3, 3).T @ v[3:]  # angular in the body's


class MovingSurfaces:
    """The bodies whose contacts see a moving surface now: ``bodies`` (k,) body ids,
    ``velocities`` (k, 6) linear and angular velocity (world axes), and ``index`` (nbody,) each
    body's row in them (-1: none)."""

    __slots__ = ("bodies", "index", "turning", "velocities")

    def __init__(self, bodies: np.ndarray, velocities: np.ndarray, nbody: int):
        self.bodies = bodies
        self.velocities = velocities
        self.turning = bool(velocities[:, 3:].any())
        self.index = np.full(nbody, -1)
        self.index[bodies] = np.arange(len(bodies))


def moving(world) -> MovingSurfaces | None:
    """The shapes that are not free bodies and have an initial velocity, or None (no surface
    moves: MuJoCo steps alone).

    Args:
        world: the World.

    Returns:
        Their bodies and velocities, or None.
    """
    if not world.init_velocities:
        return None
    m = world.model
    bodies, velocities = [], []
    for name, v in world.init_velocities.items():
        obj = world.by_name.get(name)
        if obj is not None and obj.type == SHAPE and not _is_free(m, obj.mj_id):
            bodies.append(obj.mj_id)
            velocities.append(v)
    if not bodies:
        return None
    return MovingSurfaces(np.array(bodies), np.array(velocities), m.nbody)


def substep(m: mujoco.MjModel, d: mujoco.MjData, surfaces: MovingSurfaces | None, product: bool = False) -> None:
    """One MuJoCo step whose contacts with ``surfaces`` see them move (module docstring) and,
    with ``product``, have Bullet's combined friction (:mod:`simx_server.sim.friction`):
    ``mj_step1``, the contacts changed, ``mj_step2``.

    Args:
        m: the model.
        d: its data, stepped.
        surfaces: from :func:`moving` (None: no surface moves).
        product: apply :func:`simx_server.sim.friction.combine`.
    """
    mujoco.mj_step1(m, d)
    if d.ncon:
        if surfaces is not None:
            _move(m, d, surfaces)
        if product:
            friction.combine(m, d)
    mujoco.mj_step2(m, d)


def _move(m: mujoco.MjModel, d: mujoco.MjData, surfaces: MovingSurfaces) -> None:
    """Each contact row of a moving surface gets ``+B x`` (the surface's velocity along the row's
    direction, signed for the side it is on) in ``efc_aref``, all contacts at once."""
    c = d.contact
    sides = m.geom_bodyid[c.geom]  # (ncon, 2): relative velocities are geom2's minus geom1's
    k0, k1 = surfaces.index[sides[:, 0]], surfaces.index[sides[:, 1]]
    i = np.flatnonzero(((k0 >= 0) | (k1 >= 0)) & (c.efc_address >= 0))  # address -1: no constraint
    if not len(i):
        return
    first = k0[i] >= 0
    k = np.where(first, k0[i], k1[i])
    vel = surfaces.velocities[k]
    vs = vel[:, :3]
    if surfaces.turning:  # at the contact point: v + w x (p - c)
        vs = vs + np.cross(vel[:, 3:], c.pos[i] - d.xipos[surfaces.bodies[k]])
    # the surface's velocity along the contact's axes (normal, tangents), + for geom1, - for geom2
    along = (c.frame[i].reshape(-1, 3, 3) @ vs[:, :, None])[:, :, 0] * np.where(first, 1.0, -1.0)[:, None]
    adr, dim = c.efc_address[i], c.dim[i]
    aref, gain = d.efc_aref, d.efc_KBIP[:, 1]
    if int(m.opt.cone) == _ELLIPTIC:  # rows: normal, the two tangents, then torsion and rolling (none)
        for r in range(3):
            sel = dim > r
            rows = adr[sel] + r
            aref[rows] += gain[rows] * along[sel, r]
        return
    rows = adr[dim == 1]  # frictionless: the normal row
    aref[rows] += gain[rows] * along[dim == 1, 0]
    mu = c.friction[i]
    for j in range(1, 6):  # pyramidal: per friction direction two edges, n + mu_j t_j and n - mu_j t_j
        sel = dim > j
        if not sel.any():
            break
        t = along[sel, j] * mu[sel, j - 1] if j < 3 else 0.0  # torsion and rolling: no surface motion
        for edge, sgn in ((0, 1.0), (1, -1.0)):
            rows = adr[sel] + 2 * (j - 1) + edge
            aref[rows] += gain[rows] * (along[sel, 0] + sgn * t)
