"""``sim`` of a ZMQ remote API client: the child scripts' facade, plus what remote programs need.

:class:`RemoteSim` *is* the facade of child scripts (:class:`~simx_server.scripts.facade.ScriptSim`,
docs/SCRIPTS.md): one implementation of every ``sim.NAME`` both share, with the world it works on
read from the simulation at each call (a scene load replaces it). On top it adds the calls that a
program outside the scene makes and a script did not need (CoppeliaSim 4.x's names, arguments and
returns): running the simulation, its parameters, scene files, removing objects, poses as 7
numbers, passive vision sensors and depth buffers, calls into the scene's child scripts, the
log; pose arithmetic comes with ScriptSim (:class:`~simx_server.scripts.facade_posemath.PoseMath`). The stepping calls
(``sim.setStepping``, ``sim.step``, ``sim.acquireLock``, ``sim.releaseLock``) belong to a client,
not to the scene: :mod:`simx_server.zmq.service` answers them.

Runs on the simulation thread, like every command handler.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any


from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, RemoteError, ScriptError, UnsupportedError
from simx_server.base.arguments import quote
from simx_server.scene import parameters
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import cache as ttt_cache
from simx_server.scripts.facade import ScriptSim
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int
from simx_server.base.arguments import as_text as _text, as_vector as _vector
from simx_server.scripts.signals import Signals
from simx_server.sim import paths
from simx_server.sim.sensors import set_passive_image
from simx_server.sim.objects import WORLD
from simx_server.sim.state import RunState
from simx_server.zmq import names
from simx_server.zmq.motion import MAX_MOTION_STEPS, MotionCalls, Stepped

log = logging.getLogger("simx.zmq")

#: CoppeliaSim 4.x string parameters simx answers besides the legacy ones (simConst.h's numbering).
STRINGPARAM_SCENE_PATH, STRINGPARAM_SCENE_NAME, STRINGPARAM_SCENEDEFAULTDIR = 14, 15, 132
#: Scene and model files of CoppeliaSim that stand for MJCF files of the same stem.
COPPELIASIM_SCENES, COPPELIASIM_MODELS = (".ttt",), (".ttm",)
_VERBOSITY_MASK = 0xFFF  # sim.addLog's level, without its flags (undecorated, only terminal, once)


def _strings(value: Any) -> Any:
    """Lua strings (bytes) as text where they are UTF-8, in nested lists and dicts."""
    if isinstance(value, bytes):
        try:
            return value.decode("utf-8")
        except UnicodeDecodeError:
            return value
    if isinstance(value, list):
        return [_strings(v) for v in value]
    if isinstance(value, dict):
        return {_strings(k): _strings(v) for k, v in value.items()}
    return value


class RemoteSim(MotionCalls, ScriptSim):
    """``sim`` as the ZMQ remote API offers it, over one :class:`Simulation`.

    Args:
        simulation: the server's simulation (its world, vision sensors, scripts and editor are
            read at each call).
    """

    #: Image calls answer a Deferred: the ZMQ service replies once the render thread is done.
    defer_renders = True

    def __init__(self, simulation: Simulation):
        super().__init__(simulation.world, WORLD, simulation.signals, label="zmq", simulation=simulation)
        self._simulation_ = simulation

    # The world and the scripts' forces are the simulation's current ones (a scene load replaces them).
    @property
    def _world(self):  # type: ignore[override]
        return self._simulation_.world

    @_world.setter
    def _world(self, value) -> None:
        pass

    @property
    def _forces(self):  # type: ignore[override]
        return self._simulation_.scripts.forces

    @_forces.setter
    def _forces(self, value) -> None:
        pass

    def _path_base(self) -> int | None:
        return None  # a remote program is unassociated code: no object for "." and ":"

    # ---------------------------------------------------------------- simulation
    def startSimulation(self) -> int:  # noqa: N802 (CoppeliaSim's names)
        """Start (or resume) the simulation; 1, or 0 when it already runs (CoppeliaSim's result)."""
        if self._simulation_.state is RunState.RUNNING:
            return 0
        self._simulation_.start()
        return 1

    def pauseSimulation(self) -> int:  # noqa: N802
        """Pause a running simulation; 1, or 0 when it does not run."""
        if self._simulation_.state is not RunState.RUNNING:
            return 0
        self._simulation_.pause()
        return 1

    def stopSimulation(self, wait: Any = False) -> None:  # noqa: N802
        """Stop the simulation: the scripts' cleanup, then the scene's initial state. simx stops
        at once, so ``wait`` changes nothing (the state is stopped when the call returns)."""
        self._simulation_.stop()

    def getSystemTime(self) -> float:  # noqa: N802
        """Wall-clock time in s (for differences)."""
        return time.time()

    # ---------------------------------------------------------------- parameters
    #: Kind -> (getter, setter) of the legacy API's parameters (simx_server.scene.parameters).
    _LEGACY_PARAMS = {"integer": (parameters.get_integer, parameters.set_integer),
                      "float": (parameters.get_floating, parameters.set_floating),
                      "boolean": (parameters.get_boolean, parameters.set_boolean),
                      "string": (parameters.get_string, parameters.set_string),
                      "array": (parameters.get_array, parameters.set_array)}

    def _legacy_param(self, kind: str, pid: int, *value: Any) -> Any:
        """Parameter ids the facade does not answer: the legacy API's (``simxGetIntegerParameter``
        ...: the headless mouse, the stop counter), from :mod:`simx_server.scene.parameters`."""
        get, set_ = self._LEGACY_PARAMS[kind]
        return set_(self._simulation_, pid, *value) if value else get(self._simulation_, pid)

    def getStringParam(self, parameter: Any) -> str:  # noqa: N802
        """String parameters: ``sim.stringparam_scenedefaultdir`` is the server's scene folder
        (the first ``--scene-path``, else the folder of the scene it started with), ``sim.stringparam_scene_path`` /
        ``sim.stringparam_scene_name`` the loaded scene's folder and file name; the legacy ones
        as ``simxGetStringParameter``."""
        pid = _int(parameter, "parameter")
        editor = self._simulation_.editor
        scene = self._world.scene_path
        if pid == STRINGPARAM_SCENEDEFAULTDIR:  # the first --scene-path, else the first scene's folder
            roots = editor.files.roots
            return str(roots[1] if len(roots) > 1 else roots[0])
        if pid == STRINGPARAM_SCENE_PATH:
            return editor.public(scene.parent)
        if pid == STRINGPARAM_SCENE_NAME:
            return scene.name
        return super().getStringParam(pid)

    # ------------------------------------------------------------------- the log
    def addLog(self, verbosityLevel: Any, logMessage: Any) -> None:  # noqa: N802, N803
        """Write ``logMessage`` to the server's log at the level of ``verbosityLevel``
        (``sim.verbosity_errors``/``scripterrors``: error, ``warnings``/``scriptwarnings``: warning,
        others: info)."""
        level = _int(verbosityLevel, "verbosityLevel") & _VERBOSITY_MASK
        text = _text(logMessage, "logMessage")
        text = (text[:1000] + f"... ({len(text)} characters)" if len(text) > 1000 else text).encode(
            "unicode_escape").decode("ascii")  # one log line, whatever the client sends
        if level in (200, 420):
            log.error("[client] %s", text)
        elif level in (300, 430):
            log.warning("[client] %s", text)
        elif level != 100:  # sim.verbosity_none
            log.info("[client] %s", text)

    # ---------------------------------------------------------------- scene files
    def _stand_in(self, filename: str, kinds: tuple[str, ...]) -> str:
        """The file to load for a CoppeliaSim scene (.ttt) or model (.ttm): the file itself where
        it exists (loaded through its MJCF conversion), else the MJCF that stands in for it: the
        same path with .xml, else ``<stem>.xml`` in the server's scene folders; other names as given."""
        path = Path(filename)
        if path.suffix.lower() not in kinds:
            return filename
        editor = self._simulation_.editor
        try:  # the real file, where one exists (converted to MJCF as it is loaded)
            editor.files.locate(filename, 0, ttt_cache.origin(editor.sim.world.scene_path))
            return filename
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

    def loadScene(self, filename: Any) -> None:  # noqa: N802
        """Replace the scene with a server-side scene file, under ``simxLoadScene``'s rules (the
        simulation stopped; only the scene's folder and ``--scene-path`` folders). A CoppeliaSim
        ``.ttt`` path loads the MJCF scene of the same stem (see :meth:`_stand_in`)."""
        if isinstance(filename, (bytes, bytearray)):
            raise UnsupportedError("sim.loadScene of a serialized scene (a buffer) is not supported; give a file name")
        name = self._stand_in(_text(filename, "filename"), COPPELIASIM_SCENES)
        return self._simulation_.editor.load_scene(name, 0, defer=True)  # a .ttt: converted off this thread

    def loadModel(self, filename: Any) -> int:  # noqa: N802
        """Add a server-side model file (``simxLoadModel`` with options 0; a ``.ttm`` path loads
        the MJCF model of the same stem); returns its base's handle."""
        if isinstance(filename, (bytes, bytearray)):
            raise UnsupportedError("sim.loadModel of a serialized model (a buffer) is not supported; give a file name")
        return self._simulation_.editor.load_model(self._stand_in(_text(filename, "filename"), COPPELIASIM_MODELS), 0,
                                                   defer=True)  # a .ttm: converted off this thread

    # ------------------------------------------------------------------ objects
    def getObjectSel(self) -> list[int]:  # noqa: N802
        """The object selection (no GUI: what clients set)."""
        return list(self._simulation_.selection)

    def setObjectSel(self, objectHandles: Any) -> None:  # noqa: N802, N803
        if not isinstance(objectHandles, list):
            raise ArgumentError("objectHandles must be a list of handles")
        self._simulation_.selection = [self._world.get(_int(h, "objectHandle")).handle for h in objectHandles]


    # ------------------------------------------------------------ vision sensors
    def getVisionSensorRes(self, sensorHandle: Any) -> list[int]:  # noqa: N802, N803
        """``[width, height]`` of a vision sensor's image in pixels."""
        spec = self._simulation_.vision.spec(self._h(sensorHandle))
        return [spec.width, spec.height]

    def setVisionSensorImg(self, sensorHandle: Any, image: Any, options: Any = 0, pos: Any = None,  # noqa: N802, N803
                           size: Any = None) -> None:
        """Write an image into a passive vision sensor (``image=external``): uint8 RGB (``options``
        bit 0: grey), rows bottom-up, the sensor's whole resolution; as ``simxSetVisionSensorImage``."""
        if any(v is not None and _vector(v, 2, "pos/size") != [0.0, 0.0] for v in (pos, size)):
            raise UnsupportedError("setVisionSensorImg of a window (pos/size) is not supported: send the whole image")
        set_passive_image(self._simulation_, self._h(sensorHandle), _bytes(image, "image"),
                          bool(_int(options, "options") & 1))

    def getStringSignal(self, signalName: Any) -> str | bytes | None:  # noqa: N802, N803
        """String signal ``signalName``: text where its bytes are UTF-8 (CoppeliaSim's ZMQ server
        sends Lua strings so, and its example programs compare the value with a str), else
        bytes; None when not set. ``getBufferSignal`` answers the same store as bytes."""
        return _strings(super().getStringSignal(signalName))

    def waitForSignal(self, sigName: Any) -> Stepped:  # noqa: N802, N803
        """Wait, step after step, until signal ``sigName`` (of any kind) is set; its value. A
        call that lasts several steps (docs/ZMQ.md), at most MAX_MOTION_STEPS; the coroutine
        form inside scripts is the scripts' own."""
        name, signals = _text(sigName, "sigName"), self._signals

        def waiting():
            for _ in range(MAX_MOTION_STEPS):
                for kind in Signals.KINDS:
                    value = signals.get(kind, name)
                    if value is not None:
                        return [_strings(value)]
                yield
            raise ArgumentError(f"signal {name!r} not set within {MAX_MOTION_STEPS} steps")

        return Stepped(waiting())

    def isDeprecated(self, funcOrConst: Any) -> int:  # noqa: N802, N803
        """1 for a function CoppeliaSim 4.x keeps under a deprecated name (``sim.getScriptHandle``...),
        0 for a current function or constant, -1 for an unknown name."""
        name = _text(funcOrConst, "funcOrConst").removeprefix("sim.")
        if name in names.DEPRECATED["sim"]:
            return 1
        return 0 if name in names.current_functions("sim") or name in names.constants("sim") else -1

    def setVisionSensorCharImage(self, sensorHandle: Any, image: Any) -> None:  # noqa: N802, N803
        """CoppeliaSim's older name: :meth:`setVisionSensorImg` of a whole RGB image."""
        self.setVisionSensorImg(sensorHandle, image)

    def closeScene(self) -> int:  # noqa: N802
        """Stop the simulation and replace the scene with an empty one (``simxCloseScene``); 1."""
        self._simulation_.editor.close_scene()
        return 1

    # ------------------------------------------------------------------- scripts
    def getScript(self, scriptType: Any, objectHandle: Any = -1, scriptName: Any = "") -> int:  # noqa: N802, N803
        """The script handle of an object's child script (``sim.scripttype_childscript``): in simx
        the handle of the object it is attached to (``objectHandle``, or a path or name); -1
        when it has none."""
        if _int(scriptType, "scriptType") != C.sim_scripttype_childscript:
            raise UnsupportedError("sim.getScript: simx has child scripts only (sim.scripttype_childscript)")
        target = objectHandle if isinstance(objectHandle, (str, bytes)) else scriptName if scriptName else objectHandle
        if isinstance(target, (str, bytes)):
            h = paths.find_one(self._world, _text(target, "scriptName"))
        else:
            h = self._h(target)
        return h if h in self._simulation_.scripts.scripts else -1

    def callScriptFunction(self, functionName: Any, scriptHandleOrType: Any, *args: Any) -> tuple:  # noqa: N802, N803
        """Call a function of a child script with any arguments; returns its return values.

        ``("func@/path", sim.scripttype_childscript, ...)`` (CoppeliaSim 4.0-4.5: the script of
        the object the path or name names) or ``("func", scriptHandle, ...)`` (4.6+: a handle of
        :meth:`getScript`, which is the object's). Lua strings come back as text where they are
        UTF-8, as bytes otherwise. Errors: no such object, script or function; the script's own."""
        name = _text(functionName, "functionName")
        target = _int(scriptHandleOrType, "scriptHandleOrType")
        if "@" in name:
            name, _, where = name.partition("@")
            if target != C.sim_scripttype_childscript:
                raise UnsupportedError("sim.callScriptFunction: simx has child scripts only (sim.scripttype_childscript)")
            handle = paths.find_one(self._world, where)
        else:
            handle = self._h(target)
        try:
            script = self._simulation_.scripts.script_of(self._world.get(handle).handle)
        except ScriptError:
            raise ScriptError(f"object {self._world.get(handle).name!r} has no child script") from None
        with self._simulation_.editor.files.on_behalf():  # the script's file calls act as this client
            values = script.call_values(name, list(args))
        return tuple(_strings(v) for v in values)


def facade_functions() -> dict[str, Any]:
    """``name -> unbound function`` of every public call of :class:`RemoteSim` (the ZMQ ``sim``)."""
    out = {}
    for klass in reversed(RemoteSim.__mro__[:-1]):
        for name, value in vars(klass).items():
            if not name.startswith("_") and callable(value):
                out[name] = value
    return out

