"""``sim.checkDistance`` with a dummy: the distance from its origin (a point) to a shape or to
another dummy, as CoppeliaSim measures a dummy (``CDistanceRoutine``: a dummy is a point).

The distance to a shape is the signed distance field of the shape's geoms
(:func:`simx_server.api.cloud_geometry.shape_sdf`, 0 inside), and the witness point on the
shape the point moved onto the surface along the field's gradient.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api import cloud_geometry as geo
from simx_server.api.context import CallContext
from simx_server.api.sim import core as _core
from simx_server.sim.objects import DUMMY, SHAPE


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
