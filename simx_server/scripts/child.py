"""Child scripts attached to scene objects, and the ``sim`` namespace each one calls.

A scene attaches a script (``.lua`` or ``.py``, from the server's disk: the scene's folder) to an
object with ``<custom><text name="simx:OBJECT" data="child_script=FILE"/></custom>``;
``script_timeout=SECONDS`` there bounds every call into it (default :data:`DEFAULT_TIMEOUT`).

Both languages see the one table of :mod:`simx_server.api` as ``sim`` (V-REP's names and units) and follow
V-REP's non-threaded life cycle: the file's top level and ``sysCall_init`` when the simulation
starts, ``sysCall_actuation`` before and ``sysCall_sensing`` after every step,
``sysCall_cleanup`` when it stops (then the script's state is dropped: a restart begins afresh).
Any other global function of the script can be called remotely with ``simxCallScriptFunction``:
it receives ``(inInts, inFloats, inStrings, inBuffer)`` and returns up to four values
``(ints, floats, strings, buffer)``. Lua scripts run in lupa (:mod:`simx_server.scripts.lua`).

Faults never stop the simulation: an error (at load, at run time, or a call that overruns its
time bound and is interrupted) is a :class:`~simx_wire.protocol.ScriptError` naming the file,
the line and the message; the remote caller gets it as a remote error, and errors of life-cycle
functions go to the log. See docs/SCRIPTS.md."""

from __future__ import annotations

import builtins
import contextlib
import inspect
import logging
import threading
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Iterator

from simx_wire.protocol import ScriptError
from simx_server.api import ApiNamespace, script_sim
from simx_server.scripts.budget import PASS, SHARE, ScriptBudget
from simx_server.scripts.call_arguments import legacy_outputs
from simx_server.api.signals import Signals
from simx_server.api.sim.threads import PythonThread
from simx_server.api.sim.forces import AppliedForces
from simx_server.scripts.watchdog import WATCHDOG
from simx_server.sim.world import World

__all__ = ["DEFAULT_TIMEOUT", "LIFE_CYCLE", "LIFE_CYCLE_CALLS", "PYTHON_SCRIPTS_FLAG", "REMOTE_CODE_FLAG",
           "UNSAFE_LUA_FLAG", "ChildScript", "PythonScript", "RefusedScript",
           "ScriptTimeoutError", "legacy_outputs"]

log = logging.getLogger("simx.scripts")

LIFE_CYCLE = ("sysCall_init", "sysCall_actuation", "sysCall_sensing", "sysCall_cleanup")
#: Every life-cycle function of child and customization scripts (called without arguments).
LIFE_CYCLE_CALLS = frozenset(LIFE_CYCLE + ("sysCall_nonSimulation", "sysCall_beforeSimulation",
                                           "sysCall_afterSimulation", "sysCall_suspend", "sysCall_suspended",
                                           "sysCall_resume"))
#: Seconds a single call into a script may run before it is interrupted.
DEFAULT_TIMEOUT = 1.0
#: The command-line flag that lets scripts run code sent by clients (Lua ``load``/``loadstring``,
#: Python ``exec``/``eval``/``compile``); named in error messages.
REMOTE_CODE_FLAG = "--allow-remote-code"
#: The command-line flag that gives Lua scripts back the functions CoppeliaSim calls unsafe
#: (files, processes, environment, C modules: ``io.*``, ``os.execute``, ``dofile``...).
UNSAFE_LUA_FLAG = "--allow-unsafe-lua"
#: The command-line flag that lets scenes' Python scripts run: they run with the server's rights
#: (files, processes, network), which only the operator can give.
PYTHON_SCRIPTS_FLAG = "--allow-python-scripts"
_STEP_FUNCTIONS = ("sysCall_actuation", "sysCall_sensing")
#: Why a call's bound is shorter than its own: the call into the script that called it ends first.
CALLER = "caller"
#: (thread id, deadline in that thread's CPU time) of the script calls under way, outermost first: a
#: script calling another's function (sim.callScriptFunction) gives it no more than it has left.
_UNDER_WAY: list[tuple[int, float]] = []


class ScriptTimeoutError(ScriptError):
    """A call into a script did not return within its time bound and was interrupted.

    Attributes:
        bound: the bound it passed: None (its own ``script_timeout``), ``"pass"`` (the pass's end,
            limits.MAX_SCRIPTS_STEP_TIME) or ``"share"`` (the scripts' share, limits.SCRIPTS_SHARE).
    """

    bound: str | None = None


# ---------------------------------------------------------------- child scripts
class ChildScript:
    """A child script attached to object ``owner``: life cycle, remote calls, fault handling.

    Subclasses (:class:`PythonScript`, :class:`~simx_server.scripts.lua.LuaScript`) implement
    ``_load`` (read and compile; set ``self.load_error`` on a syntax error), ``_create`` (fresh
    state, then the top level), ``_defines``/``_callable`` (a life-cycle function exists / a
    function may be called remotely), ``_run_function`` (bounded by ``self.timeout``; raises
    ScriptError) and ``_drop``. A script that failed to load stays attached: every call into it
    answers its load error.
    """

    language = "?"
    refused = False  # a RefusedScript: not run by the operator's choice (its start is not logged again)
    #: The last error's message and stack traceback (``sim.getStackTraceback`` reads and clears it).
    last_traceback = ""

    def __init__(self, world: World, owner: int, path: Path, *, signals: Signals | None = None,
                 timeout: float = DEFAULT_TIMEOUT, allow_remote_code: bool = False,
                 allow_unsafe_lua: bool = False, simulation: Any = None, forces: AppliedForces | None = None,
                 kind: str = "child", threaded: bool = False, version: int | None = None,
                 parameters: list | None = None, shared: dict | None = None):
        self.world = world
        self.simulation = simulation  # the Simulation, for the sim calls that need it (sensors, edits)
        self.forces = forces if forces is not None else AppliedForces()
        self.owner = owner
        self.path = path
        self.object_name = world.get(owner).name
        self.kind = kind  # "child" or "customization"
        self.threaded = threaded  # a V-REP 3.x threaded script: its whole text runs as a coroutine
        self.version = version  # the V-REP version that wrote it (30600 = 3.6.0), None: current
        self.parameters = list(parameters or [])  # script simulation parameters: {"name", "value", "unit"}
        self.shared = shared if shared is not None else {}  # one dict per Scripts (custom data, requests)
        self.budget: ScriptBudget | None = self.shared.get("budget")  # all scripts' time and memory together
        self.executions = 0  # sim.getScriptExecutionCount
        self.label = f"{kind} script {path.name} of {self.object_name!r}"
        self.signals = signals if signals is not None else Signals()
        self.timeout = float(timeout)
        self.allow_remote_code = allow_remote_code
        self.allow_unsafe_lua = allow_unsafe_lua  # Lua only: Python scripts are trusted code
        self.running = False
        self.disabled = False  # sim.setScriptInt32Param(h, sim.scriptintparam_enabled, 0): no callbacks
        self.pending_start = False  # disabled when it would have started: it starts once enabled
        self.load_error: str | None = None
        self.start_error: str | None = None
        self._skipped: set[str] = set()  # life-cycle functions skipped until the next start
        #: Passed the scene's scripts' time (the pass's end or their share): every callback but
        #: ``sysCall_cleanup`` is skipped until the next start.
        self.cut = False
        self._last_error: dict[str, str] = {}  # last error logged per life-cycle function
        self._load()
        if self.load_error:
            log.error("%s cannot be loaded: %s", self.label, self.load_error)

    def sim_namespace(self) -> ApiNamespace:
        """A new ``sim`` for this script (its context knows the script: execution count,
        parameters, threads)."""
        return script_sim(self.world, self.owner, self.signals, label=self.path.name,
                          simulation=self.simulation, forces=self.forces, script=self)

    # ---------------------------------------------------------------- life cycle
    def start(self) -> None:
        """Simulation starts: fresh state, the file's top level, ``sysCall_init``, then the
        script's thread (if it has one) runs to its first yield.

        Raises ScriptError when the script cannot run (load error, error in its top level);
        it then stays attached, and remote calls answer that error."""
        if self.disabled:  # a script saved disabled, or disabled since: it starts when enabled
            self.pending_start = True
            return
        self.running = True
        self.start_error = None
        self.rearm()
        self._last_error.clear()
        if self.load_error:
            raise ScriptError(f"{self.label} cannot be loaded: {self.load_error}")
        try:
            with self._charged():  # the top level counts toward the scripts' time as a callback
                self._create()
        except ScriptError as exc:
            self.start_error = str(exc)
            raise
        self.life_cycle("sysCall_init")
        if self.kind == "child":
            self._guarded("thread", self._launch_thread)
            self.resume_thread()

    def rearm(self) -> None:
        """The simulation starts: callbacks skipped for an overrun run again."""
        self._skipped.clear()
        self.cut = False

    def resume_thread(self) -> None:
        """Resume the script's thread (a coroutine) until it yields, once per step before
        ``sysCall_actuation``; errors and overruns go to the log and end the thread."""
        if self._may_run("thread") and self._thread_alive() and not self._pass_spent("thread"):
            self._guarded("thread", self._resume_thread)

    def life_cycle(self, function: str) -> None:
        """Run a life-cycle function if the script defines it; errors go to the log only.

        Repeats of the same error are logged at debug level; a script interrupted for
        overrunning its own time bound in ``sysCall_actuation``/``sysCall_sensing`` has both
        skipped until the simulation restarts, so that the simulation keeps its pace; one
        interrupted by the scene's scripts' time (the pass's end, their share) has all its
        callbacks but ``sysCall_cleanup`` skipped until then (:attr:`cut`)."""
        body = self._body(function) if self._may_run(function) else 0
        if body == 1 or (body and not self._pass_spent(function)):  # an empty one: counted, no clock read
            self.executions += 1
            if body == 2:  # with code: run it (an empty one, a V-REP template's, would do nothing)
                self._guarded(function, lambda: self._run_function(function, ()))

    def _may_run(self, function: str) -> bool:
        """Whether callback ``function`` may run now: the script runs, enabled, loaded, and neither the
        function (an overrun of its step functions) nor the script (:attr:`cut`) is skipped."""
        skipped = not self.running or self.disabled or self.load_error or function in self._skipped
        return not skipped and (not self.cut or function == "sysCall_cleanup")

    def _pass_spent(self, function: str) -> bool:
        """True (and a debug line) when the scene's scripts have used up the current pass's
        time (:class:`~simx_server.scripts.budget.ScriptBudget`): the call is skipped this pass."""
        if self.budget is not None and self.budget.spent():
            log.debug("%s, %s: skipped in this pass: the scripts' time in it is spent "
                      "(limits.MAX_SCRIPTS_STEP_TIME, SCRIPTS_SHARE)", self.label, function)
            return True
        return False

    def _charged(self) -> Any:
        """A context in which the script's work counts toward the scripts' time (a callback)."""
        return contextlib.nullcontext() if self.budget is None else self.budget.callback()

    def _call_bound(self) -> tuple[float, str | None]:
        """``(seconds, why)``: the next call's time bound, the script's ``script_timeout`` or what
        is left of the pass or of the scripts' share if less (``why``: budget.PASS or SHARE)."""
        seconds, why = (self.timeout, None) if self.budget is None else self.budget.bound(self.timeout)
        if _UNDER_WAY and _UNDER_WAY[-1][0] == threading.get_ident():
            left = _UNDER_WAY[-1][1] - time.thread_time()
            if left < seconds:
                return max(left, 0.0), CALLER
        return seconds, why

    @contextlib.contextmanager
    def _calling(self, seconds: float) -> Iterator[None]:
        """A call of at most ``seconds`` into this script is under way inside the block: calls
        it makes into other scripts end no later (:meth:`_call_bound`)."""
        _UNDER_WAY.append((threading.get_ident(), time.thread_time() + seconds))
        try:
            yield
        finally:
            _UNDER_WAY.pop()

    def _overrun(self, why: str | None) -> str:
        """The end of an overrun's message: which bound it passed."""
        budget = self.budget
        if why == PASS and budget is not None:
            return (f"interrupted: the scene's scripts used up their {budget.seconds:g} s of this pass "
                    "(limits.MAX_SCRIPTS_STEP_TIME)")
        if why == CALLER:
            return "interrupted: the call into the script that called it reached its time bound"
        if why == SHARE and budget is not None:
            return (f"interrupted: the scene's scripts took their share of the server's time, "
                    f"{budget.share:.0%} of {budget.window:g} s beyond {budget.allowance:g} s a pass "
                    "(limits.SCRIPTS_SHARE)")
        return f"interrupted: did not return within {self.timeout:g} s (script_timeout)"

    def memory_used(self) -> int:
        """Bytes its script state holds that count toward limits.MAX_SCRIPTS_MEMORY (Lua)."""
        return 0

    def _guarded(self, function: str, run: Callable[[], Any]) -> None:
        """Run callback ``function`` (``run``), charged to the scripts' time; its errors go to
        the log. An overrun of the pass's end or of the scripts' share cuts the script (every
        callback skipped until the next start); one of its own bound, in a step function, skips
        its step functions until then."""
        try:
            with self._charged():
                run()
        except ScriptTimeoutError as exc:
            if exc.bound in (PASS, SHARE):
                self.cut = True
                log.error("%s; its callbacks are skipped until the simulation restarts", exc)
            elif function in _STEP_FUNCTIONS:
                self._skipped.update(_STEP_FUNCTIONS)
                log.error("%s; its %s are skipped until the simulation restarts", exc, " and ".join(_STEP_FUNCTIONS))
            else:
                log.error("%s", exc)
        except ScriptError as exc:
            message = str(exc)
            if self._last_error.get(function) == message:
                log.debug("%s (again)", message)
            else:
                self._last_error[function] = message
                log.error("%s", message)
        except Exception:  # never let the simulation step die with a script
            log.exception("%s, %s: internal error", self.label, function)

    def stop(self) -> None:
        """Simulation stops: ``sysCall_cleanup``, then the script's state is dropped."""
        self.pending_start = False
        try:
            self.life_cycle("sysCall_cleanup")
        finally:
            self.running = False
            self._drop()

    def system_call(self, function: str, args: tuple) -> None:
        """A system callback with arguments (``sysCall_msg(message, origin)``) if the script defines
        it; its return values are dropped and its errors go to the log only, as life-cycle functions'."""
        if self._may_run(function) and self._defines(function) and not self._pass_spent(function):
            self._guarded(function, lambda: self._run_values(function, args))

    def _traced(self, fault: ScriptError, traceback_text: str = "") -> ScriptError:
        """``fault``, kept with its stack traceback as the script's :attr:`last_traceback`."""
        self.last_traceback = f"{fault}\n{traceback_text}" if traceback_text else str(fault)
        return fault

    def call(self, function: str, ints: list, floats: list, strings: list, buffer: bytes) -> list:
        """Call a script function remotely; returns ``[ints, floats, strings, buffer]``.

        Raises ScriptError (file, line and message) for anything that goes wrong."""
        self._check_call(function)
        return self._run_function(function, (ints, floats, strings, buffer))

    def call_values(self, function: str, args: list) -> list:
        """CoppeliaSim 4.x's ``sim.callScriptFunction``: ``function(*args)`` with any values
        (numbers, strings, bytes, lists, dicts, None), its return values as a list (none: []).
        Lua strings come back as bytes, Lua tables as lists (keys 1..n) or dicts.

        Raises ScriptError (file, line and message) for anything that goes wrong."""
        self._check_call(function)
        return self._run_values(function, tuple(args))

    def _check_call(self, function: str) -> None:
        if self.load_error:
            raise ScriptError(f"{self.label} cannot be loaded: {self.load_error}")
        if not self.running:
            raise ScriptError(f"{self.label} is not running: the simulation is stopped "
                              "(child scripts run only while it runs; start it first)")
        if not self._callable(function):
            hint = f" (its start failed: {self.start_error})" if self.start_error else ""
            raise ScriptError(f"{self.label} has no function {function!r} that can be called remotely{hint}")

    # ------------------------------------------------------------ to implement
    def _load(self) -> None:
        raise NotImplementedError

    def _create(self) -> None:
        raise NotImplementedError

    def _defines(self, function: str) -> bool:
        raise NotImplementedError

    def _callable(self, function: str) -> bool:
        raise NotImplementedError

    def _body(self, function: str) -> int:
        """0: ``function`` undefined; 1: defined without code (a call, not made, would change nothing); 2: with code."""
        return 2 if self._defines(function) else 0

    def _run_function(self, function: str, args: tuple) -> Any:
        raise NotImplementedError

    def _run_values(self, function: str, args: tuple, flat: bool = False) -> list:  # flat: simx's own flat data
        raise NotImplementedError

    def _drop(self) -> None:
        raise NotImplementedError

    def _launch_thread(self) -> None:
        """Start the script's thread if it has one (``sysCall_thread``, ``sysCall_threadmain``,
        a 3.x threaded script); languages without threads log why not."""
        for name in ("sysCall_thread", "sysCall_threadmain"):
            if self._defines(name):
                log.error("%s: threaded %s scripts (%s) are not supported: it does not run", self.label,
                          self.language, name)

    def _thread_alive(self) -> bool:
        return False  # _resume_thread() runs the thread until it yields, in languages that have threads

    def _fault(self, what: str, detail: str, timeout: bool = False, bound: str | None = None) -> ScriptError:
        """The error of ``what`` (a ScriptTimeoutError, of ``bound``, when ``timeout``)."""
        if not timeout:
            return ScriptError(f"{self.label}, {what}: {detail}")
        fault = ScriptTimeoutError(f"{self.label}, {what}: {detail}")
        fault.bound = bound
        return fault


class RefusedScript(ChildScript):
    """A script the server was not allowed to run (a scene's Python script without
    :data:`PYTHON_SCRIPTS_FLAG`): attached, as a script that failed to load, so that the scene
    loads and its other scripts run; its refusal is logged once, when the scene loads, and every
    remote call into it answers it. Its file is not read."""

    language = "Python"
    refused = True

    def _load(self) -> None:
        self.load_error = (f"not run: a scene's Python scripts run with the server's rights, only when the "
                           f"server is started with {PYTHON_SCRIPTS_FLAG}")

    def _drop(self) -> None:
        pass


def _refuse(name: str) -> Callable[..., Any]:
    def refused(*args: Any, **kwargs: Any) -> Any:
        raise ScriptError(f"{name}() is disabled in child scripts: simx runs code sent by clients "
                          f"only when the server is started with {REMOTE_CODE_FLAG}")
    refused.__name__ = name
    return refused


def _script_builtins(allow_remote_code: bool) -> dict[str, Any]:
    """Builtins of Python scripts: without the flag, no exec/eval/compile (a guard rail against
    running strings that clients send; Python scripts are trusted code, not a sandbox) and no
    input/breakpoint (they would block the simulation)."""
    names = dict(vars(builtins))
    blocked = ("input", "breakpoint") + (() if allow_remote_code else ("exec", "eval", "compile"))
    for name in blocked:
        names[name] = _refuse(name)
    return names


class PythonScript(ChildScript):
    """A Python child script: globals ``sim``, ``simIK``, ``simOMPL`` and ``simVision``
    (:class:`~simx_server.api.context.ApiNamespace`) and ``print`` (to the log)."""

    language = "Python"

    def _load(self) -> None:
        self._code = None
        self.namespace: dict[str, Any] = {}
        try:
            source = self.path.read_text(encoding="utf-8")
            self._code = compile(source, str(self.path), "exec", dont_inherit=True)
        except SyntaxError as exc:
            self.load_error = f"{self.path.name}:{exc.lineno}: SyntaxError: {exc.msg}"
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            self.load_error = f"{self.path.name}: {exc}"

    def _print(self, *values: Any, sep: str | None = " ", end: str | None = None, **_: Any) -> None:
        log.info("[%s] %s", self.path.name, (" " if sep is None else sep).join(str(v) for v in values))

    def _create(self) -> None:
        self.namespace = {
            "__name__": f"simx_script_{self.object_name}",
            "__file__": str(self.path),
            "__builtins__": _script_builtins(self.allow_remote_code),
            "sim": self.sim_namespace(),
            "print": self._print,
        }
        self.namespace["simIK"] = self.namespace["sim"].context.simik  # CoppeliaSim 4.x's simIK
        self.namespace["simOMPL"] = self.namespace["sim"].context.simompl  # and its OMPL plug-in
        self.namespace["simVision"] = self.namespace["sim"].context.simvision  # and its vision plug-in
        self._initial_globals = frozenset(self.namespace)
        self._bounded("top level", lambda: exec(self._code, self.namespace))

    def user_variables(self) -> dict[str, Any]:
        """``sim.getUserVariables``: the globals the script's own code made, name -> value."""
        initial = getattr(self, "_initial_globals", frozenset())
        return {k: v for k, v in self.namespace.items() if k not in initial}

    def _defines(self, function: str) -> bool:
        return callable(self.namespace.get(function))

    def _callable(self, function: str) -> bool:
        fn = self.namespace.get(function)
        # Only functions the script itself defines; not imported ones, not _private ones.
        return (not function.startswith("_") and inspect.isfunction(fn)
                and fn.__globals__ is self.namespace)

    def _run_function(self, function: str, args: tuple) -> Any:
        fn = self.namespace[function]
        out = self._bounded(function, lambda: fn(*args))
        if function in LIFE_CYCLE_CALLS:
            return out
        try:
            return legacy_outputs(out)
        except ScriptError as exc:
            raise self._fault(function, str(exc)) from None

    def _run_values(self, function: str, args: tuple, flat: bool = False) -> list:
        fn = self.namespace[function]
        out = self._bounded(function, lambda: fn(*args))
        return [] if out is None else list(out) if isinstance(out, tuple) else [out]

    def _drop(self) -> None:
        if self.py_thread is not None:
            self.py_thread.end()
            self.py_thread = None
        self.namespace = {}

    py_thread: PythonThread | None = None

    def _launch_thread(self) -> None:
        fn = self.namespace.get("sysCall_thread") or self.namespace.get("sysCall_threadmain")
        if callable(fn):
            self.py_thread = PythonThread(fn, f"{self.path.name} of {self.object_name}")

    def _thread_alive(self) -> bool:
        return self.py_thread is not None and self.py_thread.alive

    def _resume_thread(self) -> None:
        thread = self.py_thread
        seconds, why = self._call_bound()
        if not thread.resume(seconds):
            message = self._overrun(why) if why else f"interrupted: did not yield within {self.timeout:g} s " \
                                                     "(script_timeout)"
            raise self._fault("thread", f"{self.path.name}: {message}", timeout=True, bound=why)
        if thread.error is not None:
            exc, thread.error = thread.error, None
            stack = traceback.extract_tb(exc.__traceback__)
            raise self._traced(self._fault("thread", f"{self._where(stack)}{type(exc).__name__}: {exc}"),
                               self._stack_text(stack))

    def _bounded(self, what: str, fn: Callable[[], Any]) -> Any:
        seconds, why = self._call_bound()
        try:
            with self._calling(seconds):
                result, interrupted_at = WATCHDOG.bounded(fn, seconds)
        except Exception as exc:
            stack = traceback.extract_tb(exc.__traceback__)
            raise self._traced(self._fault(what, f"{self._where(stack)}{type(exc).__name__}: {exc}"),
                               self._stack_text(stack)) from None
        if interrupted_at is not None:
            raise self._traced(self._fault(what, f"{self._where(interrupted_at)}{self._overrun(why)}",
                                           timeout=True, bound=why), self._stack_text(interrupted_at))
        return result

    def _where(self, stack: traceback.StackSummary) -> str:
        frames = [f for f in stack if Path(f.filename) == self.path]
        return f"{self.path.name}:{frames[-1].lineno}: " if frames else f"{self.path.name}: "

    def _stack_text(self, stack: traceback.StackSummary) -> str:
        """The script's own frames of ``stack`` as Python prints a traceback (the server's are left out)."""
        frames = traceback.StackSummary.from_list([f for f in stack if Path(f.filename) == self.path])
        return "Traceback (most recent call last):\n" + "".join(frames.format()) if frames else ""
