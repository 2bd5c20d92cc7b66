"""CoppeliaSim 4.x's collision, distance and sensor-handling functions of ``sim`` on MuJoCo.

* ``checkCollision`` / ``checkDistance``: between the shapes' collidable geoms, on a mesh's
  triangles (coal; a client's bounded: :mod:`simx_server.api.mesh_waits`) and with
  ``mj_geomDistance`` between primitives (:mod:`simx_server.sim.collisions`);
  ``getContactInfo``: the contacts of the last step (``data.contact``).
* Sensors are rendered / cast when read: ``handleVisionSensor`` and ``readVisionSensor`` give
  V-REP's 15-value packet of the current image (a sensor with vision callbacks or explicit
  handling: of its last handling, :mod:`simx_server.sim.vision_handled`), the proximity calls
  cast the ray now.
* Joints: :mod:`simx_server.api.sim.joint_modes`.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.mesh_waits import query_work
from simx_server.api.registry import sim_function
from simx_server.api.sim import point_distance, sensors as _sensors
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text
from simx_server.sim import collisions, proximity, scene_collections, sensors
from simx_server.sim.objects import PROXIMITY_SENSOR, SHAPE, VISION_SENSOR, WORLD


# Collision and distance checks, sensor handling.

def _entity(ctx: CallContext, handle: Any, what: str) -> int:
    h = ctx.h(handle, what)
    if h == C.sim_handle_all or scene_collections.is_collection(h):
        return h
    return ctx.world.get(h, SHAPE).handle


@sim_function("checkCollision")
@point_distance.nothing_for_non_shapes((0, [-1, -1]))
def checkCollision(ctx: CallContext, entity1Handle: Any, entity2Handle: Any) -> tuple[int, list[int]]:  # noqa: N802, N803
    """``result, collidingObjects``: 1 and the two shapes' handles when shape or collection
    ``entity1`` touches or overlaps ``entity2`` (``sim.handle_all``: any other collidable geom,
    a shape's parent and children excepted as MuJoCo filters them), else (a non-shape too) 0.

    Args:
        entity1Handle: a shape, another object or a collection.
        entity2Handle: another shape, object or collection, or ``sim.handle_all``.

    Returns:
        ``(result, [h1, h2])``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape or collection, or a shape without geoms.
    """
    sim = ctx.simulation("checkCollision")
    e1, e2 = _entity(ctx, entity1Handle, "entity1Handle"), _entity(ctx, entity2Handle, "entity2Handle")
    if not collisions.collision(sim, e1, e2, work=query_work(ctx)):
        return 0, [-1, -1]
    if e2 != C.sim_handle_all and not (scene_collections.is_collection(e1) or scene_collections.is_collection(e2)):
        return 1, [e1, e2]
    return 1, _closest(ctx, e1, e2)[2]


@sim_function("checkCollisionEx")
@point_distance.nothing_for_non_shapes((0, []))
def checkCollisionEx(ctx: CallContext, entity1Handle: Any, entity2Handle: Any) -> tuple[int, list[float]]:  # noqa: N802, N803
    """``segmentCount, segmentData``: 1 and the two witness points (6 numbers, m, world) of the
    deepest touch when the shapes collide, else 0 and ``[]`` (MuJoCo gives one contact
    segment per geom pair, not the intersection curve CoppeliaSim's meshes give).

    Args:
        entity1Handle: a shape or collection.
        entity2Handle: another shape or collection, or ``sim.handle_all``.

    Returns:
        ``(count, points)``: 0 or 1, and ``[]`` or 6 floats.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape or collection, or a shape without geoms.
    """
    e1, e2 = _entity(ctx, entity1Handle, "entity1Handle"), _entity(ctx, entity2Handle, "entity2Handle")
    if not collisions.collision(ctx.simulation("checkCollisionEx"), e1, e2, work=query_work(ctx)):
        return 0, []
    points, _, _ = _closest(ctx, e1, e2)
    return 1, points


def _closest(ctx: CallContext, e1: int, e2: int) -> tuple[list[float], float, list[int]]:
    """Witness points (6, m, world), distance (m) and the shapes' handles of the closest pair."""
    world = ctx.world
    a, b = collisions._pairs(world, e1, e2)
    if a.size == 0:
        raise ArgumentError("there is no collidable geom to measure the distance to")
    best, i, fromto = collisions.closest(world, a, b, query_work(ctx))
    pair = (int(a[i]), int(b[i]))
    shape_of = {o.mj_id: o.handle for o in world.objects.values() if o.type == SHAPE}
    bodies = world.model.geom_bodyid
    return fromto.tolist(), best, [shape_of.get(int(bodies[g]), WORLD) for g in pair]


@sim_function("checkDistance")
def checkDistance(ctx: CallContext, entity1Handle: Any, entity2Handle: Any, threshold: Any = 0.0) -> tuple[int, list[float], list[int]]:  # noqa: N802, N803
    """``result, distanceData, objectHandlePair``: ``distanceData`` = the closest points on
    each shape (m, world) and their distance, ``[x1 y1 z1 x2 y2 z2 d]``; result 1 when ``d``
    is below ``threshold`` (0: no threshold), else 0. Penetrating shapes measure 0.

    Args:
        entity1Handle: a shape or collection.
        entity2Handle: another shape or collection, or ``sim.handle_all``.
        threshold: m; 0: none.

    Returns:
        ``(result, [x1, y1, z1, x2, y2, z2, d], [h1, h2])``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape or collection, or a shape without geoms.
    """
    limit = _num(threshold, "threshold")
    ctx.simulation("checkDistance")
    measured = point_distance.measure(ctx, entity1Handle, entity2Handle)  # a dummy: a point
    if measured is None:
        e1, e2 = _entity(ctx, entity1Handle, "entity1Handle"), _entity(ctx, entity2Handle, "entity2Handle")
        measured = _closest(ctx, e1, e2)
    points, d, pair = measured
    d = max(0.0, d)
    if limit > 0 and d >= limit:
        return 0, [*points, d], pair
    return 1, [*points, d], pair


@sim_function("getContactInfo")
def getContactInfo(ctx: CallContext, dynamicPass: Any, objectHandle: Any, index: Any) -> tuple[list[int], list[float], list[float], list[float]] | None:  # noqa: N802, N803
    """``collidingObjects, contactPoint, reactionForce, normalVector`` of the ``index``-th
    contact of the last step that involves shape ``objectHandle`` (``sim.handle_all``: any):
    the two shapes' handles, the point (m, world), the force on the first (N, world) and
    the contact normal; nil past the last contact.

    Args:
        dynamicPass: ignored (MuJoCo's contacts of the last step).
        objectHandle: a shape, or ``sim.handle_all``.
        index: 0-based.

    Returns:
        ``([h1, h2], [x, y, z], [fx, fy, fz], [nx, ny, nz])``, or None.
    """
    h = ctx.h(objectHandle, "objectHandle")
    i = _int(index, "index")
    world = ctx.world
    m, d = world.model, world.data
    shape_of = {o.mj_id: o.handle for o in world.objects.values() if o.type == SHAPE}
    body = None if h == C.sim_handle_all else world.get(ctx.h(h), SHAPE).mj_id
    found = -1
    wrench = np.zeros(6)
    for k in range(d.ncon):
        c = d.contact[k]
        b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
        if body is not None and body not in (b1, b2):
            continue
        found += 1
        if found != i:
            continue
        mujoco.mj_contactForce(m, d, k, wrench)
        frame = c.frame.reshape(3, 3)
        force = frame.T @ wrench[:3]
        return ([shape_of.get(b1, WORLD), shape_of.get(b2, WORLD)], c.pos.tolist(), (-force).tolist(),
                frame[0].tolist())
    return None


def vision_of(ctx: CallContext, handle: Any) -> int:
    return ctx.world.get(ctx.h(handle, "sensorHandle"), VISION_SENSOR).handle


@sim_function("handleVisionSensor")
def handleVisionSensor(ctx: CallContext, sensorHandle: Any, packets: Any = True) -> tuple:  # noqa: N802, N803
    """Render the sensor now: ``detectionCount, auxPacket1, auxPacket2...``: how many sensors
    their filters triggered, V-REP's 15 values (min, max, average of intensity, red, green,
    blue, depth, 0..1) and the filters' packets (see :func:`readVisionSensor`); a sensor with
    vision callbacks is handled with them now (:mod:`simx_server.scripts.vision_callbacks`). A
    sensor with explicit handling shows this state from now on, whatever the world does, until
    it is handled again (``CVisionSensor::handleSensor`` into its buffers;
    :meth:`simx_server.sim.vision_handled.VisionHandling.pin`).
    ``sim.handle_all``: each sensor (``_except_explicit``: but those with explicit handling);
    returns the last's packets.

    Args:
        sensorHandle: a vision sensor, or ``sim.handle_all``.
        packets: simx's own, default true; false renders and filters the same and returns the
            count alone, computing no packet (PyRep's ``handle_explicitly``, which reads none:
            on CoppeliaSim the C++ engine's statistics cost nothing, here a few tenths of a
            millisecond a sensor on the render thread).

    Returns:
        ``(count, packet, ...)``, or ``(count,)`` without ``packets`` (rendered on the render
        thread).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
        ArgumentError: ``packets`` is not a boolean.
    """
    if not isinstance(packets, bool):
        raise ArgumentError(f"packets must be true or false, not {type(packets).__name__}")
    h = ctx.h(sensorHandle, "sensorHandle")
    sim = ctx.simulation("handleVisionSensor")
    handles = (ctx.world.objects_of_type(VISION_SENSOR)
               if h in (C.sim_handle_all, C.sim_handle_all_except_explicit) else [vision_of(ctx, h)])
    if h == C.sim_handle_all_except_explicit:
        handles = [one for one in handles if one not in sim.vision.explicit]
    for one in handles:
        if one in sim.vision.explicit:  # its reads show this state until handled again
            sim.vision.pin(one)
        sensors.handle_with_callbacks(sim, one)  # a sensor whose scripts have vision callbacks: with them
    jobs = [sensors.vision_read_job(sim, one, packets) for one in handles]  # each rendered now

    def finish() -> tuple:
        results = [job() for job in jobs]
        count = sum(t for t, _ in results)
        return (count, *(results[-1][1] if results else [[]])) if packets else (count,)

    return _sensors.rendered(ctx, "handleVisionSensor", finish)


@sim_function("readVisionSensor")
def readVisionSensor(ctx: CallContext, sensorHandle: Any) -> tuple:  # noqa: N802, N803
    """``result, auxPacket1, auxPacket2...`` (as ``simxReadVisionSensor``): result 1 when a
    filter step of the sensor triggered (``binaryWorkImg``), else 0; V-REP's default packet
    of the sensor's image before its filters (15 floats in 0..1, empty when its "compute
    basic statistics" is off), then each filter step's packet (``blobDetectionOnWorkImg``:
    ``[count, 6, size, angle, x, y, width, height, ...]``).

    Args:
        sensorHandle: a vision sensor's handle.

    Returns:
        ``(result, packet, ...)``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
    """
    job = sensors.vision_read_job(ctx.simulation("readVisionSensor"), vision_of(ctx, sensorHandle))

    def finish() -> tuple:
        trigger, packets = job()
        return (int(trigger), *packets)

    return _sensors.rendered(ctx, "readVisionSensor", finish)


@sim_function("checkVisionSensor")
def checkVisionSensor(ctx: CallContext, sensorHandle: Any, entityHandle: Any) -> tuple[int, list[float]]:  # noqa: N802, N803
    """As :func:`readVisionSensor`, of the world's state now: a sensor with explicit handling
    keeps its last handling for the reads after (``CVisionSensor::checkSensor``). simx renders
    the whole scene: ``entityHandle`` is checked and must be ``sim.handle_all``.

    Args:
        sensorHandle: a vision sensor's handle.
        entityHandle: ``sim.handle_all``.

    Returns:
        ``(0, packet)``.

    Raises:
        UnsupportedError: one entity rather than ``sim.handle_all``.
    """
    e = ctx.h(entityHandle, "entityHandle")
    if e != C.sim_handle_all:
        ctx.world.get(e)
        raise UnsupportedError("checkVisionSensor of one entity: simx's sensors render the whole scene "
                               "(pass sim.handle_all)")
    with ctx.simulation("checkVisionSensor").vision.current(vision_of(ctx, sensorHandle)):
        return readVisionSensor(ctx, sensorHandle)


@sim_function("getVisionSensorResolution", "getVisionSensorRes")
def getVisionSensorResolution(ctx: CallContext, sensorHandle: Any) -> list[int]:  # noqa: N802, N803
    """``[width, height]`` (pixels; CoppeliaSim 4.0-4.2's name of ``getVisionSensorRes``).

    Args:
        sensorHandle: a vision sensor's handle.

    Returns:
        ``[width, height]``.
    """
    spec = ctx.simulation("getVisionSensorResolution").vision.spec(vision_of(ctx, sensorHandle))
    return [spec.width, spec.height]


@sim_function("getVisionSensorCharImage")
def getVisionSensorCharImage(ctx: CallContext, sensorHandle: Any, posX: Any = 0, posY: Any = 0, sizeX: Any = 0,  # noqa: N802, N803
                             sizeY: Any = 0, rgbaCutOff: Any = 0) -> tuple[bytes, int, int]:  # noqa: N803
    """``image, resolutionX, resolutionY``: uint8 RGB bytes, rows bottom-up (a window with
    ``posX..sizeY``; 0s: the whole image).

    Args:
        sensorHandle: a vision sensor's handle.
        posX: the window's first column, pixels.
        posY: its first row from the bottom, pixels.
        sizeX: its width (0: the whole image).
        sizeY: its height.
        rgbaCutOff: ignored.

    Returns:
        ``(bytes, width, height)`` of the window.

    Raises:
        ArgumentError: a window outside the image.
    """
    image = _sensors.image_job(ctx, "getVisionSensorCharImage", vision_of(ctx, sensorHandle), False)

    def finish() -> tuple[bytes, int, int]:
        img = _sensors.crop(image(), posX, posY, sizeX, sizeY)
        return img.tobytes(), int(img.shape[1]), int(img.shape[0])

    return _sensors.rendered(ctx, "getVisionSensorCharImage", finish)


@sim_function("resetVisionSensor")
def resetVisionSensor(ctx: CallContext, sensorHandle: Any) -> None:  # noqa: N802, N803
    """Nothing kept between renders: checked and done.

    Args:
        sensorHandle: a vision sensor's handle.
    """
    vision_of(ctx, sensorHandle)


def _proximity(ctx: CallContext, handle: Any) -> int:
    return ctx.world.get(ctx.h(handle, "sensorHandle"), PROXIMITY_SENSOR).handle


@sim_function("handleProximitySensor")
def handleProximitySensor(ctx: CallContext, sensorHandle: Any) -> tuple[int, float, list[float], int, list[float]]:  # noqa: N802, N803
    """Cast the sensor's ray(s) now: as :func:`~simx_server.api.sim.sensors.readProximitySensor`
    (``sim.handle_all``: each proximity sensor, the last one's reading).

    Args:
        sensorHandle: a proximity sensor, or ``sim.handle_all``.

    Returns:
        ``(result, distance, [x, y, z], handle, [nx, ny, nz])``.
    """
    h = ctx.h(sensorHandle, "sensorHandle")
    if h in (C.sim_handle_all, C.sim_handle_all_except_explicit):
        handles = ctx.world.objects_of_type(PROXIMITY_SENSOR)
        if not handles:
            return 0, 0.0, [0.0] * 3, -1, [0.0] * 3
        result = None
        for one in handles:
            result = ctx.sim.readProximitySensor(one)
        return result
    return ctx.sim.readProximitySensor(_proximity(ctx, h))


@sim_function("checkProximitySensor")
def checkProximitySensor(ctx: CallContext, sensorHandle: Any, entityHandle: Any) -> tuple[int, float, list[float]]:  # noqa: N802, N803
    """``result, distance, detectedPoint`` against ``entityHandle`` (``sim.handle_all``: any
    detectable shape; a shape: only that one, whatever its detectable flags, as V-REP's
    ``simCheckProximitySensor`` overrides them for a single object; nothing else is in the way;
    a dummy: its origin, when inside the volume, :func:`simx_server.sim.proximity.dummy_reading`).

    Args:
        sensorHandle: a proximity sensor's handle.
        entityHandle: a shape, a dummy, or ``sim.handle_all``.

    Returns:
        ``(result, distance, [x, y, z])``: m, sensor frame.
    """
    e = ctx.h(entityHandle, "entityHandle")
    if e == C.sim_handle_all:
        detected, dist, point, hit, _ = ctx.sim.readProximitySensor(_proximity(ctx, sensorHandle))
        return detected, dist, point
    if ctx.world.get(e).type == C.sim_object_dummy_type:  # a point (CProxSensorRoutine::_detectDummy)
        found, point = proximity.dummy_reading(ctx.world, _proximity(ctx, sensorHandle), e)
        return int(found), _length(point), point
    found, point, _, _ = proximity.proximity_reading(ctx.simulation("checkProximitySensor"),
                                                    _proximity(ctx, sensorHandle), ctx.world.get(e, SHAPE).handle)
    return int(found), _length(point), point


def _length(point: list[float]) -> float:
    """``float(np.linalg.norm(point))``: its sum (BLAS's dot) and root, without its checks."""
    p = np.array(point)
    return math.sqrt(p.dot(p))


@sim_function("resetProximitySensor")
def resetProximitySensor(ctx: CallContext, sensorHandle: Any) -> None:  # noqa: N802, N803
    """Nothing kept between casts: checked and done.

    Args:
        sensorHandle: a proximity sensor, or ``sim.handle_all``.
    """
    h = ctx.h(sensorHandle, "sensorHandle")
    if h not in (C.sim_handle_all, C.sim_handle_all_except_explicit):
        _proximity(ctx, h)


@sim_function("getExplicitHandling")
def getExplicitHandling(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """An object's explicit-handling flags: for a vision sensor bit 0 is whether it has explicit
    handling now (saved so in the scene, or set by :func:`setExplicitHandling`: the set the
    simulation's vision handling reads, :attr:`simx_server.sim.vision_handled.VisionHandling.explicit`);
    for other objects what :func:`setExplicitHandling` stored (0 by default: sensors are read
    when asked in simx).

    ``sim.getExplicitHandling``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        The flags.

    Raises:
        UnknownObjectError: no such object.
    """
    obj = ctx.world.get(ctx.h(objectHandle))
    if obj.type == VISION_SENSOR and ctx.view is not None:
        return int(obj.handle in ctx.view.vision.explicit)
    return int((ctx.state.explicit or {}).get(obj.handle, 0))


@sim_function("setExplicitHandling")
def setExplicitHandling(ctx: CallContext, objectHandle: Any, explicitHandlingFlags: Any) -> None:  # noqa: N802, N803
    """Stored (``getExplicitHandling`` reads it), until the simulation stops. A vision sensor with
    explicit handling (bit 0) is handled only by ``sim.handleVisionSensor`` (its scripts' vision
    callbacks too, not each simulation pass), and its reads show its last handling (from now:
    the state it shows now) until the next, as CoppeliaSim's sensor buffers
    (:mod:`simx_server.sim.vision_handled`); set back to 0, it shows each pass's state again.
    Proximity sensors and other objects are cast or read when asked either way.

    ``sim.setExplicitHandling``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        explicitHandlingFlags: the flags.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not an integer.
    """
    obj = ctx.world.get(ctx.h(objectHandle))
    flags = _int(explicitHandlingFlags, "flags")
    if obj.type == VISION_SENSOR and ctx.view is not None:  # not handled each pass (vision callbacks)
        ctx.view.vision.set_explicit(obj.handle, bool(flags & 1))
        return  # that set is the one truth of a vision sensor's flag (getExplicitHandling reads it)
    ctx.state.explicit = {**(ctx.state.explicit or {}), obj.handle: flags}


@sim_function("getVelocity")
def getVelocity(ctx: CallContext, shapeHandle: Any) -> tuple[list[float], list[float]]:  # noqa: N802, N803
    """``linearVelocity, angularVelocity`` of a shape's body (m/s, rad/s, world frame).

    ``sim.getVelocity``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.

    Returns:
        ``(linearVelocity, angularVelocity)``: 3 floats each.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
    """
    return ctx.sim.getObjectVelocity(ctx.world.get(ctx.h(shapeHandle, "shapeHandle"), SHAPE).handle)


@sim_function("getScriptHandle")
def getScriptHandle(ctx: CallContext, objectHandleOrName: Any = None) -> int:  # noqa: N802, N803
    """CoppeliaSim 4.0-4.2: the handle of an object's child script (in simx: the object's
    handle; ``sim.handle_self`` / nil: this script's); -1 without a script.

    ``sim.getScriptHandle``.

    Args:
        objectHandleOrName: a handle, a name, or None.

    Returns:
        The object's handle, or -1.

    Raises:
        UnknownObjectError: no such object.
    """
    if objectHandleOrName is None:
        h = ctx.h(C.sim_handle_self)
    elif isinstance(objectHandleOrName, (str, bytes)):
        h = ctx.world.resolve(_text(objectHandleOrName, "objectName")).handle
    else:
        h = ctx.h(objectHandleOrName)
    sim = ctx.view
    scripts = getattr(getattr(sim, "scripts", None), "scripts", {})
    return h if h in scripts else -1
