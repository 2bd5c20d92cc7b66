"""The scene's child scripts as one collection: :func:`load_script` reads an object's script
(Python or Lua, confined to the scene's folder, never from a client's transfer folder unless
``--allow-remote-code``), :class:`Scripts` drives every script through V-REP's life cycle
(``sysCall_init`` at start, actuation and sensing each step, cleanup at stop) and serves
``simxCallScriptFunction``.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any, Iterable

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ScriptError, UnknownObjectError
from simx_server.base import limits as L
from simx_server.api import script_parameters
from simx_server.scripts.child import (DEFAULT_TIMEOUT, PYTHON_SCRIPTS_FLAG, REMOTE_CODE_FLAG, UNSAFE_LUA_FLAG,
                                      ChildScript, PythonScript, RefusedScript)
from simx_server.scripts.budget import ScriptBudget, ScriptPass
from simx_server.scripts.dynamics import DynamicsCallbacks
from simx_server.scripts.vision_callbacks import VisionCallbacks
from simx_server.api.signals import Signals
from simx_server.api.sim.forces import AppliedForces
from simx_server.scripts.lua import LuaScript
from simx_server.sim.world import World

log = logging.getLogger("simx.scripts")


# ---------------------------------------------------------------- the manager
def load_script(world: World, owner: int, file: str, *, untrusted: Iterable[Path] = (),
                allow_python_scripts: bool = False, **options: Any) -> ChildScript:
    """The child script ``file`` (relative to the scene's folder) of object ``owner``.

    ``untrusted`` are folders that clients can write to (the ``simxTransferFile`` folder): a
    script there is code sent by a client, refused unless ``allow_remote_code``. A Python
    script (``.py``, also a .ttt's script with CoppeliaSim's python marker, converted to one)
    runs only with ``allow_python_scripts`` (the server's ``--allow-python-scripts``): without
    it, a :class:`~simx_server.scripts.child.RefusedScript` stands in its place, logged once.

    Raises:
        ValueError: the file lies outside the scene's folder or in an untrusted one, does not
            exist, or is neither ``.lua`` nor ``.py`` (a scene error: the scene is refused).
    """
    folder = world.scene_path.parent
    name = world.get(owner).name
    path = (folder / file).resolve()
    if folder not in path.parents:
        raise ValueError(f"child script {file!r} of {name!r} lies outside the scene folder {folder}")
    if not options.get("allow_remote_code"):
        for place in untrusted:
            place = Path(place).resolve()
            if path == place or place in path.parents:
                raise ValueError(f"child script {file!r} of {name!r} was sent by a client ({place}): simx "
                                 f"runs code sent by clients only when the server is started with "
                                 f"{REMOTE_CODE_FLAG}")
    if not path.is_file():
        raise ValueError(f"child script {file!r} of {name!r} not found in {folder}")
    if path.suffix == ".py":
        return PythonScript(world, owner, path, **options) if allow_python_scripts else RefusedScript(
            world, owner, path, **options)
    if path.suffix == ".lua":
        return LuaScript(world, owner, path, **options)
    raise ValueError(f"child script {file!r} of {name!r}: unknown language (use .lua or .py)")


class Scripts:
    """Every child script of the scene, driven through the simulation life cycle.

    Args:
        world: the scene; objects with a ``child_script`` setting get their script.
        signals: the server's signal store (a private one when None).
        allow_remote_code: let scripts run code that clients send (Lua ``load``/``loadstring``,
            Python ``exec``/``eval``/``compile``); the server's ``--allow-remote-code``.
        timeout: default bound (s) of each call into a script; a ``script_timeout=S`` setting
            of the object overrides it.
        untrusted: folders clients can write to (the ``simxTransferFile`` folder); scripts
            there are refused unless ``allow_remote_code`` (a scene sent by a client must not
            bring code with it).
        allow_unsafe_lua: give Lua scripts the functions CoppeliaSim calls unsafe (``io.*``,
            ``os.execute``/``remove``/``rename``/``getenv``..., ``dofile``/``loadfile``, any
            ``package.path``/``cpath``); the server's ``--allow-unsafe-lua``. Off: a script
            that calls one gets a Lua error naming the flag.
        allow_python_scripts: run the scene's Python scripts (``.py``), which have the server's
            rights; the server's ``--allow-python-scripts``. Off: each is refused with one log
            line, the scene loads and its Lua scripts run.
        simulation: the :class:`~simx_server.scene.simulation.Simulation` that owns these scripts;
            the ``sim`` calls that read sensors or edit the scene need it (without it they
            raise UnsupportedError).

    Raises:
        ValueError: a script file is missing, outside the scene folder, in an untrusted folder,
            or of unknown language; a ``script_timeout`` is not a positive number. (Syntax
            errors are not fatal: that script answers its error to every call, the others run.)
    """

    def __init__(self, world: World, signals: Signals | None = None, *, allow_remote_code: bool = False,
                 timeout: float = DEFAULT_TIMEOUT, untrusted: Iterable[Path] = (),
                 allow_unsafe_lua: bool = False, simulation: Any = None, allow_python_scripts: bool = False):
        self.world = world
        self.simulation = simulation
        self.signals = signals if signals is not None else Signals()
        self.forces = AppliedForces()  # sim.addForce & co., for the next step
        self.stopping = False  # True while the scripts' sysCall_cleanup run
        self.allow_remote_code = allow_remote_code
        self.allow_unsafe_lua = allow_unsafe_lua
        self.allow_python_scripts = allow_python_scripts
        self.scripts: dict[int, ChildScript] = {}
        self.customization: dict[int, ChildScript] = {}  # customization scripts, by object
        #: All scripts' time per pass, share over time and memory together (simx_server/scripts/budget.py).
        self.budget = ScriptBudget(states=self._all)
        self._step: ScriptPass | None = None  # the pass of the step whose actuation ran (the rest shares it)
        self.shared: dict = {"manager": self, "budget": self.budget}  # custom data, the scripts' view of each other
        self.opened = False
        # sysCall_jointCallback / sysCall_dynCallback / sysCall_contactCallback at each substep, in the step's pass
        self.dynamics = DynamicsCallbacks(world, lambda: self.budget.pass_of("step", self._step))
        #: Vision sensors handled with their scripts' sysCall_vision (scripts/vision_callbacks.py).
        self.vision = VisionCallbacks(self)
        for obj in world.objects.values():
            for key, table in (("child_script", self.scripts), ("customization_script", self.customization)):
                file = obj.settings.get(key)
                if not file:
                    continue
                options = script_options(world, obj, timeout)
                table[obj.handle] = load_script(world, obj.handle, file, untrusted=untrusted, signals=self.signals,
                                                allow_remote_code=allow_remote_code,
                                                allow_python_scripts=allow_python_scripts,
                                                allow_unsafe_lua=allow_unsafe_lua, simulation=simulation,
                                                forces=self.forces, shared=self.shared,
                                                kind="child" if key == "child_script" else "customization",
                                                **options)
                table[obj.handle].disabled = obj.settings.get("script_disabled") == "1"  # saved disabled
        if allow_remote_code and self.scripts:
            log.warning("child scripts may run code sent by clients (%s)", REMOTE_CODE_FLAG)
        if allow_unsafe_lua and self.scripts:
            log.warning("Lua child scripts may use files, processes and the environment (%s)", UNSAFE_LUA_FLAG)
        if allow_python_scripts and any(isinstance(s, PythonScript) for s in self._all()):
            log.warning("the scene's Python scripts run with the server's rights (%s)", PYTHON_SCRIPTS_FLAG)

    def _all(self) -> list[ChildScript]:
        return [*self.scripts.values(), *self.customization.values()]

    def open(self) -> None:
        """The scene is loaded: customization scripts run their top level and ``sysCall_init``
        (they live until :meth:`close`, across simulations). Idempotent."""
        if self.opened:
            return
        self.opened = True
        with self.budget.pass_of("open"):
            self._start_all(self.customization.values(), "at load")

    def _start_all(self, scripts: Iterable[ChildScript], when: str) -> None:
        for script in scripts:
            try:
                script.start()
            except ScriptError as exc:
                if not script.refused:  # a refused script was logged when the scene loaded
                    log.error("%s", exc)
            except Exception:  # the other scripts start all the same
                log.exception("%s: internal error %s", script.label, when)

    def close(self) -> None:
        """The scene is unloaded: customization scripts' ``sysCall_cleanup``, then their state goes;
        the dynamics-step callbacks' hooks (the process-wide contact filter) go with it."""
        self.dynamics.remove()
        if not self.opened:
            return
        self.opened = False
        for script in self.customization.values():
            script.stop()

    def idle(self, paused: bool = False) -> None:
        """A pass of the server's loop without a step: customization scripts'
        ``sysCall_nonSimulation`` while stopped, ``sysCall_suspended`` while paused."""
        with self.budget.pass_of("idle"):
            self._customization("sysCall_suspended" if paused else "sysCall_nonSimulation")

    def _customization(self, function: str) -> None:
        for script in self.customization.values():
            script.life_cycle(function)

    def start(self) -> None:
        """Simulation starts: customization scripts' ``sysCall_beforeSimulation``, then every
        child script runs its top level, ``sysCall_init`` and its thread's first part."""
        self.open()
        for script in self.customization.values():  # skipped for an overrun until this start
            script.rearm()
        with self.budget.pass_of("start"):
            self._customization("sysCall_beforeSimulation")
            self._start_all(self.scripts.values(), "at start")
        self.dynamics.install([*self.scripts.values(), *self.customization.values()])
        self.vision.install()

    def actuation(self) -> None:
        """Before a step: each child script's thread resumes, then its ``sysCall_actuation``;
        then the customization scripts' ``sysCall_actuation``."""
        self.shared["pass"] = self.shared.get("pass", 0) + 1  # simulation passes (wireless data: next pass)
        if self.scripts or self.customization:  # no script: no pass to time (a PyRep scene's usual step)
            with self.budget.pass_of("step") as step:
                self._step = step  # the step's dynamics callbacks and sensing share this pass
                for script in self.scripts.values():
                    script.resume_thread()
                    script.life_cycle("sysCall_actuation")
                self._customization("sysCall_actuation")
        particles = self.shared.get("particles")
        if particles:  # particle objects: moved once a step, their pushes applied by this step
            particles.advance(self.world, self.forces, self.world.dt)

    def sensing(self) -> None:
        """After a step: forces scripts added are reset (the step applied them), the vision
        sensors with callbacks are handled, then ``sysCall_sensing`` of every script."""
        self.forces.clear(self.world)
        step, self._step = self._step, None
        if not (self.scripts or self.customization):
            return
        with self.budget.pass_of("step", step):
            self.vision.handle_pass()
            for script in self.scripts.values():
                script.life_cycle("sysCall_sensing")
            self._customization("sysCall_sensing")

    def stop(self) -> None:
        """Simulation stops: ``sysCall_cleanup`` of every script; signals set by scripts go."""
        self.stopping = True  # sim.getSimulationState in sysCall_cleanup: the last pass before the stop
        self.dynamics.remove()
        self.vision.remove()
        try:
            with self.budget.pass_of("stop"):
                for script in self.scripts.values():
                    script.stop()
                self._customization("sysCall_afterSimulation")
        finally:
            self.stopping = False
        self.signals.clear_script_signals()
        self.forces.clear(self.world)
        for kind in ("tubes", "wireless", "particles"):  # these end with the simulation (V-REP)
            self.shared.pop(kind, None)

    def call(self, object_name: str, script_type: int, function: str, ints, floats, strings, buffer) -> list:
        """``simxCallScriptFunction`` on the child script of ``object_name``.

        Raises ScriptError (no such script or function, or the script failed) or
        ArgumentError (arguments of the wrong types)."""
        table = {C.sim_scripttype_childscript: self.scripts,
                 C.sim_scripttype_customizationscript: self.customization}.get(script_type)
        if table is None:
            raise ScriptError(f"script type {script_type} is not supported; only child scripts "
                              f"(sim_scripttype_childscript = {C.sim_scripttype_childscript}) and "
                              f"customization scripts ({C.sim_scripttype_customizationscript})")
        try:
            obj = self.world.resolve(object_name)
        except UnknownObjectError as exc:
            raise ScriptError(f"no child script: {exc}") from None
        script = table.get(obj.handle)
        if script is None:
            kind = "child" if table is self.scripts else "customization"
            raise ScriptError(f"object {obj.name!r} has no {kind} script")
        _check_call_arguments(ints, floats, strings, buffer)
        if not isinstance(function, str) or not function:
            raise ArgumentError("the function name must be a non-empty string")
        return script.call(function, list(ints), [float(v) for v in floats], list(strings), bytes(buffer))

    def script_of(self, handle: int) -> ChildScript:
        """The child script of object ``handle``, else its customization script (a 4.6+
        script object of either type); ScriptError when it has none."""
        script = self.scripts.get(handle) or self.customization.get(handle)
        if script is None:
            raise ScriptError(f"object {self.world.get(handle).name!r} has no script")
        return script


def script_options(world: World, obj: Any, timeout: float) -> dict:
    """The script settings of ``obj`` (``script_timeout=S``, ``threaded=1``, ``vrep_version=N``,
    ``script_parameters=FILE.json``) as ``load_script`` options; ValueError for a bad value."""
    settings = obj.settings
    bound = settings.get("script_timeout", timeout)
    try:
        bound = float(bound)
        if not (bound > 0 and math.isfinite(bound)):
            raise ValueError
    except ValueError:
        raise ValueError(f"script_timeout of {obj.name!r} must be a positive number of seconds, "
                         f"got {settings.get('script_timeout')!r}") from None
    threaded = settings.get("threaded", "0")
    if threaded not in ("0", "1"):
        raise ValueError(f"threaded of {obj.name!r} must be 0 or 1, got {threaded!r}")
    version = settings.get("vrep_version")
    if version is not None:
        if not version.isdigit():
            raise ValueError(f"vrep_version of {obj.name!r} must be V-REP's version number (30600 for 3.6.0), "
                             f"got {version!r}")
        version = int(version)
    return {"timeout": bound, "threaded": threaded == "1", "version": version,
            "parameters": read_parameters(world, obj.name, settings.get("script_parameters"))}


def read_parameters(world: World, name: str, file: str | None) -> list[dict]:
    """The script simulation parameters of ``file`` next to the scene
    (:func:`simx_server.api.script_parameters.load`); [] without a file. ValueError for a file
    outside the scene's folder, missing, too large or not such a list."""
    return script_parameters.load(world.scene_path.parent, name, file)


_WRONG_TYPES = "script arguments must be lists of ints, floats and strings, and bytes"


def _check_call_arguments(ints: Any, floats: Any, strings: Any, buffer: Any) -> None:
    """Types and bounds of simxCallScriptFunction's arguments, the bounds first (before any
    per-value work): at most limits.MAX_SCRIPT_CALL_VALUES values and MAX_SCRIPT_CALL_BYTES
    bytes of strings and buffer.

    Raises:
        ArgumentError: naming the bound that was passed, or the types expected.
    """
    if not (type(ints) is list and type(floats) is list and type(strings) is list
            and isinstance(buffer, (bytes, bytearray))):
        raise ArgumentError(_WRONG_TYPES)
    count = len(ints) + len(floats) + len(strings)
    if count > L.MAX_SCRIPT_CALL_VALUES:
        raise ArgumentError(f"{count} values passed to a script function: at most {L.MAX_SCRIPT_CALL_VALUES} "
                            "(limits.MAX_SCRIPT_CALL_VALUES)")
    if not all(type(v) is str for v in strings):
        raise ArgumentError(_WRONG_TYPES)
    size = len(buffer) + sum(map(len, strings))
    if size > L.MAX_SCRIPT_CALL_BYTES:
        raise ArgumentError(f"{size} bytes of strings and buffer passed to a script function: at most "
                            f"{L.MAX_SCRIPT_CALL_BYTES} (limits.MAX_SCRIPT_CALL_BYTES)")
    if not (all(type(v) is int for v in ints) and all(type(v) in (int, float) for v in floats)):
        raise ArgumentError(_WRONG_TYPES)
