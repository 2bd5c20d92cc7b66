"""Sensors: force and vision-sensor reads as V-REP's legacy remote API has them, passive
images, and the per-simulation sensor state; proximity sensors are :mod:`simx_server.sim.proximity`.

The command handlers ``(sim, args) -> value`` are in :mod:`simx_server.commands.sensors`; each
checks its arguments and raises the exceptions of :mod:`simx_wire.protocol`, and returns plain
ints, floats, bools, str, bytes and lists. The functions they call (``force_sensor_reading``,
``vision_packet`` ...) take plain values and serve in-process callers too. Neighbouring concerns
have modules of their own: :mod:`simx_server.sim.collisions` (collision and distance),
:mod:`simx_server.sim.kinematics` (joint matrices, velocities), :mod:`simx_server.sim.group_data`
and :mod:`simx_server.sim.object_params`.

A force sensor is a site carrying a ``force`` sensor (and optionally a ``torque`` sensor); it
reads the force and torque that what hangs below it exerts on its parent, in the site frame, as
CoppeliaSim reads them (:mod:`simx_server.sim.force_sensors`). Derived
quantities (positions of bodies, sensor data) are those of the world's last ``mj_forward``,
which ``World.step`` and every state change run.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Callable

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, ObjectTypeError
from simx_server.sim import force_sensors
from simx_server.sim.render_thread import wait_for
from simx_server.sim.kept import PerObject
from simx_server.sim.state import SimulationView
from simx_server.sim.world import FORCE_SENSOR, VISION_SENSOR

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
        """Store ``rgb`` ((h, w, 3) uint8, rows bottom-up) as the sensor's image.

        Args:
            handle: the sensor's handle.
            rgb: the image.
        """
        self._images[handle] = rgb

    def get(self, handle: int) -> np.ndarray | None:
        """The stored image, or None if none was ever set.

        Args:
            handle: the sensor's handle.

        Returns:
            (h, w, 3) uint8, rows bottom-up, or None.
        """
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
    """Whether vision sensor ``handle`` is passive (``image=external`` in its custom text).

    Args:
        sim: the simulation.
        handle: a vision sensor's handle.

    Returns:
        True for a passive sensor.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
    """
    return sim.world.get(handle, VISION_SENSOR).settings.get("image") == "external"


def override_image(sim: SimulationView, handle: int, grey: bool) -> np.ndarray | None:
    """The image a passive sensor shows instead of a rendering, or None for other sensors.

    Same contract as ``VisionSensors.image``: rows bottom-up, (h, w, 3) uint8 RGB, or (h, w)
    uint8 ``(R + G + B) // 3`` when ``grey``. A passive sensor nobody wrote to yet is black.
    Raises UnknownObjectError / ObjectTypeError for a handle that is not a vision sensor.

    Args:
        sim: the simulation.
        handle: a vision sensor's handle.
        grey: one byte per pixel (``simxGetVisionSensorImage``'s options bit 0).

    Returns:
        The image, or None.
    """
    if not is_passive(sim, handle) or sim.vision.record(handle) is not None:  # handled: its record
        return None
    rgb = sim.sensors.passive.get(handle)
    spec = sim.vision.spec(handle)
    if rgb is None or rgb.shape[:2] != (spec.height, spec.width):  # none yet (or scene edited)
        rgb = np.zeros((spec.height, spec.width, 3), dtype=np.uint8)
    if grey:
        return (rgb.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8)
    return rgb


def vision_hooks(sim: SimulationView, handle: int) -> Any:
    """The vision callbacks of the scripts attached to sensor ``handle``
    (:meth:`simx_server.scripts.vision_callbacks.VisionCallbacks.hook`), or None.

    Args:
        sim: the simulation.
        handle: a vision sensor's handle.

    Returns:
        A :class:`~simx_server.sim.vision_handled.VisionHooks`, or None.
    """
    callbacks = getattr(sim.scripts, "vision", None)
    return None if callbacks is None else callbacks.hook(handle)


def handle_with_callbacks(sim: SimulationView, handle: int) -> None:
    """Handle vision sensor ``handle`` now with its scripts' vision callbacks, if it has any and is
    not passive (``sim.handleVisionSensor``; :mod:`simx_server.sim.vision_handled`).

    Args:
        sim: the simulation.
        handle: a vision sensor's handle.
    """
    hooks = vision_hooks(sim, handle)
    if hooks is not None and not is_passive(sim, handle):
        sim.vision.handle(handle, hooks)


def set_passive_image(sim: SimulationView, handle: int, image: bytes, grey: bool) -> None:
    """Write the image of a passive vision sensor (``simxSetVisionSensorImage``,
    ``sim.setVisionSensorImg``); the sensor's image reads return it from then on. When the
    sensor's scripts have a vision callback, it is handled with that image as CoppeliaSim does
    (``CVisionSensor::setVisionSensorImg``): reads then return what the callbacks made of it.

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
    rec = sim.vision.in_callback(handle)
    if rec is not None:  # written by the sensor's own callback: the image it is handling
        rec.rgb = rgb
        return
    hooks = vision_hooks(sim, handle)
    if hooks is not None:
        sim.vision.handle(handle, hooks, rgb)


# ------------------------------------------------------------------ force sensors
def site_sensor(m: mujoco.MjModel, site: int, kind: mujoco.mjtSensor) -> int | None:
    """The first MuJoCo sensor of ``kind`` on ``site``.

    Args:
        m: the MuJoCo model.
        site: a site id.
        kind: the sensor type (``mjSENS_FORCE``, ``mjSENS_RANGEFINDER`` ...).

    Returns:
        The sensor's id, or None.
    """
    key = (site, int(kind))
    table = _site_sensors(m)
    if key not in table:  # kept per model: a force sensor's reading asks twice per call
        found = np.flatnonzero((m.sensor_type == key[1]) & (m.sensor_objtype == _SITE) & (m.sensor_objid == site))
        table[key] = int(found[0]) if found.size else None
    return table[key]  # type: ignore[no-any-return]


_SITE = int(mujoco.mjtObj.mjOBJ_SITE)
#: ``site_sensor``'s answers per model: {(site, kind): sensor id or None}.
_site_sensors = PerObject(lambda m: {})


def stamp(sim: SimulationView) -> tuple[int, float]:
    """When a force sensor breaks: the simulation's stop count and time (s), so that a stop
    (scene reset) repairs it.

    Args:
        sim: the simulation.

    Returns:
        ``(stops, time)``.
    """
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
    """(state, force (3,) N, torque (3,) N·m) of force sensor ``handle``: the force and torque
    that what hangs below it exerts on its parent, in the sensor's frame, the torque about its
    origin (:func:`simx_server.sim.force_sensors.child_wrench`); a hanging mass reads its weight
    along gravity. A ``<force>`` or ``<torque>`` sensor on the site with a ``cutoff`` clips it.

    Implements ``simxReadForceSensor`` / ``sim.readForceSensor`` (coppeliaSimLib
    ``simReadForceSensor_internal``: bit 0 when the dynamics gave the sensor values).

    Args:
        sim: the simulation.
        handle: a force sensor's handle.

    Returns:
        ``(state, [fx, fy, fz], [tx, ty, tz])``: state bit 0 data available (something hangs
        below the sensor; else both vectors are zero), bit 1 broken (then both vectors are
        zero); force in N, torque in N·m, in the sensor (site) frame.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a force sensor.
    """
    obj = sim.world.get(handle, FORCE_SENSOR)
    if _broken(sim, handle):
        return FORCE_STATE_BROKEN, [0.0] * 3, [0.0] * 3
    wrench = force_sensors.child_wrench(sim.world, obj)
    if wrench is None:
        return 0, [0.0] * 3, [0.0] * 3
    m = sim.world.model
    force, torque = wrench  # read-only: child_wrench keeps them
    out = []
    for kind, vec in ((mujoco.mjtSensor.mjSENS_FORCE, force), (mujoco.mjtSensor.mjSENS_TORQUE, torque)):
        k = site_sensor(m, obj.mj_id, kind)
        if k is not None and m.sensor_cutoff[k] > 0:
            vec = np.clip(vec, -m.sensor_cutoff[k], m.sensor_cutoff[k])
        out.append(vec.tolist())
    return FORCE_STATE_DATA, out[0], out[1]


# ----------------------------------------------------------------- vision sensors
def vision_packet(sim: SimulationView, handle: int) -> list[float]:
    """V-REP's default vision packet: 15 floats in 0..1 (empty when the sensor's "compute
    basic statistics" is off).

    min, max and average of (intensity, red, green, blue, depth) over the sensor's image before
    its filters (intensity = (R + G + B) // 3; bytes in V-REP's integer arithmetic, averages
    truncated) and depth buffer (normalised between near and far), as V-REP computed it
    before applying the filters (``CVisionSensor::_computeDefaultReturnValuesAndApplyFilters``).
    Passive sensors use their stored image. Waits for the render (see :func:`vision_read_job`).

    Implements ``simxReadVisionSensor``'s first packet.

    Args:
        sim: the simulation.
        handle: a vision sensor's handle.

    Returns:
        15 floats: the 5 minima, 5 maxima, 5 averages.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
    """
    return wait_for(sim.vision.after(vision_read_job(sim, handle)), "readVisionSensor")[1][0]


def vision_read_job(sim: SimulationView, handle: int,
                    packets: bool = True) -> Callable[[], tuple[bool, list[list[float]]]]:
    """``simxReadVisionSensor``'s frames submitted (simulation thread); the job returned gives
    ``(triggered, packets)`` from them, on the render thread after them: V-REP's default packet
    (:func:`vision_packet`), then one packet per filter step that makes one (blob detection,
    binary image), and whether a filter step triggered the sensor
    (``VisionSensors.read_job``). A passive sensor's stored image is measured, unfiltered.

    Args:
        sim: the simulation.
        handle: a vision sensor's handle.
        packets: False: the frames and the trigger only (``[]`` for the packets).

    Returns:
        A function of no argument that returns ``(triggered, [packet, ...])``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
    """
    return sim.vision.read_job(handle, override_image(sim, handle, False), packets)
