"""Object parameters: simxGet/SetObjectFloatParameter and simxGet/SetObjectIntParameter, as
V-REP's legacy remote API has them (velocities, bounding boxes, vision-sensor optics, joint
intrinsics and control, shape mass and flags).

Handlers are listed in :data:`PARAM_HANDLERS`; ``get_float_param`` and the other plain-value
functions serve in-process callers. Unsupported ids answer UnsupportedError naming the id and why.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Callable

import mujoco
import numpy as np

from simx_client import constants as C
from simx_client.protocol import ArgumentError, ObjectTypeError, UnsupportedError
from simx_server import handle_render, motors, physics
from simx_server.arguments import check_args as _args, quote
from simx_server.collisions import collidable
from simx_server.kinematics import _BALL, _HINGE, _SLIDE, joint_matrix, object_velocity
from simx_server.world import _TYPE_NAMES, JOINT, SHAPE, VISION_SENSOR, World

if TYPE_CHECKING:
    from simx_server.simulation import Simulation

_PLANE = int(mujoco.mjtGeom.mjGEOM_PLANE)

# ---------------------------------------------------------------- object params
#: Legacy names of the object parameter ids (vrepConst.py's first name of each id), for messages.
PARAM_NAMES = {v: n for n, v in reversed(C.VREP_CONSTANTS.items()) if n.startswith(C.OBJECT_PARAM_PREFIXES)}
_FLOAT_GET = {11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 1000, 1001, 1004, *range(2002, 2018), 3005}
_FLOAT_SET = {1000, 1001, 1004, 2002, 2003, 2004, 2017, 3005}
_INT_GET = {1002, 1003, 1017, 2000, 2001, 3003, 3004}
_INT_SET = {1002, 1003, 1017, 2000, 2001}


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
    if pid == 1017:
        _need(world, handle, VISION_SENSOR, pid)
        return sim.vision.spec(handle).render_mode
    if pid in motors.INT_PARAMS:
        _need(world, handle, JOINT, pid)
        return motors.get_param(world, handle, pid)
    obj = _need(world, handle, SHAPE, pid)
    m = world.model
    if pid == 3003:
        return int(m.body_weldid[obj.mj_id] == 0)
    return int(bool(np.any(collidable(m)[m.geom_bodyid == obj.mj_id])))


def set_int_param(sim: Simulation, handle: int, pid: int, value: int) -> None:
    """Set int parameter ``pid`` of ``handle``; see set_object_int_parameter."""
    world = sim.world
    if pid in (3003, 3004):  # static / respondable: what the MJCF says, fixed at run time
        if value not in (0, 1):
            raise ArgumentError(f"{_pname(pid)}: value must be 0 or 1, got {quote(value)}")
        if get_int_param(sim, handle, pid) != value:
            raise UnsupportedError(
                f"{_pname(pid)}: a shape's {'static' if pid == 3003 else 'respondable'} flag is fixed "
                "when the scene loads (its joints, contype/conaffinity in the MJCF); MuJoCo cannot "
                "switch it at run time")
        return  # already so (sim.importShape's shapes are dynamic and respondable): nothing to do
    if pid not in _INT_SET:
        world.get(handle)
        raise _unsupported(pid, "int", True)
    if pid in (1002, 1003):  # resolution x / y: simx_server.vision
        _need(world, handle, VISION_SENSOR, pid)
        try:
            sim.vision.set_resolution(handle, **{"width" if pid == 1002 else "height": value})
        except ArgumentError as exc:
            raise ArgumentError(f"{_pname(pid)}: {exc}") from None
        return
    if pid == 1017:  # render mode: simx_server.handle_render
        _need(world, handle, VISION_SENSOR, pid)
        spec = sim.vision.spec(handle)
        try:
            spec.render_mode = handle_render.check_mode(value)
        except UnsupportedError as exc:
            raise UnsupportedError(f"{_pname(pid)}: {exc}") from None
        world.version += 1  # the sensor's image changes
        return
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

    Supported ids: vision sensors 1002/1003 resolution x/y (pixels), 1017 render mode (0 OpenGL,
    2 colour-coded handles; simx_server.handle_render); joints 2000 motor enabled,
    2001 control loop enabled (1: position control when the motor is on); shapes
    3003 static (1 when welded to the world), 3004 respondable (1 when a geom has contype or
    conaffinity). Others -> UnsupportedError naming the id.
    """
    h, pid = _args(args, "int", "int")
    return get_int_param(sim, h, pid)


def set_object_int_parameter(sim: Simulation, args: list) -> None:
    """``simxSetObjectIntParameter`` [h, id, value] -> None.

    Settable: 1002/1003 resolution x/y of a vision sensor (1..limits.MAX_RESOLUTION pixels;
    the next image has the new size; back to the MJCF's at simulation stop;
    VisionSensors.set_resolution), 1017 render mode of a vision sensor (0 OpenGL, 2 colour-coded handles; the others
    -> UnsupportedError naming the mode; back to the MJCF's at simulation stop), 2000 motor enabled
    (0: free joint) and 2001 control loop enabled (1: position control, holding the current position when it starts; 0: velocity control) of a joint
    (simx_server.motors.set_param); 3003 static and 3004 respondable of a shape only to the
    value they have (a scene's script marking an imported shape dynamic and respondable, as
    V-REP scripts do); another value -> UnsupportedError (fixed when the scene loads). Other
    ids -> UnsupportedError with the reason.
    """
    h, pid, value = _args(args, "int", "int", "int")
    set_int_param(sim, h, pid, value)


#: Command name -> handler, to merge into simx_server.commands.HANDLERS.


#: Command name -> handler, merged into simx_server.commands.HANDLERS.
PARAM_HANDLERS: dict[str, Callable[[Simulation, list], Any]] = {
    "GetObjectFloatParameter": get_object_float_parameter,
    "SetObjectFloatParameter": set_object_float_parameter,
    "GetObjectIntParameter": get_object_int_parameter,
    "SetObjectIntParameter": set_object_int_parameter,
}

#: Command name -> number of leading arguments that identify it (for protocol.COMMANDS).
PARAM_IDENTITY_ARITY: dict[str, int] = {
    "GetObjectFloatParameter": 2,
    "SetObjectFloatParameter": 2,
    "GetObjectIntParameter": 2,
    "SetObjectIntParameter": 2,
}
