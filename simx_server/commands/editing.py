"""The scene-editing command handlers: ``(simulation, args) -> result``, each checking its
arguments and calling the simulation's :class:`~simx_server.scene.editor.Editor`.

Runs on the simulation thread, like every handler; a load of a ``.ttt``/``.ttm`` file answers
a Deferred (converted in a worker process, loaded later: :mod:`simx_server.scene.conversions`).
"""

from __future__ import annotations

from typing import Any

from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import check_args as _args
from simx_server.scene.simulation import Simulation
from simx_server.sim.vision_results import Deferred


# --------------------------------------------------------------------------- handlers
def _bool(value: Any, what: str) -> bool:
    if isinstance(value, bool) or (isinstance(value, int) and value in (0, 1)):
        return bool(value)
    raise ArgumentError(f"{what} must be a bool, got {value!r}")


def transfer_file(sim: Simulation, args: list) -> Deferred | None:
    """``simxTransferFile``: with a loop (``sim.post``), the file is written off the simulation
    thread and the reply leaves once it is written (a Deferred)."""
    name, data = _args(args, "str", "any")
    write = sim.editor.transfer_file(name, data, later=getattr(sim, "post", None) is not None)
    return None if write is None else Deferred(write)


def erase_file(sim: Simulation, args: list) -> None:
    (name,) = _args(args, "str")
    sim.editor.erase_file(name)


def load_model(sim: Simulation, args: list) -> int | Deferred:
    path, options = _args(args, "str", "int")
    return sim.editor.load_model(path, options, defer=True)  # a .ttm: converted off this thread


def remove_object(sim: Simulation, args: list) -> None:
    (h,) = _args(args, "int")
    sim.editor.remove_object(h)


def remove_model(sim: Simulation, args: list) -> None:
    (h,) = _args(args, "int")
    sim.editor.remove_model(h)


def copy_paste_objects(sim: Simulation, args: list) -> list[int]:
    (handles,) = _args(args, "any")
    if not isinstance(handles, list) or not handles or not all(
            isinstance(h, int) and not isinstance(h, bool) for h in handles):
        raise ArgumentError("object handles must be a non-empty list of ints")
    return sim.editor.copy_paste(handles)


def create_dummy(sim: Simulation, args: list) -> int:
    size, colors = _args(args, "float", "any")
    return sim.editor.create_dummy(size, colors)


def set_object_parent(sim: Simulation, args: list) -> None:
    h, parent, keep = _args(args, "int", "int", "any")
    sim.editor.set_parent(h, parent, _bool(keep, "keepInPlace"))


def load_scene(sim: Simulation, args: list) -> Deferred | None:
    path, options = _args(args, "str", "int")
    return sim.editor.load_scene(path, options, defer=True)  # a .ttt: converted off this thread


def close_scene(sim: Simulation, args: list) -> None:
    _args(args)
    sim.editor.close_scene()


#: Command name -> handler, merged into simx_server.commands.HANDLERS.
EDITING_HANDLERS = {
    "TransferFile": transfer_file,
    "EraseFile": erase_file,
    "LoadModel": load_model,
    "RemoveObject": remove_object,
    "RemoveModel": remove_model,
    "CopyPasteObjects": copy_paste_objects,
    "CreateDummy": create_dummy,
    "SetObjectParent": set_object_parent,
    "LoadScene": load_scene,
    "CloseScene": close_scene,
}
