"""Proximity sensors as V-REP's legacy remote API reads them (``simxReadProximitySensor``,
``sim.readProximitySensor``): a ray, a cone (V-REP's sonars) or a volume of rays from a MuJoCo
site carrying a ``rangefinder``.

* ray: one ``mj_ray`` along the site's +z from ``offset=`` (m, default 0; V-REP's default ray
  has 0.1) to the rangefinder's ``cutoff`` (offset + range), excluding the site's own body; what
  lies nearer than the offset is not seen, the distance is from the site (:func:`axis_offset`).
  The surface normal is the one ``mj_ray`` computes for the geom it hits.
* cone (``angle=DEG`` in the sensor's ``simx:`` settings): ``mj_multiRay`` casts a fan of rays
  filling the cone of that opening angle around +z, from its apex ``offset=`` m up the axis,
  seeing from ``radius=`` m (default 0) from the apex to the cutoff; the hit nearest to the
  site is the detection.
* ``volume=pyramid`` or ``cylinder``: the nearest point of the detectable triangles inside the
  frustum or the ``faces=``-sided prism, exactly as CoppeliaSim's volume sensors find it
  (:mod:`simx_server.sim.proximity_volume`; primitives on CoppeliaSim's tessellation of them,
  height fields and SDF geoms by rays);
* ``volume=disc``: V-REP's other volume type, a set of rays filling the volume
  (:func:`volume_rays`).
* what is seen: shapes that are detectable by the sensor's type (``sensable=``, V-REP's
  detectable flags, :mod:`simx_server.sim.properties`; coppeliaSimLib
  ``CProxSensorRoutine::detectEntity`` with ``getAllDetectableObjectsFromSceneExcept``), and the
  world body's colliding geoms; rays pass through the rest.
"""

from __future__ import annotations

import functools
import math
import types
from typing import Any

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError
from simx_server.sim import properties, proximity_volume
from simx_server.sim.proximity_volume import axis_offset, volume_span
from simx_server.sim.sensors import site_sensor
from simx_server.sim.state import SimulationView
from simx_server.sim.world import PROXIMITY_SENSOR, SHAPE, World


def _shape_of_body(world: World) -> dict[int, int]:
    return {o.mj_id: o.handle for o in world.objects.values() if o.type == SHAPE}


def sensable(obj: Any) -> int:
    """The detectable bit a proximity sensor senses (its ``simx:`` setting ``sensable=``, V-REP's
    detection type: 16 ultrasonic, 32 infrared, 64 laser, 128 inductive, 256 capacitive; default
    ultrasonic, as ``CProxSensor``'s constructor). Raises ArgumentError for another value.

    Args:
        obj: a proximity sensor's scene object.

    Returns:
        One of the ``sim.objectspecialproperty_detectable_*`` bits.
    """
    raw = obj.settings.get("sensable", "16")
    names = properties.DETECTABLE
    value = names.get(raw)
    if value is None:
        try:
            value = int(raw)
        except ValueError:
            value = -1
    if value not in names.values():
        raise ArgumentError(f"proximity sensor {obj.name!r}: sensable={raw!r} in its simx: settings is not "
                            f"one of {sorted(names.values())} or {sorted(names)}")
    return value


#: How many undetectable shapes one ray may pass through before it gives up.
MAX_PASS_THROUGH = 16


def _ray(m: mujoco.MjModel, d: mujoco.MjData, origin: np.ndarray, direction: np.ndarray, exclude: int,
         seen: np.ndarray, first: tuple[float, int, np.ndarray] | None = None) -> tuple[float, int, np.ndarray]:
    """``mj_ray`` that passes through geoms a sensor does not detect (``seen[g]`` False, V-REP's
    detectable flags): it casts again from just beyond each such geom, leaving out its body.
    ``first``: the result of a cast already made from ``origin``. Returns (distance from
    ``origin`` m or -1, geom or -1, surface normal (3,) world)."""
    gid = np.array([-1], dtype=np.int32)
    normal = np.zeros(3)
    travelled, start, skip = 0.0, origin, exclude
    for _ in range(MAX_PASS_THROUGH):
        if first is not None:
            dist, geom, normal = first
            first = None
        else:
            dist = mujoco.mj_ray(m, d, start, direction, None, 1, skip, gid, normal)
            geom = int(gid[0])
        if dist < 0 or geom < 0:
            return -1.0, -1, normal
        if seen[geom]:
            return travelled + dist, geom, normal.copy()
        travelled += dist
        start = start + dist * direction
        skip = int(m.geom_bodyid[geom])
    return -1.0, -1, normal


# -------------------------------------------------------------- proximity sensors
#: Rays of a cone-type proximity sensor: its axis, then rings of rays every CONE_RING_STEP
#: degrees of half-angle out to the cone's edge, rays CONE_RAY_SPACING degrees apart around
#: each ring (a 30-degree sonar: 4 rings, 61 rays; one mj_multiRay call).
CONE_RING_STEP = 3.75
CONE_RAY_SPACING = 4.0


@functools.lru_cache(maxsize=32)
def cone_directions(angle: float) -> np.ndarray:
    """Unit directions (n, 3) in the sensor frame filling a cone of opening ``angle`` (rad)
    around +z: the axis first, the edge of the cone last.

    Args:
        angle: the cone's opening angle, rad.

    Returns:
        Array (n, 3), cached per angle (do not modify).
    """
    half = math.degrees(angle) / 2
    rings = max(1, math.ceil(half / CONE_RING_STEP))
    dirs = [np.array([[0.0, 0.0, 1.0]])]
    for k in range(1, rings + 1):
        theta = math.radians(half * k / rings)
        count = max(6, math.ceil(360 * math.sin(theta) / CONE_RAY_SPACING))
        phi = np.arange(count) * (2 * math.pi / count)
        dirs.append(np.column_stack([math.sin(theta) * np.cos(phi), math.sin(theta) * np.sin(phi),
                                     np.full(count, math.cos(theta))]))
    return np.concatenate(dirs)


def cone_angle(obj: Any) -> float:
    """The opening angle (rad) of a cone-type proximity sensor (its ``simx:`` setting ``angle=``
    in degrees, V-REP's cone "angle"), 0 for a ray-type one. Raises ArgumentError for a value
    that is not a number in (0, 180).

    Args:
        obj: a proximity sensor's scene object.

    Returns:
        Angle in rad.
    """
    raw = obj.settings.get("angle")
    if raw is None:
        return 0.0
    try:
        deg = float(raw)
    except ValueError:
        deg = math.nan
    if not 0 < deg < 180:
        raise ArgumentError(f"proximity sensor {obj.name!r}: angle={raw!r} in its simx: settings is "
                            "not an opening angle in degrees between 0 and 180")
    return math.radians(deg)


def max_angle(obj: Any) -> float:
    """V-REP's "limited angle detection" of a proximity sensor (its ``simx:`` setting
    ``max_angle=`` in degrees): a surface is detected only where the angle between the ray and
    the surface's normal is at most this (an ultrasonic sensor does not hear a surface it meets
    at a grazing angle, such as the floor); pi/2 (every surface) when not set. Raises
    ArgumentError for a value that is not a number in (0, 90].

    Args:
        obj: a proximity sensor's scene object.

    Returns:
        Angle in rad.
    """
    raw = obj.settings.get("max_angle")
    if raw is None:
        return math.pi / 2
    try:
        deg = float(raw)
    except ValueError:
        deg = math.nan
    if not 0 < deg <= 90:
        raise ArgumentError(f"proximity sensor {obj.name!r}: max_angle={raw!r} in its simx: settings "
                            "is not an angle in degrees in (0, 90]")
    return math.radians(deg)


def cone_radius(obj: Any) -> float:
    """How far from its apex a cone-type proximity sensor starts seeing (its ``simx:`` setting
    ``radius=``, m, default 0; CoppeliaSim's cone volume lies between ``radius`` and ``radius +
    range`` from the apex, coppeliaSimLib ``CConvexVolume``). Raises ArgumentError for a value
    that is not a size in m.

    Args:
        obj: a proximity sensor's scene object.

    Returns:
        The radius, m.
    """
    return _floats(obj, "radius", 1, (0.0,))[0]


#: Rays across each side of a pyramid-type volume, and rings / rays per ring of a cylinder.
VOLUME_GRID = 7
CYLINDER_RINGS, CYLINDER_RAYS = 3, 12


def _floats(obj: Any, key: str, count: int, default: tuple[float, ...]) -> tuple[float, ...]:
    raw = obj.settings.get(key)
    if raw is None:
        return default
    try:
        values = tuple(float(v) for v in raw.split(","))
    except ValueError:
        values = ()
    if len(values) != count or not all(math.isfinite(v) and v >= 0 for v in values):
        raise ArgumentError(f"proximity sensor {obj.name!r}: {key}={raw!r} in its simx: settings is not "
                            f"{count} comma-separated sizes in m")
    return values


def volume_rays(obj: Any, cutoff: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The rays of a ``volume=pyramid|cylinder|disc`` proximity sensor, in its frame: origins
    (n, 3) m, unit directions (n, 3), lengths (n,) m; None for ray and cone types. The volume
    lies along +z between ``offset=`` (m, default 0, may be negative) and the rangefinder's
    ``cutoff`` or the ``far=`` setting (:func:`volume_span`), as V-REP's:

    * ``pyramid``: a frustum from an ``size=X,Y`` rectangle at the offset to ``size_far=X,Y`` at
      the cutoff (m); a VOLUME_GRID x VOLUME_GRID grid of rays joining the two faces;
    * ``cylinder``: a cone frustum from ``radius=R`` to ``radius_far=R`` (m); rays on rings;
    * ``disc``: a flat sector of opening ``angle=DEG`` in the sensor's x-z plane, from the
      sensor's origin; a fan of rays CONE_RAY_SPACING degrees apart.

    Raises ArgumentError for an unknown volume or a bad size.

    Args:
        obj: a proximity sensor's scene object (its ``simx:`` settings).
        cutoff: the rangefinder's range, m (``math.inf``: unlimited).

    Returns:
        ``(origins, directions, lengths)`` (read-only, shared by calls of the same settings), or None.
    """
    kind = obj.settings.get("volume", "ray")
    return None if kind in ("ray", "cone") else _volume_rays(obj.name, tuple(sorted(obj.settings.items())), float(cutoff))


@functools.lru_cache(maxsize=256)
def _volume_rays(name: str, settings: tuple, cutoff: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    out = _make_volume_rays(types.SimpleNamespace(name=name, settings=dict(settings)), cutoff)
    for a in out:
        a.setflags(write=False)
    return out


def _make_volume_rays(obj: Any, cutoff: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    kind = obj.settings.get("volume", "ray")
    offset, far = volume_span(obj, cutoff)
    if far <= offset:
        raise ArgumentError(f"proximity sensor {obj.name!r}: its range ends (cutoff {far} m) before offset={offset}")
    if kind == "pyramid":
        x, y = _floats(obj, "size", 2, (0.1, 0.1))
        xf, yf = _floats(obj, "size_far", 2, (x, y))
        u, v = np.meshgrid(np.linspace(-0.5, 0.5, VOLUME_GRID), np.linspace(-0.5, 0.5, VOLUME_GRID))
        u, v = u.ravel(), v.ravel()
        near = np.column_stack([u * x, v * y, np.full(u.size, offset)])
        end = np.column_stack([u * xf, v * yf, np.full(u.size, far)])
    elif kind == "cylinder":
        (r,) = _floats(obj, "radius", 1, (0.05,))
        (rf,) = _floats(obj, "radius_far", 1, (r,))
        frac = [0.0] + [k / CYLINDER_RINGS for k in range(1, CYLINDER_RINGS + 1) for _ in range(CYLINDER_RAYS)]
        phi = [0.0] + [2 * math.pi * i / CYLINDER_RAYS for _ in range(CYLINDER_RINGS) for i in range(CYLINDER_RAYS)]
        f, c, s = np.array(frac), np.cos(phi), np.sin(phi)
        near = np.column_stack([f * r * c, f * r * s, np.full(f.size, offset)])
        end = np.column_stack([f * rf * c, f * rf * s, np.full(f.size, far)])
    elif kind == "disc":
        angle = cone_angle(obj) or math.radians(90)
        count = max(3, math.ceil(math.degrees(angle) / CONE_RAY_SPACING) + 1)
        theta = np.linspace(-angle / 2, angle / 2, count)
        dirs = np.column_stack([np.sin(theta), np.zeros(count), np.cos(theta)])
        return np.zeros((count, 3)), dirs, np.full(count, far)
    else:
        raise ArgumentError(f"proximity sensor {obj.name!r}: volume={kind!r} in its simx: settings is not "
                            "ray, cone, pyramid, cylinder or disc")
    span = end - near
    lengths = np.linalg.norm(span, axis=1)
    return near, span / lengths[:, None], lengths


def _volume_hit(m: mujoco.MjModel, d: mujoco.MjData, rot: np.ndarray, origin: np.ndarray, exclude: int,
                rays: tuple[np.ndarray, np.ndarray, np.ndarray],
                seen: np.ndarray) -> tuple[float, int, np.ndarray, np.ndarray] | None:
    """The detection nearest to the sensor's origin among ``rays`` (see :func:`volume_rays`):
    (its distance from the origin m, geom, point (3,) in the sensor frame, surface normal (3,)
    in the world frame), or None."""
    starts, dirs, lengths = rays
    centre, reach = proximity_volume.ball(np.vstack([starts, starts + dirs * lengths[:, None]]))
    if not proximity_volume.may_meet(m, d, seen, rot, origin, centre, reach):
        return None
    n = len(starts)
    origins, world_dirs = origin + starts @ rot.T, dirs @ rot.T
    dists, geoms, normals = np.full(n, -1.0), np.full(n, -1, np.int32), np.zeros((n, 3))
    gid, normal = np.array([-1], dtype=np.int32), np.zeros(3)
    for i in range(n):  # one cast per ray (their origins differ); a ray that meets an undetectable geom goes on
        dist = mujoco.mj_ray(m, d, origins[i], world_dirs[i], None, 1, exclude, gid, normal)
        geom = int(gid[0])
        if dist >= 0 and geom >= 0 and not seen[geom]:
            dist, geom, normal = _ray(m, d, origins[i], world_dirs[i], exclude, seen, (dist, geom, normal))
        dists[i], geoms[i], normals[i] = dist, geom, normal
    found = np.flatnonzero((dists >= 0) & (geoms >= 0) & (dists <= lengths))
    if found.size == 0:
        return None
    points = starts[found] + dirs[found] * dists[found, None]
    k = int(np.argmin(np.linalg.norm(points, axis=1)))
    i = int(found[k])
    return float(np.linalg.norm(points[k])), int(geoms[i]), points[k], normals[i].copy()


def _exact_hit(m: mujoco.MjModel, d: mujoco.MjData, obj: Any, rot: np.ndarray, origin: np.ndarray,
               exclude: int, seen: np.ndarray, cutoff: float) -> tuple[float, int, np.ndarray, np.ndarray] | None:
    """A pyramid or cylinder volume's exact detection among triangle geoms
    (:func:`simx_server.sim.proximity_volume.nearest_inside`), its planes from the same settings
    as :func:`volume_rays` (a cylinder's ``faces=``, default 32, CoppeliaSim's), made once per
    settings as the rays are."""
    planes = _volume_planes(obj.name, tuple(sorted(obj.settings.items())), float(cutoff))
    return proximity_volume.nearest_inside(m, d, rot, origin, exclude, seen, planes, max_angle(obj))


@functools.lru_cache(maxsize=256)
def _volume_planes(name: str, settings: tuple, cutoff: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    obj = types.SimpleNamespace(name=name, settings=dict(settings))
    offset, far = volume_span(obj, cutoff)
    if obj.settings.get("volume") == "cylinder":
        (r,) = _floats(obj, "radius", 1, (0.05,))
        (rf,) = _floats(obj, "radius_far", 1, (r,))
        faces = int(_floats(obj, "faces", 1, (32,))[0])
        low, high = proximity_volume.CYLINDER_FACES
        if not low <= faces <= high:
            raise ArgumentError(f"proximity sensor {name!r}: faces={faces} must lie in {low}..{high}")
        out = proximity_volume.cylinder(offset, far, r, rf, faces)
    else:
        x, y = _floats(obj, "size", 2, (0.1, 0.1))
        out = proximity_volume.pyramid(offset, far, (x, y), _floats(obj, "size_far", 2, (x, y)))
    for a in out:
        a.setflags(write=False)
    return out


def _cone_hit(m: mujoco.MjModel, d: mujoco.MjData, obj: Any, rot: np.ndarray, origin: np.ndarray, exclude: int,
              seen: np.ndarray, angle: float, cutoff: float) -> tuple[int, np.ndarray, np.ndarray] | None:
    """The nearest detection of a cone-type sensor (opening ``angle`` rad): a fan of rays
    (:func:`cone_directions`) from its apex, :func:`axis_offset` up its axis, seeing from its
    ``radius=`` (m, default 0) to ``cutoff`` along the axis, as CoppeliaSim's cone volume
    (coppeliaSimLib ``CConvexVolume``: between ``radius`` and ``radius + range`` from the apex).
    A ray stopped nearer than the radius, or by an undetectable geom, casts again from beyond.
    Returns (geom, point (3,) in the sensor frame, surface normal (3,) world), the point nearest
    to the sensor's origin, or None."""
    local = cone_directions(angle)
    n = len(local)
    start, near = axis_offset(obj), cone_radius(obj)
    apex = origin + start * rot[:, 2]
    reach = cutoff - start
    geoms, dists, normals = np.full(n, -1, np.int32), np.full(n, -1.0), np.zeros(n * 3)
    world_dirs = local @ rot.T
    mujoco.mj_multiRay(m, d, apex, world_dirs.ravel(), None, 1, exclude, geoms, dists,
                       normals, n, min(reach, mujoco.mjMAXVAL))
    near_hit = (geoms >= 0) & (dists < near)
    for i in np.flatnonzero(near_hit):  # within the radius: not in the volume, look from the radius on
        dist, geoms[i], normals[3 * i:3 * i + 3] = _ray(m, d, apex + near * world_dirs[i], world_dirs[i].copy(),
                                                        exclude, seen)
        dists[i] = near + dist if dist >= 0 else -1.0
    for i in np.flatnonzero(~near_hit & (geoms >= 0) & ~seen[np.maximum(geoms, 0)]):  # undetectable: look beyond
        first = (float(dists[i]), int(geoms[i]), normals[3 * i:3 * i + 3].copy())
        dists[i], geoms[i], normals[3 * i:3 * i + 3] = _ray(m, d, apex, world_dirs[i].copy(), exclude, seen, first)
    found = (dists >= 0) & (geoms >= 0) & (dists <= reach)
    limit = max_angle(obj)
    if limit < math.pi / 2:  # the ray against the surface's normal (both unit vectors)
        facing = -np.einsum("ij,ij->i", world_dirs, normals.reshape(-1, 3))
        found &= facing >= math.cos(limit) - 1e-9
    hits = np.flatnonzero(found)
    if hits.size == 0:
        return None
    points = local[hits] * dists[hits, None] + np.array([0.0, 0.0, start])
    k = int(np.argmin(np.linalg.norm(points, axis=1)))
    i = int(hits[k])
    return int(geoms[i]), points[k], normals[3 * i:3 * i + 3]


def proximity_reading(sim: SimulationView, handle: int,
                      entity: int | None = None) -> tuple[bool, list[float], int, list[float]]:
    """``simxReadProximitySensor``'s values: (detected, detected point (3,) m, detected object
    handle, detected surface normal (3,)), point and normal in the sensor frame.

    A ray-type sensor casts one ray along +z from its :func:`axis_offset` on (nothing nearer is
    seen); a cone-type one (``angle=``) a fan of rays filling the cone (:func:`cone_directions`),
    a pyramid, cylinder or disc one (``volume=``) the rays of :func:`volume_rays`, and each
    reports the nearest hit, as V-REP's cone sensor reports the nearest point of what lies in
    its volume (within the ray spacing), leaving out surfaces met beyond ``max_angle=``
    (:func:`max_angle`; cone sensors only). Geoms of the sensor's own body are not seen; the
    range is the rangefinder's ``cutoff`` (0: unlimited). Nothing detected: (False, [0, 0, 0],
    -1, [0, 0, 0]).

    Raises UnknownObjectError/ObjectTypeError for another handle, ArgumentError for a bad
    ``angle=`` or ``offset=`` setting.

    Args:
        sim: the simulation.
        handle: a proximity sensor's handle.
        entity: None (every detectable shape), or one shape that alone is looked for, whatever
            its detectable flags, the rest neither seen nor in the way (V-REP's
            ``simCheckProximitySensor``: ``CProxSensorRoutine::detectEntity`` with the flag
            overridden for a single object).

    Returns:
        ``(detected, [x, y, z], object handle, [nx, ny, nz])``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a proximity sensor.
        ArgumentError: bad ``angle=``, ``max_angle=``, ``offset=`` or volume settings.
    """
    world = sim.world
    obj = world.get(handle, PROXIMITY_SENSOR)
    m, d = world.model, world.data
    site = obj.mj_id
    k = site_sensor(m, site, mujoco.mjtSensor.mjSENS_RANGEFINDER)
    cutoff = float(m.sensor_cutoff[k]) if k is not None and m.sensor_cutoff[k] > 0 else math.inf
    rot = d.site_xmat[site].reshape(3, 3)
    origin = d.site_xpos[site].copy()
    exclude = int(m.site_bodyid[site])
    rays = volume_rays(obj, cutoff)
    angle = cone_angle(obj) if rays is None else 0.0
    if entity is None:
        seen = properties.geom_mask(world, sensable(obj))
    else:
        seen = np.zeros(m.ngeom, dtype=bool)
        seen[properties.shape_geoms(m, world.get(entity, SHAPE).mj_id)] = True
    if rays is None and math.isfinite(cutoff):  # round the ray's segment, or the cone's ball about its apex
        start = axis_offset(obj)
        mid, reach = ((start + cutoff) / 2, abs(cutoff - start) / 2) if angle <= 0 else (start, abs(cutoff - start))
        if not proximity_volume.may_meet(m, d, seen, rot, origin, np.array([0.0, 0.0, mid]), reach):
            return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
    if rays is not None:
        planar = obj.settings.get("volume") in ("pyramid", "cylinder")
        exact = _exact_hit(m, d, obj, rot, origin, exclude, seen, cutoff) if planar else None
        found = _volume_hit(m, d, rot, origin, exclude, rays,
                            seen & ~proximity_volume.triangle_geoms(m) if planar else seen)
        if exact is not None and (found is None or exact[0] < found[0]):
            found = exact
        if found is None:
            return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
        dist, geom, point, normal = found
    elif angle > 0:
        cone = _cone_hit(m, d, obj, rot, origin, exclude, seen, angle, cutoff)
        if cone is None:
            return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
        geom, point, normal = cone
    else:  # one ray from the offset on (CoppeliaSim's ray volume), its hit measured from the origin
        axis, start = rot[:, 2].copy(), axis_offset(obj)
        dist, geom, normal = _ray(m, d, origin + start * axis, axis, exclude, seen)
        if dist < 0 or start + dist > cutoff or geom < 0:
            return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
        point = np.array([0.0, 0.0, start + dist])
    hit = _shape_of_body(world).get(int(m.geom_bodyid[geom]), -1)
    n = rot.T @ normal
    norm = np.linalg.norm(n)
    n = n / norm if norm > 0 else n
    return True, [float(x) for x in point], hit, [float(x) for x in n]


def dummy_reading(world: World, handle: int, dummy: int) -> tuple[bool, list[float]]:
    """Whether proximity sensor ``handle`` detects dummy ``dummy``, and its origin in the sensor
    frame (m): as coppeliaSimLib ``CProxSensorRoutine::_detectDummy``, a dummy is a point, seen
    when its origin lies in the sensor's volume; a ray-type sensor never sees one. The volume is
    the sensor's cone (``angle=``: its opening, from ``radius=`` around its apex ``offset=`` up
    the axis to the rangefinder's cutoff), pyramid (``size=`` at ``offset=``, ``size_far=`` at
    the range) or cylinder (``radius=``, ``radius_far=``), these between ``offset=`` and the
    rangefinder's cutoff; a disc's thickness is not known to simx: ArgumentError.

    Args:
        world: the world.
        handle: a proximity sensor's handle.
        dummy: a dummy's handle.

    Returns:
        ``(detected, [x, y, z])``; not detected: ``(False, [0, 0, 0])``.

    Raises:
        ObjectTypeError: not a proximity sensor or not a dummy.
        ArgumentError: a disc-type sensor, or bad volume settings.
    """
    from simx_server.sim.objects import DUMMY

    obj = world.get(handle, PROXIMITY_SENSOR)
    target = world.get(dummy, DUMMY)
    m, d = world.model, world.data
    k = site_sensor(m, obj.mj_id, mujoco.mjtSensor.mjSENS_RANGEFINDER)
    far = float(m.sensor_cutoff[k]) if k is not None and m.sensor_cutoff[k] > 0 else math.inf
    rot = d.site_xmat[obj.mj_id].reshape(3, 3)
    p = rot.T @ (d.site_xpos[target.mj_id] - d.site_xpos[obj.mj_id])
    kind = obj.settings.get("volume", "cone" if obj.settings.get("angle") else "ray")
    if kind == "disc":
        raise ArgumentError(f"checkProximitySensor of a dummy: {obj.name!r} is a disc-type sensor, whose "
                            "thickness simx does not know")
    dist = math.sqrt(p.dot(p))  # np.linalg.norm's own sum (BLAS's dot), without its checks
    if kind == "ray" or dist == 0.0:
        inside = False
    elif kind == "cone":  # from its apex offset= up the axis, between radius= and the cutoff
        q = p - np.array([0.0, 0.0, axis_offset(obj)])
        reach = float(np.linalg.norm(q))
        near = cone_radius(obj)
        inside = (reach > 0 and near <= reach <= far - axis_offset(obj)
                  and math.acos(max(-1.0, min(1.0, q[2] / reach))) <= cone_angle(obj) / 2)
    else:
        offset, end = volume_span(obj, far)
        f = (p[2] - offset) / (end - offset) if end > offset else -1.0
        if kind == "pyramid":
            x, y = _floats(obj, "size", 2, (0.1, 0.1))
            xf, yf = _floats(obj, "size_far", 2, (x, y))
            inside = 0 <= f <= 1 and abs(p[0]) <= (x + f * (xf - x)) / 2 and abs(p[1]) <= (y + f * (yf - y)) / 2
        else:
            (r,) = _floats(obj, "radius", 1, (0.05,))
            (rf,) = _floats(obj, "radius_far", 1, (r,))
            inside = 0 <= f <= 1 and math.hypot(p[0], p[1]) <= r + f * (rf - r)
    return (True, [float(v) for v in p]) if inside else (False, [0.0, 0.0, 0.0])
