"""PyRep's ``pyrep.backend.sim`` over simx's API table.

PyRep talks to CoppeliaSim through one process-wide C library; here every call goes to the
``sim``/``simIK`` table of :mod:`simx_server.api` (the functions Lua, Python scripts and ZMQ
clients call; ``simOMPL`` too), bound to the simulation of the current :class:`pyrep.PyRep` (the last launched
one still running, or the one made current with :meth:`pyrep.PyRep.make_current`).

Constants: every ``sim_*`` constant of V-REP/CoppeliaSim that simx knows, plus the few PyRep
uses that only CoppeliaSim 4.x has (``sim_handle_scene``, ``sim_object_octree_type``...).
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import logging
import os
from pathlib import Path
from typing import Any, ContextManager

from simx_server.api import ApiNamespace, CallContext
from simx_wire.constants import VREP_CONSTANTS
from simx_wire.protocol import SimxError

from pyrep.errors import CoppeliaSimError, PyRepError

globals().update({k: v for k, v in VREP_CONSTANTS.items() if k.startswith("sim_")})

# CoppeliaSim 4.1's values (simConst.lua of 4.1) of the constants PyRep uses that V-REP 3.x lacks.
sim_handle_scene = -12
sim_object_octree_type = 15
sim_object_pointcloud_type = 16
sim_texturemap_plane = 0
sim_texturemap_cylinder = 1
sim_texturemap_sphere = 2
sim_texturemap_cube = 3
sim_scripttype_addonscript = 2
sim_bullet_body_friction = 6003
sim_light_omnidirectional_subtype = 1
sim_light_spot_subtype = 2
sim_light_directional_subtype = 3

#: The contexts of the launched PyRep instances, the current one last.
_contexts: list[CallContext] = []


def push(ctx: CallContext) -> None:
    """Make ``ctx`` (a launched PyRep's) current."""
    if ctx in _contexts:
        _contexts.remove(ctx)
    _contexts.append(ctx)


def pop(ctx: CallContext) -> None:
    """Forget ``ctx`` (its PyRep shut down); the previous one becomes current."""
    if ctx in _contexts:
        _contexts.remove(ctx)


def use(ctx: CallContext | None) -> None:
    """Make ``ctx`` current if it is a launched PyRep's and not current already (None, or the
    context of a PyRep shut down since: nothing changes)."""
    if ctx is not None and _contexts and _contexts[-1] is not ctx and ctx in _contexts:
        _contexts.remove(ctx)
        _contexts.append(ctx)


def _on_its_world(method: Any) -> Any:
    @functools.wraps(method)
    def on_its_world(self: Any, *args: Any, **kwargs: Any) -> Any:
        ctx = self.__dict__.get("_ctx")
        if ctx is not None and _contexts and _contexts[-1] is not ctx:  # use()'s test: current already, the usual case
            use(ctx)
        return method(self, *args, **kwargs)

    return on_its_world


class OnItsWorld:
    """A mixin for PyRep's objects: each method of the class and its subclasses (not the dunder
    ones, not static or class methods) acts on the world of the PyRep the object was made in
    (:meth:`_bind_world`, called by ``__init__``), making that PyRep current first. With one
    PyRep per process, as on CoppeliaSim, nothing changes; with several (a Gymnasium
    ``SyncVectorEnv`` of RLBench environments, one PyRep each), an environment's arm no longer
    moves the arm of the environment stepped last. Objects made without a method of an object
    (``Dummy.create`` in a program's own code) go to the current PyRep, as before.
    """

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        for name, value in list(vars(cls).items()):
            if inspect.isfunction(value) and not name.startswith("__"):
                setattr(cls, name, _on_its_world(value))

    def _bind_world(self) -> None:
        """Bind this object to the current PyRep's world.

        Raises:
            PyRepError: no PyRep is launched.
        """
        self.__dict__["_ctx"] = context()


def context() -> CallContext:
    """The current PyRep's call context.

    Raises:
        PyRepError: no PyRep is launched.
    """
    if not _contexts:
        raise PyRepError("PyRep is not launched: call PyRep().launch(scene) first")
    return _contexts[-1]


def api() -> ApiNamespace:
    """``sim`` of the current PyRep (the API table bound to its simulation)."""
    return context().sim


def call(name: str, *args: Any) -> Any:
    """``sim.<name>(*args)`` on the current PyRep's simulation.

    Raises:
        CoppeliaSimError: (a RuntimeError, as PyRep's backend raises) the table refused the call
            (no such object, bad argument, not supported by simx); the message names the call.
    """
    if not _contexts:
        context()  # raises PyRepError
    try:
        return _contexts[-1].sim.call(name, *args)  # api().call, two calls fewer: ~70 a step of RLBench
    except (SimxError, AttributeError) as exc:
        raise CoppeliaSimError(f"sim.{name}: {exc}") from exc


def one_change() -> ContextManager[Any]:
    """A block of state writes (joints placed one by one) whose derived quantities (poses,
    contacts) are recomputed once at its end instead of after each write: the same state after
    (``simx_server.sim.world.World.one_change``). Calls in the block must not read poses.
    Against a remote server: no effect (each call is the server's).

    Returns:
        The context manager.
    """
    world = getattr(context(), "world", None)
    return world.one_change() if world is not None else contextlib.nullcontext()


def ik_call(name: str, *args: Any) -> Any:
    """``simIK.<name>(*args)`` on the current PyRep's simulation (errors as :func:`call`)."""
    try:
        return context().simik.call(name, *args)
    except (SimxError, AttributeError) as exc:
        raise CoppeliaSimError(f"simIK.{name}: {exc}") from exc


def ompl_call(name: str, *args: Any) -> Any:
    """``simOMPL.<name>(*args)`` on the current PyRep's simulation (errors as :func:`call`)."""
    try:
        return context().simompl.call(name, *args)
    except (SimxError, AttributeError) as exc:
        raise CoppeliaSimError(f"simOMPL.{name}: {exc}") from exc


def ompl_constants(group: str) -> dict[str, int]:
    """``simOMPL.<group>`` (``Algorithm``, ``StateSpaceType``) of the current PyRep: name -> value."""
    table = getattr(context().simompl, group)
    if isinstance(table, dict):
        return {str(k): int(v) for k, v in table.items()}
    return {k: int(v) for k, v in vars(table).items() if not k.startswith("_")}  # the official client's object


#: The algorithms already reported as planned with RRTConnect (one warning each per process).
_SUBSTITUTED: set[str] = set()


def ompl_set_algorithm(task: Any, name: str, caller: str) -> None:
    """``simOMPL.setAlgorithm`` of the planner named ``name`` (a ``ConfigurationPathAlgorithms``
    value), as PyRep's add-on's ``_getAlgorithm``; one that OMPL's Python bindings lack plans
    with RRTConnect, with a warning logged once per algorithm naming ``caller``.

    Raises:
        CoppeliaSimError: an algorithm that CoppeliaSim's simOMPL does not have (``pRRT``,
            ``pSBL``: PyRep's script call fails on them), or OMPL is not installed.
    """
    algorithms = ompl_constants("Algorithm")
    if name not in algorithms:
        raise CoppeliaSimError(f"The call failed on the V-REP side: simOMPL has no algorithm {name!r}")
    try:
        ompl_call("setAlgorithm", task, algorithms[name])
    except CoppeliaSimError as exc:
        ompl_call("setAlgorithm", task, algorithms["RRTConnect"])
        if name not in _SUBSTITUTED:
            _SUBSTITUTED.add(name)
            logging.getLogger("pyrep").warning("%s: %s; planning with RRTConnect instead", caller, exc)


def trust_folder(folder: Any) -> None:
    """Let the in-process scene read files of ``folder`` (``sim.loadModel``, ``importShape``,
    ``importMesh``...): a PyRep program owns its process, so every folder it names is its own
    (a server trusts only its scene's and ``--scene-path`` folders). Connected to a simx-server
    (a remote context has no simulation here), the server decides what it reads.

    Args:
        folder: a folder (str or Path).
    """
    view = getattr(context(), "view", None)
    if view is None:
        return
    roots = view.editor.files.roots
    real = Path(os.path.realpath(folder))
    if real not in roots:
        roots.append(real)


def program_file(filename: Any) -> str:
    """The name to give the ``sim`` table for a file the program names (``create_texture``,
    ``import_shape``, ``import_model``, ``export_scene``...). In process: its absolute path, a
    relative name taken from the program's working folder, as CoppeliaSim, which runs in PyRep's
    process, opens it, and its folder trusted (:func:`trust_folder`). Connected to a simx-server:
    the name as given, which the server resolves in its own folders and confines
    (docs/SECURITY.md).

    Args:
        filename: a path (str or path-like).

    Returns:
        The name.
    """
    name = os.fspath(filename)
    if getattr(context(), "view", None) is None:
        return name
    path = os.path.abspath(name)
    trust_folder(os.path.dirname(path))
    return path


def simulation() -> Any:
    """The current PyRep's :class:`~simx_server.scene.simulation.Simulation`."""
    return context().simulation("pyrep")
