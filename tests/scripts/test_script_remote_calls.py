"""The calls of api/sim/remote.py that child scripts make too (CoppeliaSim's scripts do):
``sim.getScript(sim.handle_self)``, ``sim.getSystemTime``, ``sim.addLog`` (a line naming the
script file, as ``print``), the object selection and ``sim.isDeprecated``; while ``sim.loadScene`` and
``sim.startSimulation`` stay refused with their names; and ``sim.callScriptFunction`` from one
child script into another (not into itself, nor back into a script whose call is under way). Lua and Python child scripts in process."""

from __future__ import annotations

import logging
import time
from pathlib import Path

import pytest

from simx_server.scene.simulation import Simulation
from simx_server.sim.state import RunState
from simx_wire.protocol import ScriptError

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

SCENE = """<mujoco model="scripts calling remote-program functions">
  <worldbody>
    <body name="LuaBox" pos="0 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
    <body name="PyBox" pos="0.2 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
  </worldbody>
  <custom>
    <text name="simx:LuaBox" data="child_script=lua_box.lua"/>
    <text name="simx:PyBox" data="child_script=py_box.py"/>
  </custom>
</mujoco>
"""

LUA = """
function own() return sim.getScript(sim.handle_self), sim.getScript(sim.scripttype_childscript, '/PyBox') end
function clock() return sim.getSystemTime() end
function logIt() sim.addLog(sim.verbosity_scriptwarnings, 'from lua') end
function selection(h) sim.setObjectSel({h}) return sim.getObjectSel() end
function deprecated() return sim.isDeprecated('sim.addStatusbarMessage'), sim.isDeprecated('sim.getObject') end
function load() local ok, err = pcall(sim.loadScene, 'x.xml') return ok, err end
function viaPython(x) return sim.callScriptFunction('double@/PyBox', sim.scripttype_childscript, x) end
function viaHandle(x) return sim.callScriptFunction('double', sim.getScript(sim.scripttype_childscript, '/PyBox'), x) end
function half(x) return x / 2, 'lua' end
function self() return pcall(sim.callScriptFunction, 'half@/LuaBox', sim.scripttype_childscript, 4) end
function cycle() return sim.callScriptFunction('back@/PyBox', sim.scripttype_childscript) end
function stopVia() local r = sim.callScriptFunction('stop@/PyBox', sim.scripttype_childscript)
  return r, sim.getSimulationState() end
"""

PY = """
def own():
    return sim.getScript(sim.handle_self)


def log_it():
    sim.addLog(sim.verbosity_scriptinfos, 'from python')


def start():
    sim.startSimulation()


def double(x):
    return 2 * x


def via_lua(x):
    return sim.callScriptFunction('half@/LuaBox', sim.scripttype_childscript, x)


def back():
    return sim.callScriptFunction('half@/LuaBox', sim.scripttype_childscript, 2)


def stop():
    return sim.stopSimulation()
"""


@pytest.fixture
def sim(tmp_path: Path):
    (tmp_path / "lua_box.lua").write_text(LUA)
    (tmp_path / "py_box.py").write_text(PY)
    (tmp_path / "scene.xml").write_text(SCENE)
    s = Simulation(tmp_path / "scene.xml", realtime=False, allow_python_scripts=True)
    s.start()
    yield s
    s.close()


def call(sim: Simulation, obj: str, function: str, *args):
    return sim.scripts.scripts[sim.world.resolve(obj).handle].call_values(function, list(args))


def test_get_script_of_self_and_of_another_object(sim):
    lua, py = sim.world.resolve("LuaBox").handle, sim.world.resolve("PyBox").handle
    assert call(sim, "LuaBox", "own") == [lua, py]
    assert call(sim, "PyBox", "own") == [py]


def test_system_time_is_the_wall_clock(sim):
    before = time.time()
    (t,) = call(sim, "LuaBox", "clock")
    assert before <= t <= time.time()


def test_add_log_names_the_script(sim, caplog):
    with caplog.at_level(logging.INFO, logger="simx.zmq"):
        call(sim, "LuaBox", "logIt")
        call(sim, "PyBox", "log_it")
    lines = [(r.levelno, r.getMessage()) for r in caplog.records if r.name == "simx.zmq"]
    assert lines == [(logging.WARNING, "[lua_box.lua] from lua"), (logging.INFO, "[py_box.py] from python")]  # as print


def test_selection_and_deprecation(sim):
    box = sim.world.resolve("PyBox").handle
    assert call(sim, "LuaBox", "selection", box) == [[box]] and sim.selection == [box]
    assert call(sim, "LuaBox", "deprecated") == [1, 0]


def test_scene_and_run_calls_stay_refused_with_their_names(sim):
    ok, err = call(sim, "LuaBox", "load")
    assert ok is False and b"sim.loadScene is served to remote API clients only" in err
    with pytest.raises(ScriptError, match="UnsupportedError: sim.startSimulation is served to remote API clients only"):
        call(sim, "PyBox", "start")


def test_a_script_calls_another_scripts_function(sim):
    assert call(sim, "LuaBox", "viaPython", 21) == [42]
    assert call(sim, "LuaBox", "viaHandle", 5) == [10]
    assert call(sim, "PyBox", "via_lua", 3) == [1.5, "lua"]


def test_a_script_cannot_call_into_itself_or_back_into_its_caller(sim):
    ok, err = call(sim, "LuaBox", "self")
    assert ok is False and b"cannot be called from inside its own call" in err
    with pytest.raises(ScriptError, match="lua_box.lua of 'LuaBox' is running"):
        call(sim, "LuaBox", "cycle")  # LuaBox -> PyBox.back -> LuaBox.half: refused in PyBox, raised on
    assert call(sim, "LuaBox", "viaPython", 1) == [2]  # nothing left behind: calls work again


def test_a_stop_asked_through_another_script_waits_for_the_pass(sim):
    assert call(sim, "LuaBox", "stopVia") == [1, 0x11]  # still running inside the calling script
    assert sim.state is RunState.RUNNING
    sim.step()
    assert sim.state is RunState.STOPPED
