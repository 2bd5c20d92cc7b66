"""Sensors and queries: proximity, force and vision sensors, collision and distance, joint
matrices, velocities, group data and object parameters, as V-REP's legacy remote API has them.

The command handlers ``(sim, args) -> value`` are listed in :data:`SENSOR_HANDLERS`; each checks
its arguments and raises the exceptions of :mod:`simx_client.protocol`, and returns plain ints,
floats, bools, str, bytes and lists. The functions they call (``joint_matrix``, ``collision``,
``distance``, ``object_velocity``, ``group_data``, ``vision_packet`` ...) take plain values and
serve in-process callers too.

MuJoCo mapping (see the per-function docstrings for the details):

* proximity sensor = a site carrying a ``rangefinder``: one ``mj_ray`` along the site's +z,
  excluding the site's own body, limited by the rangefinder's ``cutoff``; the surface normal is
  the one ``mj_ray`` computes for the geom it hits.
* force sensor = a site carrying a ``force`` sensor (and optionally a ``torque`` sensor): the
  interaction force/torque between the site's body and its parent, in the site frame.
* collision / distance = ``mj_geomDistance`` between the collidable geoms (``contype`` or
  ``conaffinity`` not 0) of shapes (bodies), independent of MuJoCo's contact filtering, so
  static bodies and excluded pairs are measured too.
* collision and distance objects are declared in the scene::

      <custom>
        <text name="simx.collision:NAME" data="entity1=BODY entity2=BODY"/>
        <text name="simx.distance:NAME" data="entity1=BODY entity2=all"/>
      </custom>

  ``entity2`` may be ``all`` (or left out): every other collidable geom. Handles of collision
  objects and of distance objects are two namespaces of their own, each from 1 in text order.

Derived quantities (positions of bodies, sensor data, velocities) are those of the world's last
``mj_forward``, which ``World.step`` and every state change run.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, Callable

import mujoco
import numpy as np

from simx_client import constants as C
from simx_client.protocol import ArgumentError, ObjectTypeError, UnknownObjectError, UnsupportedError
from simx_server import motors, physics
from simx_server.arguments import as_floats, check_args as _args, quote
from simx_server.world import (_TYPE_NAMES, FORCE_SENSOR, JOINT, PROXIMITY_SENSOR,
                               SHAPE, VISION_SENSOR, World, euler_from_matrix, parse_settings,
                               quaternion_from_matrix)

if TYPE_CHECKING:
    from simx_server.simulation import Simulation

_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
_BALL, _FREE = int(mujoco.mjtJoint.mjJNT_BALL), int(mujoco.mjtJoint.mjJNT_FREE)
_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)

#: Signed distance (m) at or below which two geoms are in collision (touching counts).
COLLISION_TOLERANCE = 1e-6
#: Largest distance (m) CheckDistance / ReadDistance report; farther is reported as this.
DISTANCE_MAX = 1000.0

# V-REP values used in replies (vrepConst.py).
SIM_JOINT_REVOLUTE, SIM_JOINT_PRISMATIC, SIM_JOINT_SPHERICAL = 10, 11, 12
SIM_JOINTMODE_FORCE = 5
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
class _Probe:
    """A declared collision or distance object."""

    handle: int
    name: str
    entity1: str | None
    entity2: str | None  # None: everything else (sim_handle_all)
    error: str | None  # why the declaration cannot be used, if it cannot


@dataclasses.dataclass
class SensorState:
    """What sensors keep between calls; one per Simulation (``sim.sensors``)."""

    passive: PassiveImages = dataclasses.field(default_factory=PassiveImages)
    broken: dict[int, tuple[int, float]] = dataclasses.field(default_factory=dict)  # handle -> (stops, t)
    probes_model: Any = None  # the model the probes below were read from
    probes: dict[str, dict[str, _Probe]] = dataclasses.field(default_factory=dict)  # kind -> name -> probe
    probe_handles: dict[str, dict[str, int]] = dataclasses.field(
        default_factory=lambda: {"collision": {}, "distance": {}})  # never reused


def is_passive(sim: Simulation, handle: int) -> bool:
    """Whether vision sensor ``handle`` is passive (``image=external`` in its custom text)."""
    return sim.world.get(handle, VISION_SENSOR).settings.get("image") == "external"


def override_image(sim: Simulation, handle: int, grey: bool) -> np.ndarray | None:
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


def _shape_of_body(world: World) -> dict[int, int]:
    return {o.mj_id: o.handle for o in world.objects.values() if o.type == SHAPE}


def _type_name(world: World, handle: int) -> str:
    return _TYPE_NAMES.get(world.objects[handle].type, "object")


# ------------------------------------------------------------------------ joints
def joint_matrix(world: World, handle: int) -> np.ndarray:
    """Intrinsic transform (3, 4) of a joint: [R | t], in the joint's own frame.

    Hinge: rotation about z by ``q - ref``; slide: translation ``q - ref`` along z; ball: the
    rotation of its quaternion; free: its position and quaternion (world frame).
    """
    obj = world.get(handle, JOINT)
    m, d = world.model, world.data
    j = obj.mj_id
    jtype, a = int(m.jnt_type[j]), int(m.jnt_qposadr[j])
    out = np.zeros((3, 4))
    out[:, :3] = np.eye(3)
    if jtype == _HINGE:
        q = float(d.qpos[a] - m.qpos0[a])
        c, s = math.cos(q), math.sin(q)
        out[:2, :2] = [[c, -s], [s, c]]
    elif jtype == _SLIDE:
        out[2, 3] = float(d.qpos[a] - m.qpos0[a])
    else:
        qa = a if jtype == _BALL else a + 3
        quat = np.array(d.qpos[qa:qa + 4], dtype=float)
        quat /= np.linalg.norm(quat)
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, quat)
        out[:, :3] = rot.reshape(3, 3)
        if jtype == _FREE:
            out[:, 3] = d.qpos[a:a + 3]
    return out


def get_joint_matrix(sim: Simulation, args: list) -> list[float]:
    """``simxGetJointMatrix`` [h] -> 12 floats: the joint's intrinsic 3x4 transform, row-major
    (R00 R01 R02 tx R10 ... tz), m. See :func:`joint_matrix`."""
    (h,) = _args(args, "int")
    return joint_matrix(sim.world, h).reshape(12).tolist()


def set_spherical_joint_matrix(sim: Simulation, args: list) -> None:
    """``simxSetSphericalJointMatrix`` [h, [12 floats]] -> None.

    Sets a ball joint's rotation from the rotation part of a 3x4 row-major matrix (the
    translation column is ignored, as in V-REP) and zeroes its angular velocity. The 12 floats
    may also come flat ([h, m0, ..., m11]). Raises ObjectTypeError for other joints and
    ArgumentError for a matrix whose 3x3 part is not a rotation (tolerance 1e-3).
    """
    if len(args) == 13:
        args = [args[0], list(args[1:])]
    h, values = _args(args, "int", "any")
    world = sim.world
    obj = world.get(h, JOINT)
    m, d = world.model, world.data
    if int(m.jnt_type[obj.mj_id]) != _BALL:
        raise ObjectTypeError(f"joint {obj.name!r} is not a spherical (ball) joint: "
                              "use simxSetJointPosition for revolute and prismatic joints")
    rot = np.array(as_floats(values, 12, "matrix")).reshape(3, 4)[:, :3]
    if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-3) or np.linalg.det(rot) < 0:
        raise ArgumentError("matrix: its 3x3 rotation part (elements 0-2, 4-6, 8-10) is not a "
                            "rotation matrix (orthonormal, determinant +1)")
    u, _, vt = np.linalg.svd(rot)  # nearest exact rotation
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (u @ vt).reshape(9))
    a, v = int(m.jnt_qposadr[obj.mj_id]), int(m.jnt_dofadr[obj.mj_id])
    d.qpos[a:a + 4] = quat / np.linalg.norm(quat)
    d.qvel[v:v + 3] = 0.0
    sim.world.changed()


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


def _stamp(sim: Simulation) -> tuple[int, float]:
    return getattr(sim, "stop_requests", 0), sim.world.time


def _broken(sim: Simulation, handle: int) -> bool:
    st = sim.sensors
    when = st.broken.get(handle)
    if when is None:
        return False
    stops, t = _stamp(sim)
    if stops != when[0] or t < when[1]:  # stopped (scene reset) since it broke
        del st.broken[handle]
        return False
    return True


def force_sensor_reading(sim: Simulation, handle: int) -> tuple[int, list[float], list[float]]:
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


def read_force_sensor(sim: Simulation, args: list) -> list:
    """``simxReadForceSensor`` [h] -> [state, [fx, fy, fz], [tx, ty, tz]].

    Force (N) and torque (N·m) that the site's body exchanges with its parent body, in the
    site frame, as MuJoCo's ``force``/``torque`` sensors report them (a torque sensor on the
    same site is used when there is one; otherwise the torque is computed the same way from
    ``cfrc_int``). ``state`` bit 0: data available (always, MuJoCo computes them at every
    step); bit 1: broken by simxBreakForceSensor, then both vectors are zero.
    """
    (h,) = _args(args, "int")
    state, force, torque = force_sensor_reading(sim, h)
    return [state, force, torque]


def break_force_sensor(sim: Simulation, args: list) -> None:
    """``simxBreakForceSensor`` [h] -> None.

    Marks the sensor broken: from now on simxReadForceSensor reports state bit 1 and zero
    vectors. Nothing else changes: in V-REP the two parts it joins come apart, but a MuJoCo
    kinematic tree cannot be cut at run time, so the bodies stay attached. A simulation stop
    (scene reset) repairs it.
    """
    (h,) = _args(args, "int")
    sim.world.get(h, FORCE_SENSOR)
    sim.sensors.broken[h] = _stamp(sim)


# ----------------------------------------------------------------- vision sensors
def vision_packet(sim: Simulation, handle: int) -> list[float]:
    """V-REP's default vision packet: 15 floats in 0..1.

    min, max and average of (intensity, red, green, blue, depth) over the sensor's current
    image (intensity = (R + G + B) / 3) and depth buffer (normalised between near and far).
    Passive sensors use their stored image; the depth is always the rendered one (what
    simxGetVisionSensorDepthBuffer returns).
    """
    rgb = override_image(sim, handle, False)
    if rgb is None:
        rgb = sim.vision.image(handle, False)
    px = rgb.reshape(-1, 3)
    intensity = px.sum(axis=1, dtype=np.uint32)
    depth = sim.vision.depth(handle)
    mins = [intensity.min() / 765.0, *(px.min(axis=0) / 255.0), float(depth.min())]
    maxs = [intensity.max() / 765.0, *(px.max(axis=0) / 255.0), float(depth.max())]
    avgs = [intensity.mean() / 765.0, *(px.mean(axis=0) / 255.0), float(depth.mean(dtype=np.float64))]
    return [float(x) for x in (*mins, *maxs, *avgs)]


def read_vision_sensor(sim: Simulation, args: list) -> list:
    """``simxReadVisionSensor`` [h] -> [detectionState, [[15 floats]]].

    One auxiliary packet, V-REP's default one (see :func:`vision_packet`), computed from the
    sensor's current image. simx has no vision filters nor trigger conditions, so
    detectionState is always False and there are no further packets.
    """
    (h,) = _args(args, "int")
    sim.world.get(h, VISION_SENSOR)
    return [False, [vision_packet(sim, h)]]


def _image_bytes(value: Any, what: str) -> bytes:
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    if isinstance(value, (list, tuple)):
        arr = np.asarray(value) if value else np.zeros(0, dtype=np.int64)
        if arr.ndim != 1 or arr.dtype.kind not in "iu" or (arr.size and (arr.min() < -128 or arr.max() > 255)):
            raise ArgumentError(f"{what} as a list must hold ints in -128..255 (signed or unsigned bytes)")
        return (arr.astype(np.int64) & 0xFF).astype(np.uint8).tobytes()
    raise ArgumentError(f"{what} must be bytes or a list of byte values, got {type(value).__name__}")


def set_vision_sensor_image(sim: Simulation, args: list) -> None:
    """``simxSetVisionSensorImage`` [h, image, options] -> None.

    Writes the image of a passive sensor (``image=external`` in its ``simx:NAME`` custom text;
    other sensors -> ObjectTypeError). ``image``: bytes (or a list of byte values), rows
    bottom-up, resX*resY*3 RGB bytes, or resX*resY grey bytes when ``options`` bit 0 is set;
    any other length -> ArgumentError. simxGetVisionSensorImage returns it from then on.
    """
    h, image, options = _args(args, "int", "any", "int")
    obj = sim.world.get(h, VISION_SENSOR)
    if obj.settings.get("image") != "external":
        raise ObjectTypeError(f"vision sensor {obj.name!r} is not passive: only sensors declared with "
                              f"<text name=\"simx:{obj.name}\" data=\"image=external\"/> accept images")
    spec = sim.vision.spec(h)
    grey = bool(options & 1)
    data = _image_bytes(image, "image")
    need = spec.width * spec.height * (1 if grey else 3)
    if len(data) != need:
        raise ArgumentError(f"image has {len(data)} bytes; vision sensor {obj.name!r} is "
                            f"{spec.width}x{spec.height}, so it needs {need} "
                            f"({'grey, options bit 0 set' if grey else 'RGB, options bit 0 clear'})")
    img = np.frombuffer(data, dtype=np.uint8)
    if grey:
        rgb = np.repeat(img.reshape(spec.height, spec.width, 1), 3, axis=2)
    else:
        rgb = img.reshape(spec.height, spec.width, 3).copy()
    sim.sensors.passive.set(h, rgb)
    sim.world.version += 1


# -------------------------------------------------------------- proximity sensors
def proximity_reading(sim: Simulation, handle: int) -> tuple[bool, list[float], int, list[float]]:
    """(detected, point (3,) m, object handle, normal (3,)) in the sensor frame; see below."""
    world = sim.world
    obj = world.get(handle, PROXIMITY_SENSOR)
    m, d = world.model, world.data
    site = obj.mj_id
    k = _site_sensor(m, site, mujoco.mjtSensor.mjSENS_RANGEFINDER)
    cutoff = float(m.sensor_cutoff[k]) if k is not None and m.sensor_cutoff[k] > 0 else math.inf
    rot = d.site_xmat[site].reshape(3, 3)
    geom = np.array([-1], dtype=np.int32)
    normal = np.zeros(3)
    dist = mujoco.mj_ray(m, d, d.site_xpos[site].copy(), rot[:, 2].copy(), None, 1,
                         int(m.site_bodyid[site]), geom, normal)
    if dist < 0 or dist > cutoff or geom[0] < 0:
        return False, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]
    hit = _shape_of_body(world).get(int(m.geom_bodyid[geom[0]]), -1)
    n = rot.T @ normal
    norm = np.linalg.norm(n)
    n = n / norm if norm > 0 else n
    return True, [0.0, 0.0, float(dist)], hit, [float(x) for x in n]


def read_proximity_sensor(sim: Simulation, args: list) -> list:
    """``simxReadProximitySensor`` [h] -> [detected, [x, y, z], objectHandle, [nx, ny, nz]].

    One ray (``mj_ray``) from the site along its +z axis (MuJoCo's rangefinder), ignoring the
    site's own body, up to the rangefinder's ``cutoff`` (unlimited when 0). Point (m) and
    surface normal (unit, pointing out of the surface hit) are in the sensor (site) frame; the
    point is therefore (0, 0, distance). objectHandle: the shape (named body) hit, -1 for an
    unnamed body or the world. Nothing hit: [False, [0,0,0], -1, [0,0,0]].
    """
    (h,) = _args(args, "int")
    detected, point, hit, normal = proximity_reading(sim, h)
    return [detected, point, hit, normal]


# ------------------------------------------------------------ collision, distance
def _collidable(m: mujoco.MjModel) -> np.ndarray:
    return (m.geom_contype != 0) | (m.geom_conaffinity != 0)


def _entity_geoms(world: World, handle: int, what: str) -> tuple[np.ndarray, int]:
    obj = world.get(handle)
    if obj.type != SHAPE:
        raise ObjectTypeError(f"{what}: object {obj.name!r} (handle {handle}) is a "
                              f"{_type_name(world, handle)}; collision and distance work on shapes (bodies)")
    m = world.model
    geoms = np.flatnonzero((m.geom_bodyid == obj.mj_id) & _collidable(m))
    if geoms.size == 0:
        raise ObjectTypeError(f"{what}: shape {obj.name!r} has no collidable geom (all have contype=0 "
                              "and conaffinity=0), so it cannot collide nor be measured")
    return geoms, obj.mj_id


def _others(world: World, body: int) -> np.ndarray:
    """Collidable geoms of every body but ``body``, its parent and its children (MuJoCo's
    parent-child filter; the world body is never filtered)."""
    m = world.model
    gb = m.geom_bodyid
    keep = _collidable(m) & (gb != body)
    if not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        parent = int(m.body_parentid[body])
        if parent != 0:
            keep &= gb != parent
        keep &= ~((m.body_parentid[gb] == body) & (gb != 0))
    return np.flatnonzero(keep)


def _pairs(world: World, e1: int, e2: int) -> tuple[np.ndarray, np.ndarray]:
    g1, body = _entity_geoms(world, e1, "entity1")
    if e2 == C.sim_handle_all:
        g2 = _others(world, body)
    else:
        g2, _ = _entity_geoms(world, e2, "entity2")
        if e2 == e1:
            raise ArgumentError("entity1 and entity2 are the same shape; pass sim_handle_all (-2) "
                                "as entity2 to test a shape against everything else")
    a, b = np.meshgrid(g1, g2, indexing="ij")
    a, b = a.ravel(), b.ravel()
    m = world.model
    both_planes = (m.geom_type[a] == _PLANE) & (m.geom_type[b] == _PLANE)
    return a[~both_planes], b[~both_planes]


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


def collision(sim: Simulation, e1: int, e2: int) -> bool:
    """Whether shape ``e1`` touches or overlaps shape ``e2`` (or anything else, ``e2`` = -2)."""
    world = sim.world
    a, b = _pairs(world, e1, e2)
    close = _lower_bounds(world, a, b) <= COLLISION_TOLERANCE
    return any(_geom_distance(world, g1, g2, 2 * COLLISION_TOLERANCE) <= COLLISION_TOLERANCE
               for g1, g2 in zip(a[close], b[close]))


def distance(sim: Simulation, e1: int, e2: int) -> float:
    """Smallest distance (m, >= 0, at most DISTANCE_MAX) between shape ``e1`` and ``e2``."""
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


def _entity_args(sim: Simulation, args: list) -> tuple[int, int]:
    e1, e2 = _args(args, "int", "int")
    if e1 == C.sim_handle_all:
        raise ArgumentError("entity1 must be a shape handle; only entity2 may be sim_handle_all (-2)")
    return e1, e2


def check_collision(sim: Simulation, args: list) -> bool:
    """``simxCheckCollision`` [entity1, entity2] -> bool.

    Entities are shapes (bodies: all their collidable geoms, i.e. contype or conaffinity not 0);
    entity2 = sim_handle_all (-2) means every other collidable geom except those of the parent
    and child bodies (MuJoCo's parent-child filter). True when two geoms are at most
    COLLISION_TOLERANCE apart (touching or penetrating), by ``mj_geomDistance`` on the current
    poses: unlike ``data.contact`` this sees pairs that MuJoCo's contype/conaffinity, weld and
    exclude filters skip, such as two static bodies.
    """
    return collision(sim, *_entity_args(sim, args))


def check_distance(sim: Simulation, args: list) -> float:
    """``simxCheckDistance`` [entity1, entity2] -> float: the smallest distance (m) between the
    collidable geoms of two shapes (entity2 may be -2, as in simxCheckCollision), by
    ``mj_geomDistance``; 0 when they touch or overlap (V-REP reports no penetration depth), at
    most DISTANCE_MAX."""
    return distance(sim, *_entity_args(sim, args))


_PROBE_PREFIX = {"collision": "simx.collision:", "distance": "simx.distance:"}


def _probes(sim: Simulation, kind: str) -> dict[str, _Probe]:
    """The declared collision or distance objects, read from the model's custom texts."""
    st, m = sim.sensors, sim.world.model
    if st.probes_model is not m:
        st.probes = {k: {} for k in _PROBE_PREFIX}
        for i in range(m.ntext):
            tname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXT, i) or ""
            for k, prefix in _PROBE_PREFIX.items():
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
                st.probes[k][name] = _Probe(handle, name, e1, e2, error)
        st.probes_model = m
    return st.probes[kind]


def _probe_handle(sim: Simulation, args: list, kind: str) -> int:
    (name,) = _args(args, "str")
    probe = _probes(sim, kind).get(name[:-1] if name.endswith("#") else name)
    if probe is None:
        raise UnknownObjectError(f"no {kind} object {name!r} in scene {sim.world.scene_path.name}; declare "
                                 f"it as <text name=\"{_PROBE_PREFIX[kind]}{name}\" "
                                 f"data=\"entity1=BODY entity2=BODY|all\"/> in <custom>")
    return probe.handle


def _probe_entities(sim: Simulation, args: list, kind: str) -> tuple[int, int]:
    (h,) = _args(args, "int")
    probe = next((p for p in _probes(sim, kind).values() if p.handle == h), None)
    if probe is None:
        raise UnknownObjectError(f"no {kind} object with handle {h}")
    if probe.error:
        raise ArgumentError(probe.error)
    world = sim.world
    try:
        e1 = world.resolve(probe.entity1).handle
        e2 = C.sim_handle_all if probe.entity2 is None else world.resolve(probe.entity2).handle
    except UnknownObjectError as exc:
        raise UnknownObjectError(f"{kind} object {probe.name!r}: {exc}") from None
    return e1, e2


def get_collision_handle(sim: Simulation, args: list) -> int:
    """``simxGetCollisionHandle`` [name] -> handle of a collision object declared with
    ``<text name="simx.collision:NAME" data="entity1=BODY entity2=BODY|all"/>`` (own handle
    namespace from 1; a trailing ``#`` is ignored). Unknown name -> UnknownObjectError."""
    return _probe_handle(sim, args, "collision")


def read_collision(sim: Simulation, args: list) -> bool:
    """``simxReadCollision`` [h] -> bool: the collision object's state now (see
    simxCheckCollision; computed on demand from the current poses)."""
    return collision(sim, *_probe_entities(sim, args, "collision"))


def get_distance_handle(sim: Simulation, args: list) -> int:
    """``simxGetDistanceHandle`` [name] -> handle of a distance object declared with
    ``<text name="simx.distance:NAME" data="entity1=BODY entity2=BODY|all"/>``."""
    return _probe_handle(sim, args, "distance")


def read_distance(sim: Simulation, args: list) -> float:
    """``simxReadDistance`` [h] -> float: the distance object's smallest distance now (m; see
    simxCheckDistance)."""
    return distance(sim, *_probe_entities(sim, args, "distance"))


# --------------------------------------------------------------------- velocities
def object_velocity(sim: Simulation, handle: int) -> tuple[np.ndarray, np.ndarray]:
    """Linear (m/s) and angular (rad/s) velocity of an object's frame, world axes.

    ``mj_objectVelocity`` of the object's body frame (mjOBJ_XBODY, flg_local=0), moved to the
    object's own origin (site, camera, joint anchor, light) with v + w x r.
    """
    world = sim.world
    obj = world.get(handle)
    res = np.zeros(6)
    # mjOBJ_XBODY: the body's frame origin (xpos); mjOBJ_BODY would be its centre of mass
    mujoco.mj_objectVelocity(world.model, world.data, mujoco.mjtObj.mjOBJ_XBODY, obj.body, res, 0)
    w, v = res[:3], res[3:]
    pos, _ = world.frame(handle)
    return v + np.cross(w, pos - world.data.xpos[obj.body]), w.copy()


def get_object_velocity(sim: Simulation, args: list) -> list[list[float]]:
    """``simxGetObjectVelocity`` [h] -> [[vx, vy, vz], [wx, wy, wz]] in the world frame (m/s,
    rad/s), of the object's origin; see :func:`object_velocity`."""
    (h,) = _args(args, "int")
    v, w = object_velocity(sim, h)
    return [v.tolist(), w.tolist()]


# --------------------------------------------------------------------- group data
def _joint_properties(world: World, handle: int) -> tuple[list[int], list[float]]:
    m = world.model
    j = world.objects[handle].mj_id
    jtype, limited = int(m.jnt_type[j]), bool(m.jnt_limited[j])
    lo, hi = (float(x) for x in m.jnt_range[j])
    if jtype == _HINGE:
        return [SIM_JOINT_REVOLUTE, SIM_JOINTMODE_FORCE], [lo, hi - lo] if limited else [-math.pi, -1.0]
    if jtype == _SLIDE:
        return [SIM_JOINT_PRISMATIC, SIM_JOINTMODE_FORCE], [lo, hi - lo] if limited else [-math.inf, math.inf]
    if jtype == _BALL:
        return [SIM_JOINT_SPHERICAL, SIM_JOINTMODE_FORCE], [0.0, hi if limited else math.pi]
    return [-1, -1], [0.0, 0.0]  # a free joint has no V-REP counterpart


def _joint_state(world: World, handle: int) -> list[float]:
    jtype = int(world.model.jnt_type[world.objects[handle].mj_id])
    if jtype not in (_HINGE, _SLIDE):
        return [0.0, 0.0]  # as V-REP's simGetJointPosition fails for spherical joints
    return [world.joint_position(handle), world.joint_force(handle)]


def _path(world: World, handle: int) -> str:
    parts, h = [], handle
    while h != -1:
        parts.append(world.objects[h].name)
        h = world.objects[h].parent
    return "/" + "/".join(reversed(parts))


#: dataType -> (ints per object, floats per object, strings per object), V-REP's table.
GROUP_DATA_TYPES = {
    0: "names", 1: "types", 2: "parents", 3: "absolute positions", 4: "positions relative to parent",
    5: "absolute Euler angles", 6: "Euler angles relative to parent", 7: "absolute quaternions",
    8: "quaternions relative to parent", 9: "absolute position + Euler angles",
    10: "position + Euler angles relative to parent", 11: "absolute position + quaternion",
    12: "position + quaternion relative to parent", 13: "proximity sensor data",
    14: "force sensor data", 15: "joint state (position, force)", 16: "joint properties",
    17: "linear velocities", 18: "angular velocities", 19: "linear + angular velocities",
    20: "aliases", 21: "paths",
}


def group_data(sim: Simulation, object_type: int, data_type: int) -> list:
    """[handles, ints, floats, strings] for ``simxGetObjectGroupData``; see get_object_group_data."""
    world = sim.world
    if object_type in (C.sim_handle_all, C.sim_appobj_object_type):
        object_type = C.sim_handle_all
    elif not 0 <= object_type <= C.sim_object_mirror_type:
        raise UnsupportedError(f"objectType {object_type}: simx supports sim_handle_all (-2), "
                               "sim_appobj_object_type (109) and the sim_object_*_type values (0-14); "
                               "it has no collections")
    if data_type not in GROUP_DATA_TYPES:
        raise UnsupportedError(f"dataType {data_type} of simxGetObjectGroupData is not one of V-REP's "
                               "(0-19; 20 alias and 21 path of CoppeliaSim 4.2)")
    handles = world.objects_of_type(object_type)
    ints: list[int] = []
    floats: list[float] = []
    strings: list[str] = []
    for h in handles:
        obj = world.objects[h]
        if data_type in (0, 20):
            strings.append(obj.name)
        elif data_type == 21:
            strings.append(_path(world, h))
        elif data_type == 1:
            ints.append(obj.type)
        elif data_type == 2:
            ints.append(obj.parent)
        elif 3 <= data_type <= 12:
            pos, rot = world.relative_frame(h, -1 if data_type % 2 else C.sim_handle_parent)
            if data_type in (3, 4, 9, 10, 11, 12):
                floats += pos.tolist()
            if data_type in (5, 6, 9, 10):
                floats += euler_from_matrix(rot)
            if data_type in (7, 8, 11, 12):
                floats += quaternion_from_matrix(rot)
        elif data_type == 13:
            if obj.type == PROXIMITY_SENSOR:
                detected, point, hit, normal = proximity_reading(sim, h)
                ints += [int(detected), hit]
                floats += point + normal
            else:
                ints += [-1, -1]
                floats += [0.0] * 6
        elif data_type == 14:
            if obj.type == FORCE_SENSOR:
                state, force, torque = force_sensor_reading(sim, h)
                ints.append(state)
                floats += force + torque
            else:
                ints.append(-1)
                floats += [0.0] * 6
        elif data_type == 15:
            floats += _joint_state(world, h) if obj.type == JOINT else [0.0, 0.0]
        elif data_type == 16:
            i, f = _joint_properties(world, h) if obj.type == JOINT else ([-1, -1], [0.0, 0.0])
            ints += i
            floats += f
        else:  # 17, 18, 19
            v, w = object_velocity(sim, h)
            floats += (v.tolist() if data_type != 18 else []) + (w.tolist() if data_type != 17 else [])
    return [handles, ints, [float(x) for x in floats], strings]


def get_object_group_data(sim: Simulation, args: list) -> list:
    """``simxGetObjectGroupData`` [objectType, dataType] -> [handles, ints, floats, strings].

    objectType: sim_handle_all (-2) or sim_appobj_object_type (109) for every object, or a
    sim_object_*_type. Per object, by dataType (V-REP's table):
    0 name (1 string); 1 type (1 int); 2 parent handle (1 int); 3/4 position abs/rel-to-parent
    (3 floats, m); 5/6 Euler angles abs/rel (3 floats, rad, as simxGetObjectOrientation);
    7/8 quaternion abs/rel (4 floats x, y, z, w); 9/10 position + Euler (6 floats);
    11/12 position + quaternion (7 floats; V-REP's server wrote Euler angles there, simx writes
    the quaternion it names); 13 proximity sensor (2 ints state, object; 6 floats point, normal;
    -1, -1 and zeros for other objects); 14 force sensor (1 int state; 6 floats force, torque;
    -1 and zeros for others); 15 joint (2 floats position, force; zeros for others and for ball
    and free joints); 16 joint (2 ints type 10/11/12 revolute/prismatic/spherical and mode 5
    "force/torque" (every MuJoCo joint is dynamic); 2 floats lower limit and range: range -1
    for an unlimited hinge (V-REP's cyclic), -inf/inf for an unlimited slide, 0 and the cone
    angle for a ball; -1, -1, 0, 0 for others and free joints); 17 linear velocity (3 floats,
    m/s); 18 angular velocity (3 floats, rad/s); 19 both (6 floats); 20 alias (the name) and
    21 path ("/a/b/c"), strings, as CoppeliaSim 4.2. Others -> UnsupportedError.
    """
    object_type, data_type = _args(args, "int", "int")
    return group_data(sim, object_type, data_type)


# ---------------------------------------------------------------- object params
#: Known legacy object parameter ids (vrepConst.py), for messages.
PARAM_NAMES = {
    10: "sim_objintparam_visibility_layer", 11: "sim_objfloatparam_abs_x_velocity",
    12: "sim_objfloatparam_abs_y_velocity", 13: "sim_objfloatparam_abs_z_velocity",
    14: "sim_objfloatparam_abs_rot_velocity", 15: "sim_objfloatparam_objbbox_min_x",
    16: "sim_objfloatparam_objbbox_min_y", 17: "sim_objfloatparam_objbbox_min_z",
    18: "sim_objfloatparam_objbbox_max_x", 19: "sim_objfloatparam_objbbox_max_y",
    20: "sim_objfloatparam_objbbox_max_z", 21: "sim_objfloatparam_modelbbox_min_x",
    22: "sim_objfloatparam_modelbbox_min_y", 23: "sim_objfloatparam_modelbbox_min_z",
    24: "sim_objfloatparam_modelbbox_max_x", 25: "sim_objfloatparam_modelbbox_max_y",
    26: "sim_objfloatparam_modelbbox_max_z", 1000: "sim_visionfloatparam_near_clipping",
    1001: "sim_visionfloatparam_far_clipping", 1002: "sim_visionintparam_resolution_x",
    1003: "sim_visionintparam_resolution_y", 1004: "sim_visionfloatparam_perspective_angle",
    1005: "sim_visionfloatparam_ortho_size", 2000: "sim_jointintparam_motor_enabled",
    2001: "sim_jointintparam_ctrl_enabled", 2002: "sim_jointfloatparam_pid_p",
    2003: "sim_jointfloatparam_pid_i", 2004: "sim_jointfloatparam_pid_d",
    2005: "sim_jointfloatparam_intrinsic_x", 2006: "sim_jointfloatparam_intrinsic_y",
    2007: "sim_jointfloatparam_intrinsic_z", 2008: "sim_jointfloatparam_intrinsic_qx",
    2009: "sim_jointfloatparam_intrinsic_qy", 2010: "sim_jointfloatparam_intrinsic_qz",
    2011: "sim_jointfloatparam_intrinsic_qw", 2012: "sim_jointfloatparam_velocity",
    2013: "sim_jointfloatparam_spherical_qx", 2014: "sim_jointfloatparam_spherical_qy",
    2015: "sim_jointfloatparam_spherical_qz", 2016: "sim_jointfloatparam_spherical_qw",
    2017: "sim_jointfloatparam_upper_limit", 3000: "sim_shapefloatparam_init_velocity_x",
    3001: "sim_shapefloatparam_init_velocity_y", 3002: "sim_shapefloatparam_init_velocity_z",
    3003: "sim_shapeintparam_static", 3004: "sim_shapeintparam_respondable",
    3005: "sim_shapefloatparam_mass",
}
_FLOAT_GET = {11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 1000, 1001, 1004, *range(2002, 2018), 3005}
_FLOAT_SET = {1000, 1001, 1004, 2002, 2003, 2004, 2017, 3005}
_INT_GET = {1002, 1003, 2000, 2001, 3003, 3004}
_INT_SET = {2000, 2001}


def _pname(pid: int) -> str:
    return f"{PARAM_NAMES[pid]} ({pid})" if pid in PARAM_NAMES else f"parameter {pid}"


def _need(world: World, handle: int, otype: int, pid: int):
    obj = world.get(handle)
    if obj.type != otype:
        raise ObjectTypeError(f"{_pname(pid)} applies to {_TYPE_NAMES[otype]}s; object {obj.name!r} "
                              f"(handle {handle}) is a {_type_name(world, handle)}")
    return obj


def _unsupported(pid: int, kind: str, setting: bool) -> UnsupportedError:
    other = "int" if kind == "float" else "float"
    other_ids = (_INT_GET | _INT_SET) if kind == "float" else (_FLOAT_GET | _FLOAT_SET)
    if pid in other_ids:
        fn = f"simx{'Set' if setting else 'Get'}Object{other.capitalize()}Parameter"
        return UnsupportedError(f"{_pname(pid)} is an {other} parameter: use {fn}")
    if (pid in _FLOAT_GET and kind == "float") or (pid in _INT_GET and kind == "int"):
        return UnsupportedError(f"{_pname(pid)} is read-only in simx (it follows from the MJCF scene or the "
                                "simulation state)")
    return UnsupportedError(f"object {kind} {_pname(pid)} has no MuJoCo counterpart in simx")


def _perspective(m: mujoco.MjModel, spec) -> float:
    """V-REP's perspective angle: the larger of the horizontal and vertical view angles (rad)."""
    half = math.radians(float(m.cam_fovy[spec.camera])) / 2
    if spec.width > spec.height:
        return 2 * math.atan(math.tan(half) * spec.width / spec.height)
    return 2 * half


def _camera_check(world: World, obj, pid: int) -> None:
    m = world.model
    if m.cam_projection[obj.mj_id] != mujoco.mjtProjection.mjPROJ_PERSPECTIVE:
        raise ObjectTypeError(f"{_pname(pid)}: vision sensor {obj.name!r} is orthographic")
    if np.any(m.cam_sensorsize[obj.mj_id] > 0):
        raise UnsupportedError(f"{_pname(pid)}: camera {obj.name!r} defines its optics with sensorsize/"
                               "focal, not fovy; simx reads and sets the angle only for fovy cameras")


def _bbox(world: World, handle: int, pid: int) -> tuple[np.ndarray, np.ndarray]:
    obj = _need(world, handle, SHAPE, pid)
    m = world.model
    geoms = [g for g in np.flatnonzero(m.geom_bodyid == obj.mj_id) if m.geom_type[g] != _PLANE]
    if not geoms:
        raise ObjectTypeError(f"{_pname(pid)}: shape {obj.name!r} has no bounded geometry")
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    pts = []
    for g in geoms:
        c, half = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, m.geom_quat[g])
        pts.append((c + corners * half) @ rot.reshape(3, 3).T + m.geom_pos[g])
    allp = np.vstack(pts)
    return allp.min(axis=0), allp.max(axis=0)


def get_float_param(sim: Simulation, handle: int, pid: int) -> float:
    """Value of float parameter ``pid`` of object ``handle``; see get_object_float_parameter."""
    world = sim.world
    if pid not in _FLOAT_GET:
        world.get(handle)
        raise _unsupported(pid, "float", False)
    if pid in (11, 12, 13, 14):
        v, w = object_velocity(sim, handle)
        return float(np.linalg.norm(w)) if pid == 14 else float(v[pid - 11])
    if 15 <= pid <= 20:
        lo, hi = _bbox(world, handle, pid)
        return float((lo if pid < 18 else hi)[(pid - 15) % 3])
    if pid in (1000, 1001, 1004):
        obj = _need(world, handle, VISION_SENSOR, pid)
        spec = sim.vision.spec(handle)
        if pid == 1004:
            _camera_check(world, obj, pid)
            return _perspective(world.model, spec)
        return float(spec.near if pid == 1000 else spec.far)
    if pid == 3005:
        return float(world.model.body_mass[_need(world, handle, SHAPE, pid).mj_id])
    if pid in motors.FLOAT_PARAMS:
        _need(world, handle, JOINT, pid)
        return motors.get_param(world, handle, pid)
    obj = _need(world, handle, JOINT, pid)
    m, d = world.model, world.data
    jtype = int(m.jnt_type[obj.mj_id])
    if pid == 2012:
        if jtype not in (_HINGE, _SLIDE):
            raise ObjectTypeError(f"{_pname(pid)}: joint {obj.name!r} is not revolute nor prismatic")
        return float(d.qvel[m.jnt_dofadr[obj.mj_id]])
    if 2013 <= pid <= 2016 and jtype != _BALL:
        raise ObjectTypeError(f"{_pname(pid)}: joint {obj.name!r} is not a spherical (ball) joint")
    mat = joint_matrix(world, handle)
    if 2005 <= pid <= 2007:
        return float(mat[pid - 2005, 3])
    quat = np.empty(4)  # w, x, y, z
    mujoco.mju_mat2Quat(quat, mat[:, :3].reshape(9).copy())
    i = (pid - 2008) if pid <= 2011 else (pid - 2013)
    return float(quat[(i + 1) % 4])  # x, y, z, w


def set_float_param(sim: Simulation, handle: int, pid: int, value: float) -> None:
    """Set float parameter ``pid`` of ``handle``; see set_object_float_parameter."""
    world = sim.world
    if pid not in _FLOAT_SET:
        world.get(handle)
        raise _unsupported(pid, "float", True)
    if pid in (1000, 1001, 1004):
        if not math.isfinite(value):
            raise ArgumentError(f"{_pname(pid)}: value must be finite, got {quote(value)}")
        obj = _need(world, handle, VISION_SENSOR, pid)
        spec = sim.vision.spec(handle)
        if pid == 1004:
            _camera_check(world, obj, pid)
            if not 0 < value < math.pi:
                raise ArgumentError(f"{_pname(pid)}: angle must be in (0, pi) rad, got {value}")
            half = value / 2
            if spec.width > spec.height:
                half = math.atan(math.tan(half) * spec.height / spec.width)
            world.model.cam_fovy[spec.camera] = math.degrees(2 * half)
        else:
            near, far = (value, spec.far) if pid == 1000 else (spec.near, value)
            if not 0 < near < far:
                raise ArgumentError(f"{_pname(pid)}: need 0 < near < far (m), got near={near} far={far}")
            spec.near, spec.far = near, far
        world.version += 1  # renders and normalised depth change
        return
    if pid in motors.FLOAT_PARAMS:
        _need(world, handle, JOINT, pid)
        motors.set_param(world, handle, pid, value, _pname(pid))
        return
    # 3005: mass; the inertia scales with it (same shape, new density), as V-REP keeps it
    body = _need(world, handle, SHAPE, pid).mj_id
    m, d = world.model, world.data
    try:
        m.body_inertia[body] = physics.scaled_inertia(value, float(m.body_mass[body]), m.body_inertia[body])
    except ArgumentError as exc:
        raise ArgumentError(f"{_pname(pid)}: {exc}") from None
    m.body_mass[body] = value
    saved = (d.qpos.copy(), d.qvel.copy(), d.act.copy(), d.qacc_warmstart.copy(), d.time)
    mujoco.mj_setConst(m, d)  # subtree masses and other mass-dependent constants; clobbers qpos
    d.qpos[:], d.qvel[:], d.act[:], d.qacc_warmstart[:], d.time = saved
    sim.world.changed()


def get_int_param(sim: Simulation, handle: int, pid: int) -> int:
    """Value of int parameter ``pid`` of ``handle``; see get_object_int_parameter."""
    world = sim.world
    if pid not in _INT_GET:
        world.get(handle)
        raise _unsupported(pid, "int", False)
    if pid in (1002, 1003):
        _need(world, handle, VISION_SENSOR, pid)
        spec = sim.vision.spec(handle)
        return spec.width if pid == 1002 else spec.height
    if pid in motors.INT_PARAMS:
        _need(world, handle, JOINT, pid)
        return motors.get_param(world, handle, pid)
    obj = _need(world, handle, SHAPE, pid)
    m = world.model
    if pid == 3003:
        return int(m.body_weldid[obj.mj_id] == 0)
    return int(bool(np.any(_collidable(m)[m.geom_bodyid == obj.mj_id])))


def set_int_param(sim: Simulation, handle: int, pid: int, value: int) -> None:
    """Set int parameter ``pid`` of ``handle``; see set_object_int_parameter."""
    world = sim.world
    if pid not in _INT_SET:
        world.get(handle)
        if pid in (1002, 1003):
            _need(world, handle, VISION_SENSOR, pid)
            raise UnsupportedError(f"{_pname(pid)}: the resolution of a vision sensor is fixed when the scene "
                                   "loads (the MJCF camera's resolution attribute); it cannot change at run time")
        raise _unsupported(pid, "int", True)
    # 2000 motor enabled, 2001 control loop enabled: simx_server.motors
    _need(world, handle, JOINT, pid)
    motors.set_param(world, handle, pid, value, _pname(pid))


def get_object_float_parameter(sim: Simulation, args: list) -> float:
    """``simxGetObjectFloatParameter`` [h, id] -> float.

    Supported ids: 11/12/13 absolute x/y/z velocity (m/s) and 14 absolute rotation speed
    (|w|, rad/s) of any object; 15-20 bounding box min/max x/y/z of a shape's geoms in its own
    frame (m); vision sensors: 1000 near and 1001 far clipping (m), 1004 perspective angle
    (rad, the larger of the horizontal and vertical view angles, from the camera's fovy);
    joints: 2005-2007 intrinsic translation, 2008-2011 intrinsic quaternion (x, y, z, w),
    2012 velocity (rad/s or m/s), 2013-2016 spherical joint quaternion, 2002-2004 PID gains and
    2017 upper velocity of the motor (simx_server.motors.get_param); shapes: 3005 mass (kg).
    Any other id -> UnsupportedError naming it.
    """
    h, pid = _args(args, "int", "int")
    return get_float_param(sim, h, pid)


def set_object_float_parameter(sim: Simulation, args: list) -> None:
    """``simxSetObjectFloatParameter`` [h, id, value] -> None.

    Settable: 1000 near / 1001 far clipping (m, 0 < near < far; they rescale the depth buffer
    and depth images at once), 1004 perspective angle (rad, in (0, pi); changes the camera's
    fovy), 2002 P gain and 2017 upper velocity of a joint motor (simx_server.motors.set_param), 3005 mass of a shape (kg, within limits.MIN_MASS..MAX_MASS; its
    inertia scales along and must stay under limits.MAX_INERTIA). Values out of range, NaN and
    infinities -> ArgumentError naming the bound. Read-only ids and unknown ids -> UnsupportedError.
    """
    h, pid, value = _args(args, "int", "int", "float")
    set_float_param(sim, h, pid, value)


def get_object_int_parameter(sim: Simulation, args: list) -> int:
    """``simxGetObjectIntParameter`` [h, id] -> int.

    Supported ids: vision sensors 1002/1003 resolution x/y (pixels); joints 2000 motor enabled,
    2001 control loop enabled (1: position control when the motor is on); shapes
    3003 static (1 when welded to the world), 3004 respondable (1 when a geom has contype or
    conaffinity). Others -> UnsupportedError naming the id.
    """
    h, pid = _args(args, "int", "int")
    return get_int_param(sim, h, pid)


def set_object_int_parameter(sim: Simulation, args: list) -> None:
    """``simxSetObjectIntParameter`` [h, id, value] -> None.

    Settable: 2000 motor enabled (0: free joint) and 2001 control loop enabled (1: position
    control, holding the current position when it starts; 0: velocity control) of a joint
    (simx_server.motors.set_param). Resolutions (1002/1003) cannot change at run time and
    other ids -> UnsupportedError with the reason.
    """
    h, pid, value = _args(args, "int", "int", "int")
    set_int_param(sim, h, pid, value)


#: Command name -> handler, to merge into simx_server.commands.HANDLERS.
SENSOR_HANDLERS: dict[str, Callable[[Simulation, list], Any]] = {
    "GetJointMatrix": get_joint_matrix,
    "SetSphericalJointMatrix": set_spherical_joint_matrix,
    "ReadForceSensor": read_force_sensor,
    "BreakForceSensor": break_force_sensor,
    "ReadVisionSensor": read_vision_sensor,
    "SetVisionSensorImage": set_vision_sensor_image,
    "ReadProximitySensor": read_proximity_sensor,
    "GetCollisionHandle": get_collision_handle,
    "ReadCollision": read_collision,
    "GetDistanceHandle": get_distance_handle,
    "ReadDistance": read_distance,
    "CheckCollision": check_collision,
    "CheckDistance": check_distance,
    "GetObjectVelocity": get_object_velocity,
    "GetObjectGroupData": get_object_group_data,
    "GetObjectFloatParameter": get_object_float_parameter,
    "SetObjectFloatParameter": set_object_float_parameter,
    "GetObjectIntParameter": get_object_int_parameter,
    "SetObjectIntParameter": set_object_int_parameter,
}

#: Command name -> number of leading arguments that identify it (for protocol.COMMANDS).
SENSOR_IDENTITY_ARITY: dict[str, int] = {
    "GetJointMatrix": 1, "SetSphericalJointMatrix": 1, "ReadForceSensor": 1, "BreakForceSensor": 1,
    "ReadVisionSensor": 1, "SetVisionSensorImage": 1, "ReadProximitySensor": 1,
    "GetCollisionHandle": 1, "ReadCollision": 1, "GetDistanceHandle": 1, "ReadDistance": 1,
    "CheckCollision": 2, "CheckDistance": 2, "GetObjectVelocity": 1, "GetObjectGroupData": 2,
    "GetObjectFloatParameter": 2, "SetObjectFloatParameter": 2,
    "GetObjectIntParameter": 2, "SetObjectIntParameter": 2,
}
