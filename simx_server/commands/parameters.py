"""Parameter commands: the simulator's integer, floating, boolean, string and array parameters
(``simxGetIntegerParameter``, ...) and objects' parameters (``simxGetObjectFloatParameter``, ...).
Every handler is ``(simulation, args) -> result``; an id without a MuJoCo meaning is a remote error
that names it. The object parameters themselves are :mod:`simx_server.sim.object_params`."""

from __future__ import annotations

import os
import random
import sys
from pathlib import Path
from typing import Any, Callable

from simx_wire import constants as C
from simx_wire.protocol import RemoteError, UnsupportedError
from simx_server.base.arguments import check_args as _args
from simx_server.commands.handler import Handler
from simx_server.scene.simulation import Simulation
from simx_server.sim import physics
from simx_server.sim.object_params import get_float_param, get_int_param, set_float_param, set_int_param
from simx_server.sim.state import RunState

# Parameters: what has a MuJoCo meaning (ids from vrepConst.py).
INTPARAM_DYNAMIC_STEP_DIVIDER, INTPARAM_PLATFORM, INTPARAM_CORE_COUNT, INTPARAM_STOP_REQUEST_COUNTER = 7, 19, 24, 29


INTPARAM_MOUSE_X, INTPARAM_MOUSE_Y, INTPARAM_MOUSE_BUTTONS = 22, 23, 31


#: The mouse of a headless server: it never moves from the top-left corner of a window nobody
#: sees (x = y = 0 pixels) and no button is ever pressed (bit mask 0). V-REP without a window
#: answered an error; CoppeliaSim's simpleTest.py streams mouse_x, so simx answers this fixed
#: point instead, the same every time (no made-up motion).
HEADLESS_MOUSE = {INTPARAM_MOUSE_X: 0, INTPARAM_MOUSE_Y: 0, INTPARAM_MOUSE_BUTTONS: 0}


_READ_ONLY_INTPARAMS = (INTPARAM_DYNAMIC_STEP_DIVIDER, INTPARAM_PLATFORM, INTPARAM_CORE_COUNT,
                        INTPARAM_STOP_REQUEST_COUNTER, *HEADLESS_MOUSE)


FLOATPARAM_RAND, FLOATPARAM_SIMULATION_TIME_STEP = 0, 1


BOOLPARAM_DYNAMICS_HANDLING, BOOLPARAM_DISPLAY_ENABLED, BOOLPARAM_REALTIME = 6, 16, 25


BOOLPARAM_HEADLESS, BOOLPARAM_WAITING_FOR_TRIGGER = 34, 45


STRINGPARAM_APPLICATION_PATH, STRINGPARAM_SCENE_PATH_AND_NAME = 0, 13


ARRAYPARAM_GRAVITY = 0


def _param(kind: str, pid: int) -> str:
    """How messages name a global parameter: ``boolean parameter sim_boolparam_fog_enabled (19)``."""
    return f"{kind} parameter {C.describe(pid, C.GLOBAL_PARAM_PREFIXES[kind])}"


def _unsupported_param(kind: str, pid: int) -> UnsupportedError:
    return UnsupportedError(f"{_param(kind, pid)} has no meaning in simx (see docs/API.md for the supported ids)")


def get_integer_parameter(sim: Simulation, args: list) -> int:
    """``simxGetIntegerParameter`` [id] -> int: 7 dynamics step divider (MuJoCo substeps per
    step), 19 platform (0 Windows, 1 macOS, 2 Linux), 24 core count, 29 stop request counter,
    22/23 mouse x/y and 31 mouse buttons (always 0: see HEADLESS_MOUSE). Other ids ->
    UnsupportedError."""
    (pid,) = _args(args, "int")
    if pid in HEADLESS_MOUSE:
        return HEADLESS_MOUSE[pid]
    values = {
        INTPARAM_DYNAMIC_STEP_DIVIDER: lambda: sim.world.substeps,
        INTPARAM_PLATFORM: lambda: 0 if sys.platform.startswith("win") else 1 if sys.platform == "darwin" else 2,
        INTPARAM_CORE_COUNT: lambda: os.cpu_count() or 1,
        INTPARAM_STOP_REQUEST_COUNTER: lambda: sim.stop_requests,
    }
    if pid not in values:
        raise _unsupported_param("integer", pid)
    return int(values[pid]())


def set_integer_parameter(sim: Simulation, args: list) -> None:
    pid, _value = _args(args, "int", "int")
    if pid in HEADLESS_MOUSE:
        raise RemoteError(f"{_param('integer', pid)} (the mouse) is read-only: a headless server's mouse "
                          "stays at (0, 0) with no button pressed")
    if pid in _READ_ONLY_INTPARAMS:
        raise RemoteError(f"{_param('integer', pid)} is read-only")
    raise _unsupported_param("integer", pid)


def get_floating_parameter(sim: Simulation, args: list) -> float:
    (pid,) = _args(args, "int")
    if pid == FLOATPARAM_SIMULATION_TIME_STEP:
        return sim.world.dt
    if pid == FLOATPARAM_RAND:
        return random.random()
    raise _unsupported_param("float", pid)


def set_floating_parameter(sim: Simulation, args: list) -> None:
    """``simxSetFloatingParameter`` [id, value]: 1 (time step, s) only, while stopped;
    0 < dt <= limits.MAX_DT and at most limits.MAX_SUBSTEPS substeps, else ArgumentError."""
    pid, value = _args(args, "int", "float")
    if pid != FLOATPARAM_SIMULATION_TIME_STEP:
        raise _unsupported_param("float", pid)
    if sim.state is not RunState.STOPPED:
        raise RemoteError("the simulation time step can only change while the simulation is stopped")
    sim.world.set_dt(value)


def get_boolean_parameter(sim: Simulation, args: list) -> bool:
    (pid,) = _args(args, "int")
    values = {
        BOOLPARAM_DYNAMICS_HANDLING: True,
        BOOLPARAM_DISPLAY_ENABLED: False,
        BOOLPARAM_HEADLESS: True,
        BOOLPARAM_REALTIME: sim.realtime,
        BOOLPARAM_WAITING_FOR_TRIGGER: sim.synchronous and sim.state is RunState.RUNNING,
    }
    if pid not in values:
        raise _unsupported_param("boolean", pid)
    return values[pid]


def set_boolean_parameter(sim: Simulation, args: list) -> None:
    pid, value = _args(args, "int", "any")
    if pid != BOOLPARAM_REALTIME:
        raise _unsupported_param("boolean", pid)
    sim.realtime = bool(value)


def get_string_parameter(sim: Simulation, args: list) -> str:
    (pid,) = _args(args, "int")
    if pid == STRINGPARAM_APPLICATION_PATH:
        return str(Path(__file__).resolve().parent)
    if pid == STRINGPARAM_SCENE_PATH_AND_NAME:
        return sim.editor.public(sim.world.scene_path)  # never the transfer folder's path
    raise _unsupported_param("string", pid)


def get_array_parameter(sim: Simulation, args: list) -> list[float]:
    (pid,) = _args(args, "int")
    if pid != ARRAYPARAM_GRAVITY:
        raise _unsupported_param("array", pid)
    return sim.world.model.opt.gravity.tolist()


def set_array_parameter(sim: Simulation, args: list) -> None:
    """``simxSetArrayParameter`` [id, 3 floats]: 0 (gravity, m/s²) only; a magnitude above
    limits.MAX_GRAVITY, NaN or infinity -> ArgumentError."""
    pid, values = _args(args, "int", "any")
    if pid != ARRAYPARAM_GRAVITY:
        raise _unsupported_param("array", pid)
    sim.world.model.opt.gravity[:] = physics.check_gravity(values)



def get_object_float_parameter(sim: Simulation, args: list) -> float:
    """``simxGetObjectFloatParameter`` [h, id] -> float.

    Supported ids: 11/12/13 absolute x/y/z velocity (m/s) and 14 absolute rotation speed
    (|w|, rad/s) of any object; 15-20 bounding box min/max x/y/z of a shape's geoms in its own
    frame (m); vision sensors: 1000 near and 1001 far clipping (m), 1004 perspective angle
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
    (simx_server.sim.joint_params.set_param); 3003 static and 3004 respondable of a shape only to the
    value they have (a scene's script marking an imported shape dynamic and respondable, as
    V-REP scripts do); another value -> UnsupportedError (fixed when the scene loads). Other
    ids -> UnsupportedError with the reason.
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
