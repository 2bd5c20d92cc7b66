"""Bounding boxes of scene objects and of models, as CoppeliaSim 4.1 gives them through
``sim.getObjectFloatParam`` ``sim.objfloatparam_objbbox_*`` (15-20) and
``sim.objfloatparam_modelbbox_*`` (21-26).

* An object's box (coppeliaSimLib 4.1 ``CSceneObject::getMarkingBoundingBox`` of each type), in
  its own frame: a shape's geoms (:func:`shape_box`); a dummy's and a force sensor's cube of
  their size; a proximity sensor's sensing volume and the cube of its size; a joint's cylinder
  (length ``length=``, diameter ``diameter=`` of its ``simx:`` settings, CoppeliaSim's defaults
  0.15 m and 0.02 m otherwise); a vision sensor's view frustum from its near to its far plane.
* A model's box (``CSceneObject::getGlobalMarkingBoundingBox``): the boxes of the base and of
  every object below it, in the base's frame; an object whose ``object_property=`` has
  ``sim.objectproperty_dontshowasinsidemodel`` (256) is left out, and the objects below a
  sub-model base whose ``model_property=`` has ``sim.modelproperty_not_showasinsidemodel``
  (1024) are not explored.

A shape marked ``flat=1`` in its ``simx:`` settings stands for a V-REP plane or disc (no
thickness): MuJoCo needs a volume to simulate it, so its box or cylinder geoms are
:data:`THIN` thick, but its bounding box has no height, as CoppeliaSim's (RLBench tells a
plane spawn boundary by its zero height).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_wire.protocol import ObjectTypeError, UnsupportedError
from simx_server.sim import proximity, properties
from simx_server.sim.objects import (_TYPE_NAMES, DUMMY, FORCE_SENSOR, JOINT, PROXIMITY_SENSOR, SHAPE,
                                     VISION_SENSOR, subtree)
from simx_server.sim.sensors import site_sensor

_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
_CYLINDER = int(mujoco.mjtGeom.mjGEOM_CYLINDER)
_MESH = int(mujoco.mjtGeom.mjGEOM_MESH)
#: Half-thickness (m) of the box or cylinder that stands for a V-REP plane or disc.
THIN = 0.0005
#: ``sim.objectproperty_dontshowasinsidemodel``, ``sim.modelproperty_not_showasinsidemodel``.
DONT_SHOW_IN_MODEL, NOT_SHOW_INSIDE = 256, 1024
#: CoppeliaSim's joint length and diameter when a scene gives none (``CJoint::CJoint``), m.
JOINT_LENGTH, JOINT_DIAMETER = 0.15, 0.02
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


def _is_flat(obj) -> bool:
    return obj.settings.get("flat") == "1"


def shape_box(world, obj) -> tuple[np.ndarray, np.ndarray] | None:
    """The box around a shape's geoms in its frame, planes left out (they are unbounded): a mesh's
    vertices (CoppeliaSim's box around a shape's vertices; MuJoCo's ``geom_aabb`` of a mesh is
    in the frame of its principal axes, so its corners would make a larger box), another
    geom's ``geom_aabb``; a ``flat=1`` shape's thin geoms count as of no thickness.

    Args:
        world: the world.
        obj: the shape's scene object.

    Returns:
        ``(min, max)``: arrays (3,), m; None for a shape without bounded geometry.
    """
    m = world.model
    geoms = [g for g in np.flatnonzero(m.geom_bodyid == obj.mj_id) if m.geom_type[g] != _PLANE]
    if not geoms:
        return None
    flat = _is_flat(obj)
    pts = []
    for g in geoms:
        c, half = m.geom_aabb[g, :3].copy(), m.geom_aabb[g, 3:].copy()
        t, size = int(m.geom_type[g]), m.geom_size[g]
        if flat and ((t == _BOX and size[2] <= THIN * 1.001) or (t == _CYLINDER and size[1] <= THIN * 1.001)):
            half[2] = 0.0
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, m.geom_quat[g])
        mesh = int(m.geom_dataid[g]) if t == _MESH else -1
        if mesh >= 0:
            adr, n = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
            local = m.mesh_vert[adr:adr + n]
        else:
            local = c + _CORNERS * half
        pts.append(local @ rot.reshape(3, 3).T + m.geom_pos[g])
    allp = np.vstack(pts)
    return allp.min(axis=0), allp.max(axis=0)


def _cube(half: float) -> tuple[np.ndarray, np.ndarray]:
    return np.full(3, -half), np.full(3, half)


def _setting(obj, key: str, default: float) -> float:
    try:
        value = float(obj.settings.get(key, default))
    except ValueError:
        return default
    return value if math.isfinite(value) and value >= 0 else default


def _proximity_box(world, obj) -> tuple[np.ndarray, np.ndarray]:
    """The sensing volume of a proximity sensor and the cube of its size (``CProxSensor::
    getFullBoundingBox``), in its frame; the volume's points as simx casts them."""
    m = world.model
    k = site_sensor(m, obj.mj_id, mujoco.mjtSensor.mjSENS_RANGEFINDER)
    cutoff = float(m.sensor_cutoff[k]) if k is not None and m.sensor_cutoff[k] > 0 else math.inf
    far = cutoff if math.isfinite(cutoff) else 0.0
    rays = proximity.volume_rays(obj, cutoff) if math.isfinite(cutoff) else None
    if rays is not None:
        origins, dirs, lengths = rays
        pts = np.vstack([origins, origins + dirs * lengths[:, None]])
    else:
        offset = proximity.axis_offset(obj)
        angle = proximity.cone_angle(obj)
        if angle > 0:
            dirs = proximity.cone_directions(angle)
            r = proximity.cone_radius(obj)
            pts = np.vstack([dirs * r, dirs * (r + far)]) + [0.0, 0.0, offset]
        else:
            pts = np.array([[0.0, 0.0, offset], [0.0, 0.0, offset + far]])
    half = float(m.site_size[obj.mj_id, 0])
    return np.minimum(pts.min(axis=0), -half), np.maximum(pts.max(axis=0), half)


def _vision_box(world, obj) -> tuple[np.ndarray, np.ndarray]:
    """A vision sensor's view volume, near to far plane (``CVisionSensor::getFullBoundingBox``)."""
    from simx_server.sim.sensor_spec import sensor_spec

    spec = sensor_spec(world.model, obj)
    m = world.model
    if m.cam_projection[obj.mj_id] == mujoco.mjtProjection.mjPROJ_PERSPECTIVE:
        ty = math.tan(math.radians(float(m.cam_fovy[obj.mj_id])) / 2)
        hy = np.array([spec.near, spec.far]) * ty
    else:
        hy = np.full(2, float(m.cam_fovy[obj.mj_id]) / 2)
    hx = hy * spec.width / max(spec.height, 1)
    pts = np.array([[sx * hx[i], sy * hy[i], z] for i, z in enumerate((spec.near, spec.far))
                    for sx in (-1, 1) for sy in (-1, 1)])
    return pts.min(axis=0), pts.max(axis=0)


def object_box(world, handle: int, what: str = "bounding box") -> tuple[np.ndarray, np.ndarray]:
    """The bounding box of object ``handle`` in its own frame, as CoppeliaSim 4.1's
    ``CSceneObject::getMarkingBoundingBox`` of its type (see the module's text).

    Args:
        world: the world.
        handle: an object's handle.
        what: how messages name the request.

    Returns:
        ``(min, max)``: arrays (3,), m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: a shape without bounded geometry (an MJCF body with no geom or only
            planes).
        UnsupportedError: a light or another type simx keeps no size for.
    """
    obj = world.get(handle)
    m = world.model
    if obj.type == SHAPE:
        box = shape_box(world, obj)
        if box is None:
            raise ObjectTypeError(f"{what}: shape {obj.name!r} has no bounded geometry")
        return box
    if obj.type in (DUMMY, FORCE_SENSOR):
        return _cube(float(m.site_size[obj.mj_id, 0]))
    if obj.type == PROXIMITY_SENSOR:
        return _proximity_box(world, obj)
    if obj.type == JOINT:
        if int(m.jnt_type[obj.mj_id]) == int(mujoco.mjtJoint.mjJNT_BALL):
            return _cube(_setting(obj, "diameter", JOINT_DIAMETER))
        r, h = _setting(obj, "diameter", JOINT_DIAMETER) / 2, _setting(obj, "length", JOINT_LENGTH) / 2
        return np.array([-r, -r, -h]), np.array([r, r, h])
    if obj.type == VISION_SENSOR:
        return _vision_box(world, obj)
    raise UnsupportedError(f"{what}: simx keeps no size for {_TYPE_NAMES.get(obj.type, 'object')} {obj.name!r}")


def _int_setting(obj, key: str) -> int:
    try:
        return int(obj.settings.get(key, "0"), 0)
    except ValueError:
        return 0


def model_box(world, handle: int, what: str = "model bounding box") -> tuple[np.ndarray, np.ndarray] | None:
    """The box, in the frame of object ``handle``, around the bounding boxes of it and of
    every object below it (CoppeliaSim 4.1 ``CSceneObject::getGlobalMarkingBoundingBox`` from
    ``simGetObjectFloatParameter``); objects simx keeps no size for (lights, shapes without
    bounded geometry) are left out. None when nothing is left.

    Args:
        world: the world.
        handle: an object's handle (a model base, usually).
        what: how messages name the request.

    Returns:
        ``(min, max)``: arrays (3,), m; or None.

    Raises:
        UnknownObjectError: no such object.
    """
    cache = getattr(world, "_model_boxes", None)  # the six parameters are asked one by one
    key = (world.model, world.version)
    if cache is None or cache[0] != key:
        cache = world._model_boxes = (key, {})
    if handle not in cache[1]:
        cache[1][handle] = _model_box(world, handle, what)
    return cache[1][handle]


def _model_box(world, handle: int, what: str) -> tuple[np.ndarray, np.ndarray] | None:
    base_pos, base_rot = world.frame(handle)
    objects = subtree(world, handle)
    skipped: set[int] = set()
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for obj in objects:
        if obj.parent in skipped:
            skipped.add(obj.handle)
            continue
        if obj.handle != handle and properties.model_property(world, obj.handle) & properties.NOT_MODEL != \
                properties.NOT_MODEL and properties.model_property(world, obj.handle) & NOT_SHOW_INSIDE:
            skipped.add(obj.handle)
            continue
        if _int_setting(obj, "object_property") & DONT_SHOW_IN_MODEL:
            continue
        try:
            a, b = object_box(world, obj.handle, what)
        except (ObjectTypeError, UnsupportedError):
            continue
        pos, rot = world.frame(obj.handle)
        corners = np.where(_CORNERS > 0, b, a)
        pts = (corners @ rot.T + pos - base_pos) @ base_rot
        lo, hi = np.minimum(lo, pts.min(axis=0)), np.maximum(hi, pts.max(axis=0))
    if not np.all(np.isfinite(lo)):
        return None
    return lo, hi
