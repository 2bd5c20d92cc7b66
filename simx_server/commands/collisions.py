"""Collision and distance commands: ``simxCheckCollision``, ``simxCheckDistance``, and the
collision / distance objects a scene declares (``simxGetCollisionHandle``, ``simxReadCollision``,
...). Every handler is ``(simulation, args) -> result``; the geometry is :mod:`simx_server.sim.collisions`.
Every query is a client's: bounded (``mesh_geometry.MAX_QUERY_SECONDS``), and a mesh's tree not
built yet is built off the simulation thread while the door waits
(:class:`~simx_server.sim.mesh_geometry.TreesPending`)."""

from __future__ import annotations

from typing import Any, Callable

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import check_args as _args
from simx_server.scene.simulation import Simulation
from simx_server.sim.collisions import collision, distance, probe_entities, probe_named
from simx_server.sim.mesh_geometry import Work


def _entity_args(sim: Simulation, args: list) -> tuple[int, int]:
    e1, e2 = _args(args, "int", "int")
    if e1 == C.sim_handle_all:
        raise ArgumentError("entity1 must be a shape handle; only entity2 may be sim_handle_all (-2)")
    return e1, e2


def check_collision(sim: Simulation, args: list) -> bool:
    """``simxCheckCollision`` [entity1, entity2] -> bool.

    Entities are shapes (bodies: their colliding geoms, all of them for a shape that has none),
    tested whatever their collidable flag, as V-REP's ``simCheckCollision``; entity2 =
    sim_handle_all (-2) means every other collidable shape (V-REP's flag,
    :mod:`simx_server.sim.properties`) except the parent and child bodies (MuJoCo's parent-child filter). True when two geoms are at most
    COLLISION_TOLERANCE apart (touching or penetrating), by ``mj_geomDistance`` on the current
    poses: unlike ``data.contact`` this sees pairs that MuJoCo's contype/conaffinity, weld and
    exclude filters skip, such as two static bodies.
    """
    return collision(sim, *_entity_args(sim, args), work=Work.client())


def check_distance(sim: Simulation, args: list) -> float:
    """``simxCheckDistance`` [entity1, entity2] -> float: the smallest distance (m) between the
    geoms of two shapes (entity2 may be -2: every measurable shape, as in simxCheckCollision), by
    ``mj_geomDistance``; 0 when they touch or overlap (V-REP reports no penetration depth), at
    most DISTANCE_MAX."""
    return distance(sim, *_entity_args(sim, args), work=Work.client())


def _probe_handle(sim: Simulation, args: list, kind: str) -> int:
    (name,) = _args(args, "str")
    return probe_named(sim, kind, name).handle


def _probe_entities(sim: Simulation, args: list, kind: str) -> tuple[int, int]:
    (h,) = _args(args, "int")
    return probe_entities(sim, kind, h)


def get_collision_handle(sim: Simulation, args: list) -> int:
    """``simxGetCollisionHandle`` [name] -> handle of a collision object declared with
    ``<text name="simx.collision:NAME" data="entity1=BODY entity2=BODY|all"/>`` (own handle
    namespace from 1; a trailing ``#`` is ignored). Unknown name -> UnknownObjectError."""
    return _probe_handle(sim, args, "collision")


def read_collision(sim: Simulation, args: list) -> bool:
    """``simxReadCollision`` [h] -> bool: the collision object's state now (see
    simxCheckCollision; computed on demand from the current poses). Only collidable shapes take
    part, as in V-REP's collision objects (``CCollisionObject_old::handleCollision``)."""
    return collision(sim, *_probe_entities(sim, args, "collision"), override=False, work=Work.client())


def get_distance_handle(sim: Simulation, args: list) -> int:
    """``simxGetDistanceHandle`` [name] -> handle of a distance object declared with
    ``<text name="simx.distance:NAME" data="entity1=BODY entity2=BODY|all"/>``."""
    return _probe_handle(sim, args, "distance")


def read_distance(sim: Simulation, args: list) -> float:
    """``simxReadDistance`` [h] -> float: the distance object's smallest distance now (m; see
    simxCheckDistance). Only measurable shapes take part, as in V-REP's distance objects."""
    return distance(sim, *_probe_entities(sim, args, "distance"), override=False, work=Work.client())


#: Command name -> handler, merged into simx_server.commands.HANDLERS.
COLLISION_HANDLERS: dict[str, Callable[[Simulation, list], Any]] = {
    "GetCollisionHandle": get_collision_handle,
    "ReadCollision": read_collision,
    "GetDistanceHandle": get_distance_handle,
    "ReadDistance": read_distance,
    "CheckCollision": check_collision,
    "CheckDistance": check_distance,
}


#: Command name -> number of leading arguments that identify it (for protocol.COMMANDS).
COLLISION_IDENTITY_ARITY: dict[str, int] = {
    "GetCollisionHandle": 1,
    "ReadCollision": 1,
    "GetDistanceHandle": 1,
    "ReadDistance": 1,
    "CheckCollision": 2,
    "CheckDistance": 2,
}




