"""Sensors: proximity, force and vision-sensor reads, as V-REP's legacy remote API has them,
and the per-simulation sensor state.

The command handlers ``(sim, args) -> value`` are in :mod:`simx_server.commands.sensors`; each
checks its arguments and raises the exceptions of :mod:`simx_wire.protocol`, and returns plain
ints, floats, bools, str, bytes and lists. The functions they call (``proximity_reading``,
``force_sensor_reading``, ``vision_packet`` ...) take plain values and serve in-process callers
too. Neighbouring concerns have modules of their own: :mod:`simx_server.sim.collisions` (collision
and distance), :mod:`simx_server.sim.kinematics` (joint matrices, velocities),
:mod:`simx_server.sim.group_data` and :mod:`simx_server.sim.object_params`.

MuJoCo mapping (see the per-function docstrings for the details):

* proximity sensor = a site carrying a ``rangefinder``: one ``mj_ray`` along the site's +z,
  excluding the site's own body, limited by the rangefinder's ``cutoff``; the surface normal is
  the one ``mj_ray`` computes for the geom it hits. With ``angle=DEG`` in its ``simx:`` settings
  it is V-REP's cone-type sensor (a sonar): ``mj_multiRay`` casts a fan of rays filling the cone
  of that opening angle around +z, and the nearest hit is the detection. ``volume=pyramid``,
  ``cylinder`` or ``disc`` are V-REP's other volume types, each a set of rays filling the volume
  (:func:`volume_rays`).
* force sensor = a site carrying a ``force`` sensor (and optionally a ``torque`` sensor): the
  interaction force/torque between the site's body and its parent, in the site frame.

Derived quantities (positions of bodies, sensor data) are those of the world's last
``mj_forward``, which ``World.step`` and every state change run.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import TYPE_CHECKING, Any, Callable

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, ObjectTypeError
from simx_server.sim.state import SimulationView
from simx_server.sim.world import FORCE_SENSOR, PROXIMITY_SENSOR, SHAPE, VISION_SENSOR, World

if TYPE_CHECKING:
    from simx_server.sim.collisions import Probe
    pass

FORCE_STATE_DATA = 1  # simReadForceSensor bit 0: force and torque data available
FORCE_STATE_BROKEN = 2  # bit 1: the sensor is broken


# --------------------------------------------------------------- per-simulation state
class PassiveImages:
    """Images written with ``simxSetVisionSensorImage`` into passive vision sensors.

    A passive sensor ("external input" in V-REP) is a camera whose ``simx:NAME`` custom text
    says ``image=external``. Images are stored per handle as (h, w, 3) uint8 RGB, rows
    bottom-up (V-REP's order, as they arrive); grey images are stored with R = G = B.
    """

    def __init__(self) -> None:
        self._images: dict[int, np.ndarray] = {}

    def set(self, handle: int, rgb: np.ndarray) -> None:
        """Store ``rgb`` ((h, w, 3) uint8, rows bottom-up) as the sensor's image."""
        self._images[handle] = rgb

    def get(self, handle: int) -> np.ndarray | None:
        """The stored image, or None if none was ever set."""
        return self._images.get(handle)

    def clear(self) -> None:
        """Forget every stored image."""
        self._images.clear()

@dataclasses.dataclass
class SensorState:
    """What sensors keep between calls; one per SimulationView (``sim.sensors``)."""

    passive: PassiveImages = dataclasses.field(default_factory=PassiveImages)
    broken: dict[int, tuple[int, float]] = dataclasses.field(default_factory=dict)  # handle -> (stops, t)
    probes_model: Any = None  # the model the probes below were read from
    probes: dict[str, dict[str, Probe]] = dataclasses.field(default_factory=dict)  # kind -> name -> probe
    probe_handles: dict[str, dict[str, int]] = dataclasses.field(
        default_factory=lambda: {"collision": {}, "distance": {}})  # never reused


def is_passive(sim: SimulationView, handle: int) -> bool:
    """Whether vision sensor ``handle`` is passive (``image=external`` in its custom text)."""
    return sim.world.get(handle, VISION_SENSOR).settings.get("image") == "external"


def override_image(sim: SimulationView, handle: int, grey: bool) -> np.ndarray | None:
    """The image a passive sensor shows instead of a rendering, or None for other sensors.

    Same contract as ``VisionSensors.image``: rows bottom-up, (h, w, 3) uint8 RGB, or (h, w)
    uint8 ``(R + G + B) // 3`` when ``grey``. A passive sensor nobody wrote to yet is black.
    Raises UnknownObjectError / ObjectTypeError for a handle that is not a vision sensor.
    """
    if not is_passive(sim, handle):
        return None
    rgb = sim.sensors.passive.get(handle)
    spec = sim.vision.spec(handle)
    if rgb is None or rgb.shape[:2] != (spec.height, spec.width):  # none yet (or scene edited)
        rgb = np.zeros((spec.height, spec.width, 3), dtype=np.uint8)
    if grey:
        return (rgb.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8)
    return rgb


def set_passive_image(sim: SimulationView, handle: int, image: bytes, grey: bool) -> None:
    """Write the image of a passive vision sensor (``simxSetVisionSensorImage``,
    ``sim.setVisionSensorImg``); the sensor's image reads return it from then on.

    Args:
        sim: the simulation.
        handle: a vision sensor declared ``image=external`` in its ``simx:NAME`` custom text.
        image: rows bottom-up, width*height*3 RGB bytes, or width*height grey bytes when ``grey``
            (stored with R = G = B).
        grey: whether ``image`` is grey (the legacy ``options`` bit 0).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor, or one that is not passive.
        ArgumentError: ``image`` is not the sensor's whole resolution in that format.
    """
    obj = sim.world.get(handle, VISION_SENSOR)
    if obj.settings.get("image") != "external":
        raise ObjectTypeError(f"vision sensor {obj.name!r} is not passive: only sensors declared with "
                              f"<text name=\"simx:{obj.name}\" data=\"image=external\"/> accept images")
    spec = sim.vision.spec(handle)
    need = spec.image_size(grey)
    if len(image) != need:
        raise ArgumentError(f"image has {len(image)} bytes; vision sensor {obj.name!r} is "
                            f"{spec.width}x{spec.height}, so it needs {need} "
                            f"({'grey, options bit 0 set' if grey else 'RGB, options bit 0 clear'})")
    img = np.frombuffer(image, dtype=np.uint8)
    if grey:
        rgb = np.repeat(img.reshape(spec.height, spec.width, 1), 3, axis=2)
    else:
        rgb = img.reshape(spec.height, spec.width, 3).copy()
    sim.sensors.passive.set(handle, rgb)
    sim.world.version += 1


def _shape_of_body(world: World) -> dict[int, int]:
    return {o.mj_id: o.handle for o in world.objects.values() if o.type == SHAPE}


# ------------------------------------------------------------------ force sensors
def _site_sensor(m: mujoco.MjModel, site: int, kind: mujoco.mjtSensor) -> int | None:
    for k in range(m.nsensor):
        if (m.sensor_type[k] == kind and m.sensor_objtype[k] == mujoco.mjtObj.mjOBJ_SITE
                and m.sensor_objid[k] == site):
            return k
    return None


def _site_wrench(world: World, site: int) -> tuple[np.ndarray, np.ndarray]:
    """Force and torque between the site's body and its parent, in the site frame (as
    MuJoCo's force/torque sensors compute them, from ``cfrc_int``)."""
    m, d = world.model, world.data
    body = int(m.site_bodyid[site])
    conv = np.empty(6)
    mujoco.mju_transformSpatial(conv, d.cfrc_int[body], 1, d.site_xpos[site],
                                d.subtree_com[m.body_rootid[body]], np.eye(3).reshape(9))
    rot = d.site_xmat[site].reshape(3, 3)
    return rot.T @ conv[3:], rot.T @ conv[:3]


def stamp(sim: SimulationView) -> tuple[int, float]:
    return getattr(sim, "stop_requests", 0), sim.world.time


def _broken(sim: SimulationView, handle: int) -> bool:
    st = sim.sensors
    when = st.broken.get(handle)
    if when is None:
        return False
    stops, t = stamp(sim)
    if stops != when[0] or t < when[1]:  # stopped (scene reset) since it broke
        del st.broken[handle]
        return False
    return True


def force_sensor_reading(sim: SimulationView, handle: int) -> tuple[int, list[float], list[float]]:
    """(state, force (3,) N, torque (3,) N·m) of force sensor ``handle``; see read_force_sensor."""
    obj = sim.world.get(handle, FORCE_SENSOR)
    if _broken(sim, handle):
        return FORCE_STATE_BROKEN, [0.0] * 3, [0.0] * 3
    m, d = sim.world.model, sim.world.data
    kf = _site_sensor(m, obj.mj_id, mujoco.mjtSensor.mjSENS_FORCE)
    kt = _site_sensor(m, obj.mj_id, mujoco.mjtSensor.mjSENS_TORQUE)
    force, torque = _site_wrench(sim.world, obj.mj_id)
    if kf is not None:  # the sensor's own output (with the model's noise/cutoff settings)
        force = d.sensordata[m.sensor_adr[kf]:m.sensor_adr[kf] + 3]
    if kt is not None:
        torque = d.sensordata[m.sensor_adr[kt]:m.sensor_adr[kt] + 3]
    return FORCE_STATE_DATA, [float(x) for x in force], [float(x) for x in torque]


# ----------------------------------------------------------------- vision sensors
def vision_packet(sim: SimulationView, handle: int) -> list[float]:
    """V-REP's default vision packet: 15 floats in 0..1.

    min, max and average of (intensity, red, green, blue, depth) over the sensor's current
    image (intensity = (R + G + B) / 3) and depth buffer (normalised between near and far).
    Passive sensors use their stored image; the depth is always the rendered one (what
    simxGetVisionSensorDepthBuffer returns). Waits for the render (see :func:`vision_packet_job`).
    """
    return sim.vision.after(vision_packet_job(sim, handle)).result()


def vision_packet_job(sim: SimulationView, handle: int) -> Callable[[], list[float]]:
    """:func:`vision_packet`'s frames submitted (simulation thread); the job returned computes
    the packet from them, on the request render thread after them (``VisionSensors.after``)."""
    rgb = override_image(sim, handle, False)
    image = (lambda: rgb) if rgb is not None else sim.vision.image_job(handle, False)
    depth_job = sim.vision.depth_job(handle)

    def packet() -> list[float]:
        px = image().reshape(-1, 3)
        intensity = px.sum(axis=1, dtype=np.uint32)
        depth = depth_job()
        mins = [intensity.min() / 765.0, *(px.min(axis=0) / 255.0), float(depth.min())]
        maxs = [intensity.max() / 765.0, *(px.max(axis=0) / 255.0), float(depth.max())]
        avgs = [intensity.mean() / 765.0, *(px.mean(axis=0) / 255.0), float(depth.mean(dtype=np.float64))]
        return [float(x) for x in (*mins, *maxs, *avgs)]

    return packet


# -------------------------------------------------------------- proximity sensors
#: Rays of a cone-type proximity sensor: its axis, then rings of rays every CONE_RING_STEP
#: degrees of half-angle out to the cone's edge, rays CONE_RAY_SPACING degrees apart around
#: each ring (a 30-degree sonar: 4 rings, 61 rays; one mj_multiRay call).
CONE_RING_STEP = 3.75
CONE_RAY_SPACING = 4.0


@functools.lru_cache(maxsize=32)
def cone_directions(angle: float) -> np.ndarray:
    """Unit directions (n, 3) in the sensor frame filling a cone of opening ``angle`` (rad)
    around +z: the axis first, the edge of the cone last."""
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
    that is not a number in (0, 180)."""
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
    ArgumentError for a value that is not a number in (0, 90]."""
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
    lies between ``offset=`` (m, default 0) and the rangefinder's ``cutoff`` along +z, as V-REP's:

    * ``pyramid``: a frustum from an ``size=X,Y`` rectangle at the offset to ``size_far=X,Y`` at
      the cutoff (m); a VOLUME_GRID x VOLUME_GRID grid of rays joining the two faces;
    * ``cylinder``: a cone frustum from ``radius=R`` to ``radius_far=R`` (m); rays on rings;
    * ``disc``: a flat sector of opening ``angle=DEG`` in the sensor's x-z plane, from the
      sensor's origin; a fan of rays CONE_RAY_SPACING degrees apart.

    Raises ArgumentError for an unknown volume or a bad size."""
    kind = obj.settings.get("volume", "ray")
    if kind in ("ray", "cone"):
        return None
    (offset,) = _floats(obj, "offset", 1, (0.0,))
    far = cutoff if math.isfinite(cutoff) else offset + 1.0
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
                rays: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[float, int, np.ndarray, np.ndarray] | None:
    """The detection nearest to the sensor's origin among ``rays`` (see :func:`volume_rays`):
    (its distance from the origin m, geom, point (3,) in the sensor frame, surface normal (3,)
    in the world frame), or None."""
    starts, dirs, lengths = rays
    best = None
    gid = np.array([-1], dtype=np.int32)
    normal = np.zeros(3)
    for o, u, length in zip(starts, dirs, lengths):
        dist = mujoco.mj_ray(m, d, origin + rot @ o, rot @ u, None, 1, exclude, gid, normal)
        if dist < 0 or dist > length or gid[0] < 0:
            continue
        point = o + u * dist
        reach = float(np.linalg.norm(point))
        if best is None or reach < best[0]:
            best = (reach, int(gid[0]), point, normal.copy())
    return best


def proximity_reading(sim: SimulationView, handle: int) -> tuple[bool, list[float], int, list[float]]:
    """``simxReadProximitySensor``'s values: (detected, detected point (3,) m, detected object
    handle, detected surface normal (3,)), point and normal in the sensor frame.

    A ray-type sensor casts one ray along +z; a cone-type one (``angle=``) a fan of rays filling
    the cone (:func:`cone_directions`), a pyramid, cylinder or disc one (``volume=``) the rays of
    :func:`volume_rays`, and each reports the nearest hit, as V-REP's cone sensor
    reports the nearest point of what lies in its volume (within the ray spacing), leaving out
    surfaces met beyond ``max_angle=`` (:func:`max_angle`; cone sensors only). Geoms of the
    sensor's own body are not seen; the range is the rangefinder's ``cutoff`` (0: unlimited).
    Nothing detected: (False, [0, 0, 0], -1, [0, 0, 0]).

    Raises UnknownObjectError/ObjectTypeError for another handle, ArgumentError for a bad
    ``angle=`` setting.
    """
    world = sim.world
    obj = world.get(handle, PROXIMITY_SENSOR)
    m, d = world.model, world.data
    site = obj.mj_id
    k = _site_sensor(m, site, mujoco.mjtSensor.mjSENS_RANGEFINDER)
    cutoff = float(m.sensor_cutoff[k]) if k is not None and m.sensor_cutoff[k] > 0 else math.inf
    rot = d.site_xmat[site].reshape(3, 3)
    origin = d.site_xpos[site].copy()
    exclude = int(m.site_bodyid[site])
    rays = volume_rays(obj, cutoff)
    angle = cone_angle(obj) if rays is None else 0.0
    if rays is not None:
        found = _volume_hit(m, d, rot, origin, exclude, rays)
        if found is None:
            return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
        dist, geom, point, normal = found
    elif angle > 0:
        local = cone_directions(angle)
        n = len(local)
        geoms, dists, normals = np.full(n, -1, np.int32), np.full(n, -1.0), np.zeros(n * 3)
        mujoco.mj_multiRay(m, d, origin, (local @ rot.T).ravel(), None, 1, exclude, geoms, dists,
                           normals, n, min(cutoff, mujoco.mjMAXVAL))
        found = (dists >= 0) & (geoms >= 0) & (dists <= cutoff)
        limit = max_angle(obj)
        if limit < math.pi / 2:  # the ray against the surface's normal (both unit vectors)
            facing = -np.einsum("ij,ij->i", local @ rot.T, normals.reshape(-1, 3))
            found &= facing >= math.cos(limit) - 1e-9
        hits = np.flatnonzero(found)
        if hits.size == 0:
            return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
        i = int(hits[np.argmin(dists[hits])])
        dist, geom, point = float(dists[i]), int(geoms[i]), local[i] * dists[i]
        normal = normals[3 * i:3 * i + 3]
    else:
        ids = np.array([-1], dtype=np.int32)
        normal = np.zeros(3)
        dist = mujoco.mj_ray(m, d, origin, rot[:, 2].copy(), None, 1, exclude, ids, normal)
        geom = int(ids[0])
        if dist < 0 or dist > cutoff or geom < 0:
            return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
        point = np.array([0.0, 0.0, dist])
    hit = _shape_of_body(world).get(int(m.geom_bodyid[geom]), -1)
    n = rot.T @ normal
    norm = np.linalg.norm(n)
    n = n / norm if norm > 0 else n
    return True, [float(x) for x in point], hit, [float(x) for x in n]
