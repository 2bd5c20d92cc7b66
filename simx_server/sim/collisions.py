"""Collision and distance: simxCheckCollision/Distance and the declared collision and
distance objects (simxGetCollisionHandle, simxReadCollision, simxGetDistanceHandle,
simxReadDistance), as V-REP's legacy remote API has them.

* collision / distance = ``mj_geomDistance`` between the collidable geoms (``contype`` or
  ``conaffinity`` not 0) of shapes (bodies), independent of MuJoCo's contact filtering, so
  static bodies and excluded pairs are measured too.
* collision and distance objects are declared in the scene::

      <custom>
        <text name="simx.collision:NAME" data="entity1=BODY entity2=BODY"/>
        <text name="simx.distance:NAME" data="entity1=BODY entity2=all"/>
      </custom>

  ``entity2`` may be ``all`` (or left out): every other collidable geom; an entity
  ``collection:NAME`` is a declared collection (``simx:collection:NAME``). Handles of collision
  objects and of distance objects are two namespaces of their own, each from 1 in text order. A
  converted ``.ttt`` declares its own (V-REP's ``COL`` / ``DST`` records,
  :mod:`simx_server.scene.ttt.measurements`).

The command handlers are in :mod:`simx_server.commands.collisions`; poses are those of the last ``mj_forward``.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ObjectTypeError, UnknownObjectError, UnsupportedError
from simx_server.sim import scene_collections
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


def _entity_geoms(world: World, handle: int, what: str) -> tuple[np.ndarray, list[int]]:
    """The collidable geoms of a shape or of a collection's shapes, and their bodies."""
    m = world.model
    if scene_collections.is_collection(handle):
        members = scene_collections.of(world).present(handle)
        bodies = [world.objects[h].mj_id for h in members if world.objects[h].type == SHAPE]
        geoms = np.flatnonzero(np.isin(m.geom_bodyid, bodies) & collidable(m))
        if geoms.size == 0:
            raise ObjectTypeError(f"{what}: collection {handle} has no shape with a collidable geom")
        return geoms, bodies
    obj = world.get(handle)
    if obj.type != SHAPE:
        raise ObjectTypeError(f"{what}: object {obj.name!r} (handle {handle}) is a "
                              f"{_TYPE_NAMES.get(obj.type, 'object')}; collision and distance work on shapes (bodies) "
                              "and collections")
    geoms = np.flatnonzero((m.geom_bodyid == obj.mj_id) & collidable(m))
    if geoms.size == 0:
        raise ObjectTypeError(f"{what}: shape {obj.name!r} has no collidable geom (all have contype=0 "
                              "and conaffinity=0), so it cannot collide nor be measured")
    return geoms, [obj.mj_id]


def _others(world: World, bodies: list[int]) -> np.ndarray:
    """Collidable geoms of every body but ``bodies``; for a single body also but its parent and
    its children (MuJoCo's parent-child filter; the world body is never filtered)."""
    m = world.model
    gb = m.geom_bodyid
    keep = collidable(m) & ~np.isin(gb, bodies)
    if len(bodies) == 1 and not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        body = bodies[0]
        parent = int(m.body_parentid[body])
        if parent != 0:
            keep &= gb != parent
        keep &= ~((m.body_parentid[gb] == body) & (gb != 0))
    return np.flatnonzero(keep)


def _pairs(world: World, e1: int, e2: int) -> tuple[np.ndarray, np.ndarray]:
    g1, bodies = _entity_geoms(world, e1, "entity1")
    if e2 == C.sim_handle_all:
        g2 = _others(world, bodies)
    else:
        g2, _ = _entity_geoms(world, e2, "entity2")
        if e2 == e1:
            raise ArgumentError("entity1 and entity2 are the same; pass sim_handle_all (-2) "
                                "as entity2 to test it against everything else")
    a, b = np.meshgrid(g1, g2, indexing="ij")
    a, b = a.ravel(), b.ravel()
    m = world.model
    keep = ~((m.geom_type[a] == _PLANE) & (m.geom_type[b] == _PLANE)) & (a != b)
    return a[keep], b[keep]


def _lower_bounds(world: World, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Lower bound of each pair's distance from bounding spheres (-inf with a plane)."""
    m, d = world.model, world.data
    lb = np.linalg.norm(d.geom_xpos[a] - d.geom_xpos[b], axis=1) - m.geom_rbound[a] - m.geom_rbound[b]
    lb[(m.geom_type[a] == _PLANE) | (m.geom_type[b] == _PLANE)] = -np.inf
    return lb


def _geom_distance(world: World, g1: int, g2: int, distmax: float) -> float:
    try:
        return float(mujoco.mj_geomDistance(world.model, world.data, int(g1), int(g2), distmax, None))
    except Exception as exc:  # mju_error for a geom pair MuJoCo has no distance function for
        m = world.model
        names = [mujoco.mjtGeom(int(m.geom_type[g])).name for g in (g1, g2)]
        raise UnsupportedError(f"MuJoCo cannot measure the distance between a {names[0]} and a "
                               f"{names[1]} geom: {exc}") from None


def collision(sim: SimulationView, e1: int, e2: int) -> bool:
    """Whether shape ``e1`` touches or overlaps shape ``e2`` (or anything else, ``e2`` = -2).

    Implements ``simxReadCollision`` (V-REP's ``simCheckCollision``): geom pairs whose bounding
    spheres come within COLLISION_TOLERANCE are measured with ``mj_geomDistance``.

    Args:
        sim: the simulation.
        e1: handle of a shape or a collection.
        e2: handle of another shape or collection, or ``sim_handle_all`` (-2): every collidable
            geom but ``e1``'s (and, for a single body, its parent's and children's).

    Returns:
        True when some geom pair is within COLLISION_TOLERANCE (m) of touching.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape or collection, or one without a collidable geom.
        ArgumentError: ``e1`` and ``e2`` are the same.
        UnsupportedError: MuJoCo has no distance function for a pair of geom types.
    """
    world = sim.world
    a, b = _pairs(world, e1, e2)
    close = _lower_bounds(world, a, b) <= COLLISION_TOLERANCE
    return any(_geom_distance(world, g1, g2, 2 * COLLISION_TOLERANCE) <= COLLISION_TOLERANCE
               for g1, g2 in zip(a[close], b[close]))


def distance(sim: SimulationView, e1: int, e2: int) -> float:
    """Smallest distance (m, >= 0, at most DISTANCE_MAX) between shape ``e1`` and ``e2``.

    Implements ``simxReadDistance`` (V-REP's ``simCheckDistance``): ``mj_geomDistance`` over the
    geom pairs, nearest bounding spheres first.

    Args:
        sim: the simulation.
        e1: handle of a shape or a collection.
        e2: handle of another shape or collection, or ``sim_handle_all`` (-2).

    Returns:
        The distance in m (0 when they touch or overlap).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape or collection, or one without a collidable geom.
        ArgumentError: ``e1`` and ``e2`` are the same, or no collidable geom to measure to.
        UnsupportedError: MuJoCo has no distance function for a pair of geom types.
    """
    world = sim.world
    a, b = _pairs(world, e1, e2)
    if a.size == 0:
        raise ArgumentError("there is no collidable geom to measure the distance to")
    lb = _lower_bounds(world, a, b)
    best = DISTANCE_MAX
    for i in np.argsort(lb, kind="stable"):
        if lb[i] >= best:
            break
        best = min(best, _geom_distance(world, a[i], b[i], best))
    return max(0.0, best)


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
                adr, size = m.text_adr[i], m.text_size[i]
                raw = bytes(m.text_data[adr:adr + size - 1]).decode()
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


