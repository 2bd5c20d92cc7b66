"""Sensor commands: vision sensor images and depth buffers, force, proximity and vision sensor
reads (``simxGetVisionSensorImage``, ``simxReadForceSensor``, ...). Every handler is
``(simulation, args) -> result``; readings come from :mod:`simx_server.sim.sensors`, images from
:mod:`simx_server.sim.vision` (deferred to the render thread)."""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from simx_server.base.arguments import as_bytes, check_args as _args
from simx_server.commands.handler import Handler
from simx_server.scene.simulation import Simulation
from simx_server.sim import sensors
from simx_server.sim.proximity import proximity_reading
from simx_server.sim.sensors import force_sensor_reading, set_passive_image, stamp, vision_read_job
from simx_server.sim.vision import Deferred
from simx_server.sim.world import FORCE_SENSOR, VISION_SENSOR


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
    sim.sensors.broken[h] = stamp(sim)


def read_vision_sensor(sim: Simulation, args: list) -> Deferred:
    """``simxReadVisionSensor`` [h] -> [detectionState, [packet, ...]], rendered later.

    V-REP's default packet (15 floats, see :func:`vision_packet`; empty when the sensor's
    "compute basic statistics" is off), then one packet per filter step that makes one (blob
    detection: ``[count, 6, size, angle, x, y, width, height, ...]``), computed from the
    sensor's current frames on the render thread that draws them, as images are: the
    simulation thread goes on while a large sensor renders. detectionState: a filter step
    triggered the sensor (``binaryWorkImg``'s trigger).
    """
    (h,) = _args(args, "int")
    sim.world.get(h, VISION_SENSOR)
    read = vision_read_job(sim, h)

    def reply() -> list:
        trigger, packets = read()
        return [trigger, packets]

    return sim.vision.rendered_with(h, reply)


def set_vision_sensor_image(sim: Simulation, args: list) -> None:
    """``simxSetVisionSensorImage`` [h, image, options] -> None.

    Writes the image of a passive sensor (``image=external`` in its ``simx:NAME`` custom text;
    other sensors -> ObjectTypeError). ``image``: bytes (or a list of byte values), rows
    bottom-up, resX*resY*3 RGB bytes, or resX*resY grey bytes when ``options`` bit 0 is set;
    any other length -> ArgumentError. simxGetVisionSensorImage returns it from then on.
    """
    h, image, options = _args(args, "int", "any", "int")
    set_passive_image(sim, h, as_bytes(image, "image", byte_values=True), bool(options & 1))


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


def get_vision_sensor_image(sim: Simulation, args: list) -> list | Deferred:
    h, options = _args(args, "int", "int")
    passive = sensors.override_image(sim, h, bool(options & 1))  # what simxSetVisionSensorImage wrote
    if passive is not None:
        spec = sim.vision.spec(h)
        return [[spec.width, spec.height], np.ascontiguousarray(passive).tobytes()]
    return sim.vision.image_deferred(h, options)


def get_vision_sensor_depth_buffer(sim: Simulation, args: list) -> Deferred:
    (h,) = _args(args, "int")
    return sim.vision.depth_deferred(h)



#: Bytes a ReadVisionSensor reply counts in a reply's budget (15 doubles and their framing).
PACKET_BYTES = 256

#: Command name -> handler: vision sensor images and depth buffers (rendered on the render thread).
IMAGE_HANDLERS: dict[str, Handler] = {
    "GetVisionSensorImage": get_vision_sensor_image,
    "GetVisionSensorDepthBuffer": get_vision_sensor_depth_buffer,
}

#: Commands whose result is an image: its size is known before it is rendered.
IMAGES = frozenset(IMAGE_HANDLERS)


def image_pixels(sim: Simulation, args: list) -> int:
    """Pixels of the frame an image command of these arguments makes (0: no vision sensor)."""
    spec = sim.vision.specs.get(args[0]) if args and type(args[0]) is int else None
    return 0 if spec is None else spec.pixels


def image_size(sim: Simulation, name: str, args: list) -> int:
    """Bytes of the image a ``GetVisionSensorImage`` / ``GetVisionSensorDepthBuffer`` command of
    these arguments will return, before it is rendered (0 when its handle is no vision sensor:
    the handler then answers the error); a ``ReadVisionSensor``'s packet counts PACKET_BYTES."""
    spec = sim.vision.specs.get(args[0]) if args and type(args[0]) is int else None
    if spec is None:
        return 0
    if name == "ReadVisionSensor":  # blob packets: at most a blob per 2 pixels, 6 doubles each
        blobs = any(st.name == "blobDetectionOnWorkImg" for st in spec.filters)
        return PACKET_BYTES + (27 * spec.pixels if blobs else 0)
    if name == "GetVisionSensorDepthBuffer":
        return spec.depth_size()
    return spec.image_size(len(args) > 1 and type(args[1]) is int and bool(args[1] & 1))
