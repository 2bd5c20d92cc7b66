"""Issue 23 parts 1 and 5: a script call's arguments cannot abort the server, and no call into a
Lua script escapes its bounds (pattern matching in C, finalizers at teardown, precompiled chunks).

In-process tests drive a :class:`Simulation` on a small scene written into tmp_path; the attack
shapes of the issue run against a real server."""

from __future__ import annotations

import re
import time

import pytest

import vrep
from conftest import SCENE, ServerProcess
from simx_client.protocol import ArgumentError, ScriptError
from simx_server.scripts.child import ScriptTimeoutError
from simx_server.base import limits as L
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

CHILD = vrep.sim_scripttype_childscript
B = vrep.simx_opmode_blocking

SCENE_XML = """<mujoco model="hardening">
  <worldbody><body name="Box"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody>
  <custom><text name="simx:Box" data="child_script=box.lua"/></custom>
</mujoco>
"""

BOX_LUA = r"""
function echo(inInts, inFloats, inStrings, inBuffer) return {#inInts}, {}, {}, "" end
function hog(inInts, inFloats, inStrings, inBuffer)
  hoard = {}
  for i = 1, 9 do hoard[i] = string.rep(tostring(i), 20 * 1024 * 1024) end  -- 180 MiB kept
  return {}, {}, {}, ""
end
function find(inInts, inFloats, inStrings, inBuffer)
  local a, b = string.find(inStrings[1], inStrings[2])
  return {a or -1}, {}, {}, ""
end
function method(inInts, inFloats, inStrings, inBuffer)
  local a = (inStrings[1]):match(inStrings[2])
  return {a and 1 or 0}, {}, {}, ""
end
function finalizer(inInts, inFloats, inStrings, inBuffer)
  keep = setmetatable({}, {__gc = function() while true do end end})
  return {}, {}, {}, ""
end
function needs(inInts, inFloats, inStrings, inBuffer)
  local m = require("dumped")
  return {m.answer}, {}, {}, ""
end
"""


@pytest.fixture
def sim(tmp_path):
    (tmp_path / "box.lua").write_text(BOX_LUA)
    (tmp_path / "scene.xml").write_text(SCENE_XML)
    s = Simulation(tmp_path / "scene.xml", dt=0.05, realtime=False)
    s.start()
    yield s
    s.close()


def call(sim, function, ints=(), strings=()):
    return sim.scripts.call("Box", CHILD, function, list(ints), [], list(strings), b"")


def test_the_values_of_a_call_are_bounded_before_any_conversion(sim):
    with pytest.raises(ArgumentError, match=r"MAX_SCRIPT_CALL_VALUES"):
        call(sim, "echo", [1] * (L.MAX_SCRIPT_CALL_VALUES + 1))
    with pytest.raises(ArgumentError, match=r"MAX_SCRIPT_CALL_BYTES"):
        call(sim, "echo", strings=["x" * (L.MAX_SCRIPT_CALL_BYTES + 1)])
    assert call(sim, "echo", [1] * 1000)[0] == [1000]  # the script is still usable


def test_arguments_that_would_not_fit_in_the_lua_state_are_refused_not_a_crash(sim):
    call(sim, "hog")  # the state keeps about 180 of its 256 MiB
    with pytest.raises(ArgumentError, match=r"MAX_SCRIPT_MEMORY"):
        call(sim, "echo", [7] * L.MAX_SCRIPT_CALL_VALUES)
    assert call(sim, "echo", [7] * 10)[0] == [10]


def test_a_pathological_pattern_is_refused_and_a_normal_one_works(sim):
    # The outcome is the error naming the bound: a match this size, run, would take hours (the
    # test would then end at pytest's timeout), and the scripts' time bound cannot stop C code.
    subject = "a" * 100_000
    with pytest.raises(ScriptError, match=r"MAX_PATTERN_WORK"):
        call(sim, "find", strings=[subject, ".-.-.-.-.-b"])
    with pytest.raises(ScriptError, match=r"MAX_PATTERN_WORK"):
        call(sim, "method", strings=[subject, "(.-)(.-)(.-)b"])  # the string metatable's methods too
    assert call(sim, "find", strings=["abc123", "%d+"])[0] == [4]
    assert call(sim, "find", strings=[subject, "b"])[0] == [-1]  # one repetition-free scan: fine


def test_finalizers_are_refused_so_a_stop_cannot_hang(sim):
    with pytest.raises(ScriptError, match=r"__gc finalizers are not available"):
        call(sim, "finalizer")
    sim.stop()  # the state is closed at once


def test_require_loads_text_chunks_only(sim, tmp_path):
    import lupa.lua54

    source = "return {answer = 42}"
    dumped = lupa.lua54.LuaRuntime(encoding=None).eval(f'string.dump(load("{source}"))')
    assert dumped.startswith(b"\x1bLua")
    (tmp_path / "dumped.lua").write_bytes(dumped)
    with pytest.raises(ScriptError, match=r"binary chunk"):
        call(sim, "needs")
    (tmp_path / "dumped.lua").write_text(source)
    assert call(sim, "needs")[0] == [42]


def test_the_issues_attack_on_a_real_server_is_a_remote_error():
    """9 M ints to RG2's rg2Open aborted the server (Lua panic, exit 134)."""
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    try:
        assert cid >= 0
        rc, *_ = vrep.simxCallScriptFunction(cid, "RG2", CHILD, "rg2Open", [1] * 9_000_000, [], [], bytearray(), B)
        # 9 M values: refused before it is decoded (protocol.MAX_REQUEST_ITEMS, 2 M values)
        assert rc == vrep.simx_return_remote_error_flag and srv.proc.poll() is None
        # 1.5 M values: decoded, refused before the script sees them (limits.MAX_SCRIPT_CALL_VALUES)
        rc, *_ = vrep.simxCallScriptFunction(cid, "RG2", CHILD, "rg2Open", [1] * 1_500_000, [], [], bytearray(), B)
        assert rc == vrep.simx_return_remote_error_flag
        rc, errors = vrep.simxGetLastErrors(cid, B)
        assert rc == 0 and any("MAX_SCRIPT_CALL_VALUES" in e for e in errors), errors
        rc, *_ = vrep.simxCallScriptFunction(cid, "RG2", CHILD, "rg2Open", [], [], [], bytearray(), B)
        assert rc == 0 and srv.proc.poll() is None
    finally:
        vrep.simxFinish(cid)
        srv.stop()


# Issue 48: Lua runs a message handler with hooks off when the error comes from inside a hook (the
# time bound's own error), and a coroutine that died of it keeps hooks off, so its __close
# metamethods would run unbounded at coroutine.close. Each function below froze the server for good.
HANDLERS_LUA = r"""
local function spin() while true do end end
function loop_in_handler_of_timeout() xpcall(spin, spin) return {}, {}, {}, "" end
function loop_in_handler_of_error() xpcall(function() error("plain") end, spin) return {}, {}, {}, "" end
function pcall_loop_in_handler()
  xpcall(spin, function(m) while true do pcall(spin) end end) return {}, {}, {}, ""
end
function doom_coroutine()
  co = coroutine.create(function() local x <close> = setmetatable({}, {__close = spin}); spin() end)
  local ok = coroutine.resume(co)
  return {ok and 1 or 0}, {}, {}, ""
end
function close_doomed() local ok, err = coroutine.close(co) return {ok and 1 or 0}, {}, {tostring(err)}, "" end
function close_in_timeout() local x <close> = setmetatable({}, {__close = spin}); spin() end
function swallowed_by_resume() coroutine.resume(coroutine.create(spin)) return {7}, {}, {}, "" end
function swallowed_by_wrap() pcall(coroutine.wrap(spin)) return {7}, {}, {}, "" end
function swallowed_in_nested_coroutines()
  coroutine.resume(coroutine.create(function() coroutine.resume(coroutine.create(spin)) end))
  return {7}, {}, {}, ""
end
function swallowed_by_a_tail_pcall() return pcall(spin) end
function handlers_still_work()
  local _, handled = xpcall(function() error("plain", 0) end, function(m) return "handled " .. m end)
  local co = coroutine.create(function()
    local x <close> = setmetatable({}, {__close = function() closed = true end})
    coroutine.yield()
  end)
  coroutine.resume(co)
  local ok = coroutine.close(co)
  return {ok and 1 or 0, closed and 1 or 0}, {}, {handled}, ""
end
"""


@pytest.fixture
def handler_sim(tmp_path):
    (tmp_path / "box.lua").write_text(HANDLERS_LUA)
    (tmp_path / "scene.xml").write_text(SCENE_XML.replace("child_script=box.lua", "child_script=box.lua script_timeout=0.2"))
    s = Simulation(tmp_path / "scene.xml", dt=0.05, realtime=False)
    s.start()
    yield s
    s.close()


@pytest.mark.parametrize("function", ["loop_in_handler_of_timeout", "loop_in_handler_of_error",
                                      "pcall_loop_in_handler", "close_in_timeout"])
def test_message_handlers_and_closers_stay_inside_the_time_bound(handler_sim, function):
    with pytest.raises(ScriptTimeoutError, match=r"within 0.2 s \(script_timeout\)"):
        call(handler_sim, function)
    assert call(handler_sim, "handlers_still_work")[0] == [1, 1]  # the script serves its next call


def test_a_coroutine_killed_by_the_time_bound_does_not_run_its_closers(handler_sim):
    with pytest.raises(ScriptTimeoutError):  # the timeout goes on in the resumer
        call(handler_sim, "doom_coroutine")
    ints, _, strings, _ = call(handler_sim, "close_doomed")  # its closers would run with hooks off
    assert ints == [0] and "time bound" in strings[0]
    ints, _, strings, _ = call(handler_sim, "handlers_still_work")
    assert ints == [1, 1] and strings == ["handled plain"]


# Issue 48, what an attacker tries next: the time bound's error caught where no later instruction
# of the script runs to raise it again (a coroutine's resume returning false to its resumer, a
# tail call of pcall returning to the server), so that the call returned as if it had kept its
# bound and a step function spent its whole bound every pass without being cut.
@pytest.mark.parametrize("function", ["swallowed_by_resume", "swallowed_by_wrap", "swallowed_in_nested_coroutines",
                                      "swallowed_by_a_tail_pcall"])
def test_a_timeout_caught_by_the_script_is_still_an_overrun(handler_sim, function):
    with pytest.raises(ScriptTimeoutError, match=r"within 0.2 s \(script_timeout\)"):
        call(handler_sim, function)
    assert call(handler_sim, "handlers_still_work")[0] == [1, 1]


def test_a_step_function_that_swallows_its_timeout_is_skipped_from_then_on(tmp_path, caplog):
    (tmp_path / "box.lua").write_text("""function sysCall_actuation()
  sim.setInt32Signal("runs", (sim.getInt32Signal("runs") or 0) + 1)
  coroutine.resume(coroutine.create(function() while true do end end))
end""")
    (tmp_path / "scene.xml").write_text(SCENE_XML.replace("child_script=box.lua", "child_script=box.lua script_timeout=0.2"))
    s = Simulation(tmp_path / "scene.xml", dt=0.05, realtime=False)
    try:
        with caplog.at_level("ERROR", "simx.scripts"):
            s.start()
            for _ in range(3):
                s.step()
        assert s.signals.get_int("runs") == 1  # before: every step ran it, 0.2 s each
    finally:
        s.close()
    assert any(re.search(r"sysCall_actuation: (box\.lua:\d+: )?interrupted: did not return within 0\.2 s", r.getMessage())
               for r in caplog.records), caplog.text


# A script calling another's function (sim.callScriptFunction): the callee had a bound of its own
# from the moment it was called, so a caller near its deadline bought a fresh one; and a Python
# callee disarmed the one watchdog, after which the Python caller ran without any bound.
NESTED_XML = """<mujoco model="nested">
  <worldbody><body name="A"><geom type="box" size="0.1 0.1 0.1"/></body>
    <body name="B" pos="1 0 0"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody>
  <custom><text name="simx:A" data="child_script=a.{0} script_timeout=0.3"/>
    <text name="simx:B" data="child_script=b.{0} script_timeout=0.3"/></custom>
</mujoco>
"""


def test_a_script_called_by_another_ends_within_the_callers_bound(tmp_path):
    (tmp_path / "a.lua").write_text("""function outer()
  local t = os.clock() while os.clock() - t < 0.25 do end
  local ok, e = pcall(sim.callScriptFunction, "inner@/B", sim.scripttype_childscript)
  return {ok and 1 or 0}, {}, {tostring(e)}, ""
end""")
    (tmp_path / "b.lua").write_text("function inner() while true do end end")
    (tmp_path / "scene.xml").write_text(NESTED_XML.format("lua"))
    s = Simulation(tmp_path / "scene.xml", dt=0.05, realtime=False)
    s.start()
    try:
        start = time.thread_time()  # the scripts' bounds count this thread's CPU time
        try:
            ints, _, (why,), _ = s.scripts.call("A", CHILD, "outer", [], [], [], b"")
            # the callee was cut at the caller's deadline (before: after 0.3 s of its own)
            assert ints == [0] and "the call into the script that called it reached its time bound" in why, why
        except ScriptTimeoutError as exc:
            # the caller, at its own deadline then, may be cut too at its next check (where the
            # count hook stands when the callee returns); the callee's error came first
            assert "outer: a.lua:4:" in str(exc) and "script_timeout" in str(exc), exc
        # the caller's 0.3 s in all, not its 0.25 s plus the callee's own 0.3 s
        assert time.thread_time() - start < 0.45
    finally:
        s.close()


def test_a_python_script_keeps_its_bound_after_calling_another(tmp_path):
    (tmp_path / "a.py").write_text("""import time
def outer(*args):
    sim.callScriptFunction("inner@/B", sim.scripttype_childscript)
    t = time.thread_time()
    while time.thread_time() - t < 5:
        pass
    return [1]
""")
    (tmp_path / "b.py").write_text("def inner(*args):\n    return [2]\n")
    (tmp_path / "scene.xml").write_text(NESTED_XML.format("py"))
    s = Simulation(tmp_path / "scene.xml", dt=0.05, realtime=False, allow_python_scripts=True)
    s.start()
    try:
        with pytest.raises(ScriptTimeoutError, match=r"a.py:5: interrupted: did not return within 0.3 s"):
            s.scripts.call("A", CHILD, "outer", [], [], [], b"")  # before: [1] after 5 s
    finally:
        s.close()
