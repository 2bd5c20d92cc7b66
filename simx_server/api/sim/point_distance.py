"""``sim.checkDistance`` with a dummy: the distance from its origin (a point) to a shape or to
another dummy, as CoppeliaSim measures a dummy (``CDistanceRoutine``: a dummy is a point); and
``sim.checkCollision`` with an object that is not a shape (:func:`not_shapes`).

The distance to a shape is the signed distance field of the shape's geoms
(:func:`simx_server.api.cloud_geometry.shape_sdf`, 0 inside), and the witness point on the
shape the point moved onto the surface along the field's gradient.
"""

from __future__ import annotations

import functools
from typing import Any, Callable

import numpy as np

from simx_server.api import cloud_geometry as geo
from simx_server.api.context import CallContext
from simx_server.api.sim import core as _core
from simx_server.sim import scene_collections
from simx_server.sim.objects import DUMMY, SHAPE
from simx_wire import constants as C


def nothing_for_non_shapes(answer: tuple) -> Callable:
    """A decorator of ``sim.checkCollision`` and ``checkCollisionEx``: ``answer`` (no collision)
    when either entity is a scene object that is not a shape (a dummy, a sensor, a joint), as
    CoppeliaSim 4.1 answers (coppeliaSimLib ``CCollisionRoutine::_doesObjectCollideWithObject``
    tests shapes, octrees and point clouds; a dummy collides with octrees alone, which simx
    keeps as data). Unknown handles still raise UnknownObjectError.

    Args:
        answer: what the function returns then.

    Returns:
        The decorator.
    """
    def wrap(fn: Callable) -> Callable:
        @functools.wraps(fn)
        def call(ctx: CallContext, entity1Handle: Any, entity2Handle: Any) -> Any:  # noqa: N803
            for value, what in ((entity1Handle, "entity1Handle"), (entity2Handle, "entity2Handle")):
                h = ctx.h(value, what)
                if h != C.sim_handle_all and not scene_collections.is_collection(h) and ctx.world.get(h).type != SHAPE:
                    return answer
            return fn(ctx, entity1Handle, entity2Handle)
        return call
    return wrap


def _kind(ctx: CallContext, handle: Any) -> int | None:
    """The object's type when ``handle`` is a dummy or a shape, else None (collections, all)."""
    h = ctx.h(handle, "entity handle")
    if h < 0 or h not in ctx.world.objects:
        return None
    kind = ctx.world.get(h).type
    return kind if kind in (DUMMY, SHAPE) else None


def _to_shape(ctx: CallContext, point: np.ndarray, shape: int) -> tuple[np.ndarray, float]:
    world = ctx.world
    m, d = world.model, world.data
    geoms = np.flatnonzero(m.geom_bodyid == world.get(shape, SHAPE).mj_id)
    dist = float(geo.shape_sdf(m, d, geoms, point[None, :])[0])
    h = 1e-5
    grad = np.array([geo.shape_sdf(m, d, geoms, (point + h * e)[None, :])[0]
                     - geo.shape_sdf(m, d, geoms, (point - h * e)[None, :])[0] for e in np.eye(3)])
    grad /= max(float(np.linalg.norm(grad)), 1e-12)
    return point - dist * grad, max(dist, 0.0)


def measure(ctx: CallContext, entity1: Any, entity2: Any) -> tuple[list[float], float, list[int]] | None:
    """``(witness points (6), distance (m), handles)`` when one entity is a dummy and the other a
    shape or a dummy; None otherwise (the shapes' own routine measures)."""
    k1, k2 = _kind(ctx, entity1), _kind(ctx, entity2)
    if DUMMY not in (k1, k2) or None in (k1, k2):
        return None
    h1, h2 = ctx.h(entity1), ctx.h(entity2)
    p1 = np.asarray(_core.frame_of(ctx, h1)[1], dtype=float)
    p2 = np.asarray(_core.frame_of(ctx, h2)[1], dtype=float)
    if k1 == DUMMY and k2 == DUMMY:
        return [*p1, *p2], float(np.linalg.norm(p2 - p1)), [h1, h2]
    if k1 == DUMMY:
        on, d = _to_shape(ctx, p1, h2)
        return [*p1, *on], d, [h1, h2]
    on, d = _to_shape(ctx, p2, h1)
    return [*on, *p2], d, [h1, h2]
