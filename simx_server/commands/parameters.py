"""Parameter commands: the simulator's integer, floating, boolean, string and array parameters
(``simxGetIntegerParameter``, ...) and objects' parameters (``simxGetObjectFloatParameter``, ...).
Every handler is ``(simulation, args) -> result``; an id without a MuJoCo meaning is a remote error
that names it. The simulator's parameters themselves are :mod:`simx_server.scene.parameters`
(which the ZMQ ``sim`` calls too), objects' :mod:`simx_server.sim.object_params`."""

from __future__ import annotations

from typing import Any, Callable

from simx_server.base.arguments import check_args as _args
from simx_server.commands.handler import Handler
from simx_server.scene import parameters
from simx_server.scene.simulation import Simulation
from simx_server.sim.object_params import get_float_param, get_int_param, set_float_param, set_int_param


def get_integer_parameter(sim: Simulation, args: list) -> int:
    """``simxGetIntegerParameter`` [id] -> int (:func:`simx_server.scene.parameters.get_integer`)."""
    (pid,) = _args(args, "int")
    return parameters.get_integer(sim, pid)


def set_integer_parameter(sim: Simulation, args: list) -> None:
    """``simxSetIntegerParameter`` [id, value] (:func:`simx_server.scene.parameters.set_integer`)."""
    pid, value = _args(args, "int", "int")
    parameters.set_integer(sim, pid, value)


def get_floating_parameter(sim: Simulation, args: list) -> float:
    """``simxGetFloatingParameter`` [id] -> float (:func:`simx_server.scene.parameters.get_floating`)."""
    (pid,) = _args(args, "int")
    return parameters.get_floating(sim, pid)


def set_floating_parameter(sim: Simulation, args: list) -> None:
    """``simxSetFloatingParameter`` [id, value] (:func:`simx_server.scene.parameters.set_floating`)."""
    pid, value = _args(args, "int", "float")
    parameters.set_floating(sim, pid, value)


def get_boolean_parameter(sim: Simulation, args: list) -> bool:
    """``simxGetBooleanParameter`` [id] -> bool (:func:`simx_server.scene.parameters.get_boolean`)."""
    (pid,) = _args(args, "int")
    return parameters.get_boolean(sim, pid)


def set_boolean_parameter(sim: Simulation, args: list) -> None:
    """``simxSetBooleanParameter`` [id, value] (:func:`simx_server.scene.parameters.set_boolean`)."""
    pid, value = _args(args, "int", "any")
    parameters.set_boolean(sim, pid, value)


def get_string_parameter(sim: Simulation, args: list) -> str:
    """``simxGetStringParameter`` [id] -> str (:func:`simx_server.scene.parameters.get_string`)."""
    (pid,) = _args(args, "int")
    return parameters.get_string(sim, pid)


def get_array_parameter(sim: Simulation, args: list) -> list[float]:
    """``simxGetArrayParameter`` [id] -> 3 floats (:func:`simx_server.scene.parameters.get_array`)."""
    (pid,) = _args(args, "int")
    return parameters.get_array(sim, pid)


def set_array_parameter(sim: Simulation, args: list) -> None:
    """``simxSetArrayParameter`` [id, 3 floats] (:func:`simx_server.scene.parameters.set_array`)."""
    pid, values = _args(args, "int", "any")
    parameters.set_array(sim, pid, values)


def get_object_float_parameter(sim: Simulation, args: list) -> float:
    """``simxGetObjectFloatParameter`` [h, id] -> float.

    Supported ids: 11/12/13 absolute x/y/z velocity (m/s) and 14 absolute rotation speed
    (|w|, rad/s) of any object; 15-20 bounding box min/max x/y/z of an object in its own frame
    (m; a shape's geoms, a dummy's size, a sensor's volume: simx_server.sim.bounding_boxes), 21-26
    its model's (the object and every object below it, in its frame); vision sensors: 1000 near and 1001 far clipping (m), 1004 perspective angle
    (rad, the larger of the horizontal and vertical view angles, from the camera's fovy);
    joints: 2005-2007 intrinsic translation, 2008-2011 intrinsic quaternion (x, y, z, w),
    2012 velocity (rad/s or m/s), 2013-2016 spherical joint quaternion, 2002-2004 PID gains and
    2017 upper velocity of the motor (simx_server.sim.joint_params.get_param); shapes: 3005 mass (kg).
    Any other id -> UnsupportedError naming it.
    """
    h, pid = _args(args, "int", "int")
    return get_float_param(sim, h, pid)


def set_object_float_parameter(sim: Simulation, args: list) -> None:
    """``simxSetObjectFloatParameter`` [h, id, value] -> None.

    Settable: 1000 near / 1001 far clipping (m, 0 < near < far; they rescale the depth buffer
    and depth images at once), 1004 perspective angle (rad, in (0, pi); changes the camera's
    fovy), 2002 P gain and 2017 upper velocity of a joint motor (simx_server.sim.joint_params.set_param), 3005 mass of a shape (kg, within limits.MIN_MASS..MAX_MASS; its
    inertia scales along and must stay under limits.MAX_INERTIA). Values out of range, NaN and
    infinities -> ArgumentError naming the bound. Read-only ids and unknown ids -> UnsupportedError.
    """
    h, pid, value = _args(args, "int", "int", "float")
    set_float_param(sim, h, pid, value)


def get_object_int_parameter(sim: Simulation, args: list) -> int:
    """``simxGetObjectIntParameter`` [h, id] -> int.

    Supported ids: vision sensors 1002/1003 resolution x/y (pixels), 1017 render mode (0 OpenGL,
    2 colour-coded handles; simx_server.sim.handle_render); joints 2000 motor enabled,
    2001 control loop enabled (1: position control when the motor is on), 2030 motor locked at
    zero velocity; shapes
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
    (simx_server.sim.joint_params.set_param), 2030 motor locked at zero velocity; 3003 static
    (the scene rebuilt with the shape's free joint taken away or added: shapes on joints or grasped
    -> UnsupportedError) and 3004 respondable (its geoms' contact bits) of a shape
    (simx_server.sim.shape_dynamics). Other ids -> UnsupportedError with the reason.
    """
    h, pid, value = _args(args, "int", "int", "int")
    set_int_param(sim, h, pid, value)


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


#: Command name -> handler: the simulator's parameters.
SIMULATION_PARAM_HANDLERS: dict[str, Handler] = {
    "GetIntegerParameter": get_integer_parameter,
    "SetIntegerParameter": set_integer_parameter,
    "GetFloatingParameter": get_floating_parameter,
    "SetFloatingParameter": set_floating_parameter,
    "GetBooleanParameter": get_boolean_parameter,
    "SetBooleanParameter": set_boolean_parameter,
    "GetStringParameter": get_string_parameter,
    "GetArrayParameter": get_array_parameter,
    "SetArrayParameter": set_array_parameter,
}
