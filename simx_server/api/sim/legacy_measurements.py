"""V-REP 3.x's collision and distance objects in scripts: ``simGetCollisionHandle``,
``simHandleCollision``, ``simReadCollision``, ``simResetCollision`` and the distance twins
(CoppeliaSim keeps them as ``sim.getCollisionHandle``... until 4.1; ``_simHandleCollision``,
``_simReadDistance``... in its ``luaScriptFunctions-old.cpp``).

The objects are the scene's declared ones (:func:`simx_server.sim.collisions.probes`: a
converted ``.ttt``'s ``COL``/``DST`` records). simx measures when asked, so *handle* and *read*
give the same answer, from the current poses; a reset has nothing to clear.
"""

from __future__ import annotations

from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.mesh_waits import query_work
from simx_wire import constants as C
from simx_server.base.arguments import as_integer as _int, as_text as _text
from simx_server.sim import collisions

_ALL = (C.sim_handle_all, C.sim_handle_all_except_explicit)


# Collision and distance objects.

@sim_function("getCollisionHandle")
def getCollisionHandle(ctx: CallContext, collisionObjectName: Any) -> int:  # noqa: N802, N803
    """The handle of the scene's collision object ``collisionObjectName`` (``#`` ignored).

    ``simGetCollisionHandle``.

    Args:
        collisionObjectName: its name.

    Returns:
        Its handle (collision objects' own namespace, from 1).

    Raises:
        UnknownObjectError: no such collision object.
    """
    return collisions.probe_named(ctx.simulation("getCollisionHandle"), "collision",
                                  _text(collisionObjectName, "collisionObjectName")).handle


@sim_function("getDistanceHandle")
def getDistanceHandle(ctx: CallContext, distanceObjectName: Any) -> int:  # noqa: N802, N803
    """The handle of the scene's distance object ``distanceObjectName`` (``#`` ignored).

    ``simGetDistanceHandle``.

    Args:
        distanceObjectName: its name.

    Returns:
        Its handle (distance objects' own namespace, from 1).

    Raises:
        UnknownObjectError: no such distance object.
    """
    return collisions.probe_named(ctx.simulation("getDistanceHandle"), "distance",
                                  _text(distanceObjectName, "distanceObjectName")).handle


def _measured(ctx: CallContext, kind: str, what: str, handle: Any) -> list[int]:
    h = _int(handle, what)
    sim = ctx.simulation(what)
    if h in _ALL:
        return [p.handle for p in collisions.probes(sim, kind).values() if not p.error]
    return [h]


@sim_function("handleCollision")
def handleCollision(ctx: CallContext, collisionObjectHandle: Any) -> Any:  # noqa: N802, N803
    """Test collision object ``collisionObjectHandle`` now: ``1, {shape1, shape2}`` when its
    entities touch, else 0; with ``sim.handle_all`` (or ``..._all_except_explicit``): how
    many of the scene's collision objects collide.

    ``simHandleCollision``.

    Args:
        collisionObjectHandle: a collision object's handle, or ``sim.handle_all``.

    Returns:
        ``(1, [h1, h2])`` or 0 for one object; the count for all.

    Raises:
        UnknownObjectError: no such collision object, or an entity not in the scene.
        ObjectTypeError: an entity that is not a shape or collection, or has no collidable geom.
    """
    handles = _measured(ctx, "collision", "handleCollision", collisionObjectHandle)
    sim = ctx.simulation("handleCollision")
    results = []
    for h in handles:  # a collision object tests collidable shapes only (override off, as V-REP's)
        e1, e2 = collisions.probe_entities(sim, "collision", h)
        results.append(ctx.sim.checkCollision(e1, e2) if collisions.collision(sim, e1, e2, False, query_work(ctx))
                       else (0, [-1, -1]))
    if _int(collisionObjectHandle, "collisionObjectHandle") in _ALL:
        return sum(1 for r, _ in results if r)
    result, pair = results[0]
    return (1, pair) if result else 0


@sim_function("readCollision")
def readCollision(ctx: CallContext, collisionObjectHandle: Any) -> Any:  # noqa: N802, N803
    """The state of collision object ``collisionObjectHandle``: ``1, {shape1, shape2}`` when
    its entities touch, else 0 (measured now, as :func:`handleCollision`).

    ``simReadCollision``.

    Args:
        collisionObjectHandle: a collision object's handle.

    Returns:
        ``(1, [h1, h2])`` or 0.

    Raises:
        UnknownObjectError: no such collision object, or an entity not in the scene.
    """
    return handleCollision(ctx, _int(collisionObjectHandle, "collisionObjectHandle"))


@sim_function("handleDistance")
def handleDistance(ctx: CallContext, distanceObjectHandle: Any) -> Any:  # noqa: N802, N803
    """Measure distance object ``distanceObjectHandle`` now: ``1, distance`` (m, 0 when its
    entities touch); with ``sim.handle_all``: the number of distance objects measured.

    ``simHandleDistance``.

    Args:
        distanceObjectHandle: a distance object's handle, or ``sim.handle_all``.

    Returns:
        ``(1, d)`` for one object; the count for all.

    Raises:
        UnknownObjectError: no such distance object, or an entity not in the scene.
        ObjectTypeError: an entity that is not a shape or collection, or has no collidable geom.
    """
    handles = _measured(ctx, "distance", "handleDistance", distanceObjectHandle)
    sim = ctx.simulation("handleDistance")
    values = [collisions.distance(sim, *collisions.probe_entities(sim, "distance", h), False, query_work(ctx))
              for h in handles]  # measurable shapes only, as V-REP's distance objects
    if _int(distanceObjectHandle, "distanceObjectHandle") in _ALL:
        return len(values)
    return 1, values[0]


@sim_function("readDistance")
def readDistance(ctx: CallContext, distanceObjectHandle: Any) -> Any:  # noqa: N802, N803
    """``1, distance`` (m) of distance object ``distanceObjectHandle``, measured now.

    ``simReadDistance``.

    Args:
        distanceObjectHandle: a distance object's handle.

    Returns:
        ``(1, d)``.

    Raises:
        UnknownObjectError: no such distance object, or an entity not in the scene.
    """
    return handleDistance(ctx, _int(distanceObjectHandle, "distanceObjectHandle"))


@sim_function("resetCollision")
def resetCollision(ctx: CallContext, collisionObjectHandle: Any) -> int:  # noqa: N802, N803
    """Nothing to clear (simx keeps no collision result between calls); returns 1.

    ``simResetCollision``.

    Args:
        collisionObjectHandle: a collision object's handle, or ``sim.handle_all``.

    Returns:
        1.

    Raises:
        ArgumentError: not an integer.
    """
    _int(collisionObjectHandle, "collisionObjectHandle")
    return 1


@sim_function("resetDistance")
def resetDistance(ctx: CallContext, distanceObjectHandle: Any) -> int:  # noqa: N802, N803
    """Nothing to clear (simx keeps no distance result between calls); returns 1.

    ``simResetDistance``.

    Args:
        distanceObjectHandle: a distance object's handle, or ``sim.handle_all``.

    Returns:
        1.

    Raises:
        ArgumentError: not an integer.
    """
    _int(distanceObjectHandle, "distanceObjectHandle")
    return 1


