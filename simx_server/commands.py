"""One handler per remote command: ``(simulation, args) -> result``.

Handlers raise the exceptions of :mod:`simx_client.protocol` (RemoteError and subclasses); the
server turns them into error results and one log line. Argument lists are those the client's
facade sends (see docs/PROTOCOL.md); every value is checked here, never trusted.
"""

from __future__ import annotations

from typing import Any, Callable

from simx_client import constants as C
from simx_client.protocol import PROTOCOL_VERSION, ArgumentError
from simx_server.simulation import Simulation

Handler = Callable[[Simulation, list], Any]


def _int(value: Any, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ArgumentError(f"{what} must be an int, got {type(value).__name__}")
    return value


def _float(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ArgumentError(f"{what} must be a number, got {type(value).__name__}")
    return float(value)


def _args(args: list, *kinds: str) -> list:
    """Check arity and convert each argument: kinds are "int", "float", "str", "any"."""
    if len(args) != len(kinds):
        raise ArgumentError(f"expected {len(kinds)} arguments, got {len(args)}")
    out = []
    for i, (a, k) in enumerate(zip(args, kinds)):
        if k == "int":
            out.append(_int(a, f"argument {i + 1}"))
        elif k == "float":
            out.append(_float(a, f"argument {i + 1}"))
        elif k == "str":
            if not isinstance(a, str):
                raise ArgumentError(f"argument {i + 1} must be a string, got {type(a).__name__}")
            out.append(a)
        else:
            out.append(a)
    return out


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


def start_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.start()


def stop_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.stop()


def pause_simulation(sim: Simulation, args: list) -> None:
    _args(args)
    sim.pause()


def get_vision_sensor_image(sim: Simulation, args: list) -> list:
    h, options = _args(args, "int", "int")
    resolution, data = sim.vision.image_bytes(h, options)
    return [resolution, data]


def get_vision_sensor_depth_buffer(sim: Simulation, args: list) -> list:
    (h,) = _args(args, "int")
    resolution, data = sim.vision.depth_bytes(h)
    return [resolution, data]


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
}
