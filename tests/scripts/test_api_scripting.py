"""The scripts' own services (simx_server/api/sim/scripting.py): ``sim.broadcastMsg`` reaching
the other scripts' ``sysCall_msg``, ``sim.getUserVariables``, ``sim.getStackTraceback`` (the last
error, then forgotten) and ``sim.get/setAutoYieldDelay``, from Lua and Python child scripts in
process, and from the official ZMQ client against a real server."""

from __future__ import annotations

from pathlib import Path

import pytest

from conftest import ServerProcess, free_port, wait_until
from simx_server.scene.simulation import Simulation
from simx_wire.protocol import ScriptError

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

SCENE = """<mujoco model="scripting services">
  <option timestep="0.005" gravity="0 0 0"/>
  <worldbody>
    <body name="LuaBox" pos="0 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
    <body name="PyBox" pos="0.2 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
    <body name="Custom" pos="0.4 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
    <body name="Quiet" pos="0.6 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
  </worldbody>
  <custom>
    <text name="simx:LuaBox" data="child_script=lua_box.lua"/>
    <text name="simx:PyBox" data="child_script=py_box.py"/>
    <text name="simx:Custom" data="customization_script=custom.lua"/>
    <text name="simx:Quiet" data="child_script=quiet.lua"/>
  </custom>
</mujoco>
"""

LUA_BOX = """
received = {}
counter = 0
local hidden = 5
function sysCall_init()
  myName = 'lua box'
end
function sysCall_msg(msg, origin)
  received[#received + 1] = {id = msg.id, origin = origin, from = msg.from}
  if msg.echo then sim.broadcastMsg(msg) end
end
function send(id)
  sim.broadcastMsg({id = id, from = 'lua'})
end
function got()
  local ids, origins, froms = {}, {}, {}
  for i, r in ipairs(received) do ids[i], origins[i], froms[i] = r.id, r.origin, r.from end
  return ids, origins, froms
end
function userVars()
  local names = {}
  for name, value in pairs(sim.getUserVariables()) do names[#names + 1] = name end
  table.sort(names)
  return names, type(sim.getUserVariables().send), sim.getUserVariables().myName
end
function failing() error('boom in failing') end
function callFailing() failing() end
function traceOf(h) return sim.getStackTraceback(h) end
function ownTrace() return sim.getStackTraceback() end
function yieldDelay(dt)
  local before = sim.getAutoYieldDelay()
  sim.setAutoYieldDelay(dt)
  return before, sim.getAutoYieldDelay()
end
function badMessage() sim.broadcastMsg('not a table') end
"""

PY_BOX = """
import math

received = []


def sysCall_init():
    global ready
    ready = True


def sysCall_msg(msg, origin):
    received.append((msg['id'], origin, type(msg).__name__))
    if msg.get('echo'):
        sim.broadcastMsg(msg)


def send(i):
    sim.broadcastMsg({'id': i, 'from': 'py'}, 0)


def send_echo():
    sim.broadcastMsg({'id': 0, 'echo': True})


def got():
    return [r[0] for r in received], [r[1] for r in received], [r[2] for r in received]


def userVars():
    variables = sim.getUserVariables()
    return sorted(variables), variables['ready']


def failing():
    raise ValueError('boom in failing')


def callFailing():
    failing()


def traceOf(h):
    return sim.getStackTraceback(h)


def yieldDelay(dt):
    before = sim.getAutoYieldDelay()
    sim.setAutoYieldDelay(dt)
    return before, sim.getAutoYieldDelay()
"""

CUSTOM = """
got_ids = {}
function sysCall_msg(msg, origin)
  if msg.id == 13 then explode() end
  got_ids[#got_ids + 1] = msg.id
end
function explode() error('receiver exploded') end
function got() return got_ids end
"""

QUIET = "function sysCall_init() end\n"


def write_scene(folder: Path) -> Path:
    for name, text in (("lua_box.lua", LUA_BOX), ("py_box.py", PY_BOX), ("custom.lua", CUSTOM),
                       ("quiet.lua", QUIET)):
        (folder / name).write_text(text)
    (folder / "scene.xml").write_text(SCENE)
    return folder / "scene.xml"


@pytest.fixture
def running(tmp_path):
    sim = Simulation(write_scene(tmp_path), realtime=False, allow_python_scripts=True)
    sim.start()
    sim.step()
    yield sim
    sim.close()


def handle(sim: Simulation, name: str) -> int:
    return sim.world.resolve(name).handle


def call(sim: Simulation, obj: str, function: str, *args, customization: bool = False) -> list:
    table = sim.scripts.customization if customization else sim.scripts.scripts
    return table[handle(sim, obj)].call_values(function, list(args))


# ------------------------------------------------------------------ sim.broadcastMsg
def test_broadcast_reaches_every_other_script_with_the_senders_handle(running):
    lua, py = handle(running, "LuaBox"), handle(running, "PyBox")
    call(running, "LuaBox", "send", 1)
    assert call(running, "PyBox", "got") == [[1], [lua], ["dict"]]  # the Python receiver: a dict
    assert call(running, "Custom", "got", customization=True) == [[1]]  # customization scripts too
    assert call(running, "LuaBox", "got") == [[], [], []]  # not the sender itself
    call(running, "PyBox", "send", 2)
    assert call(running, "LuaBox", "got") == [[2], [py], [b"py"]]
    assert call(running, "Custom", "got", customization=True) == [[1, 2]]
    assert call(running, "PyBox", "got")[0] == [1]


def test_a_failing_receiver_does_not_fail_the_sender_and_keeps_its_traceback(running, caplog):
    call(running, "PyBox", "send", 13)  # Custom's sysCall_msg raises: logged, the others still receive
    assert call(running, "LuaBox", "got")[0] == [13]
    assert "receiver exploded" in caplog.text
    trace = call(running, "PyBox", "traceOf", handle(running, "Custom"))[0]
    assert "sysCall_msg" in trace and "receiver exploded" in trace and "in function 'explode'" in trace
    assert call(running, "PyBox", "traceOf", handle(running, "Custom")) == [""]  # read once


def test_receivers_broadcasting_back_stop_at_the_depth_bound(running, caplog):
    call(running, "PyBox", "send_echo")  # LuaBox and PyBox answer each other's echo, and so on
    assert "broadcasts nested 16 deep" in caplog.text  # refused there, logged by that receiver
    lua_ids, py_ids = call(running, "LuaBox", "got")[0], call(running, "PyBox", "got")[0]
    assert len(lua_ids) + len(py_ids) == 16  # one receipt per level, alternately
    call(running, "PyBox", "send", 5)  # and the next broadcast is served again
    assert call(running, "LuaBox", "got")[0][-1] == 5


def test_broadcast_wants_a_table(running):
    with pytest.raises(ScriptError, match=r"sim.broadcastMsg: .*message must be a table"):
        call(running, "LuaBox", "badMessage")


# ------------------------------------------------------------------ sim.getUserVariables
def test_user_variables_are_the_scripts_own_globals(running):
    names, send_type, my_name = call(running, "LuaBox", "userVars")
    assert names == sorted([b"received", b"counter", b"myName", b"sysCall_init", b"sysCall_msg", b"send", b"got",
                            b"userVars", b"failing", b"callFailing", b"traceOf", b"ownTrace", b"yieldDelay",
                            b"badMessage"])  # not the local, not sim/simIK/print, not Lua's own
    assert (send_type, my_name) == (b"function", b"lua box")
    names, ready = call(running, "PyBox", "userVars")
    assert names == sorted(["math", "received", "sysCall_init", "ready", "sysCall_msg", "send", "send_echo", "got",
                            "userVars",
                            "failing", "callFailing", "traceOf", "yieldDelay"])
    assert ready is True


# ------------------------------------------------------------------ sim.getStackTraceback
def test_stack_traceback_of_a_lua_error_names_its_functions_then_is_cleared(running):
    with pytest.raises(ScriptError, match="boom in failing"):
        call(running, "LuaBox", "callFailing")
    trace = call(running, "PyBox", "traceOf", handle(running, "LuaBox"))[0]
    assert "lua_box.lua:" in trace and "boom in failing" in trace
    assert "stack traceback:" in trace
    assert "in function 'failing'" in trace and "callFailing" in trace
    assert call(running, "PyBox", "traceOf", handle(running, "LuaBox")) == [""]
    with pytest.raises(ScriptError):
        call(running, "LuaBox", "callFailing")
    own = call(running, "LuaBox", "ownTrace")[0]  # sim.handle_self: the caller's own
    assert b"in function 'failing'" in own


def test_stack_traceback_of_a_python_error_names_its_functions(running):
    with pytest.raises(ScriptError, match="boom in failing"):
        call(running, "PyBox", "callFailing")
    trace = call(running, "LuaBox", "traceOf", handle(running, "PyBox"))[0].decode()
    assert "Traceback (most recent call last):" in trace and "ValueError: boom in failing" in trace
    assert "py_box.py" in trace and "in failing" in trace and "in callFailing" in trace
    assert "simx_server" not in trace  # the script's frames only
    assert call(running, "LuaBox", "traceOf", handle(running, "PyBox")) == [b""]
    assert call(running, "LuaBox", "traceOf", handle(running, "Quiet")) == [b""]  # no error yet


# ------------------------------------------------------------------ sim.get/setAutoYieldDelay
def test_auto_yield_delay_is_kept_per_script_in_seconds(running):
    assert call(running, "LuaBox", "yieldDelay", 0.0105) == [pytest.approx(0.002), pytest.approx(0.010)]
    assert call(running, "PyBox", "yieldDelay", 20) == [pytest.approx(0.002), pytest.approx(10.0)]  # bounded
    assert call(running, "PyBox", "yieldDelay", -1)[1] == 0.0
    assert call(running, "LuaBox", "yieldDelay", 0.5)[0] == pytest.approx(0.010)  # its own value kept
    running.stop()
    running.start()
    assert call(running, "LuaBox", "yieldDelay", 0.5)[0] == pytest.approx(0.002)  # a restart begins afresh


# ------------------------------------------------------------------ over ZMQ
@pytest.fixture(scope="module")
def zmq_server(tmp_path_factory):
    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    port = free_port()
    scene = write_scene(tmp_path_factory.mktemp("scripting"))
    srv = ServerProcess(str(scene), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    srv.zmq_port = port
    yield srv
    srv.stop()


def test_a_zmq_client_broadcasts_and_reads_a_scripts_traceback(zmq_server, official):
    sim = official(zmq_server.zmq_port).require("sim")
    sim.startSimulation()
    try:
        lua = sim.getObject("/LuaBox")
        wait_until(lambda: sim.getSimulationState() != sim.simulation_stopped, 5, what="the simulation runs")
        sim.broadcastMsg({"id": 7, "from": "client"})
        ids, origins, froms = sim.callScriptFunction("got", lua)
        assert (ids, origins, froms) == ([7], [-1], ["client"])  # origin -1: no script sent it
        with pytest.raises(Exception, match="boom in failing"):
            sim.callScriptFunction("callFailing", lua)
        trace = sim.getStackTraceback(lua)
        assert "boom in failing" in trace and "in function 'failing'" in trace
        assert sim.getStackTraceback(lua) == ""
        assert sim.getStackTraceback() == ""  # a client is no script
        assert sim.getUserVariables() == []
        assert sim.getAutoYieldDelay() == pytest.approx(0.002)
        sim.setAutoYieldDelay(0.05)
        assert sim.getAutoYieldDelay() == pytest.approx(0.05)
    finally:
        sim.stopSimulation()
