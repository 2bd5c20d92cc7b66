"""One handler per remote command: ``(simulation, args) -> result``.

Handlers raise the exceptions of :mod:`simx_client.protocol` (RemoteError and subclasses); the
server turns them into error results and one log line. Argument lists are those the client's
facade sends (see docs/PROTOCOL.md); every value is checked here, never trusted.
"""

from __future__ import annotations

import os
import random
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np

from simx_client import constants as C
from simx_client.protocol import PROTOCOL_VERSION, ArgumentError, RemoteError, UnknownObjectError, UnsupportedError
from simx_server import collisions, group_data, kinematics, object_params, physics, sensors
from simx_server.arguments import as_floats, as_int, check_args as _args
from simx_server.editing_commands import EDITING_HANDLERS
from simx_server.simulation import RunState, Simulation
from simx_server.vision import Deferred
from simx_server.world import matrix_from_euler, matrix_from_quaternion

Handler = Callable[[Simulation, list], Any]


def hello(sim: Simulation, args: list) -> dict:
    """Handshake: the scene and protocol the server runs."""
    return {
        "protocol": PROTOCOL_VERSION,
        "scene": sim.world.scene_path.name,
        "objects": len(sim.world.objects),
        "dt": sim.world.dt,
    }


def get_object_handle(sim: Simulation, args: list) -> int:
    (name,) = _args(args, "str")
    return sim.world.resolve(name).handle


def get_objects(sim: Simulation, args: list) -> list[int]:
    (otype,) = _args(args, "int")
    return sim.world.objects_of_type(otype)


def get_joint_position(sim: Simulation, args: list) -> float:
    (h,) = _args(args, "int")
    return sim.world.joint_position(h)


def set_joint_position(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_position(h, v)


def set_joint_target_position(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_target_position(h, v)


def set_joint_target_velocity(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_target_velocity(h, v)


def set_joint_force(sim: Simulation, args: list) -> None:
    h, v = _args(args, "int", "float")
    sim.world.set_joint_force(h, v)


def get_joint_force(sim: Simulation, args: list) -> float:
    (h,) = _args(args, "int")
    return sim.world.joint_force(h)


def get_joint_max_force(sim: Simulation, args: list) -> float:
    (h,) = _args(args, "int")
    return sim.world.joint_max_force(h)


def _pose_args(sim: Simulation, args: list) -> tuple[int, int]:
    h, rel = _args(args, "int", "int")
    if rel != -1 and rel != C.sim_handle_parent:
        sim.world.get(rel)
    return h, rel


def get_object_position(sim: Simulation, args: list) -> list[float]:
    return sim.world.position(*_pose_args(sim, args))


def get_object_orientation(sim: Simulation, args: list) -> list[float]:
    return sim.world.orientation(*_pose_args(sim, args))


def get_object_quaternion(sim: Simulation, args: list) -> list[float]:
    return sim.world.quaternion(*_pose_args(sim, args))


def get_object_child(sim: Simulation, args: list) -> int:
    h, index = _args(args, "int", "int")
    children = sim.world.children(h)
    return children[index] if 0 <= index < len(children) else -1


def get_object_parent(sim: Simulation, args: list) -> int:
    (h,) = _args(args, "int")
    return sim.world.get(h).parent


def _pose_set_args(sim: Simulation, args: list, n: int, what: str) -> tuple[int, int, list[float]]:
    h, rel, values = _args(args, "int", "int", "any")
    return (*_pose_args(sim, [h, rel]), as_floats(values, n, what))


def set_object_position(sim: Simulation, args: list) -> None:
    h, rel, position = _pose_set_args(sim, args, 3, "position")
    sim.world.set_pose(h, rel, position=position)


def set_object_orientation(sim: Simulation, args: list) -> None:
    h, rel, euler = _pose_set_args(sim, args, 3, "Euler angles")
    sim.world.set_pose(h, rel, rotation=matrix_from_euler(*euler))


def set_object_quaternion(sim: Simulation, args: list) -> None:
    h, rel, quaternion = _pose_set_args(sim, args, 4, "quaternion")
    sim.world.set_pose(h, rel, rotation=matrix_from_quaternion(*quaternion))


def get_object_selection(sim: Simulation, args: list) -> list[int]:
    _args(args)
    sim.selection = [h for h in sim.selection if h in sim.world.objects]
    return list(sim.selection)


def set_object_selection(sim: Simulation, args: list) -> None:
    (handles,) = _args(args, "any")
    if not isinstance(handles, list):
        raise ArgumentError("object handles must be a list")
    for h in handles:
        sim.world.get(as_int(h, "object handle"))
    sim.selection = list(dict.fromkeys(handles))


MODELPROPERTY_NOT_MODEL = 0xF000  # sim_modelproperty_not_model


def get_model_property(sim: Simulation, args: list) -> int:
    """A body directly under the world with bodies below it is a model (all its parts on: 0)."""
    (h,) = _args(args, "int")
    obj = sim.world.get(h)
    is_model = obj.parent == -1 and obj.type == 0 and bool(sim.world.children(h))
    return 0 if is_model else MODELPROPERTY_NOT_MODEL


def set_model_property(sim: Simulation, args: list) -> None:
    h, _prop = _args(args, "int", "int")
    sim.world.get(h)
    raise UnsupportedError("model properties (collidable, renderable, dynamic...) cannot be switched in MuJoCo "
                           "at run time; edit the MJCF (contype/conaffinity, group, mass) instead")


def get_collection_handle(sim: Simulation, args: list) -> int:
    (name,) = _args(args, "str")
    raise UnknownObjectError(f"collection {name!r} does not exist: simx scenes declare no collections")


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


# Signals: one store per server, shared by every client and child script.
_SIGNAL_KINDS = {"Integer": "int", "Float": "float", "String": "string"}


def _set_signal(kind: str) -> Handler:
    def handler(sim: Simulation, args: list) -> None:
        name, value = _args(args, "str", "any")
        sim.signals.set(kind, name, value)

    return handler


def _get_signal(kind: str, clear: bool = False) -> Handler:
    def handler(sim: Simulation, args: list) -> Any:
        (name,) = _args(args, "str")
        value = sim.signals.get(kind, name)
        if value is None:
            raise UnknownObjectError(f"{kind} signal {name!r} does not exist")
        if clear:
            sim.signals.clear(kind, name)
        return value

    return handler


def _clear_signal(kind: str) -> Handler:
    def handler(sim: Simulation, args: list) -> None:
        (name,) = _args(args, "str")
        sim.signals.clear(kind, name or None)  # "" clears every signal of the kind

    return handler


def append_string_signal(sim: Simulation, args: list) -> None:
    name, value = _args(args, "str", "any")
    if not isinstance(value, bytes):
        raise ArgumentError("string signal data must be bytes")
    sim.signals.set("string", name, sim.signals.get("string", name, b"") + value)


def read_string_stream(sim: Simulation, args: list) -> bytes:
    """What was written to the stream since the last read (empty when nothing was)."""
    (name,) = _args(args, "str")
    value = sim.signals.get("string", name, b"")
    sim.signals.clear("string", name)
    return value


SIGNAL_HANDLERS: dict[str, Handler] = {
    **{f"Set{k}Signal": _set_signal(v) for k, v in _SIGNAL_KINDS.items()},
    **{f"Get{k}Signal": _get_signal(v) for k, v in _SIGNAL_KINDS.items()},
    **{f"Clear{k}Signal": _clear_signal(v) for k, v in _SIGNAL_KINDS.items()},
    "GetAndClearStringSignal": _get_signal("string", clear=True),
    "AppendStringSignal": append_string_signal,
    "WriteStringStream": append_string_signal,
    "ReadStringStream": read_string_stream,
}


def gui_only(name: str) -> Handler:
    """Handler for a call that needs V-REP's GUI (custom UIs, dialogs): always a remote error."""

    def handler(sim: Simulation, args: list) -> None:
        raise UnsupportedError(f"simx{name} needs V-REP's graphical user interface; simx is headless")

    return handler


GUI_ONLY = ("LoadUI", "GetUIHandle", "GetUISlider", "SetUISlider", "GetUIEventButton", "GetUIButtonProperty",
            "SetUIButtonProperty", "SetUIButtonLabel", "RemoveUI", "DisplayDialog", "EndDialog",
            "GetDialogInput", "GetDialogResult")


def start_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.start()


def stop_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.stop()


def pause_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.pause()


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


def call_script_function(sim: Simulation, args: list) -> list:
    obj, stype, fn, ints, floats, strings, buf = _args(args, "str", "int", "str", "any", "any", "any", "any")
    return sim.scripts.call(obj, stype, fn, ints, floats, strings, buf)


def get_ping_time(sim: Simulation, args: list) -> None:
    """A no-op executed in order with the others: its round trip is the ping time."""
    _args(args)


#: Command name -> handler. Synchronous, SynchronousTrigger and Bye are handled by the
#: server itself, since they concern the client connection and the stepping loop.
HANDLERS: dict[str, Handler] = {
    "Hello": hello,
    "GetPingTime": get_ping_time,
    "GetObjectHandle": get_object_handle,
    "GetObjects": get_objects,
    "GetJointPosition": get_joint_position,
    "SetJointPosition": set_joint_position,
    "SetJointTargetPosition": set_joint_target_position,
    "SetJointTargetVelocity": set_joint_target_velocity,
    "SetJointForce": set_joint_force,
    "GetJointForce": get_joint_force,
    "GetJointMaxForce": get_joint_max_force,
    "GetObjectPosition": get_object_position,
    "GetObjectOrientation": get_object_orientation,
    "GetObjectQuaternion": get_object_quaternion,
    "StartSimulation": start_simulation,
    "StopSimulation": stop_simulation,
    "PauseSimulation": pause_simulation,
    "GetVisionSensorImage": get_vision_sensor_image,
    "GetVisionSensorDepthBuffer": get_vision_sensor_depth_buffer,
    "CallScriptFunction": call_script_function,
    "GetObjectChild": get_object_child,
    "GetObjectParent": get_object_parent,
    "SetObjectPosition": set_object_position,
    "SetObjectOrientation": set_object_orientation,
    "SetObjectQuaternion": set_object_quaternion,
    "GetObjectSelection": get_object_selection,
    "SetObjectSelection": set_object_selection,
    "GetModelProperty": get_model_property,
    "SetModelProperty": set_model_property,
    "GetCollectionHandle": get_collection_handle,
    "GetIntegerParameter": get_integer_parameter,
    "SetIntegerParameter": set_integer_parameter,
    "GetFloatingParameter": get_floating_parameter,
    "SetFloatingParameter": set_floating_parameter,
    "GetBooleanParameter": get_boolean_parameter,
    "SetBooleanParameter": set_boolean_parameter,
    "GetStringParameter": get_string_parameter,
    "GetArrayParameter": get_array_parameter,
    "SetArrayParameter": set_array_parameter,
    **{name: gui_only(name) for name in GUI_ONLY},
    **SIGNAL_HANDLERS,
    **sensors.SENSOR_HANDLERS,
    **kinematics.KINEMATICS_HANDLERS,
    **collisions.COLLISION_HANDLERS,
    **group_data.GROUP_DATA_HANDLERS,
    **object_params.PARAM_HANDLERS,
    **EDITING_HANDLERS,
}
