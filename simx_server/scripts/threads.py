"""Threaded child scripts as coroutines on the simulation thread, as CoppeliaSim 4.x runs them,
and the pre-3.6 ``sim_call_type`` scripts (Lua).

A script's thread is a Lua coroutine: ``sysCall_thread`` (4.x), ``sysCall_threadmain`` (3.6) or,
for a V-REP 3.x threaded script (the ``threaded=1`` setting of its object), the script's whole
text. It starts when the simulation starts (after ``sysCall_init``) and runs until it yields;
the simulation then resumes it once per step, before the script's ``sysCall_actuation``, until
it ends or the simulation stops (then it is dropped, as CoppeliaSim drops its coroutines; the
script's ``sysCall_cleanup`` still runs). It yields in:

* ``sim.switchThread()`` / ``simSwitchThread()``, ``sim.yield()``, ``sim.step()`` (4.6);
* ``sim.wait(dt [, simulationTime=true])`` / ``simWait``: until ``dt`` s of simulation time (or
  of wall time) have passed (its value: the simulation time waited past ``dt``, as
  CoppeliaSim's ``sim-1.lua`` ``sim.wait``); like ``sim.waitForSignal``, it also waits in any
  coroutine a non-threaded script resumes (4.x's ``coroutineMain`` pattern, where CoppeliaSim's
  ``sim.wait`` loops on ``sim.switchThread``, a yield of the running coroutine), and raises an
  error on a main line, where it could never end; ``sim.moveToConfig`` / ``sim.moveToPose``: once per increment of
  the motion (:mod:`simx_server.api.sim.motion`), whose 4.3-4.5 callback runs in Lua; ``sim.waitForSignal(name)`` / ``simWaitForSignal``: until an
  integer, float or string signal ``name`` exists (returns its value);
* anywhere, once the thread has run longer than its time slice since it was resumed
  (``sim.setThreadSwitchTiming(ms)``, default 2 ms) while automatic switching is on: at its next
  ``sim`` call, or, in code that calls none (a V-REP 3.x thread that loops without a switch),
  at the count hook's next check (every :data:`~simx_server.scripts.lua.HOOK_COUNT`
  instructions), from a hook in C as CoppeliaSim's ``CDetachedScript::_hookFunction_lua`` yields
  (:mod:`simx_server.scripts.auto_switch`; not inside a C function's Lua callback, where Lua
  cannot yield). The slice is counted in the simulation thread's CPU time (CoppeliaSim counts
  wall time): a loaded machine that deschedules the server does not move a thread's switches
  (``sim.setThreadAutomaticSwitch(false)`` forbids it, ``true`` allows it again; levels nest as
  in CoppeliaSim 4.x).

Each resume is one call into the script, under its time bound (``script_timeout``) and the Lua
count hook: a loop that never yields (automatic switching forbidden) is interrupted, the error
logged and the thread ended, while the simulation goes on.

Old style: a script whose text tests ``sim_call_type`` and that defines no ``sysCall_*``
function runs its whole text at every call, with ``sim_call_type`` set to the call's type
(``sim_childscriptcall_initialization`` at start, ``..._actuation``, ``..._sensing``,
``..._cleanup``; the customization types likewise), as V-REP before 3.6 did and CoppeliaSim
still does for such scripts.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from simx_wire.protocol import RemoteError
from simx_server.api import SIM, Callers
from simx_server.api import long_calls
from simx_server.api.sim import motion
from simx_server.api.sim.stepped import CallbackCall
from simx_server.sim.vision_results import Deferred
from simx_server.scripts import auto_switch
from simx_server.api.legacy_names import (CALL_TYPES, CONSTANTS, FUNCTION_ALIASES, LEGACY_LUA, UI_FUNCTIONS,
                                              doc_table)

__all__ = ["LUA_FUNCTIONS", "THREADS_LUA", "LuaStyles", "script_functions"]

log = logging.getLogger("simx.scripts")

#: ``sim`` functions that Lua scripts get from :data:`THREADS_LUA` (not entries of the API table).
LUA_FUNCTIONS = ("switchThread", "yield", "step", "wait", "waitForSignal", "setThreadAutomaticSwitch",
                 "getThreadAutomaticSwitch", "setThreadSwitchTiming", "getThreadSwitchTiming",
                 "setThreadResumeLocation", "resumeThreads", "setThreadIsFree", "isScriptRunningInThread",
                 "isScriptExecutionThreaded")


def script_functions() -> frozenset[str]:
    """Every ``sim.NAME`` function of child scripts: the table's (those scripts may call) and
    :data:`LUA_FUNCTIONS`."""
    return frozenset(SIM.names(Callers.SCRIPTS)) | frozenset(LUA_FUNCTIONS)

#: Lua run in each script's state after the prelude: the thread functions of ``sim``; returns
#: ``launch(f)``, ``resume()`` (true while the thread lives; raises the thread's error),
#: ``wrap()`` (automatic switching at every ``sim`` call, for threaded scripts only) and ``alive()``.
THREADS_LUA = r"""
local sim, now, motion, slice_clock, on_count, arm, disarm, long, ompl = ...
local fmt = string.format
local co_create, co_resume = coroutine.create, coroutine.resume
local co_running, co_yield = coroutine.running, coroutine.yield
local co_status, yieldable = coroutine.status, coroutine.isyieldable
local error, type, pairs, pack, unpack = error, type, pairs, table.pack, table.unpack
local T = {co = nil, level = 0, slice = 0.002, resumed = 0}
local function in_thread() return T.co ~= nil and co_running() == T.co end
-- sim.switchThread / sim.yield: the thread's switch, or (CoppeliaSim 4.2+'s coroutineMain pattern of
-- non-threaded scripts) a yield of the script's own coroutine; in a main-line callback: nothing
local function switch() local _, main = co_running() if not main and yieldable() then co_yield() end end
local get_time, get_int = sim.getSimulationTime, sim.getInt32Signal
local get_float, get_string = sim.getFloatSignal, sim.getStringSignal
local step = rawget(sim, "step")

local function threaded_only(name)
  if not in_thread() then
    error(name .. " can only be called in a threaded script (sysCall_thread, sysCall_threadmain, threaded=1)", 3)
  end
end
-- sim.wait and sim.waitForSignal wait in the thread or in any coroutine a script resumes (the
-- coroutineMain of CoppeliaSim 4.x's non-threaded scripts: its sim.wait loops on sim.switchThread
-- / sim.yield, which yield the running coroutine); on a script's main line they would never end
local function waiting_allowed(name)
  local _, main = co_running()
  if not in_thread() and (main or not yieldable()) then
    error(name .. " can only be called in a threaded script or in a coroutine the script resumes "
      .. "(here it would wait forever: the simulation does not advance inside a callback)", 3)
  end
end
sim.switchThread = function() switch() return 1 end
sim.yield = function() switch() end
sim.step = function(...) if in_thread() then switch() elseif step then return step(...) else
  error("sim.step can only be called in a threaded script here", 2) end end
sim.wait = function(dt, simulationTime)
  waiting_allowed("sim.wait")
  if type(dt) ~= "number" then error("sim.wait: dt must be a number of seconds", 2) end
  if simulationTime == false then
    local t_end = now() + dt
    while now() < t_end do co_yield() end
    return 0
  end
  local start = get_time()
  while get_time() - start < dt - 1e-9 do co_yield() end
  local over = get_time() - start - dt  -- the time waited past dt (sim-1.lua's return value)
  return over > 1e-9 and over or 0
end
sim.waitForSignal = function(name)
  waiting_allowed("sim.waitForSignal")
  while true do
    local v = get_int(name)
    if v == nil then v = get_float(name) end
    if v == nil then v = get_string(name) end
    if v ~= nil then return v end
    co_yield()
  end
end
local tube_read = rawget(sim, "tubeRead")
if tube_read then
  sim.tubeRead = function(handle, blocking)  -- blocking: yields until a packet arrives (threads only)
    local data = tube_read(handle)
    while data == nil and blocking and in_thread() and yieldable() do co_yield() data = tube_read(handle) end
    return data
  end
end
sim.setThreadAutomaticSwitch = function(allow)
  if type(allow) == "number" then T.level = math.max(0, math.floor(allow))
  elseif allow then T.level = math.max(0, T.level - 1)
  else T.level = T.level + 1 end
  return T.level
end
sim.getThreadAutomaticSwitch = function() return T.level == 0 end
sim.setThreadSwitchTiming = function(ms) T.slice = math.max(0, ms) / 1000 return 1 end
sim.getThreadSwitchTiming = function() return math.floor(T.slice * 1000 + 0.5) end
sim.setThreadResumeLocation = function() return 1 end
sim.resumeThreads = function() return 0 end
sim.setThreadIsFree = function() return 0 end
sim.isScriptRunningInThread = function() return in_thread() and 1 or 0 end
sim.isScriptExecutionThreaded = function() return T.co ~= nil and 1 or 0 end

-- sim.moveToConfig / sim.moveToPose (threads only): the motion is the API's (motion("begin")),
-- run one increment at a time (motion("next")): "call" runs the 4.3-4.5 callback here, in Lua,
-- with the auxData kept here; "step" yields the thread; "done" returns the call's values.
local function mover(name, at)
  local function run(m, callback, aux)
    while true do
      local r = pack(motion("next", m))
      if not r[1] then error("sim." .. name .. ": " .. tostring(r[2]), 0) end
      if r[2] == "call" then
        callback(r[3][1], r[3][2], r[3][3], aux)
      elseif r[2] == "step" then
        co_yield()
      else
        return r[3]
      end
    end
  end
  return function(...)
    threaded_only("sim." .. name)
    local args = pack(...)
    local callback, aux
    if type(args[1]) ~= "table" and type(args[at]) == "function" then
      callback, aux = args[at], args[at + 1]
      args[at], args[at + 1] = true, nil
    end
    local r = pack(motion("begin", name, unpack(args, 1, args.n)))
    if not r[1] then error("sim." .. name .. ": " .. tostring(r[2]), 2) end
    T.level = T.level + 1  -- no automatic switch inside (CoppeliaSim's sim.setThreadAutomaticSwitch(false))
    local ok, out = pcall(run, r[2], callback, aux)
    T.level = math.max(0, T.level - 1)
    if not ok then error(out, 0) end
    return unpack(out, 1, #out)
  end
end
if motion then
  sim.moveToConfig = mover("moveToConfig", 10)
  sim.moveToPose = mover("moveToPose", 7)
end

-- sim.convexDecompose, simOMPL.solve / simplifyPath / compute in a thread: long("begin") makes the
-- call, off the simulation thread for a script that acts for a client ("wait": the thread yields
-- until long("poll") says it is done, as sim.wait yields); elsewhere at once, as before.
local function deferred(lib, prefix, name)
  local f = lib and rawget(lib, name)
  if not (long and f) then return end
  lib[name] = function(...)
    if not (in_thread() and yieldable()) then return f(...) end
    local r = pack(long("begin", prefix .. name, ...))
    while r[1] and r[2] == "wait" do co_yield() r = pack(long("poll", r[3])) end
    if not r[1] then error(prefix .. name .. ": " .. tostring(r[2]), 2) end
    return unpack(r[3], 1, r[4])
  end
end
deferred(sim, "sim.", "convexDecompose")
for _, name in ipairs({"solve", "simplifyPath", "compute"}) do deferred(ompl, "simOMPL.", name) end

local function launch(f, whole)  -- coroutine.create of the prelude: hooked
  if whole then  -- a threaded script's text; a V-REP 3.6 one then runs its sysCall_threadmain
    local chunk = f
    f = function()
      chunk()
      local main = rawget(_G, "sysCall_threadmain")
      if type(main) == "function" then return main() end
    end
  end
  T.co = co_create(f)
end
local armed = false
local function resume()
  local co = T.co
  if co == nil then return false end
  T.resumed = slice_clock()
  local ok, err = co_resume(co)
  if armed then armed = false disarm(fmt("%p", co)) end
  if not ok then T.co = nil error(err, 0) end
  if co_status(co) == "dead" then T.co = nil return false end
  return true
end
local function wrap()
  for name, f in pairs(sim) do
    if type(f) == "function" and name ~= "wait" and name ~= "waitForSignal" and name ~= "switchThread"
       and name ~= "tubeRead" and name ~= "moveToConfig" and name ~= "moveToPose" then
      sim[name] = function(...)
        local r = pack(f(...))
        if T.level == 0 and in_thread() and slice_clock() - T.resumed > T.slice and yieldable() then co_yield() end
        return unpack(r, 1, r.n)
      end
    end
  end
end
local function alive() return T.co ~= nil end
-- The count hook's check, in the thread only: its slice used up and switching allowed, the next
-- instruction yields if Lua can yield there (auto_switch.py: a hook in C).
if arm then
  on_count(function()
    local co = T.co
    if co ~= nil and T.level == 0 and co_running() == co and slice_clock() - T.resumed > T.slice then
      armed = true
      arm(fmt("%p", co))
    end
  end)
end
return launch, resume, wrap, alive
"""

_LIFE = frozenset(CALL_TYPES) - {"sysCall_init"}
_SYSCALLS = ("sysCall_init", "sysCall_cleanup", "sysCall_actuation", "sysCall_sensing", "sysCall_nonSimulation",
             "sysCall_beforeSimulation", "sysCall_afterSimulation", "sysCall_suspend", "sysCall_suspended",
             "sysCall_resume", "sysCall_thread", "sysCall_threadmain", "sysCall_jointCallback",
             "sysCall_dynCallback", "sysCall_contactCallback")


class LuaStyles:
    """Mixin of :class:`~simx_server.scripts.lua.LuaScript`: the 3.x names (:data:`LEGACY_LUA`),
    threads (:data:`THREADS_LUA`) and old-style ``sim_call_type`` dispatch."""

    old_style = False

    def _prepare_styles(self, rt: Any, on_count: Any) -> None:
        """After the prelude: 3.x globals and thread functions in the new state (``on_count``:
        the prelude's setter of what its count hook also calls)."""
        g = rt.globals()
        aliases = rt.table_from({k.encode(): v.encode() for k, v in FUNCTION_ALIASES.items()})
        uis = rt.table_from({k.encode(): (rt.table_from(v) if isinstance(v, list) else
                                          v.encode() if isinstance(v, str) else v) for k, v in UI_FUNCTIONS.items()})
        rt.compile(LEGACY_LUA, name="=simx")(g.sim, aliases, uis, self._write_log)
        threads = rt.compile(THREADS_LUA, name="=simx")
        hooks = (auto_switch.arm, auto_switch.disarm) if auto_switch.available() else (None, None)
        self._launch, self._resume, self._wrap, self._alive = threads(g.sim, time.monotonic, self._motion_call,
                                                                     time.thread_time, on_count, *hooks,
                                                                     self._long_call, g.simOMPL)
        self._long_calls: list[Deferred] = []  # the thread's long calls under way (off the simulation thread)
        self.old_style = False

    def _long_call(self, op: bytes, *args: Any) -> tuple:
        """``sim.convexDecompose`` and simOMPL's ``solve``, ``simplifyPath``, ``compute`` of a
        Lua thread (:data:`THREADS_LUA`): ``("begin", name, args...)`` makes the call, off the
        simulation thread for a script that acts for a client
        (:func:`simx_server.api.long_calls.deferring`): ``(True, "wait", deferred)``, which
        ``("poll", deferred)`` answers again until it is done; done: ``(True, "done", {values},
        n)``; ``(False, message)`` on an error. Never raises."""
        try:
            if op == b"begin":
                library, _, name = args[0].decode().rpartition(".")
                ctx = self._sim.context
                with long_calls.deferring(ctx):
                    result = (ctx.simompl if library == "simOMPL" else self._sim).call(
                        name, *[self._from_lua(a, callbacks=library == "simOMPL") for a in args[1:]])
                if type(result) is not Deferred:
                    return self._long_done(result)
                self._long_calls.append(result)
            else:
                result = args[0]
            if not result.future.done():
                return True, b"wait", result
            if result in self._long_calls:
                self._long_calls.remove(result)
            return self._long_done(result.future.result())
        except RemoteError as exc:
            return False, str(exc).encode()
        except (TypeError, ValueError, OverflowError) as exc:
            return False, f"bad arguments: {exc}".encode()
        except Exception as exc:  # a bug in simx, not in the script: say so
            log.exception("a long call of %s", getattr(self, "label", "a Lua script"))
            return False, f"internal error: {type(exc).__name__}: {exc}".encode()

    def _long_done(self, result: Any) -> tuple:
        values = list(result) if isinstance(result, tuple) else [result]
        return True, b"done", self._to_lua(values), len(values)

    def _drop_long_calls(self) -> None:
        """The thread ends (the simulation stops): its long calls under way are dropped, and what
        they would have made (a decomposed shape) is not made."""
        for deferred in getattr(self, "_long_calls", ()):
            deferred.future.cancel()
        self._long_calls = []

    def _motion_call(self, op: bytes, *args: Any) -> tuple:
        """``sim.moveToConfig`` / ``sim.moveToPose`` of a Lua thread (:data:`THREADS_LUA`):
        ``("begin", name, args...)`` makes the motion (:func:`simx_server.api.sim.motion.lua_motion`),
        ``("next", motion)`` runs its next increment: ``(True, "call", {pos, vel, accel})``,
        ``(True, "step")`` or ``(True, "done", {return values})``; ``(False, message)`` on an error.
        Never raises."""
        try:
            if op == b"begin":
                name = args[0].decode() if isinstance(args[0], bytes) else str(args[0])
                return True, motion.lua_motion(self._sim.context, name, [self._from_lua(a) for a in args[1:]])
            wanted = args[0].send(None)
            if isinstance(wanted, CallbackCall):
                return True, b"call", self._to_lua(wanted.args[:3])
            return True, b"step"
        except StopIteration as done:
            return True, b"done", self._to_lua(done.value or [])
        except RemoteError as exc:
            return False, str(exc).encode()
        except (TypeError, ValueError, OverflowError, AttributeError) as exc:
            return False, f"bad arguments: {exc}".encode()
        except Exception as exc:  # a bug in simx, not in the script: say so
            log.exception("a motion of %s", getattr(self, "label", "a Lua script"))
            return False, f"internal error: {type(exc).__name__}: {exc}".encode()

    def _run_top_level(self, chunk: Any) -> None:
        """The file's top level with ``sim_call_type`` = initialization; a 3.x threaded script's
        text is kept for its thread instead."""
        g = self._runtime.globals()
        self._chunk = chunk
        if self.threaded:
            g.sim_call_type = CONSTANTS["childscriptcall_threaded"]
            return
        g.sim_call_type = CALL_TYPES["sysCall_init"]
        self._bounded("top level", chunk, ())
        self.old_style = b"sim_call_type" in self._source and not any(
            self._lookup(n.encode()) is not None for n in _SYSCALLS)
        if not self.old_style:
            g.sim_call_type = None

    def _old_style_defines(self, function: str) -> bool:
        return function in _LIFE

    def _old_style_run(self, function: str) -> Any:
        self._runtime.globals().sim_call_type = CALL_TYPES[function]
        return self._bounded(function, self._chunk, ())

    def _launch_thread(self) -> None:
        body = self._chunk if self.threaded else None
        for name in ("sysCall_thread", "sysCall_threadmain"):
            if body is None and self._lookup is not None:
                body = self._lookup(name.encode())
        if body is not None:
            self._wrap()
            self._launch(body, self.threaded)

    def _thread_alive(self) -> bool:
        return self._runtime is not None and bool(self._alive())

    def _resume_thread(self) -> None:
        self._bounded("thread", self._resume, ())


if __name__ == "__main__":  # pragma: no cover - prints docs/SCRIPTS.md's list of 3.x functions
    print(doc_table(script_functions()))

