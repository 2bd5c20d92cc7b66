"""Object commands: handles, object lists, poses (position, orientation, quaternion), the tree
(child, parent), the selection, model properties and collections (``simxGetObjectHandle``,
``simxGetObjectPosition``, ...). Every handler is ``(simulation, args) -> result``; values are
checked here, never trusted."""

from __future__ import annotations

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_floats, as_int
from simx_server.base.arguments import check_args as _args
from simx_server.commands.handler import Handler
from simx_server.scene.simulation import Simulation
from simx_server.sim import properties, scene_collections
from simx_server.sim.world import matrix_from_euler, matrix_from_quaternion


def get_object_handle(sim: Simulation, args: list) -> int:
    (name,) = _args(args, "str")
    return sim.world.resolve(name).handle


def get_objects(sim: Simulation, args: list) -> list[int]:
    (otype,) = _args(args, "int")
    return sim.world.objects_of_type(otype)


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
    """``simxGetModelProperty``: the model's bits where the scene or a client gave them (a
    ``.ttt``'s model bases, ``simxSetModelProperty``: :func:`simx_server.sim.properties.model_property`);
    otherwise a body directly under the world with bodies below it is a model (all its parts
    on: 0)."""
    (h,) = _args(args, "int")
    world = sim.world
    obj = world.get(h)
    bits = properties.model_property(world, h)
    if bits != MODELPROPERTY_NOT_MODEL or h in world.properties.model:
        return bits
    is_model = obj.parent == -1 and obj.type == 0 and bool(world.children(h))
    return 0 if is_model else MODELPROPERTY_NOT_MODEL


def set_model_property(sim: Simulation, args: list) -> None:
    """``simxSetModelProperty``: a model base's ``sim_modelproperty_not_*`` bits; not
    collidable, measurable, detectable, renderable (and not visible) act on every object of the
    model (V-REP's overrides of the special properties); the others are kept, nothing else
    changes (MuJoCo's dynamics and contacts follow the MJCF)."""
    h, prop = _args(args, "int", "int")
    properties.set_model_property(sim.world, h, prop)


def get_collection_handle(sim: Simulation, args: list) -> int:
    """``simxGetCollectionHandle``: the handle of a collection the scene declares
    (``simx:collection:NAME``, :mod:`simx_server.sim.scene_collections`; a ``.ttt`` file's own)."""
    (name,) = _args(args, "str")
    return scene_collections.of(sim.world).handle(name)



#: Command name -> handler: object handles, poses, tree, selection, model properties.
OBJECT_HANDLERS: dict[str, Handler] = {
    "GetObjectHandle": get_object_handle,
    "GetObjects": get_objects,
    "GetObjectPosition": get_object_position,
    "GetObjectOrientation": get_object_orientation,
    "GetObjectQuaternion": get_object_quaternion,
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
}
