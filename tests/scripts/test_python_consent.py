"""Issue 40: a scene's Python scripts run only with the operator's consent (``--allow-python-scripts``).

A Python script runs with the server's rights (a scene's child script ran ``os.system("id")``).
Without the flag each is refused with one log line naming it and the flag, the scene loads and its
Lua scripts run; a remote call into the refused script answers the refusal. With the flag it runs."""

from __future__ import annotations

import logging

import pytest

import vrep
from conftest import ServerProcess
from simx_client.protocol import ScriptError
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

CHILD = vrep.sim_scripttype_childscript
CUSTOM = vrep.sim_scripttype_customizationscript
B = vrep.simx_opmode_blocking

SCENE = """<mujoco model="consent">
  <worldbody>
    <body name="Lua"><geom type="box" size="0.1 0.1 0.1"/></body>
    <body name="Py" pos="1 0 0"><geom type="box" size="0.1 0.1 0.1"/></body>
    <body name="PyCustom" pos="2 0 0"><geom type="box" size="0.1 0.1 0.1"/></body>
  </worldbody>
  <custom>
    <text name="simx:Lua" data="child_script=lua.lua"/>
    <text name="simx:Py" data="child_script=py.py"/>
    <text name="simx:PyCustom" data="customization_script=custom.py"/>
  </custom>
</mujoco>
"""
LUA = 'function sysCall_init() sim.setInt32Signal("lua", 1) end\n'
PY = """import pathlib
pathlib.Path(__file__).with_name("ran.txt").write_text("ran")  # what os.system("id") could do too


def sysCall_init():
    sim.setInt32Signal("py", 1)


def hello(ints, floats, strings, buffer):
    return [42]
"""
CUSTOM_PY = "def sysCall_init():\n    sim.setInt32Signal('custom', 1)\n"


@pytest.fixture
def scene(tmp_path):
    (tmp_path / "lua.lua").write_text(LUA)
    (tmp_path / "py.py").write_text(PY)
    (tmp_path / "custom.py").write_text(CUSTOM_PY)
    (tmp_path / "scene.xml").write_text(SCENE)
    return tmp_path / "scene.xml"


def test_without_the_flag_python_scripts_are_refused_once_and_the_scene_runs(scene, caplog):
    with caplog.at_level(logging.INFO, "simx.scripts"):
        sim = Simulation(scene, realtime=False)
        try:
            sim.start()
            sim.step()
            assert sim.signals.get_int("lua") == 1  # the Lua script runs
            assert sim.signals.get_int("py") is None and sim.signals.get_int("custom") is None
            with pytest.raises(ScriptError, match=r"child script py\.py of 'Py' .*--allow-python-scripts"):
                sim.scripts.call("Py", CHILD, "hello", [], [], [], b"")
            sim.stop()
            sim.start()  # a restart says nothing new
            sim.stop()
        finally:
            sim.close()
    assert not (scene.parent / "ran.txt").exists()  # not even its top level ran
    refusals = [r.getMessage() for r in caplog.records if "--allow-python-scripts" in r.getMessage()]
    assert len(refusals) == 2, refusals  # one line per script, at load
    assert any(m.startswith("child script py.py of 'Py' cannot be loaded: not run") for m in refusals)
    assert any(m.startswith("customization script custom.py of 'PyCustom'") for m in refusals)
    assert all(r.levelno == logging.ERROR for r in caplog.records if "--allow-python-scripts" in r.getMessage())


def test_with_the_flag_python_scripts_run(scene, caplog):
    with caplog.at_level(logging.WARNING, "simx.scripts"):
        sim = Simulation(scene, realtime=False, allow_python_scripts=True)
        try:
            assert sim.signals.get_int("custom") == 1  # customization scripts run from the load
            sim.start()
            assert sim.signals.get_int("py") == 1 and sim.signals.get_int("lua") == 1
            assert sim.scripts.call("Py", CHILD, "hello", [], [], [], b"")[0] == [42]
        finally:
            sim.close()
    assert (scene.parent / "ran.txt").read_text() == "ran"
    assert "the scene's Python scripts run with the server's rights (--allow-python-scripts)" in caplog.text


def test_a_real_server_refuses_them_without_the_flag_and_runs_them_with_it(scene):
    for allowed in (False, True):
        srv = ServerProcess(str(scene), "--pacing", "immediate", renderers="on-demand", python_scripts=allowed)
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        try:
            assert cid >= 0 and vrep.simxStartSimulation(cid, B) == 0
            rc, ints, *_ = vrep.simxCallScriptFunction(cid, "Py", CHILD, "hello", [], [], [], bytearray(), B)
            rc_lua, value = vrep.simxGetIntegerSignal(cid, "lua", B)
            assert rc_lua == 0 and value == 1
            if allowed:
                assert rc == 0 and ints == [42]
            else:
                assert rc == vrep.simx_return_remote_error_flag
                rc, errors = vrep.simxGetLastErrors(cid, B)
                assert any("--allow-python-scripts" in e for e in errors), errors
        finally:
            vrep.simxFinish(cid)
            log = srv.stop()
        assert (scene.parent / "ran.txt").exists() == allowed
        lines = [x for x in log.splitlines() if "simx.scripts: child script py.py of 'Py'" in x
                 and "--allow-python-scripts" in x]  # (besides the failed call's own line)
        assert len(lines) == (0 if allowed else 1), log


def test_instances_get_the_flag():
    from simx_server.cli import _child_args, parse_args

    assert "--allow-python-scripts" in _child_args(parse_args(["--instances", "2", "--allow-python-scripts"]))
    assert "--allow-python-scripts" not in _child_args(parse_args(["--instances", "2"]))

