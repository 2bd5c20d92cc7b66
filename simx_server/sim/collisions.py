"""Collision and distance: simxCheckCollision/Distance and the declared collision and
distance objects (simxGetCollisionHandle, simxReadCollision, simxGetDistanceHandle,
simxReadDistance), as V-REP's legacy remote API has them.

* collision / distance between the geoms of shapes (bodies): on the triangles of a mesh geom
  with coal (:mod:`simx_server.sim.mesh_geometry`; V-REP and CoppeliaSim test the meshes, not
  their convex hulls), ``mj_geomDistance`` between two primitives; independent
  of MuJoCo's contact filtering, so static bodies and excluded pairs are measured too. Which
  shapes take part follows V-REP's collidable / measurable flags, not physical contact
  (:mod:`simx_server.sim.properties`): a shape named explicitly is always tested, the members of
  a collection and "everything else" only when they have the flag.
* collision and distance objects are declared in the scene::

      <custom>
        <text name="simx.collision:NAME" data="entity1=BODY entity2=BODY"/>
        <text name="simx.distance:NAME" data="entity1=BODY entity2=all"/>
      </custom>

  ``entity2`` may be ``all`` (or left out): every other collidable shape; an entity
  ``collection:NAME`` is a declared collection (``simx:collection:NAME``). A declared object
  tests only shapes that have the flag, even the ones it names, as V-REP's collision and
  distance objects do. Handles of collision objects and of distance objects are two namespaces
  of their own, each from 1 in text order. A converted ``.ttt`` declares its own (V-REP's
  ``COL`` / ``DST`` records, :mod:`simx_server.scene.ttt.measurements`).

The command handlers are in :mod:`simx_server.commands.collisions`; poses are those of the last ``mj_forward``.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ObjectTypeError, UnknownObjectError, UnsupportedError
from simx_server.sim import mesh_geometry, properties, scene_collections
from simx_server.sim.mesh_geometry import UNBOUNDED, Work
from simx_server.sim.objects import text_at
from simx_server.sim.state import SimulationView
from simx_server.sim.world import _TYPE_NAMES, SHAPE, World, parse_settings

_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)

#: Signed distance (m) at or below which two geoms are in collision (touching counts).
COLLISION_TOLERANCE = 1e-6
#: Largest distance (m) CheckDistance / ReadDistance report; farther is reported as this.
DISTANCE_MAX = 1000.0


@dataclasses.dataclass
class Probe:
    """A declared collision or distance object."""

    handle: int
    name: str
    entity1: str | None
    entity2: str | None  # None: everything else (sim_handle_all)
    error: str | None  # why the declaration cannot be used, if it cannot


# ------------------------------------------------------------ collision, distance
def collidable(m: mujoco.MjModel) -> np.ndarray:
    """Mask (ngeom,) of the geoms that can collide: contype or conaffinity not 0.

    Args:
        m: the MuJoCo model.

    Returns:
        Boolean array of shape (ngeom,).
    """
    return (m.geom_contype != 0) | (m.geom_conaffinity != 0)


def _entity_geoms(world: World, handle: int, what: str, bit: int, override: bool) -> tuple[np.ndarray, list[int]]:
    """The geoms of a shape or of a collection's shapes that take part, and their bodies.

    V-REP's rule (coppeliaSimLib ``CCollisionRoutine::doEntitiesCollide``,
    ``CDistanceRoutine::getDistanceBetweenEntitiesIfSmaller``): a shape named explicitly is tested
    whatever its collidable / measurable flag when ``override`` (``sim.checkCollision``,
    ``sim.checkDistance``); a collection's members, and every shape of a declared collision or
    distance object (``override`` False), only when they have the flag ``bit``
    (:mod:`simx_server.sim.properties`). Empty when nothing takes part."""
    m = world.model
    if scene_collections.is_collection(handle):
        members = scene_collections.of(world).present(handle)
        bodies = [world.objects[h].mj_id for h in members if world.objects[h].type == SHAPE]
        flagged = properties.geom_mask(world, bit)
        geoms = np.flatnonzero(np.isin(m.geom_bodyid, bodies) & flagged)
        return geoms, bodies
    obj = world.get(handle)
    if obj.type != SHAPE:
        raise ObjectTypeError(f"{what}: object {obj.name!r} (handle {handle}) is a "
                              f"{_TYPE_NAMES.get(obj.type, 'object')}; collision and distance work on shapes (bodies) "
                              "and collections")
    geoms = properties.shape_geoms(m, obj.mj_id)
    if geoms.size == 0:
        raise ObjectTypeError(f"{what}: shape {obj.name!r} has no geom, so it cannot collide nor be measured")
    if not override and not properties.cumulative(world, handle) & bit:
        geoms = geoms[:0]
    return geoms, [obj.mj_id]


def _others(world: World, bodies: list[int], bit: int) -> np.ndarray:
    """Geoms of every shape with the flag ``bit`` (and the world body's colliding geoms) but
    ``bodies``; for a single body also but its parent and its children (MuJoCo's parent-child
    filter; the world body is never filtered)."""
    m = world.model
    gb = m.geom_bodyid
    keep = properties.geom_mask(world, bit) & ~np.isin(gb, bodies)
    if len(bodies) == 1 and not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        body = bodies[0]
        parent = int(m.body_parentid[body])
        if parent != 0:
            keep &= gb != parent
        keep &= ~((m.body_parentid[gb] == body) & (gb != 0))
    return np.flatnonzero(keep)


def _pairs(world: World, e1: int, e2: int, bit: int = properties.COLLIDABLE, override: bool = True) -> tuple[np.ndarray, np.ndarray]:
    g1, bodies = _entity_geoms(world, e1, "entity1", bit, override)
    if e2 == C.sim_handle_all:
        g2 = _others(world, bodies, bit)
    elif e2 == e1:  # a shape never collides with itself; a collection's members with one another
        g2 = g1
    else:
        g2, _ = _entity_geoms(world, e2, "entity2", bit, override)
    a, b = np.meshgrid(g1, g2, indexing="ij")
    a, b = a.ravel(), b.ravel()
    m = world.model
    keep = ~((m.geom_type[a] == _PLANE) & (m.geom_type[b] == _PLANE)) & (a != b)
    if e2 == e1:  # each pair of two different shapes once (CCollisionRoutine::_doesGroupCollideWithItself)
        keep &= (a < b) & (m.geom_bodyid[a] != m.geom_bodyid[b])
    return a[keep], b[keep]


def _lower_bounds(world: World, a: np.ndarray, b: np.ndarray, data: mujoco.MjData | None = None) -> np.ndarray:
    """Lower bound of each pair's distance from bounding spheres (-inf with a plane), at the poses
    of ``data`` (default: the world's)."""
    m, d = world.model, world.data if data is None else data
    lb = np.linalg.norm(d.geom_xpos[a] - d.geom_xpos[b], axis=1) - m.geom_rbound[a] - m.geom_rbound[b]
    lb[(m.geom_type[a] == _PLANE) | (m.geom_type[b] == _PLANE)] = -np.inf
    return lb


def _geom_distance(world: World, g1: int, g2: int, distmax: float, data: mujoco.MjData | None = None,
                   fromto: np.ndarray | None = None, work: Work = UNBOUNDED) -> float:
    """Distance (m, negative when they overlap) between two geoms at the poses of ``data``
    (default: the world's): on the triangles with coal when one is a mesh
    (:mod:`simx_server.sim.mesh_geometry`: what lies beyond ``distmax`` is not measured), else
    ``mj_geomDistance`` (``distmax`` caps it)."""
    m, d = world.model, world.data if data is None else data
    if mesh_geometry.handles(m, g1, g2):
        return mesh_geometry.distance(m, d, int(g1), int(g2), fromto, work, distmax)
    try:
        return float(mujoco.mj_geomDistance(m, d, int(g1), int(g2), distmax, fromto))
    except Exception as exc:  # mju_error for a geom pair MuJoCo has no distance function for
        names = [mujoco.mjtGeom(int(m.geom_type[g])).name for g in (g1, g2)]
        raise UnsupportedError(f"MuJoCo cannot measure the distance between a {names[0]} and a "
                               f"{names[1]} geom: {exc}") from None


def collision(sim: SimulationView, e1: int, e2: int, override: bool = True, work: Work = UNBOUNDED) -> bool:
    """Whether shape ``e1`` touches or overlaps shape ``e2`` (or anything else, ``e2`` = -2).

    Implements ``simxReadCollision`` (V-REP's ``simCheckCollision``): geom pairs whose bounding
    spheres come within COLLISION_TOLERANCE are tested on their triangles (a mesh, with coal) or
    with ``mj_geomDistance`` (two primitives).

    Args:
        sim: the simulation.
        e1: handle of a shape or a collection.
        e2: handle of another shape or collection, or ``sim_handle_all`` (-2): every collidable
            shape but ``e1`` (and, for a single body, its parent and children). ``e1`` itself:
            a shape never collides with itself (False), a collection's shapes are tested against
            one another (coppeliaSimLib 4.1 ``CCollisionRoutine::doEntitiesCollide``).
        override: test the shapes named explicitly whatever their collidable flag (V-REP's
            ``simCheckCollision``); False for a declared collision object.
        work: the query's bound (:class:`~simx_server.sim.mesh_geometry.Work`; default none).

    Returns:
        True when some geom pair is within COLLISION_TOLERANCE (m) of touching.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape or collection, or a shape without geoms.
        UnsupportedError: MuJoCo has no distance function for a pair of geom types.
        ArgumentError: past the work's bound (``mesh_geometry.MAX_QUERY_SECONDS``).
        TreesPending: a mesh's tree is being built (a client's query, ``work.defer``).
    """
    world = sim.world
    return pairs_collide(world, *_pairs(world, e1, e2, properties.COLLIDABLE, override), work=work)


def collision_pairs(world: World, e1: int, e2: int) -> tuple[np.ndarray, np.ndarray]:
    """The geom pairs that :func:`collision` of ``e1`` and ``e2`` tests (the shapes' collidable
    flags as they are now), for :func:`pairs_collide` at other poses.

    Args:
        world: the scene.
        e1: handle of a shape or a collection.
        e2: handle of another shape or collection, or ``sim_handle_all`` (-2).

    Returns:
        ``(a, b)``: geom ids, (k,) each.

    Raises:
        UnknownObjectError, ObjectTypeError, ArgumentError: as :func:`collision`.
    """
    return _pairs(world, e1, e2, properties.COLLIDABLE, True)


def pairs_collide(world: World, a: np.ndarray, b: np.ndarray, data: mujoco.MjData | None = None,
                  work: Work = UNBOUNDED) -> bool:
    """Whether some geom pair touches or overlaps.

    Args:
        world: the scene (its model).
        a: (k,) geom ids.
        b: (k,) geom ids, ``b[i]`` paired with ``a[i]``.
        data: whose poses (default: the world's; a scratch MjData after ``mj_kinematics`` tests
            a configuration without touching the simulation).
        work: the query's bound (:class:`~simx_server.sim.mesh_geometry.Work`; default none).

    Returns:
        True when some pair is within COLLISION_TOLERANCE (m) of touching.

    Raises:
        ArgumentError: past the work's bound (``mesh_geometry.MAX_QUERY_SECONDS``).
        TreesPending: a mesh's tree is being built (``work.defer``).
    """
    lb = _lower_bounds(world, a, b, data)
    close = np.flatnonzero(lb <= COLLISION_TOLERANCE)
    close = close[np.argsort(lb[close], kind="stable")]  # the deepest overlaps of spheres first
    if not close.size:
        return False
    # a pair with a mesh: its triangles touch or intersect (coal; no tolerance: it costs 40 %),
    # each geom's coal transform made once for all its pairs (a planner's state check tests some
    # fifty pairs of a few geoms); two primitives: within COLLISION_TOLERANCE (_geom_distance)
    m = world.model
    ga, gb = a[close], b[close]
    touching = mesh_geometry.Touching(m, world.data if data is None else data, 0.0, work)
    for g1, g2, by_coal in zip(ga.tolist(), gb.tolist(), mesh_geometry.handled(m, ga, gb).tolist()):
        if by_coal:
            if touching(g1, g2):
                return True
        elif _geom_distance(world, g1, g2, 2 * COLLISION_TOLERANCE, data) <= COLLISION_TOLERANCE:
            return True
    return False


def distance(sim: SimulationView, e1: int, e2: int, override: bool = True, work: Work = UNBOUNDED) -> float:
    """Smallest distance (m, >= 0, at most DISTANCE_MAX) between shape ``e1`` and ``e2``.

    Implements ``simxReadDistance`` (V-REP's ``simCheckDistance``): the geom pairs' distances
    (a mesh's triangles with coal, ``mj_geomDistance`` between primitives), nearest bounding
    spheres first.

    Args:
        sim: the simulation.
        e1: handle of a shape or a collection.
        e2: handle of another shape or collection, or ``sim_handle_all`` (-2).
        override: measure the shapes named explicitly whatever their measurable flag (V-REP's
            ``simCheckDistance``); False for a declared distance object.
        work: the query's bound (:class:`~simx_server.sim.mesh_geometry.Work`; default none).

    Returns:
        The distance in m (0 when they touch or overlap).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape or collection, or a shape without geoms.
        ArgumentError: no measurable shape to measure to (``e1`` and ``e2`` the same shape
            too); past the work's bound (``mesh_geometry.MAX_QUERY_SECONDS``).
        UnsupportedError: MuJoCo has no distance function for a pair of geom types.
        TreesPending: a mesh's tree is being built (``work.defer``).
    """
    a, b = _pairs(sim.world, e1, e2, properties.MEASURABLE, override)
    if a.size == 0:
        raise ArgumentError("there is no measurable shape to measure the distance to (V-REP's measurable "
                            "flag, sim.setObjectSpecialProperty)")
    return closest(sim.world, a, b, work)[0]


def closest(world: World, a: np.ndarray, b: np.ndarray, work: Work = UNBOUNDED) -> tuple[float, int, np.ndarray]:
    """The nearest of the geom pairs at the world's poses (``sim.checkDistance``'s search).

    Args:
        world: the scene.
        a: (k,) geom ids, k >= 1.
        b: (k,) geom ids, ``b[i]`` paired with ``a[i]``.
        work: the query's bound (:class:`~simx_server.sim.mesh_geometry.Work`; default none).

    Returns:
        ``(distance, i, fromto)``: the distance (m, >= 0, at most DISTANCE_MAX), the index of
        the nearest pair (0 when none is nearer than DISTANCE_MAX), and its nearest points
        (6,) (m, world; zeros when none).

    Raises:
        UnsupportedError: MuJoCo has no distance function for a pair of geom types.
        ArgumentError: past the work's bound (``mesh_geometry.MAX_QUERY_SECONDS``).
        TreesPending: a mesh's tree is being built (``work.defer``).
    """
    lb = _lower_bounds(world, a, b)
    best, nearest, fromto, scratch = DISTANCE_MAX, 0, np.zeros(6), np.zeros(6)
    for i in np.argsort(lb, kind="stable"):
        if lb[i] >= best:
            break
        d = _geom_distance(world, a[i], b[i], best, fromto=scratch, work=work)
        if d < best:
            best, nearest, fromto = d, int(i), scratch.copy()
    return max(0.0, best), nearest, fromto


PROBE_PREFIX = {"collision": "simx.collision:", "distance": "simx.distance:"}
COLLECTION_ENTITY = "collection:"  # an entity that names a declared collection


def probe_named(sim: SimulationView, kind: str, name: str) -> Probe:
    """The declared collision or distance object ``name`` (a trailing ``#`` ignored, as V-REP's
    ``simGetCollisionHandle`` / ``simGetDistanceHandle``).

    Args:
        sim: the simulation.
        kind: ``"collision"`` or ``"distance"``.
        name: the object's name.

    Returns:
        The probe.

    Raises:
        UnknownObjectError: no such object, naming the scene and how to declare one.
    """
    probe = probes(sim, kind).get(name[:-1] if name.endswith("#") else name)
    if probe is None:
        raise UnknownObjectError(f"no {kind} object {name!r} in scene {sim.world.scene_name}; declare "
                                 f"it as <text name=\"{PROBE_PREFIX[kind]}{name}\" "
                                 f"data=\"entity1=BODY entity2=BODY|all\"/> in <custom>")
    return probe


def probe_entities(sim: SimulationView, kind: str, handle: int) -> tuple[int, int]:
    """The two entities (shape or collection handles; entity2 ``sim_handle_all`` for "all other
    objects") of the collision or distance object ``handle``.

    Args:
        sim: the simulation.
        kind: ``"collision"`` or ``"distance"``.
        handle: the object's handle (its own namespace, from 1).

    Returns:
        ``(entity1, entity2)``.

    Raises:
        UnknownObjectError: no such object, or an entity that names nothing in the scene.
        ArgumentError: the declaration cannot be used (its error).
    """
    probe = next((p for p in probes(sim, kind).values() if p.handle == handle), None)
    if probe is None:
        raise UnknownObjectError(f"no {kind} object with handle {handle}")
    if probe.error:
        raise ArgumentError(probe.error)
    world = sim.world

    def entity(text: str) -> int:
        if text.startswith(COLLECTION_ENTITY):
            return scene_collections.of(world).handle(text[len(COLLECTION_ENTITY):])
        return world.resolve(text).handle

    try:
        e1 = entity(probe.entity1)
        e2 = C.sim_handle_all if probe.entity2 is None else entity(probe.entity2)
    except UnknownObjectError as exc:
        raise UnknownObjectError(f"{kind} object {probe.name!r}: {exc}") from None
    return e1, e2


def probes(sim: SimulationView, kind: str) -> dict[str, Probe]:
    """The declared collision or distance objects, read from the model's custom texts.

    Read again only when the model changed; each name keeps its handle for the simulation's life
    (``simxGetCollisionHandle`` / ``simxGetDistanceHandle``).

    Args:
        sim: the simulation (its ``sensors`` keep the probes).
        kind: ``"collision"`` or ``"distance"``.

    Returns:
        Name -> :class:`Probe`; a declaration that cannot be used has its ``error`` set.
    """
    st, m = sim.sensors, sim.world.model
    if st.probes_model is not m:
        st.probes = {k: {} for k in PROBE_PREFIX}
        for i in range(m.ntext):
            tname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXT, i) or ""
            for k, prefix in PROBE_PREFIX.items():
                if not tname.startswith(prefix) or not tname[len(prefix):]:
                    continue
                name = tname[len(prefix):]
                raw = text_at(m, i)
                handles = st.probe_handles[k]
                handle = handles.setdefault(name, len(handles) + 1)
                e1 = e2 = error = None
                try:
                    settings = parse_settings(raw)
                    unknown = set(settings) - {"entity1", "entity2"}
                    if unknown:
                        raise ValueError(f"unknown keys {sorted(unknown)}; use entity1= and entity2=")
                    if "entity1" not in settings:
                        raise ValueError("entity1= is missing")
                    e1 = settings["entity1"]
                    e2 = settings.get("entity2", "all")
                    e2 = None if e2 == "all" else e2
                except ValueError as exc:
                    error = f"custom text {tname!r} ({raw!r}): {exc}"
                st.probes[k][name] = Probe(handle, name, e1, e2, error)
        st.probes_model = m
    return st.probes[kind]


