"""Sensors: proximity, force and vision-sensor reads, as V-REP's legacy remote API has them,
and the per-simulation sensor state.

The command handlers ``(sim, args) -> value`` are listed in :data:`SENSOR_HANDLERS`; each checks
its arguments and raises the exceptions of :mod:`simx_client.protocol`, and returns plain ints,
floats, bools, str, bytes and lists. The functions they call (``proximity_reading``,
``force_sensor_reading``, ``vision_packet`` ...) take plain values and serve in-process callers
too. Neighbouring concerns have modules of their own: :mod:`simx_server.collisions` (collision
and distance), :mod:`simx_server.kinematics` (joint matrices, velocities),
:mod:`simx_server.group_data` and :mod:`simx_server.object_params`.

MuJoCo mapping (see the per-function docstrings for the details):

* proximity sensor = a site carrying a ``rangefinder``: one ``mj_ray`` along the site's +z,
  excluding the site's own body, limited by the rangefinder's ``cutoff``; the surface normal is
  the one ``mj_ray`` computes for the geom it hits.
* force sensor = a site carrying a ``force`` sensor (and optionally a ``torque`` sensor): the
  interaction force/torque between the site's body and its parent, in the site frame.

Derived quantities (positions of bodies, sensor data) are those of the world's last
``mj_forward``, which ``World.step`` and every state change run.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any, Callable

import mujoco
import numpy as np

from simx_client.protocol import ArgumentError, ObjectTypeError
from simx_server.arguments import check_args as _args
from simx_server.world import FORCE_SENSOR, PROXIMITY_SENSOR, SHAPE, VISION_SENSOR, World

if TYPE_CHECKING:
    from simx_server.collisions import _Probe
    from simx_server.simulation import Simulation

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


#: Command name -> handler, merged into simx_server.commands.HANDLERS.
SENSOR_HANDLERS: dict[str, Callable[[Simulation, list], Any]] = {
    "ReadForceSensor": read_force_sensor,
    "BreakForceSensor": break_force_sensor,
    "ReadVisionSensor": read_vision_sensor,
    "SetVisionSensorImage": set_vision_sensor_image,
    "ReadProximitySensor": read_proximity_sensor,
}

#: Command name -> number of leading arguments that identify it (for protocol.COMMANDS).
SENSOR_IDENTITY_ARITY: dict[str, int] = {
    "ReadForceSensor": 1,
    "BreakForceSensor": 1,
    "ReadVisionSensor": 1,
    "SetVisionSensorImage": 1,
    "ReadProximitySensor": 1,
}
