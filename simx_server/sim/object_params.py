"""Object parameters: simxGet/SetObjectFloatParameter and simxGet/SetObjectIntParameter, as
V-REP's legacy remote API has them (velocities, bounding boxes, vision-sensor optics, joint
intrinsics and control, shape mass and flags).

The command handlers are in :mod:`simx_server.commands.parameters`; ``get_float_param`` and the
other plain-value functions here serve them, the script facade and in-process callers. Unsupported ids answer UnsupportedError naming the id and why.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ObjectTypeError, UnsupportedError
from simx_server.base.arguments import quote
from simx_server.sim import (bounding_boxes, camera_params, handle_render, joint_params, light_params, physics,
                             shape_dynamics, surfaces, texture_motion, vision_params)
from simx_server.sim.kinematics import _BALL, _HINGE, _SLIDE, joint_matrix, object_velocity
from simx_server.sim.state import SimulationView
from simx_server.sim.world import _TYPE_NAMES, CAMERA, JOINT, LIGHT, SHAPE, VISION_SENSOR, World


# ---------------------------------------------------------------- object params
#: Legacy names of the object parameter ids (vrepConst.py's first name of each id), for messages.
PARAM_NAMES = {v: n for n, v in reversed(C.VREP_CONSTANTS.items()) if n.startswith(C.OBJECT_PARAM_PREFIXES)}
_FLOAT_GET = {11, 12, 13, 14, *range(15, 27), 1000, 1001, 1004, *range(2002, 2020), 3005}
_FLOAT_SET = {1000, 1001, 1004, 2002, 2003, 2004, 2017, 2018, 2019, 3005}

_INT_GET = {1002, 1003, 1017, 2000, 2001, 2030, 2039, 3003, 3004}
_INT_SET = {1002, 1003, 1017, 2000, 2001, 2030, 2039}


def _pname(pid: int) -> str:
    return f"{PARAM_NAMES[pid]} ({pid})" if pid in PARAM_NAMES else f"parameter {pid}"


def _need(world: World, handle: int, otype: int, pid: int):
    obj = world.get(handle)
    if obj.type != otype:
        raise ObjectTypeError(f"{_pname(pid)} applies to {_TYPE_NAMES[otype]}s; object {obj.name!r} "
                              f"(handle {handle}) is a {_TYPE_NAMES.get(obj.type, 'object')}")
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
    """The object's box (15-20) or its model's (21-26): :mod:`simx_server.sim.bounding_boxes`."""
    if pid <= 20:
        return bounding_boxes.object_box(world, handle, _pname(pid))
    box = bounding_boxes.model_box(world, handle, _pname(pid))
    if box is None:
        raise ObjectTypeError(f"{_pname(pid)}: object {world.get(handle).name!r} and the objects below it have "
                              "no bounding box")
    return box


def joint_velocity(world: World, handle: int) -> float:
    """The velocity (rad/s or m/s) of a hinge or slide joint: ``sim.jointfloatparam_velocity``,
    ``sim.getJointVelocity`` (coppeliaSimLib ``CJoint::getMeasuredJointVelocity``: MuJoCo's ``qvel``).

    Args:
        world: the world.
        handle: a joint's handle.

    Returns:
        rad/s or m/s.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint, or a spherical one.
    """
    obj = _need(world, handle, JOINT, 2012)
    m = world.model
    if int(m.jnt_type[obj.mj_id]) not in (_HINGE, _SLIDE):
        raise ObjectTypeError(f"{_pname(2012)}: joint {obj.name!r} is not revolute nor prismatic")
    return float(world.data.qvel[m.jnt_dofadr[obj.mj_id]])


def get_float_param(sim: SimulationView, handle: int, pid: int) -> float:
    """Value of float parameter ``pid`` of object ``handle``; see get_object_float_parameter.

    Implements ``simxGetObjectFloatParameter`` / ``sim.getObjectFloatParam`` (ids in
    :func:`simx_server.commands.parameters.get_object_float_parameter`).

    Args:
        sim: the simulation.
        handle: the object's handle.
        pid: the parameter id.

    Returns:
        The value (m, m/s, rad, rad/s, kg, or a gain).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        UnsupportedError: an id simx does not answer.
    """
    world = sim.world
    if pid in camera_params.FLOAT_IDS and world.get(handle).type == CAMERA:
        return camera_params.get_float(world, handle, pid)
    if pid in vision_params.FLOAT_IDS and world.get(handle).type == VISION_SENSOR:
        return vision_params.get_float(sim, handle, pid)
    if pid in light_params.FLOAT_IDS and world.get(handle).type == LIGHT:
        return light_params.get_float(sim, handle, pid)
    if pid in surfaces.IDS:  # a shape's initial velocity (sim/surfaces.py)
        return surfaces.get(world, _need(world, handle, SHAPE, pid).name, pid)
    if pid in texture_motion.IDS:
        obj = _need(world, handle, SHAPE, pid)
        value = texture_motion.get(world, obj, pid)
        if value is None:
            raise UnsupportedError(f"{_pname(pid)}: shape {obj.name!r} has no texture whose placement simx keeps "
                                   "(a texture mapped by projection, of a converted .ttt)")
        return value
    if pid not in _FLOAT_GET:
        world.get(handle)
        raise _unsupported(pid, "float", False)
    if pid in (11, 12, 13, 14):
        v, w = object_velocity(sim, handle)
        return float(np.linalg.norm(w)) if pid == 14 else float(v[pid - 11])
    if 15 <= pid <= 26:  # objbbox_min_x ... max_z, modelbbox_min_x ... max_z
        lo, hi = _bbox(world, handle, pid)
        return float((lo if (pid - 15) % 6 < 3 else hi)[(pid - 15) % 3])
    if pid in (1000, 1001, 1004):
        obj = _need(world, handle, VISION_SENSOR, pid)
        spec = sim.vision.spec(handle)
        if pid == 1004:
            _camera_check(world, obj, pid)
            return _perspective(world.model, spec)
        return float(spec.near if pid == 1000 else spec.far)
    if pid == 3005:
        return float(world.model.body_mass[_need(world, handle, SHAPE, pid).mj_id])
    if pid in joint_params.FLOAT_PARAMS:
        _need(world, handle, JOINT, pid)
        return joint_params.get_param(world, handle, pid)
    if pid == 2012:
        return joint_velocity(world, handle)
    obj = _need(world, handle, JOINT, pid)
    m = world.model
    jtype = int(m.jnt_type[obj.mj_id])
    if 2013 <= pid <= 2016 and jtype != _BALL:
        raise ObjectTypeError(f"{_pname(pid)}: joint {obj.name!r} is not a spherical (ball) joint")
    mat = joint_matrix(world, handle)
    if 2005 <= pid <= 2007:
        return float(mat[pid - 2005, 3])
    quat = np.empty(4)  # w, x, y, z
    mujoco.mju_mat2Quat(quat, mat[:, :3].reshape(9).copy())
    i = (pid - 2008) if pid <= 2011 else (pid - 2013)
    return float(quat[(i + 1) % 4])  # x, y, z, w


def set_float_param(sim: SimulationView, handle: int, pid: int, value: float) -> None:
    """Set float parameter ``pid`` of ``handle``; see set_object_float_parameter.

    Implements ``simxSetObjectFloatParameter`` / ``sim.setObjectFloatParam``.

    Args:
        sim: the simulation.
        handle: the object's handle.
        pid: 1000/1001 clipping (m), 1004 perspective angle (rad), 2002/2017 joint motor, 2018/2019
            the spring-damper mode's K and C,
            3000-3002 and 3020-3022 a shape's initial velocity (m/s, rad/s, world axes: a static
            shape's surface moves in its contacts, a dynamic one starts with it when reset;
            :mod:`simx_server.sim.surfaces`), 3005 mass (kg); 3006-3013 a shape's texture position, orientation,
            scaling (a projected texture's coordinates follow its position and scaling,
            :mod:`simx_server.sim.texture_motion`).
        value: the new value.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        ArgumentError: a value out of range, NaN or infinite.
        UnsupportedError: a read-only or unknown id.
    """
    world = sim.world
    if pid in texture_motion.IDS:  # V-REP's belts slide their texture (sim/texture_motion.py)
        if not math.isfinite(value) or abs(value) > 1e6:
            raise ArgumentError(f"{_pname(pid)}: {value!r} is not a finite value within 1e6")
        texture_motion.set_value(world, _need(world, handle, SHAPE, pid), pid, value)
        return
    if pid in camera_params.FLOAT_IDS and world.get(handle).type == CAMERA:
        camera_params.set_float(world, handle, pid, value)
        return
    if pid in vision_params.FLOAT_IDS and world.get(handle).type == VISION_SENSOR:
        vision_params.set_float(sim, handle, pid, value)
        return
    if pid in light_params.FLOAT_IDS and world.get(handle).type == LIGHT:
        light_params.set_float(sim, handle, pid, value)
        return
    if pid in surfaces.IDS:  # a static shape's moving surface, a dynamic one's velocity at reset
        obj = _need(world, handle, SHAPE, pid)
        try:
            surfaces.set_value(world, obj.name, pid, value)
        except ArgumentError as exc:
            raise ArgumentError(f"{_pname(pid)}: {exc}") from None
        return
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
    if pid in joint_params.FLOAT_PARAMS:
        _need(world, handle, JOINT, pid)
        joint_params.set_param(world, handle, pid, value, _pname(pid))
        return
    # 3005: mass; the inertia scales with it (same shape, new density), as V-REP keeps it
    body = _need(world, handle, SHAPE, pid).mj_id
    m, d = world.model, world.data
    try:
        m.body_inertia[body] = physics.scaled_inertia(value, float(m.body_mass[body]), m.body_inertia[body])
    except ArgumentError as exc:
        raise ArgumentError(f"{_pname(pid)}: {exc}") from None
    m.body_mass[body] = value
    physics.mass_constants(m, d)
    sim.world.changed()


def get_int_param(sim: SimulationView, handle: int, pid: int) -> int:
    """Value of int parameter ``pid`` of ``handle``; see get_object_int_parameter.

    Implements ``simxGetObjectIntParameter`` / ``sim.getObjectInt32Param``.

    Args:
        sim: the simulation.
        handle: the object's handle.
        pid: 1002/1003 resolution (pixels), 1017 render mode, 2000/2001 joint motor flags,
            2039 a joint's dynamic control mode, 3003 static, 3004 respondable.

    Returns:
        The value.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        UnsupportedError: an id simx does not answer.
    """
    world = sim.world
    if pid in camera_params.INT_IDS and world.get(handle).type == CAMERA:
        return camera_params.get_int(world, handle, pid)
    if pid in vision_params.INT_IDS and world.get(handle).type == VISION_SENSOR:
        return vision_params.get_int(sim, handle, pid)
    if pid in light_params.INT_IDS and world.get(handle).type == LIGHT:
        return light_params.get_int(sim, handle, pid)
    if pid not in _INT_GET:
        world.get(handle)
        raise _unsupported(pid, "int", False)
    if pid in (1002, 1003):
        _need(world, handle, VISION_SENSOR, pid)
        spec = sim.vision.spec(handle)
        return spec.width if pid == 1002 else spec.height
    if pid == 1017:
        _need(world, handle, VISION_SENSOR, pid)
        return sim.vision.spec(handle).render_mode
    if pid in joint_params.INT_PARAMS:
        _need(world, handle, JOINT, pid)
        return joint_params.get_param(world, handle, pid)
    obj = _need(world, handle, SHAPE, pid)
    if pid == shape_dynamics.STATIC:
        return int(shape_dynamics.is_static(world, obj))
    return int(shape_dynamics.is_respondable(world, obj))


def set_int_param(sim: SimulationView, handle: int, pid: int, value: int) -> None:
    """Set int parameter ``pid`` of ``handle``; see set_object_int_parameter.

    Implements ``simxSetObjectIntParameter`` / ``sim.setObjectInt32Param``.

    Args:
        sim: the simulation.
        handle: the object's handle.
        pid: 1002/1003 resolution (pixels), 1017 render mode, 2000/2001/2030 joint motor flags,
            2039 a joint's dynamic control mode (:mod:`simx_server.sim.dyn_ctrl`), 3003 static,
            3004 respondable (:mod:`simx_server.sim.shape_dynamics`).
        value: the new value.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        ArgumentError: a value out of range.
        UnsupportedError: a value or id simx cannot set.
    """
    world = sim.world
    if pid in (shape_dynamics.STATIC, shape_dynamics.RESPONDABLE):  # CShape::setStatic / setRespondable
        obj = _need(world, handle, SHAPE, pid)
        try:
            if pid == shape_dynamics.STATIC:
                shape_dynamics.set_static(sim, obj, value != 0)
            else:
                shape_dynamics.set_respondable(world, obj, value != 0, getattr(sim, "editor", None))
        except UnsupportedError as exc:
            raise UnsupportedError(f"{_pname(pid)}: {exc}") from None
        return
    if pid in camera_params.INT_IDS and world.get(handle).type == CAMERA:
        camera_params.set_int(world, handle, pid, value)
        return
    if pid in vision_params.INT_IDS and world.get(handle).type == VISION_SENSOR:
        vision_params.set_int(sim, handle, pid, value)
        return
    if pid in light_params.INT_IDS and world.get(handle).type == LIGHT:
        light_params.set_int(sim, handle, pid, value)
        return
    if pid not in _INT_SET:
        world.get(handle)
        raise _unsupported(pid, "int", True)
    if pid in (1002, 1003):  # resolution x / y: simx_server.sim.vision
        _need(world, handle, VISION_SENSOR, pid)
        try:
            sim.vision.set_resolution(handle, **{"width" if pid == 1002 else "height": value})
        except ArgumentError as exc:
            raise ArgumentError(f"{_pname(pid)}: {exc}") from None
        return
    if pid == 1017:  # render mode: simx_server.sim.handle_render
        _need(world, handle, VISION_SENSOR, pid)
        spec = sim.vision.spec(handle)
        try:
            spec.render_mode = handle_render.check_mode(value)
        except UnsupportedError as exc:
            raise UnsupportedError(f"{_pname(pid)}: {exc}") from None
        world.version += 1  # the sensor's image changes
        return
    # 2000 motor enabled, 2001 control loop enabled, 2039 control mode: simx_server.sim.motors, dyn_ctrl
    _need(world, handle, JOINT, pid)
    joint_params.set_param(world, handle, pid, value, _pname(pid))
