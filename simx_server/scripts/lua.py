"""Lua child scripts, run by lupa (Lua 5.4) against the shared ``sim`` API table.

Each script gets its own Lua state, made afresh at every simulation start, prepared by
:data:`simx_server.scripts.lua_prelude.PRELUDE`:

* ``sim``: one Lua function per entry of :data:`simx_server.api.registry.SIM`,
  each calling the table with the script's context through one Python
  dispatcher;
  Python lists come back as Lua tables, ``str`` and ``bytes`` as Lua strings. A ``sim`` error
  becomes a Lua error at the script's line (``RG2.lua:17: sim.getObjectHandle: ...``); an
  unknown ``sim.NAME`` is a Lua error that names it. Every V-REP constant is ``sim.NAME`` too,
  and the pre-3.6 spellings ``simGetObjectHandle`` / ``sim_handle_self`` resolve to them.
* ``print`` writes to the server log; Lua 5.1 names V-REP scripts used (``unpack``,
  ``table.getn``, ``math.pow``) exist.
* A count hook bounds every call: every :data:`HOOK_COUNT` instructions it asks Python whether
  the call's deadline (in the thread's CPU time) has passed, and then raises a Lua error and keeps raising at every
  instruction so that no ``pcall`` can swallow it. Lua runs code in an error's wake with hooks
  off, so none of the script's runs there: an ``xpcall`` message handler is skipped once the
  deadline has passed, and ``coroutine.close`` does not run the ``__close`` metamethods of a
  coroutine the timeout killed (``__gc`` is refused outright). Coroutines get the hook too (a
  timeout inside one is raised again in its resumer), a call that returns once its deadline was
  found passed is an overrun all the same (``return pcall(f)``), and the hook also
  runs after each garbage-collection cycle (one ``..`` of long strings copies much memory in one
  instruction; ``collectgarbage("stop")`` is a no-op). The library functions that loop in C
  (patterns, ``string.rep``, ``table.sort``...) are bounded by
  :mod:`simx_server.scripts.lua_bounds`.
* Safety (CoppeliaSim's defaults): no ``python`` bridge (no eval, no builtins, no Python
  attribute access), no binary chunks, no ``os.exit``, no ``debug.sethook``. Unless the server
  runs with ``--allow-unsafe-lua``: no ``dofile``/``loadfile``, no ``io`` functions (no files, no
  ``io.popen``, no standard streams), no ``os.execute``/``remove``/``rename``/``tmpname``/
  ``getenv``/``setlocale``, no ``package.loadlib``/``searchpath``, and ``require`` loads Lua
  modules from the scene's folder only whatever a script does to ``package.path``,
  ``package.cpath`` or ``package.searchers``: the file is read by the host
  (:meth:`LuaScript._read_module`) and compiled as text; Lua's searchers are not in the state. ``load``/``loadstring`` work only when the server
  runs with ``--allow-remote-code`` (they are how a script would run code that a client sends).
  Memory is capped at :data:`MAX_MEMORY` bytes per script.
"""

from __future__ import annotations

import logging
import math
import re
import time
from typing import Any

from simx_wire.protocol import ArgumentError, RemoteError, ScriptError
from simx_server.base import limits as L
from simx_server.scripts.call_arguments import script_argument_bytes
from simx_server.scripts.child import LIFE_CYCLE_CALLS, REMOTE_CODE_FLAG, UNSAFE_LUA_FLAG, ChildScript, legacy_outputs
from simx_server.api import SIM, SIMIK, SIMOMPL, SIMVISION
from simx_server.scripts.lua_bounds import BOUNDS_LUA, CHECK_WORK, PIECE, SORT_IN_C
from simx_server.scripts.lua_prelude import PRELUDE
from simx_server.scripts.model_library import module_text
from simx_server.scripts.rewrites import lua_file_text, rewrite
from simx_server.scripts.threads import LuaStyles

try:
    import lupa.lua54 as _lupa
except ImportError:  # pragma: no cover - lupa is a dependency; kept for a clear message
    _lupa = None

log = logging.getLogger("simx.scripts")

#: Instructions between two checks of the deadline.
HOOK_COUNT = 10_000
#: What simx's own callback data take in a Lua state at most (:meth:`LuaScript._call_with` with
#: ``flat``): a joint callback's 19 values, about 1.2 KiB by call_arguments' estimate.
_FLAT_BYTES = 4096
#: Memory cap of one script's Lua state (bytes).
MAX_MEMORY = L.MAX_SCRIPT_MEMORY
#: Bytes of one module ``require`` reads (a quarter of a script's memory cap).
MAX_MODULE_BYTES = MAX_MEMORY // 4
_MODULE_NAME = re.compile(r"[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*")
_MAX_DEPTH = 32  # nesting of tables converted between Lua and Python
#: ``shape(lookup, chunk)``: a function of a global's name that gives nil for an undefined name;
#: for a Lua function of several lines of chunk ``chunk`` whose only instruction lies on its last
#: line (the implicit return of an empty body, as V-REP's script templates leave
#: sysCall_actuation), that line; false otherwise. Kept per function value (weakly); compiled
#: before the prelude hides ``debug``.
_SHAPE_LUA = r"""
local getinfo, pairs, type, setmetatable = debug.getinfo, pairs, type, setmetatable
return function(lookup, chunk)
  local seen = setmetatable({}, {__mode = "k"})
  return function(name)
    local f = lookup(name)
    if f == nil then return nil end
    if type(f) ~= "function" then return false end
    local line = seen[f]
    if line == nil then
      local i = getinfo(f, "SL")
      line = i.what == "Lua" and i.source == chunk and i.linedefined < i.lastlinedefined and i.lastlinedefined
      if line then
        for l in pairs(i.activelines) do if l ~= line then line = false break end end
      end
      seen[f] = line
    end
    return line
  end
end
"""



def _deny_attributes(obj: Any, name: Any, is_setting: bool) -> Any:
    raise AttributeError("Python objects cannot be inspected from child scripts")


def _first_line(exc: BaseException) -> str:
    """A Lua error's message without lupa's traceback."""
    msg = exc.args[0] if exc.args else str(exc)
    if isinstance(msg, bytes):
        msg = msg.decode("utf-8", errors="replace")
    msg = str(msg)
    return msg.split("\nstack traceback:", 1)[0].strip()


def _stack_traceback(exc: BaseException) -> str:
    """The ``stack traceback:`` part of a Lua error's message (lupa adds Lua's), or ""."""
    msg = exc.args[0] if exc.args else str(exc)
    if isinstance(msg, bytes):
        msg = msg.decode("utf-8", errors="replace")
    _, found, rest = str(msg).partition("\nstack traceback:")
    return f"stack traceback:{rest}" if found else ""


#: :attr:`LuaScript._bodies` when nothing is known: ``(Lua state's shape function, {callback: body})``,
#: what :meth:`LuaScript._body` found since Lua last ran in the script (any call may redefine its
#: callbacks, so every bounded call and thread launch forgets it).
_NO_BODIES: tuple[Any, dict[str, int]] = (None, {})
_ALIVE = "\0thread alive"  # the key of :meth:`LuaScript._thread_alive` in the same cache


class LuaScript(LuaStyles, ChildScript):
    """A Lua child script (the V-REP kind), in a lupa Lua 5.4 state of its own."""

    language = "Lua"
    _bodies = _NO_BODIES

    def _load(self) -> None:
        self._runtime = None
        self._lookup = None
        self._deadline = math.inf
        self._timed_out = False
        if _lupa is None:
            self.load_error = "Lua scripts need lupa with Lua 5.4: pip install 'lupa>=2.2'"
            return
        try:
            self._source, steps = rewrite(lua_file_text(self.path.read_bytes()), self.version)
            if steps:
                log.info("%s written by V-REP %s: rewritten as CoppeliaSim does (%s)", self.label, self.version,
                         ", ".join(steps))
        except OSError as exc:
            self.load_error = f"{self.path.name}: {exc}"
            return
        try:  # syntax check now, so that the error shows up when the scene loads
            self._new_runtime().compile(self._source, name=f"@{self.path.name}", mode="t")
        except _lupa.LuaError as exc:
            self.load_error = _first_line(exc)

    def _new_runtime(self) -> Any:
        return _lupa.LuaRuntime(encoding=None, unpack_returned_tuples=True, register_eval=False,
                                register_builtins=False, attribute_filter=_deny_attributes,
                                max_memory=MAX_MEMORY)

    # ------------------------------------------------------------ the bridge
    def _expired(self) -> bool:
        # The deadline is in the calling thread's CPU time: a bound on the script's own work, which
        # a loaded machine (other processes, other threads holding the GIL) does not shorten.
        if time.thread_time() > self._deadline:
            self._timed_out = True
            return True
        return False

    def _read_module(self, name: Any, probe: Any = None) -> Any:
        """``require(name)``'s file, read for the script (its Lua side compiles it as text):
        ``(text, "a/b.lua")`` for the module ``a.b`` of the scene's own folder, else
        ``(None, "no file '<scene folder>/a/b.lua'")``; with ``probe``, whether it exists.

        Only a name of letters, digits, ``_`` and ``-`` parts joined by dots is looked for, and
        only a regular file that lies inside the scene's folder once links are resolved, of at
        most :data:`MAX_MODULE_BYTES`: no script reads a file outside its scene's folder, whatever
        it does to ``package.path`` or ``package.searchers`` (Lua's searchers are not in the
        script's state: :data:`~simx_server.scripts.lua_prelude.PRELUDE`)."""
        text = name.decode("utf-8", errors="replace") if isinstance(name, bytes) else str(name)
        shown = f"<scene folder>/{text.replace('.', '/')[:200]}.lua"
        if not _MODULE_NAME.fullmatch(text):
            return False if probe else (None, f"no file '{shown}' (a module name is parts of letters, digits, "
                                              "'_' and '-' joined by dots)".encode())
        relative = text.replace(".", "/") + ".lua"
        folder = self.path.parent.resolve()
        try:
            file = (folder / relative).resolve()
            found = file.is_relative_to(folder) and file.is_file()
            size = file.stat().st_size if found else 0
        except OSError:
            found, size = False, 0
        if probe:
            return found
        if not found:
            return None, f"no file '{shown}'".encode()
        if size > MAX_MODULE_BYTES:
            return None, f"'{shown}' is {size} bytes, more than {MAX_MODULE_BYTES} (lua.MAX_MODULE_BYTES)".encode()
        try:
            return lua_file_text(file.read_bytes()), relative.encode()
        except OSError as exc:
            return None, f"cannot read '{shown}': {exc.strerror}".encode()

    def _model_module(self, name: Any) -> Any:
        """The Lua text of simx's module for CoppeliaSim model-library module ``name``
        (:mod:`simx_server.scripts.model_library`), or None; the prelude loads it when the
        scene's folder has no module of that name."""
        text = name.decode("utf-8", errors="replace") if isinstance(name, bytes) else str(name)
        found = module_text(text)
        return None if found is None else found.encode()

    def _model_host(self, op: Any, *args: Any) -> tuple:
        """What simx's model-library modules ask of the host besides ``sim`` calls (never
        raises: ``(True,)`` or ``(False, message)``): ``"poses", handles, poses, relativeTo,
        moving, velocities`` sets each object's pose (7 numbers each, in ``relativeTo``'s frame)
        with one update of the scene for all (a conveyor's pads, every step), then the initial
        velocity of each of ``moving`` (3 numbers each, world axes, m/s: its surface's motion)."""
        try:
            if op != b"poses":
                raise ValueError(f"no host operation {op!r}")
            handles, poses, rel, moving, velocities = (self._from_lua(a) for a in args)
            world = self._sim.context.world
            with world.one_change():
                world.set_poses(handles, poses, rel)
            for i, h in enumerate(moving):
                for k in range(3):
                    self._sim.call("setObjectFloatParam", h, 3000 + k, velocities[3 * i + k])
            return (True,)
        except RemoteError as exc:
            return False, str(exc).encode()
        except (TypeError, ValueError, IndexError) as exc:
            return False, f"bad arguments: {exc}".encode()

    def _write_log(self, text: bytes) -> None:
        log.info("[%s] %s", self.path.name, text.decode("utf-8", errors="replace"))

    def _dispatch(self, name: bytes, *args: Any) -> tuple:
        """``sim.NAME(...)`` from Lua: (True, results...) or (False, message); never raises."""
        fname = name.decode()
        try:
            target, callbacks = self._sim, False
            if fname.startswith("simIK."):  # simIK's functions over this script's context
                target, fname = self._sim.context.simik, fname[6:]
            elif fname.startswith("simOMPL."):  # and simOMPL's, which take Lua functions as callbacks
                target, fname, callbacks = self._sim.context.simompl, fname[8:], True
            elif fname.startswith("simVision."):  # and simVision's
                target, fname = self._sim.context.simvision, fname[10:]
            result = target.call(fname, *[self._from_lua(a, callbacks=callbacks) for a in args])
            if isinstance(result, tuple):
                return (True, *[self._to_lua(v) for v in result])
            return True, self._to_lua(result)
        except RemoteError as exc:
            return False, str(exc).encode()
        except (TypeError, ValueError, OverflowError) as exc:
            return False, f"bad arguments: {exc}".encode()
        except Exception as exc:  # a bug in simx, not in the script: say so
            log.exception("sim.%s called by %s", fname, self.label)
            return False, f"internal error: {type(exc).__name__}: {exc}".encode()

    def _from_lua(self, value: Any, depth: int = 0, callbacks: bool = False) -> Any:
        """A Lua value as Python: tables with keys 1..n as lists, other tables as dicts,
        strings as bytes; with ``callbacks`` an argument that is a function as a Python callable
        (simOMPL's validation callback, which the script's own later simOMPL calls run)."""
        kind = _lupa.lua_type(value)
        if kind is None:
            return value
        if kind == "function" and callbacks and depth == 0:
            return self._callback(value)
        if kind != "table":
            raise TypeError(f"a Lua {kind} cannot be passed to sim functions")
        if depth > _MAX_DEPTH:
            raise ValueError("tables nested too deeply")
        items = [(self._from_lua(k, depth + 1), self._from_lua(v, depth + 1)) for k, v in value.items()]
        keys = [k for k, _ in items]
        if all(isinstance(k, int) for k in keys) and sorted(keys) == list(range(1, len(keys) + 1)):
            return [v for _, v in sorted(items, key=lambda kv: kv[0])]
        return {(k.decode("utf-8", errors="replace") if isinstance(k, bytes) else k): v for k, v in items}

    def _callback(self, function: Any) -> Any:
        """A Lua function as a Python callable: arguments to Lua, its first result back."""
        def call(*args: Any) -> Any:
            return self._from_lua(function(*[self._to_lua(a) for a in args]), 1)

        return call

    def _to_lua(self, value: Any, depth: int = 0) -> Any:
        """A Python value as Lua: lists and tuples as tables, str as (UTF-8) strings."""
        if value is None or isinstance(value, (bool, int, float, bytes)):
            return value
        if isinstance(value, str):
            return value.encode("utf-8")
        if isinstance(value, (bytearray, memoryview)):
            return bytes(value)
        if hasattr(value, "tolist"):  # numpy scalars and arrays
            return self._to_lua(value.tolist(), depth)
        if depth > _MAX_DEPTH:
            raise ValueError("values nested too deeply")
        if isinstance(value, (list, tuple)):
            return self._runtime.table_from([self._to_lua(v, depth + 1) for v in value])
        if isinstance(value, dict):
            return self._runtime.table_from({self._to_lua(k, depth + 1): self._to_lua(v, depth + 1)
                                             for k, v in value.items()})
        raise TypeError(f"{type(value).__name__} cannot be passed to Lua")

    def _flat_table(self, value: dict) -> Any:
        """A dict of simx's own, str keys to Python numbers and booleans, as a Lua table: what
        :meth:`_to_lua` makes of it, without its walk (a joint callback's data, at every substep)."""
        return self._runtime.table_from({k.encode(): v for k, v in value.items()})

    # ---------------------------------------------------------- life cycle
    def _create(self) -> None:
        self._sim = self.sim_namespace()
        rt = self._runtime = self._new_runtime()
        shape = rt.compile(_SHAPE_LUA, name="=simx")()
        prelude = rt.compile(PRELUDE, name="=simx")
        self._lookup, snapshot, on_count = prelude(
            self._dispatch, self._expired, self._write_log,
            rt.table_from([n.encode() for n in SIM] + [f"simIK.{n}".encode() for n in SIMIK]
                          + [f"simOMPL.{n}".encode() for n in SIMOMPL] + [f"simVision.{n}".encode() for n in SIMVISION]),
            rt.table_from({**{k.encode(): v for k, v in SIM.constants.items()},
                           **{f"simIK.{k}".encode(): v for k, v in SIMIK.constants.items()},
                           **{f"simOMPL.{k}".encode(): self._to_lua(v) for k, v in SIMOMPL.constants.items()}}),
            self.allow_remote_code, str(self.path.parent).encode(), HOOK_COUNT, REMOTE_CODE_FLAG.encode(),
            self.allow_unsafe_lua, UNSAFE_LUA_FLAG.encode(),
            rt.compile(BOUNDS_LUA, name="=simx")(L.MAX_PATTERN_WORK, CHECK_WORK, PIECE, SORT_IN_C, MAX_MEMORY),
            self._read_module, self._model_module, self._model_host)
        self._prepare_styles(rt, on_count)
        self._shape, self._ends = shape(self._lookup, f"@{self.path.name}".encode()), {}
        snapshot()  # sim.getUserVariables: the globals from here on are the script's
        self._run_top_level(rt.compile(self._source, name=f"@{self.path.name}", mode="t"))

    def _defines(self, function: str) -> bool:
        if self.old_style and function in LIFE_CYCLE_CALLS:
            return self._old_style_defines(function)
        return self._lookup is not None and self._lookup(function.encode()) is not None

    def _callable(self, function: str) -> bool:
        return self._defines(function)

    def _body(self, function: str) -> int:
        """:meth:`ChildScript._body`, in one Lua call: a function whose lines before ``end`` are
        blank or comments (:data:`_SHAPE_LUA`) is empty, as V-REP's templates leave some."""
        if self.old_style or self._lookup is None:
            return super()._body(function)
        shape, known = self._bodies
        if shape is not self._shape:  # a new Lua state
            shape, known = self._bodies = (self._shape, {})
        body = known.get(function)
        if body is None:
            known[function] = body = self._body_now(function)
        return body

    def fixed_bodies(self) -> object | None:
        """The answers :meth:`_body` and :meth:`_thread_alive` keep until Lua code runs again
        (:meth:`_bounded`), or None while none are kept.

        Returns:
            An object the same while the answers are, or None."""
        bodies = self._bodies
        return None if self.old_style or self._lookup is None or bodies[0] is not self._shape else bodies

    def _thread_alive(self) -> bool:
        """Whether the script's thread lives, cached as :meth:`_body` (asked before every step)."""
        if self._runtime is None:
            return False
        shape, known = self._bodies
        if shape is not self._shape:
            shape, known = self._bodies = (self._shape, {})
        alive = known.get(_ALIVE)
        if alive is None:
            known[_ALIVE] = alive = super()._thread_alive()
        return bool(alive)

    def _launch_thread(self) -> None:
        self._bodies = _NO_BODIES  # Lua runs outside a bounded call: nothing known before holds
        try:
            super()._launch_thread()
        finally:
            self._bodies = _NO_BODIES

    def _body_now(self, function: str) -> int:
        """:meth:`_body` asked of the Lua state (uncached)."""
        line = self._shape(function.encode())
        if line is None or line is False:
            return 0 if line is None else 2
        if line not in self._ends:  # the line holds ``end`` alone, comments aside
            lines = self._source.splitlines()
            self._ends[line] = line <= len(lines) and lines[line - 1].split(b"--", 1)[0].strip() == b"end"
        return 1 if self._ends[line] else 2

    def _run_function(self, function: str, args: tuple) -> Any:
        if self.old_style and function in LIFE_CYCLE_CALLS:
            return self._old_style_run(function)
        fn = self._lookup(function.encode())
        if fn is None:
            raise self._fault(function, "no such function")
        if function in LIFE_CYCLE_CALLS:
            return self._bounded(function, fn, ())
        ints, floats, strings, buffer = args
        lua_args = (ints, floats, [s.encode("utf-8") for s in strings], bytes(buffer))
        out = self._call_with(function, fn, lua_args)
        try:
            values = list(out) if isinstance(out, tuple) else ([] if out is None else [out])
            return legacy_outputs(tuple(self._from_lua(v) for v in values))
        except (TypeError, ValueError) as exc:
            raise self._fault(function, f"returned values of the wrong types: {exc}") from None
        except ScriptError as exc:
            raise self._fault(function, str(exc)) from None

    def _run_values(self, function: str, args: tuple, flat: bool = False) -> list:
        fn = self._lookup(function.encode())
        if fn is None:
            raise self._fault(function, "no such function")
        out = self._call_with(function, fn, args, flat)
        values = list(out) if isinstance(out, tuple) else ([] if out is None else [out])
        try:
            return [self._from_lua(v) for v in values]
        except (TypeError, ValueError) as exc:
            raise self._fault(function, f"returned values that cannot be sent: {exc}") from None

    def _call_with(self, function: str, fn: Any, args: tuple, flat: bool = False) -> Any:
        """``fn(*args)`` in the script's protected, time-bounded call (both doors: the legacy
        simxCallScriptFunction's four lists and buffer, the ZMQ sim.callScriptFunction's values;
        ``flat``: simx's own callback data, a few flat tables of numbers and booleans that simx
        made, :mod:`simx_server.scripts.dynamics`, which skip the estimate below).

        Bounds first, before any conversion (:func:`script_argument_bytes`: limits.MAX_SCRIPT_CALL_VALUES,
        MAX_SCRIPT_CALL_TABLES, MAX_SCRIPT_CALL_BYTES), then the state's free memory (half of it at
        most). A failed allocation outside a protected call aborts the whole process (Lua's panic),
        so the arguments are converted, into one table, with the state's cap lifted (by at most the
        bounded size), and the cap is back before the call: a script that keeps what it gets runs
        out of memory inside the call, a Lua error. Raises ArgumentError or ScriptError."""
        rt = self._runtime
        need = _FLAT_BYTES if flat else script_argument_bytes(args)
        free = MAX_MEMORY - rt.get_memory_used()
        if need > free // 2:
            raise ArgumentError(f"{self.label}: the arguments of {function!r} need about {need >> 20} MiB in the "
                                f"script's Lua state, which has {free >> 20} MiB free of {MAX_MEMORY >> 20} "
                                "(limits.MAX_SCRIPT_MEMORY); send less")
        rt.set_max_memory(0)
        try:
            packed = rt.table_from([self._flat_table(a) if flat else self._to_lua(a) for a in args])
            apply = getattr(self, "_apply", None)
            if apply is None or apply[0] is not rt:
                apply = self._apply = (rt, rt.eval("function(f, t, n) return f(table.unpack(t, 1, n)) end"))
        except (TypeError, ValueError, OverflowError) as exc:
            raise ArgumentError(f"{self.label}, {function}: arguments that Lua cannot take: {exc}") from None
        finally:
            rt.set_max_memory(MAX_MEMORY)
        return self._bounded(function, apply[1], (fn, packed, len(args)))

    def _drop(self) -> None:
        self._drop_long_calls()
        self._lookup = None
        self._runtime = None
        self._sim = None

    def memory_used(self) -> int:
        rt = self._runtime
        return 0 if rt is None else rt.get_memory_used()

    def _bounded(self, what: str, fn: Any, args: tuple) -> Any:
        """``fn(*args)`` under the call's time bound (the script's or what is left of the pass,
        :meth:`_call_bound`) and memory cap (its own, or what the scene's other Lua scripts leave
        of limits.MAX_SCRIPTS_MEMORY); raises ScriptError / ScriptTimeoutError naming the bound."""
        self._bodies = _NO_BODIES  # the call may define, redefine or remove its callbacks
        self._timed_out = False
        seconds, why = self._call_bound()
        self._deadline = time.thread_time() + seconds
        rt = self._runtime
        cap = MAX_MEMORY if self.budget is None or rt is None else max(1, self.budget.memory_cap(self, MAX_MEMORY))
        if cap != MAX_MEMORY:
            rt.set_max_memory(cap)
        try:
            with self._calling(seconds):
                result = fn(*args)
        except _lupa.LuaMemoryError as exc:
            bound = (f"{MAX_MEMORY >> 20} MiB per script" if cap == MAX_MEMORY else
                     f"the scene's Lua scripts hold at most {self.budget.memory >> 20} MiB together, "
                     f"limits.MAX_SCRIPTS_MEMORY; {cap >> 20} MiB were left to this one")
            raise self._fault(what, f"out of memory ({bound}): {_first_line(exc)}") from None
        except _lupa.LuaError as exc:
            stack = _stack_traceback(exc)
            if self._timed_out:
                where = re.match(rf"{re.escape(self.path.name)}:\d+: ", _first_line(exc))
                prefix = where.group(0) if where else ""
                raise self._traced(self._fault(what, f"{prefix}{self._overrun(why)}", timeout=True, bound=why),
                                  stack) from None
            raise self._traced(self._fault(what, _first_line(exc)), stack) from None
        except Exception as exc:  # a Python error crossing Lua (a bug in simx): still the script's fault line
            raise self._fault(what, f"internal error: {type(exc).__name__}: {exc}") from None
        finally:
            self._bodies = _NO_BODIES
            self._deadline = math.inf
            if cap != MAX_MEMORY and self._runtime is rt:
                rt.set_max_memory(MAX_MEMORY)
        if self._timed_out:  # the deadline passed and the script caught the error (a load's reader...)
            raise self._fault(what, self._overrun(why), timeout=True, bound=why)
        return result
