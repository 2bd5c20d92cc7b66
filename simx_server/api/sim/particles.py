"""V-REP's particle objects (``sim.addParticleObject``, ``sim.addParticleObjectItem``,
``sim.removeParticleObject``; and 3.x's ``simAddParticleObject`` and its kin) as force sources: those
``sim`` functions and the registry that moves the particles (:class:`Particles`).

MuJoCo has no particles. Here each particle is a point of mass ``density * pi * size**3 / 6``
(a sphere of diameter ``size``) that flies in a straight line (under gravity unless the object
has ``sim.particle_ignoresgravity``) for ``lifeTime`` seconds. Once per simulation step, before
the physics, every particle moves by its velocity times the step; a particle of a respondable
object (``sim.particle_respondable1to4`` or ``..5to8``) whose path meets a geom (``mj_ray``) is
absorbed there and pushes that geom's body with its momentum over the step (force ``m v / dt``
at the hit point, through the same per-step forces as ``sim.addForceAndTorque``). Particles are
not drawn, do not collide with each other (``sim.particle_particlerespondable``), and
``sim.particle_water`` adds no buoyancy. The body of the script that made the object is not hit
by its own particles (a propeller's jet starts inside it). Particle objects end with the
simulation, as in V-REP.

An item is V-REP's six numbers: a position and the point where the particle would be one second
later (m, world frame), so its velocity is the second point minus the first (m/s).
"""

from __future__ import annotations

import logging
import math
from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_integer as _int, as_number as _num

log = logging.getLogger("simx.scripts")

__all__ = ["Particles"]

PARTICLE_RESPONDABLE = 32 | 64  # sim.particle_respondable1to4 | sim.particle_respondable5to8
PARTICLE_IGNORES_GRAVITY = 256  # sim.particle_ignoresgravity
PARTICLE_CYCLIC = 8192  # sim.particle_cyclic: past maxItemCount the oldest items go
#: Particles of one object at most, and of all objects together (each is one ray per step).
MAX_ITEMS_PER_OBJECT = 10_000
MAX_PARTICLES = 20_000
HANDLE_ALL = -2


class _ParticleObject:
    """One particle object: its parameters and its live particles (positions, velocities, ages)."""

    def __init__(self, options: int, size: float, density: float, life: float, max_items: int, body: int):
        self.options, self.size, self.life, self.max_items, self.body = options, size, life, max_items, body
        self.mass = density * math.pi * size ** 3 / 6.0  # kg: a sphere of diameter size
        self.pos = np.zeros((0, 3))
        self.vel = np.zeros((0, 3))
        self.age = np.zeros(0)

    def add(self, item: np.ndarray) -> None:
        if len(self.age) >= self.max_items:
            if not self.options & PARTICLE_CYCLIC:
                return  # full: V-REP ignores new items of a non-cyclic object
            self.pos, self.vel, self.age = self.pos[1:], self.vel[1:], self.age[1:]
        self.pos = np.vstack([self.pos, item[:3]])
        self.vel = np.vstack([self.vel, item[3:6] - item[:3]])
        self.age = np.append(self.age, 0.0)


class Particles:
    """The scene's particle objects, moved once a step by :meth:`advance` (one per scene's
    scripts, kept in their shared dictionary)."""

    def __init__(self) -> None:
        self.objects: dict[int, _ParticleObject] = {}
        self._next = 1

    def __bool__(self) -> bool:
        return bool(self.objects)

    def count(self) -> int:
        """Particles alive in the scene.

        Returns:
            The count.

        """
        return sum(len(o.age) for o in self.objects.values())

    def create(self, obj: _ParticleObject) -> int:
        """Keep a new particle object.

        Args:
            obj: the object.

        Returns:
            Its handle.

        """
        handle, self._next = self._next, self._next + 1
        self.objects[handle] = obj
        return handle

    def advance(self, world: Any, forces: Any, dt: float) -> int:
        """Move every particle by one step of ``dt`` s; absorbed particles add their push to
        ``forces`` (an :class:`~simx_server.api.sim.forces.AppliedForces`). Returns how
        many hit a body.

        Args:
            world: the scene's :class:`~simx_server.sim.world.World`.
            forces: the forces scripts add for the next step.
            dt: s.

        Returns:
            The count of particles that hit a body.
        """
        m, d = world.model, world.data
        gravity = np.asarray(m.opt.gravity, dtype=float)
        geomid = np.zeros(1, dtype=np.int32)
        hits = 0
        for obj in self.objects.values():
            if not len(obj.age):
                continue
            if not obj.options & PARTICLE_IGNORES_GRAVITY:
                obj.vel = obj.vel + gravity * dt
            keep = np.ones(len(obj.age), dtype=bool)
            if obj.options & PARTICLE_RESPONDABLE:
                for k in range(len(obj.age)):
                    step = obj.vel[k] * dt
                    length = float(np.linalg.norm(step))
                    if length == 0.0:
                        continue
                    dist = mujoco.mj_ray(m, d, obj.pos[k], step / length, None, 1, obj.body, geomid)
                    if 0.0 <= dist <= length and geomid[0] >= 0:
                        body = int(m.geom_bodyid[geomid[0]])
                        keep[k] = False
                        if body == 0 or m.body_weldid[body] == 0:
                            continue  # the world and what is welded to it take no push
                        force = obj.mass * obj.vel[k] / dt
                        point = obj.pos[k] + step / length * dist
                        torque = np.cross(point - d.xipos[body], force)
                        try:
                            forces.add(world, body, force, torque)
                            hits += 1
                        except ArgumentError:
                            pass  # past limits.MAX_SCRIPT_FORCE for this step: that push is lost
            obj.pos = obj.pos + obj.vel * dt
            obj.age = obj.age + dt
            if obj.life > 0:
                keep &= obj.age <= obj.life
            obj.pos, obj.vel, obj.age = obj.pos[keep], obj.vel[keep], obj.age[keep]
        return hits


# ``sim.addParticleObject`` & co.; the registry lives in the scripts' shared
# dictionary, so that the simulation moves it every step.

def _particles(ctx: CallContext) -> Particles:
    me = ctx.script
    shared = me.shared if me is not None else ctx.state.own_shared
    return shared.setdefault("particles", Particles())


@sim_function("addParticleObject")
def addParticleObject(ctx: CallContext, objectType: Any, size: Any, density: Any, params: Any = None,  # noqa: N802, N803
                      lifeTime: Any = 0, maxItemCount: Any = 1000, *colors: Any) -> int:
    """A particle object: ``objectType`` (``sim.particle_*`` bits: respondable, cyclic,
    ignores gravity; the drawing kinds are accepted and not drawn), ``size`` (m, the
    particles' diameter), ``density`` (kg/m^3), ``params`` (ignored: V-REP's engine
    parameters), ``lifeTime`` (s; 0: until the simulation stops), ``maxItemCount`` (1 to
    MAX_ITEMS_PER_OBJECT), colours (not drawn). Returns its handle. Raises ArgumentError.

    ``sim.addParticleObject``.

    Args:
        objectType: ``sim.particle_*`` bits.
        size: m.
        density: kg/m³.
        params: ignored.
        lifeTime: s.
        maxItemCount: 1..MAX_ITEMS_PER_OBJECT.
        *colors: ignored.

    Returns:
        The particle object's handle.

    Raises:
        ArgumentError: values out of range.
    """
    options = _int(objectType, "objectType")
    d, s, life = _num(size, "size"), _num(density, "density"), _num(lifeTime, "lifeTime")
    count = _int(maxItemCount, "maxItemCount")
    if d <= 0 or s <= 0 or life < 0:
        raise ArgumentError("sim.addParticleObject: size and density must be > 0 and lifeTime >= 0")
    if not 1 <= count <= MAX_ITEMS_PER_OBJECT:
        raise ArgumentError(f"sim.addParticleObject: maxItemCount must be 1..{MAX_ITEMS_PER_OBJECT}, got {count}")
    owner = ctx.owner
    world = ctx.world
    body = world.objects[owner].mj_id if owner in world.objects and world.objects[owner].type == 0 else -1
    particles = _particles(ctx)
    if not particles:
        log.info("particle objects: simulated as points pushing the bodies they hit, not drawn (docs/SCRIPTS.md)")
    return particles.create(_ParticleObject(options, d, s, life, count, body))


@sim_function("addParticleObjectItem")
def addParticleObjectItem(ctx: CallContext, objectHandle: Any, itemData: Any) -> None:  # noqa: N802, N803
    """Add a particle to the object: ``itemData`` is a position and the point it would
    reach one second later (6 numbers, m, world frame); nil or an empty table removes all
    of the object's particles. Raises ArgumentError (unknown handle, bad data, or more than
    MAX_PARTICLES particles in the scene).

    ``sim.addParticleObjectItem``.

    Args:
        objectHandle: the particle object's handle.
        itemData: 6 numbers (m), or None / empty.

    Raises:
        ArgumentError: as said above.
    """
    particles = _particles(ctx)
    obj = particles.objects.get(_int(objectHandle, "objectHandle"))
    if obj is None:
        raise ArgumentError(f"sim.addParticleObjectItem: no particle object {objectHandle!r}")
    if itemData is None or (hasattr(itemData, "__len__") and len(itemData) == 0):
        obj.pos, obj.vel, obj.age = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
        return
    values = list(itemData.values()) if hasattr(itemData, "values") else list(itemData)
    if len(values) < 6:
        raise ArgumentError("sim.addParticleObjectItem: itemData needs 6 numbers (a position, then a velocity point)")
    item = np.array([_num(v, "itemData") for v in values[:6]])
    if particles.count() >= MAX_PARTICLES:
        raise ArgumentError(f"sim.addParticleObjectItem: the scene has {MAX_PARTICLES} particles already "
                            "(MAX_PARTICLES of simx_server/api/sim/particles.py)")
    obj.add(item)


@sim_function("removeParticleObject")
def removeParticleObject(ctx: CallContext, objectHandle: Any) -> None:  # noqa: N802, N803
    """Remove a particle object and its particles (``sim.handle_all``: every one). Raises
    ArgumentError for an unknown handle.

    ``sim.removeParticleObject``.

    Args:
        objectHandle: the particle object's handle, or ``sim.handle_all``.

    Raises:
        ArgumentError: no such particle object.
    """
    particles = _particles(ctx)
    h = _int(objectHandle, "objectHandle")
    if h == HANDLE_ALL:
        particles.objects.clear()
    elif particles.objects.pop(h, None) is None:
        raise ArgumentError(f"sim.removeParticleObject: no particle object {h}")


