"""CoppeliaSim 4.x's ``sim.checkVisionSensorEx`` and ``sim.checkProximitySensorEx2``. Dummy links
(``sim.getLinkDummy`` / ``sim.setLinkDummy``: the scene's equalities between two dummies' sites) are
in :mod:`simx_server.api.sim.legacy_objects`.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import sensing as _sensing
from simx_server.api.sim import sensors as _sensors
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.sim import proximity
from simx_server.sim.objects import PROXIMITY_SENSOR

HANDLE_ALL, MAX_ITEMS = -2, 100_000
#: Ray-triangle tests of one ``checkProximitySensorEx2`` (rays x triangles): beyond, refused
#: before any; 4,000,000 held the simulation thread 7.1 s and took 450 MB (issue 84).
MAX_TESTS = 1 << 20
#: Tests made at once (a piece of the triangles against every ray): the working arrays stay
#: within some 10 MB whatever the call.
_PIECE_TESTS = 1 << 16


# Vision and proximity sensor checks of CoppeliaSim 4.x.

@sim_function("checkVisionSensorEx")
def checkVisionSensorEx(ctx: CallContext, sensorHandle: Any, entityHandle: Any, returnImage: Any) -> list[float]:  # noqa: N802, N803
    """The sensor's image now: RGB values 0..1 (``returnImage`` true) or its depth 0..1 (near
    to far), rows bottom-up, of the world's state now (a sensor with explicit handling keeps
    its last handling for the reads after: ``CVisionSensor::checkSensorEx``). simx renders the
    whole scene: ``entityHandle`` must be ``sim.handle_all`` (an object alone: UnsupportedError).

    ``sim.checkVisionSensorEx``.

    Args:
        sensorHandle: a vision sensor's handle.
        entityHandle: ``sim.handle_all``.
        returnImage: true: RGB, false: depth.

    Returns:
        w*h*3 (or w*h) floats in 0..1.

    Raises:
        UnsupportedError: one entity, or no simulation behind the script.
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
    """
    e = ctx.h(entityHandle, "entityHandle")
    if e != HANDLE_ALL:
        ctx.world.get(e)
        raise UnsupportedError("checkVisionSensorEx of one entity: simx's sensors render the whole scene "
                               "(pass sim.handle_all)")
    h = _sensing.vision_of(ctx, sensorHandle)
    with ctx.simulation("checkVisionSensorEx").vision.current(h):
        if returnImage:
            image = _sensors.image_job(ctx, "checkVisionSensorEx", h, False)
            return _sensors.rendered(ctx, "checkVisionSensorEx", lambda: (image().reshape(-1) / 255.0).tolist())
        depth = _sensors.depth_job(ctx, "checkVisionSensorEx", h, False)
        return _sensors.rendered(ctx, "checkVisionSensorEx", lambda: depth().astype(np.float64).reshape(-1).tolist())


@sim_function("checkProximitySensorEx2")
def checkProximitySensorEx2(ctx: CallContext, sensorHandle: Any, vertices: Any, itemType: Any, itemCount: Any,  # noqa: N802, N803
                            mode: Any, threshold: Any, maxAngle: Any) -> tuple[int, float, list[float], list[float]]:  # noqa: N803
    """``result, distance, detectedPoint, normalVector`` (sensor frame) of the sensor's ray(s)
    (one along +z, or a cone's fan) against given geometry: ``itemType`` 0 points, 1
    segments (no area: a ray meets neither, result 0), 2 triangles (9 numbers each, world
    coordinates, ``itemCount`` of them). The ray starts, the cone's apex lies, at the sensor's
    ``offset=`` up its axis, and a cone sees from its ``radius=`` on
    (:func:`~simx_server.sim.proximity.axis_offset`, :func:`~simx_server.sim.proximity.cone_radius`);
    distances from the sensor's origin. Within the sensor's range and ``threshold`` (m);
    ``mode`` bit 0 front faces (counter-clockwise seen from the sensor), bit 1 back faces,
    bit 3 only surfaces facing the sensor within ``maxAngle`` (rad).

    ``sim.checkProximitySensorEx2``.

    Args:
        sensorHandle: a proximity sensor's handle.
        vertices: the items' numbers, m (world frame).
        itemType: 0, 1 or 2.
        itemCount: how many items.
        mode: detection bits.
        threshold: m.
        maxAngle: rad.

    Returns:
        ``(result, distance, detectedPoint, normalVector)``: int, m, 3 floats (m), 3 floats.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a proximity sensor.
        ArgumentError: an unknown item type, or vertices that do not fit the count.
    """
    h = ctx.world.get(ctx.h(sensorHandle, "sensorHandle"), PROXIMITY_SENSOR).handle
    kind, count, opts = _int(itemType, "itemType"), _int(itemCount, "itemCount"), _int(mode, "mode")
    limit, angle = _num(threshold, "threshold"), _num(maxAngle, "maxAngle")
    per = {0: 3, 1: 6, 2: 9}.get(kind)
    if per is None:
        raise ArgumentError("itemType must be 0 (points), 1 (segments) or 2 (triangles)")
    if not isinstance(vertices, (list, tuple)) or count < 0 or len(vertices) < per * count or count > MAX_ITEMS:
        raise ArgumentError(f"vertices must hold itemCount x {per} numbers (at most {MAX_ITEMS} items)")
    none = (0, 0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    if kind != 2 or not count or not opts & 3:
        return none
    obj = ctx.world.objects[h]
    cone = proximity.cone_angle(obj)
    dirs = proximity.cone_directions(cone) if cone > 0 else np.array([[0.0, 0.0, 1.0]])
    if len(dirs) * count > MAX_TESTS:
        raise ArgumentError(f"{count} triangles against the sensor's {len(dirs)} rays: {len(dirs) * count:,} tests, "
                            f"more than {MAX_TESTS:,} (links.MAX_TESTS); give fewer triangles")
    tri = np.array([_num(v, "vertices[i]") for v in vertices[:9 * count]], dtype=float).reshape(count, 3, 3)
    m, d = ctx.world.model, ctx.world.data
    rot, origin = d.site_xmat[obj.mj_id].reshape(3, 3), d.site_xpos[obj.mj_id]
    start = proximity.axis_offset(obj)  # the ray's start, the cone's apex, up the axis
    near = proximity.cone_radius(obj) if cone > 0 else 0.0
    local = (tri - origin) @ rot - np.array([0.0, 0.0, start])  # into the sensor frame, from the start
    k = next((i for i in range(m.nsensor) if m.sensor_type[i] == mujoco.mjtSensor.mjSENS_RANGEFINDER
              and m.sensor_objtype[i] == mujoco.mjtObj.mjOBJ_SITE and m.sensor_objid[i] == obj.mj_id), None)
    reach = (float(m.sensor_cutoff[k]) if k is not None and m.sensor_cutoff[k] > 0 else np.inf) - start
    best = None
    step = max(1, _PIECE_TESTS // len(dirs))
    for first in range(0, count, step):  # a piece of the triangles at a time: bounded working arrays
        found = _nearest_hit(local[first:first + step], dirs, near, reach, start, limit, opts, angle)
        if found is not None and (best is None or found[0] < best[0]):
            best = found
    if best is None:
        return none
    return 1, best[0], best[1], best[2]


def _nearest_hit(local: np.ndarray, dirs: np.ndarray, near: float, reach: float, start: float, limit: float,
                 opts: int, angle: float) -> tuple[float, list[float], list[float]] | None:
    """:func:`checkProximitySensorEx2`'s nearest detection among triangles ``local`` (t, 3, 3:
    the sensor frame, from the rays' start) by rays ``dirs`` (r, 3): ``(distance, point,
    normal)``, or None."""
    e1, e2 = local[:, 1] - local[:, 0], local[:, 2] - local[:, 0]  # Moller-Trumbore, rays x triangles
    p = np.cross(dirs[:, None, :], e2[None])
    det = np.einsum("tk,rtk->rt", e1, p)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = -local[:, 0]
    u = np.einsum("tk,rtk->rt", tv, p) * inv
    q = np.cross(tv, e1)
    v = np.einsum("rk,tk->rt", dirs, q) * inv
    dist = np.einsum("tk,tk->t", e2, q)[None] * inv
    normal = np.cross(e1, e2)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    front = np.einsum("rk,tk->rt", dirs, normal) < 0  # facing the ray: counter-clockwise seen from the sensor
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (dist >= near) & (dist <= reach)
    hit &= np.linalg.norm(dirs[:, None, :] * dist[..., None] + [0.0, 0.0, start], axis=2) <= limit
    hit &= np.where(front, bool(opts & 1), bool(opts & 2))
    if opts & 8:
        cosine = np.abs(np.einsum("rk,tk->rt", dirs, normal))
        hit &= np.arccos(np.clip(cosine, -1.0, 1.0)) <= angle
    if not hit.any():
        return None
    points = dirs[:, None, :] * dist[..., None] + [0.0, 0.0, start]  # from the origin, as CoppeliaSim's
    reaches = np.linalg.norm(points, axis=2)
    r, t = np.unravel_index(np.argmin(np.where(hit, reaches, np.inf)), hit.shape)
    n = normal[t] if front[r, t] else -normal[t]  # towards the sensor
    return float(reaches[r, t]), points[r, t].tolist(), n.tolist()


