"""The scene's child scripts as one collection: :func:`load_script` reads an object's script
(Python or Lua, confined to the scene's folder or to a loaded model's, never from a client's
transfer folder unless ``--allow-remote-code``), :class:`Scripts` drives every script through
V-REP's life cycle (``sysCall_init`` at start, actuation and sensing each step, cleanup at stop),
takes in the scripts of objects that arrive later (a loaded model's, copies': :meth:`Scripts.attach`),
ends those of removed objects (:meth:`Scripts.drop_removed`) and serves ``simxCallScriptFunction``.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any, Iterable, Iterator, NamedTuple

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ScriptError, UnknownObjectError
from simx_server.api import script_parameters
from simx_server.scripts.child import (DEFAULT_TIMEOUT, PYTHON_SCRIPTS_FLAG, REMOTE_CODE_FLAG, UNSAFE_LUA_FLAG,
                                      ChildScript, PythonScript, RefusedScript)
from simx_server.scripts.budget import ScriptBudget, ScriptPass
from simx_server.scripts.call_arguments import check_call_arguments
from simx_server.scripts.script_settings import script_options
from simx_server.scripts.dynamics import DynamicsCallbacks
from simx_server.scripts.vision_callbacks import VisionCallbacks
from simx_server.api.signals import Signals
from simx_server.api.sim.forces import AppliedForces
from simx_server.scripts.lua import LuaScript
from simx_server.sim.world import World

log = logging.getLogger("simx.scripts")

def _fixed_bodies(script: ChildScript) -> object | None:
    """What a script's ``_body`` answers stay the same with (a Lua script's, :meth:`LuaScript.fixed_bodies`),
    or None where they may change at any time (a Python script's namespace)."""
    return script.fixed_bodies() if isinstance(script, LuaScript) else None


#: The scripts' callbacks of a step's pass (child scripts also resume their threads).
_STEP_CALLBACKS = ("sysCall_actuation", "sysCall_sensing")


# ---------------------------------------------------------------- the manager
def load_script(world: World, owner: int, file: str, *, untrusted: Iterable[Path] = (),
                allow_python_scripts: bool = False, folder: Path | None = None, **options: Any) -> ChildScript:
    """The child script ``file`` (relative to ``folder``, by default the scene's) of object ``owner``.

    ``untrusted`` are folders that clients can write to (the ``simxTransferFile`` folder): a
    script there is code sent by a client, refused unless ``allow_remote_code``. A Python
    script (``.py``, also a .ttt's script with CoppeliaSim's python marker, converted to one)
    runs only with ``allow_python_scripts`` (the server's ``--allow-python-scripts``): without
    it, a :class:`~simx_server.scripts.child.RefusedScript` stands in its place, logged once.
    ``folder``: a loaded model's folder (its MJCF's, or its ``.ttm``'s conversion's), where
    its scripts lie.

    Raises:
        ValueError: the file lies outside the folder or in an untrusted one, does not exist,
            or is neither ``.lua`` nor ``.py`` (a scene error: the scene is refused).
    """
    name = world.get(owner).name
    path = script_file(world.scene_path.parent if folder is None else folder, file, name)
    if not options.get("allow_remote_code"):
        for place in untrusted:
            place = Path(place).resolve()
            if path == place or place in path.parents:
                raise ValueError(f"child script {file!r} of {name!r} was sent by a client ({place}): simx "
                                 f"runs code sent by clients only when the server is started with "
                                 f"{REMOTE_CODE_FLAG}")
    if path.suffix == ".py":
        return PythonScript(world, owner, path, **options) if allow_python_scripts else RefusedScript(
            world, owner, path, **options)
    if path.suffix == ".lua":
        return LuaScript(world, owner, path, **options)
    raise ValueError(f"child script {file!r} of {name!r}: unknown language (use .lua or .py)")


def script_file(folder: Path, file: str, name: str) -> Path:
    """The script file ``file`` of object ``name``, resolved inside ``folder``.

    Raises:
        ValueError: it lies outside ``folder`` (links followed) or does not exist.
    """
    path = (folder / file).resolve()
    if folder.resolve() not in path.parents:
        raise ValueError(f"child script {file!r} of {name!r} lies outside the scene folder {folder}")
    if not path.is_file():
        raise ValueError(f"child script {file!r} of {name!r} not found in {folder}")
    return path


class ScriptSource(NamedTuple):
    """A script that arrives with objects after the scene loaded (a loaded model's, a copy's):
    what :meth:`Scripts.attach` loads for the object's handle."""

    name: str  #: the object's name where the script was read (in the model, before any suffix)
    kind: str  #: ``"child"`` or ``"customization"``
    path: Path  #: its file, resolved
    options: dict  #: :func:`load_script`'s options (``timeout`` None: the scripts' default)
    disabled: bool  #: saved disabled (``script_disabled=1``): loaded, not run until enabled


def model_scripts(settings: dict[str, dict[str, str]], folder: Path) -> list[ScriptSource]:
    """The scripts that a model's ``simx:`` settings name (``child_script=FILE``,
    ``customization_script=FILE`` and their options, as a scene's), their files in ``folder``
    (the model file's own folder: a ``.ttm``'s conversion writes them there). Run on any
    thread: reads only the model's files.

    Args:
        settings: object name -> its settings (the model's ``simx:NAME`` texts, parsed).
        folder: the model file's folder.

    Raises:
        ValueError: a script file outside ``folder`` or missing, a bad ``script_timeout``,
            ``threaded`` or ``vrep_version``, a bad ``script_parameters`` file.
    """
    out = []
    for name, items in settings.items():
        for key, kind in (("child_script", "child"), ("customization_script", "customization")):
            file = items.get(key)
            if not file:
                continue
            path = script_file(folder, file, name)
            options = script_options(items, name, DEFAULT_TIMEOUT, folder)
            if "script_timeout" not in items:
                options["timeout"] = None  # the server's default, known where the script is attached
            out.append(ScriptSource(name, kind, path, options, items.get("script_disabled") == "1"))
    return out


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
        self.timeout = timeout
        self.scripts: dict[int, ChildScript] = {}
        self.customization: dict[int, ChildScript] = {}  # customization scripts, by object
        self.user_parameters: dict[int, list] = {}  # sim.setUserParameter of objects without a script
        #: Child scripts attached while the simulation runs: they begin in its next pass (attach).
        self._pending: list[ChildScript] = []
        self._parameter_bytes: int | None = None  # of every parameter list (parameter_lists), once counted
        #: All scripts' time per pass, share over time and memory together (simx_server/scripts/budget.py):
        #: their Lua states and their parameters (memory_used).
        self.budget = ScriptBudget(states=lambda: [*self._all(), self])
        self._step: ScriptPass | None = None  # the pass of the step whose actuation ran (the rest shares it)
        self._thread_cost: dict[ChildScript, float] = {}  # s of CPU each thread's last resume took
        self._thread_next = 0  # where the next pass's threads' turn begins (_threads_in_turn)
        self._quiet = True  # the step's pass runs no script code (_nothing_to_run, asked by its actuation)
        #: (the scripts' fixed_bodies(), _nothing_to_run's answer for them)
        self._bodies: tuple[tuple, bool] = ((None,), False)
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
                options = script_options(obj.settings, obj.name, timeout, world.scene_path.parent)
                table[obj.handle] = self._load(obj.handle, file, None, untrusted,
                                               "child" if key == "child_script" else "customization", options)
                table[obj.handle].disabled = obj.settings.get("script_disabled") == "1"  # saved disabled
        if allow_remote_code and self.scripts:
            log.warning("child scripts may run code sent by clients (%s)", REMOTE_CODE_FLAG)
        if allow_unsafe_lua and self.scripts:
            log.warning("Lua child scripts may use files, processes and the environment (%s)", UNSAFE_LUA_FLAG)
        if allow_python_scripts and any(isinstance(s, PythonScript) for s in self._all()):
            log.warning("the scene's Python scripts run with the server's rights (%s)", PYTHON_SCRIPTS_FLAG)

    def _load(self, owner: int, file: str, folder: Path | None, untrusted: Iterable[Path], kind: str,
              options: dict) -> ChildScript:
        return load_script(self.world, owner, file, folder=folder, untrusted=untrusted, signals=self.signals,
                           allow_remote_code=self.allow_remote_code, allow_python_scripts=self.allow_python_scripts,
                           allow_unsafe_lua=self.allow_unsafe_lua, simulation=self.simulation, forces=self.forces,
                           shared=self.shared, kind=kind, **options)

    def _all(self) -> list[ChildScript]:
        return [*self.scripts.values(), *self.customization.values()]

    def parameter_lists(self) -> list[list]:
        """Every parameter list of the scene: its scripts' and the other objects' user parameters."""
        return [s.parameters for s in self._all()] + list(self.user_parameters.values())

    def parameters_changed(self) -> None:
        """A parameter was set: :meth:`memory_used` counts them again."""
        self._parameter_bytes = None

    def memory_used(self) -> int:
        """Bytes of the scene's parameters (:meth:`parameter_lists`): they count toward
        limits.MAX_SCRIPTS_MEMORY with the Lua states (the budget's ``holders``)."""
        if self._parameter_bytes is None:
            self._parameter_bytes = script_parameters.stored(self.parameter_lists())[1]
        return self._parameter_bytes

    def attach(self, sources: Iterable[tuple[int, ScriptSource]], running: bool,
               untrusted: Iterable[Path] = ()) -> list[ChildScript]:
        """The scripts of objects that arrived after the scene loaded: a loaded model's
        (``sim.loadModel``, ``simxLoadModel``) or copies' (``sim.copyPasteObjects``). As in
        CoppeliaSim, where a model's scripts come with it and run as the scene's own
        (``CDetachedScript::initScript``: a customization script's ``sysCall_init`` at once;
        ``CDetachedScript::systemCallScript``: a child script that was not initialised runs
        ``sysCall_init`` before its first call of a simulation pass), a customization script
        runs its top level and ``sysCall_init`` now, and a child script begins with the next
        simulation start, or, while the simulation runs (``running``), in its next pass:
        ``sysCall_init``, then that pass's ``sysCall_actuation``. They share the scene's
        scripts' budget.

        Args:
            sources: (object handle, script) pairs; an object's script of the same kind
                already there is ended first.
            running: the simulation runs or is paused.
            untrusted: folders clients write to (scripts there need ``allow_remote_code``).

        Returns:
            The scripts attached.

        Raises:
            ValueError: a script file refused (as :func:`load_script`); those before it stay.
        """
        added: list[ChildScript] = []
        for owner, source in sources:
            options = dict(source.options)
            if options.get("timeout") is None:
                options["timeout"] = self.timeout
            script = self._load(owner, source.path.name, source.path.parent, untrusted, source.kind, options)
            script.disabled = source.disabled
            table = self.customization if source.kind == "customization" else self.scripts
            old = table.pop(owner, None)
            if old is not None:
                self._end(old)
            table[owner] = script
            added.append(script)
        self.parameters_changed()  # the new scripts' parameters count too
        customization = [s for s in added if s.kind == "customization"]
        if customization and self.opened:
            with self.budget.pass_of("open"):
                self._start_all(customization, "at load")
        if running:
            self._pending.extend(s for s in added if s.kind == "child")
        return added

    def source_of(self, owner: int) -> list[ScriptSource]:
        """The scripts of object ``owner`` as :meth:`attach` takes them (a copy's scripts)."""
        return [ScriptSource(s.object_name, s.kind, s.path,
                             {"timeout": s.timeout, "threaded": s.threaded, "version": s.version,
                              "parameters": list(s.parameters)}, s.disabled)
                for s in (self.scripts.get(owner), self.customization.get(owner)) if s is not None]

    def drop_removed(self) -> None:
        """End the scripts of objects no longer in the scene (``sim.removeModel``,
        ``sim.removeObject``): ``sysCall_cleanup`` of a running one, then its state goes, as
        CoppeliaSim's ``CSceneObjectContainer::eraseObject`` ends an erased object's scripts."""
        self.parameters_changed()
        gone = [(t, h) for t in (self.scripts, self.customization) for h in t if h not in self.world.objects]
        if not gone:
            return
        for table, handle in gone:
            script = table.pop(handle)
            if script in self._pending:
                self._pending.remove(script)
            self._end(script)
            log.info("%s script of removed object %r dropped", script.kind, script.object_name)
        if self.dynamics.joints or self.dynamics.dyn or self.dynamics.contact:  # installed: the simulation runs
            self.dynamics.install(self._all())  # the removed scripts' substep callbacks go

    def _end(self, script: ChildScript) -> None:
        with self.budget.pass_of("stop"):
            try:
                script.stop()  # sysCall_cleanup if it runs, then its state goes
            except ScriptError as exc:
                log.error("%s", exc)

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

    def _count_empty(self, function: str) -> None:
        """A pass of ``function`` in which no script has code for it (:meth:`_nothing_to_run`): no
        code runs, so the tables stay as they are while they are walked."""
        for table in (self.scripts, self.customization):
            for script in table.values():
                if script._may_run(function) and script._body(function):
                    script.executions += 1  # ChildScript.life_cycle of an empty callback

    def _customization(self, function: str) -> None:
        for script in self._present(self.customization):
            script.life_cycle(function)

    def _threads_in_turn(self) -> set[ChildScript] | None:
        """The threads a step's pass resumes: all (None) while their last resumes took no more
        than the pass's allowance together (``budget.allowance``, limits.SCRIPTS_PASS_ALLOWANCE);
        else as many as fit in it by those costs, in turn from where the last pass stopped (the
        others wait a pass or more; none is cut), so that threads alone keep a pass within its
        allowance: 200 auto-switched threads made every pass 200 slices long."""
        threads = list(self.scripts.values())  # a script without a thread: a resume of no cost
        costs = [self._thread_cost.get(s, 0.0) for s in threads]
        self._thread_cost = {s: c for s, c in zip(threads, costs)}
        if sum(costs) <= self.budget.allowance:
            return None
        start, used, turn = self._thread_next % len(threads), 0.0, set()
        for k in range(len(threads)):
            script, cost = threads[(start + k) % len(threads)], costs[(start + k) % len(threads)]
            if turn and used + cost > self.budget.allowance:
                break
            turn.add(script)
            used += cost
        self._thread_next = start + len(turn)
        return turn

    def _present(self, table: dict[int, ChildScript]) -> Iterator[ChildScript]:
        """The scripts of ``table`` in turn, as a pass calls them: a script that an earlier
        one's edit removed is skipped (its object went), one attached meanwhile waits for the
        next pass."""
        for owner, script in list(table.items()):
            if table.get(owner) is script:
                yield script

    def start(self) -> None:
        """Simulation starts: customization scripts' ``sysCall_beforeSimulation``, then every
        child script runs its top level, ``sysCall_init`` and its thread's first part."""
        self.open()
        for script in self.customization.values():  # skipped for an overrun until this start
            script.rearm()
        self._pending.clear()  # every child script starts now
        with self.budget.pass_of("start"):
            self._customization("sysCall_beforeSimulation")
            self._start_all(list(self.scripts.values()), "at start")
        self.dynamics.install(self._all())
        self.vision.install()

    def actuation(self) -> None:
        """Before a step: each child script's thread resumes, then its ``sysCall_actuation``;
        then the customization scripts' ``sysCall_actuation``."""
        self.shared["pass"] = self.shared.get("pass", 0) + 1  # simulation passes (wireless data: next pass)
        self._quiet = self._nothing_to_run()
        if self._quiet:  # no script code in this pass: the empty callbacks counted, nothing timed
            self._count_empty("sysCall_actuation")
        else:
            with self.budget.pass_of("step") as step:
                self._step = step  # the step's dynamics callbacks and sensing share this pass
                if self._pending:  # attached while running: sysCall_init first, in this pass
                    pending, self._pending = self._pending, []
                    self._start_all(pending, "in the simulation")
                    self.dynamics.install(self._all())
                turn = self._threads_in_turn()
                for script in self._present(self.scripts):
                    if turn is None or script in turn:
                        began = time.thread_time()
                        script.resume_thread()
                        self._thread_cost[script] = time.thread_time() - began
                    script.life_cycle("sysCall_actuation")
                self._customization("sysCall_actuation")
        particles = self.shared.get("particles")
        if particles:  # particle objects: moved once a step, their pushes applied by this step
            particles.advance(self.world, self.forces, self.world.dt)

    def _nothing_to_run(self) -> bool:
        """Whether a step's pass would run no script code: none attached meanwhile, no script's
        dynamics or vision callbacks, no child script's thread alive, and no ``sysCall_actuation``
        or ``sysCall_sensing`` with code (V-REP's templates, as PyRep's models have them, leave
        them empty or out). Such a pass only counts the empty callbacks' executions
        (:meth:`_count_empty`); its time is not taken (no code, no charge). The answer is kept
        while every script's callbacks are known to be the same (:func:`_fixed_bodies`)."""
        if self._pending or self.world.substep_hook is not None or self.vision.sensors:
            return False
        scripts = self._all()
        key = tuple(map(_fixed_bodies, scripts))
        if key == self._bodies[0]:
            return self._bodies[1]
        loaded = [script for script in scripts if not script.load_error]  # the others never run
        answer = not any(script._body(f) == 2 for script in loaded for f in _STEP_CALLBACKS) and \
            not any(script._thread_alive() for script in loaded if script.kind == "child")
        key = tuple(map(_fixed_bodies, scripts))  # the answers just read are kept by then
        self._bodies = (key if None not in key else (None,), answer)
        return answer

    def sensing(self) -> None:
        """After a step: forces scripts added are reset (the step applied them), the vision
        sensors with callbacks are handled, then ``sysCall_sensing`` of every script."""
        self.forces.clear(self.world)
        step, self._step = self._step, None
        if self._quiet:
            self._count_empty("sysCall_sensing")
            return
        with self.budget.pass_of("step", step):
            self.vision.handle_pass()
            for script in self._present(self.scripts):
                script.life_cycle("sysCall_sensing")
            self._customization("sysCall_sensing")

    def stop(self) -> None:
        """Simulation stops: ``sysCall_cleanup`` of every script; signals set by scripts go."""
        self.stopping = True  # sim.getSimulationState in sysCall_cleanup: the last pass before the stop
        self.dynamics.remove()
        self.vision.remove()
        try:
            self._pending.clear()
            with self.budget.pass_of("stop"):
                for script in self._present(self.scripts):
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
        check_call_arguments(ints, floats, strings, buffer)
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
