"""The ``sim`` functions of a program outside the scene (running the simulation, scene files, the log).

A ZMQ remote API client calls the same table as child scripts (docs/SCRIPTS.md): one
implementation of every ``sim.NAME``, with the world read from the simulation at each call (a
scene load replaces it; :func:`simx_server.api.client_context`). The functions here are the
ones a remote program adds (CoppeliaSim 4.x's names, arguments and returns): running the
simulation, scene files, the object selection, passive vision sensors' images, calls into the
scene's child scripts, the log. Those that act on the server from outside the scene
(starting the simulation, loading and closing scenes and models, calling into scripts) are
registered for clients only (:attr:`~simx_server.api.registry.Callers.CLIENTS`); a child
script calls the others too (``sim.stopSimulation`` and ``sim.pauseSimulation`` are then a
request, carried out once its pass is over). Pose arithmetic is shared with scripts
(:mod:`simx_server.api.sim.posemath`). The stepping calls
(``sim.setStepping``, ``sim.step``, ``sim.acquireLock``, ``sim.releaseLock``) belong to a client,
not to the scene: :mod:`simx_server.zmq.service` answers them.

Runs on the simulation thread, like every command handler.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any


from simx_server.api.context import CallContext
from simx_server.api.registry import Callers, sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, RemoteError, ScriptError, UnsupportedError
from simx_server.base.arguments import quote
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int
from simx_server.base.arguments import as_text as _text, as_vector as _vector
from simx_server.sim import paths
from simx_server.sim.sensors import set_passive_image
from simx_server.sim.state import RunState
from simx_server.api import names
from simx_server.api.sim.stepped import strings_as_text

log = logging.getLogger("simx.zmq")

#: Scene and model files of CoppeliaSim that stand for MJCF files of the same stem.
COPPELIASIM_SCENES, COPPELIASIM_MODELS = (".ttt",), (".ttm",)
_VERBOSITY_MASK = 0xFFF  # sim.addLog's level, without its flags (undecorated, only terminal, once)


# ``sim`` as the ZMQ remote API offers it, over the server's simulation (its world, vision
# sensors, scripts and editor are read at each call: :meth:`CallContext.simulation`).

@sim_function("startSimulation", callers=Callers.CLIENTS)
def startSimulation(ctx: CallContext) -> int:  # noqa: N802 (CoppeliaSim's names)
    """Start (or resume) the simulation; 1, or 0 when it already runs (CoppeliaSim's result)."""
    if ctx.simulation("startSimulation").state is RunState.RUNNING:
        return 0
    ctx.simulation("startSimulation").start()
    return 1


@sim_function("pauseSimulation")
def pauseSimulation(ctx: CallContext) -> int:  # noqa: N802
    """Pause a running simulation; 1, or 0 when it does not run. From a child script, a
    request carried out once the current pass is over (as CoppeliaSim's, whose scripts'
    requests wait for the main loop): the script's code goes on meanwhile."""
    if ctx.caller is Callers.SCRIPTS:
        return ctx.simulation("pauseSimulation").request(RunState.PAUSED)
    if ctx.simulation("pauseSimulation").state is not RunState.RUNNING:
        return 0
    ctx.simulation("pauseSimulation").pause()
    return 1


@sim_function("stopSimulation")
def stopSimulation(ctx: CallContext, wait: Any = False) -> int | None:  # noqa: N802
    """Stop the simulation: the scripts' cleanup, then the scene's initial state. For a remote
    client simx stops at once, so ``wait`` changes nothing (the state is stopped when the call
    returns). From a child script (V-REP's ``simStopSimulation`` too), a request carried out
    once the current pass is over, as in CoppeliaSim (its scripts' requests wait for the main
    loop; ``wait`` cannot wait for the pass the script runs in): 1, or 0 when stopped already.
    """
    if ctx.caller is Callers.SCRIPTS:
        return ctx.simulation("stopSimulation").request(RunState.STOPPED)
    ctx.simulation("stopSimulation").stop()
    return None


@sim_function("getSystemTime")
def getSystemTime(ctx: CallContext) -> float:  # noqa: N802
    """Wall-clock time in s (for differences)."""
    return time.time()


@sim_function("addLog")
def addLog(ctx: CallContext, verbosityLevel: Any, logMessage: Any) -> None:  # noqa: N802, N803
    """Write ``logMessage`` to the server's log at the level of ``verbosityLevel``
    (``sim.verbosity_errors``/``scripterrors``: error, ``warnings``/``scriptwarnings``: warning,
    others: info)."""
    level = _int(verbosityLevel, "verbosityLevel") & _VERBOSITY_MASK
    text = _text(logMessage, "logMessage")
    text = (text[:1000] + f"... ({len(text)} characters)" if len(text) > 1000 else text).encode(
        "unicode_escape").decode("ascii")  # one log line, whatever the client sends
    who = "client" if ctx.caller is Callers.CLIENTS else ctx.label  # a script: its own name, as print
    if level in (200, 420):
        log.error("[%s] %s", who, text)
    elif level in (300, 430):
        log.warning("[%s] %s", who, text)
    elif level != 100:  # sim.verbosity_none
        log.info("[%s] %s", who, text)


def _stand_in(ctx: CallContext, filename: str, kinds: tuple[str, ...]) -> str:
    """The file to load for a CoppeliaSim scene (.ttt) or model (.ttm): the file itself where
    it exists (loaded through its MJCF conversion), else the MJCF that stands in for it: the
    same path with .xml, else ``<stem>.xml`` in the server's scene folders; other names as given."""
    path = Path(filename)
    if path.suffix.lower() not in kinds:
        return filename
    editor = ctx.simulation("_stand_in").editor
    try:  # the real file, where one exists (converted to MJCF as it is loaded)
        editor.files.locate(filename, 0, editor.scene_origin())
        return filename
    except ArgumentError:  # a name refused as it is (its length): no other file stands in
        raise
    except RemoteError:
        pass
    candidates = [str(path.with_suffix(".xml"))] + [str(root / f"{path.stem}.xml") for root in editor.files.roots]
    for candidate in candidates:
        try:
            file = editor.resolve(candidate, 0)
        except RemoteError:
            continue
        log.info("%s %s: %s stands in for it", "scene" if kinds == COPPELIASIM_SCENES else "model",
                 quote(filename), editor.public(file))
        return str(file)
    raise RemoteError(f"no MJCF file stands in for {quote(filename)}: looked for {path.stem}.xml beside it and "
                      "in the server's scene folders (the scene's folder and --scene-path)")


@sim_function("loadScene", callers=Callers.CLIENTS)
def loadScene(ctx: CallContext, filename: Any) -> None:  # noqa: N802
    """Replace the scene with a server-side scene file, under ``simxLoadScene``'s rules (the
    simulation stopped; only the scene's folder and ``--scene-path`` folders). A CoppeliaSim
    ``.ttt`` path loads the MJCF scene of the same stem (see :func:`_stand_in`)."""
    if isinstance(filename, (bytes, bytearray)):
        raise UnsupportedError("sim.loadScene of a serialized scene (a buffer) is not supported; give a file name")
    name = _stand_in(ctx, _text(filename, "filename"), COPPELIASIM_SCENES)
    return ctx.simulation("loadScene").editor.load_scene(name, 0, defer=True)  # a .ttt: converted off this thread


@sim_function("loadModel")
def loadModel(ctx: CallContext, filename: Any) -> int:  # noqa: N802
    """Add a server-side model file (``simxLoadModel`` with options 0: the scene's folder and
    ``--scene-path`` folders; a ``.ttm`` path loads the file through its conversion, else the
    MJCF model of the same stem) with its scripts (:mod:`simx_server.scene.model_scripts`);
    returns its base's handle. A client's ``.ttm`` is converted off the simulation thread
    (the reply waits for it); a script's call converts it at once and returns the handle, as
    CoppeliaSim's ``sim.loadModel`` (``CFileOperations::loadModel``).

    Args:
        filename: a path, absolute or relative to the scene's folder.

    Returns:
        The model base's handle.

    Raises:
        UnsupportedError: a buffer instead of a file name, or no simulation behind the call.
        RemoteError: the file is refused (outside the trusted folders) or cannot be loaded.
    """
    if isinstance(filename, (bytes, bytearray)):
        raise UnsupportedError("sim.loadModel of a serialized model (a buffer) is not supported; give a file name")
    name = _stand_in(ctx, _text(filename, "filename"), COPPELIASIM_MODELS)
    # a client's .ttm: converted off this thread; a script waits for its handle
    return ctx.simulation("loadModel").editor.load_model(name, 0, defer=ctx.caller is Callers.CLIENTS)


@sim_function("getObjectSel")
def getObjectSel(ctx: CallContext) -> list[int]:  # noqa: N802
    """The object selection (no GUI: what clients set)."""
    return list(ctx.simulation("getObjectSel").selection)


@sim_function("setObjectSel")
def setObjectSel(ctx: CallContext, objectHandles: Any) -> None:  # noqa: N802, N803
    if not isinstance(objectHandles, list):
        raise ArgumentError("objectHandles must be a list of handles")
    ctx.simulation("setObjectSel").selection = [ctx.world.get(ctx.h(h, "objectHandle")).handle for h in objectHandles]


@sim_function("setVisionSensorImg")
def setVisionSensorImg(ctx: CallContext, sensorHandle: Any, image: Any, options: Any = 0, pos: Any = None,  # noqa: N802, N803
                       size: Any = None) -> None:
    """Write an image into a passive vision sensor (``image=external``): uint8 RGB (``options``
    bit 0: grey), rows bottom-up, the sensor's whole resolution; as ``simxSetVisionSensorImage``."""
    if any(v is not None and _vector(v, 2, "pos/size") != [0.0, 0.0] for v in (pos, size)):
        raise UnsupportedError("setVisionSensorImg of a window (pos/size) is not supported: send the whole image")
    set_passive_image(ctx.simulation("setVisionSensorImg"), ctx.h(sensorHandle), _bytes(image, "image"),
                      bool(_int(options, "options") & 1))


@sim_function("isDeprecated")
def isDeprecated(ctx: CallContext, funcOrConst: Any) -> int:  # noqa: N802, N803
    """1 for a function CoppeliaSim 4.x keeps under a deprecated name (``sim.getScriptHandle``...),
    0 for a current function or constant, -1 for an unknown name."""
    name = _text(funcOrConst, "funcOrConst").removeprefix("sim.")
    if name in names.DEPRECATED["sim"]:
        return 1
    return 0 if name in names.current_functions("sim") or name in names.constants("sim") else -1


@sim_function("setVisionSensorCharImage")
def setVisionSensorCharImage(ctx: CallContext, sensorHandle: Any, image: Any) -> None:  # noqa: N802, N803
    """CoppeliaSim's older name: :func:`setVisionSensorImg` of a whole RGB image."""
    setVisionSensorImg(ctx, sensorHandle, image)


@sim_function("closeScene", callers=Callers.CLIENTS)
def closeScene(ctx: CallContext) -> int:  # noqa: N802
    """Stop the simulation and replace the scene with an empty one (``simxCloseScene``); 1."""
    ctx.simulation("closeScene").editor.close_scene()
    return 1


@sim_function("getScript")
def getScript(ctx: CallContext, scriptType: Any, objectHandle: Any = -1, scriptName: Any = "") -> int:  # noqa: N802, N803
    """The script handle of an object's child script (``sim.scripttype_childscript``): in simx
    the handle of the object it is attached to (``objectHandle``, or a path or name); -1
    when it has none. From a script, ``sim.getScript(sim.handle_self)`` is its own handle
    (CoppeliaSim 4.6+)."""
    if _int(scriptType, "scriptType") == C.sim_handle_self and ctx.caller is Callers.SCRIPTS:
        return ctx.owner
    if _int(scriptType, "scriptType") != C.sim_scripttype_childscript:
        raise UnsupportedError("sim.getScript: simx has child scripts only (sim.scripttype_childscript)")
    target = objectHandle if isinstance(objectHandle, (str, bytes)) else scriptName if scriptName else objectHandle
    if isinstance(target, (str, bytes)):
        h = paths.find_one(ctx.world, _text(target, "scriptName"))
    else:
        h = ctx.h(target)
    return h if h in ctx.simulation("getScript").scripts.scripts else -1


#: The child scripts whose call into another script (``sim.callScriptFunction``) is under way:
#: a call back into one of them would run inside its own running code (its time bound and
#: state are those of the call under way), so it is refused.
_WAITING: set[int] = set()


@sim_function("callScriptFunction")
def callScriptFunction(ctx: CallContext, functionName: Any, scriptHandleOrType: Any, *args: Any) -> tuple:  # noqa: N802, N803
    """Call a function of a child script with any arguments; returns its return values.

    ``("func@/path", sim.scripttype_childscript, ...)`` (CoppeliaSim 4.0-4.5: the script of
    the object the path or name names) or ``("func", scriptHandle, ...)`` (4.6+: a handle of
    :func:`getScript`, which is the object's). Lua strings come back as text where they are
    UTF-8, as bytes otherwise. A child script calls another script's function the same way
    (CoppeliaSim's gripper and controller scripts do), not its own nor one whose call to it is
    under way. A stop or pause the function asks for comes once a client's call has returned
    (a script's: at the end of its pass). Errors: no such object, script or function; a call
    back into a calling script; the script's own."""
    name = _text(functionName, "functionName")
    target = _int(scriptHandleOrType, "scriptHandleOrType")
    if "@" in name:
        name, _, where = name.partition("@")
        if target != C.sim_scripttype_childscript:
            raise UnsupportedError("sim.callScriptFunction: simx has child scripts only (sim.scripttype_childscript)")
        handle = paths.find_one(ctx.world, where)
    else:
        handle = ctx.h(target)
    simulation = ctx.simulation("callScriptFunction")
    try:
        script = simulation.scripts.script_of(ctx.world.get(handle).handle)
    except ScriptError:
        raise ScriptError(f"object {ctx.world.get(handle).name!r} has no child script") from None
    caller = ctx.script
    if caller is not None and (script is caller or id(script) in _WAITING):
        raise ScriptError(f"sim.callScriptFunction: {script.label} is running (it made this call, or a call that "
                          f"led to it): a script's function cannot be called from inside its own call")
    if caller is not None:
        _WAITING.add(id(caller))
    try:
        with simulation.editor.files.on_behalf():  # the script's file calls act as this client
            values = script.call_values(name, list(args))
    finally:
        if caller is not None:
            _WAITING.discard(id(caller))
        else:  # a client's call: a stop or pause the function asked for, now that it returned
            simulation.apply_requests()
    return tuple(strings_as_text(v) for v in values)
