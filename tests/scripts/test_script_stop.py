"""A child script stops or pauses the simulation (``sim.stopSimulation``, ``sim.pauseSimulation``,
V-REP 3.x's ``simStopSimulation``): as in CoppeliaSim, a request carried out once the current
pass is over, never in the middle of the script that asks (the rest of its pass runs, then the
scripts' cleanup and the scene's initial state); through a client's call into a script, once
that call has returned. In process, and through a real server with the legacy client."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

import vrep
from conftest import ServerProcess, free_port
from simx_server.scene.simulation import Simulation
from simx_server.sim.state import RunState

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

SCENE = """<mujoco model="scripts that stop">
  <option timestep="0.01" gravity="0 0 0"/>
  <worldbody>
    <body name="Box" pos="0 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
    <body name="Old" pos="0.2 0 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
  </worldbody>
  <custom>
    <text name="simx:Box" data="child_script=box.lua"/>
    <text name="simx:Old" data="child_script=old.lua"/>
  </custom>
</mujoco>
"""

#: Stops (or pauses) at the pass the test names in the integer signals "stop_at" / "pause_at"
#: (set by the test: signals a script sets are cleared at a stop) and prints what each callback
#: did, so that the log shows what ran after the request.
BOX = """
local passes = 0
function sysCall_init()
  if sim.getIntegerSignal('stop_in_init') == 1 then print('init stop', sim.stopSimulation()) end
end
function sysCall_actuation()
  passes = passes + 1
  print('actuation', passes)
  if passes == sim.getIntegerSignal('stop_at') then
    print('stop', sim.stopSimulation(), sim.getSimulationState())
  end
  if passes == sim.getIntegerSignal('pause_at') then print('pause', sim.pauseSimulation()) end
end
function sysCall_sensing() print('sensing', passes) end
function sysCall_cleanup() print('cleanup', sim.stopSimulation()) end
function stopFromClient(ints, floats, strings, buffer)
  local r = sim.stopSimulation()
  return {r, sim.getSimulationState()}, {}, {'still running here'}, ''
end
"""

#: V-REP 3.x's way: simStopSimulation from an old-style script.
OLD = """
if (sim_call_type == sim_childscriptcall_actuation) then
  if simGetIntegerSignal('old_stop') == 1 then print('old stop', simStopSimulation()) end
end
"""

RUNNING = 0x11  # sim.simulation_advancing_running


def write_scene(folder: Path) -> Path:
    (folder / "box.lua").write_text(BOX)
    (folder / "old.lua").write_text(OLD)
    scene = folder / "scene.xml"
    scene.write_text(SCENE)
    return scene


@pytest.fixture
def sim(tmp_path):
    s = Simulation(write_scene(tmp_path), realtime=False)
    yield s
    s.close()


@pytest.fixture
def lines(caplog):
    """The scripts' printed lines so far (a function), without the script's name."""
    caplog.set_level(logging.INFO, logger="simx.scripts")
    return lambda: [r.getMessage().split("] ", 1)[1] for r in caplog.records
                    if r.name == "simx.scripts" and r.getMessage().startswith("[box.lua] ")]


def test_a_scripts_stop_comes_after_its_pass(sim, lines):
    sim.scripts.signals.set_int("stop_at", 3)
    sim.start()
    for _ in range(3):
        sim.step()
    assert sim.state is RunState.STOPPED
    # the pass that asked ran to its end (the script went on, sensing ran), then the cleanup,
    # where a stop is no longer possible
    assert lines() == ["actuation\t1", "sensing\t1", "actuation\t2", "sensing\t2", "actuation\t3",
                       f"stop\t1\t{RUNNING}", "sensing\t3", "cleanup\t0"]
    assert sim.world.time == 0.0  # the scene's initial state
    assert sim.stop_requests == 1  # sim.intparam_stop_request_counter counts it


def test_a_stop_asked_in_init_comes_after_the_first_pass(sim, lines):
    sim.scripts.signals.set_int("stop_in_init", 1)
    sim.start()
    assert sim.state is RunState.RUNNING
    sim.step()
    assert sim.state is RunState.STOPPED
    assert lines() == ["init stop\t1", "actuation\t1", "sensing\t1", "cleanup\t0"]


def test_a_scripts_pause_keeps_the_state_and_resumes(sim, lines):
    sim.scripts.signals.set_int("pause_at", 2)
    sim.start()
    sim.step()
    sim.step()
    assert sim.state is RunState.PAUSED
    t = sim.world.time
    assert t > 0 and "cleanup\t0" not in lines() and "pause\t1" in lines()  # paused, not stopped
    sim.start()
    sim.step()
    assert sim.state is RunState.RUNNING and sim.world.time > t and lines()[-2:] == ["actuation\t3", "sensing\t3"]


def test_a_stop_outranks_a_pause_in_the_same_pass(sim):
    sim.scripts.signals.set_int("pause_at", 1)
    sim.scripts.signals.set_int("stop_at", 1)
    sim.start()
    sim.step()
    assert sim.state is RunState.STOPPED


def test_a_stop_asked_when_stopped_is_refused(sim):
    assert sim.request(RunState.STOPPED) == 0 and sim.request(RunState.PAUSED) == 0
    sim.start()
    sim.pause()
    assert sim.request(RunState.PAUSED) == 0 and sim.request(RunState.STOPPED) == 1


def test_v_rep_3_scripts_stop_with_simStopSimulation(sim, caplog):  # noqa: N802
    caplog.set_level(logging.INFO, logger="simx.scripts")
    sim.scripts.signals.set_int("old_stop", 1)
    sim.start()
    sim.step()
    assert sim.state is RunState.STOPPED
    assert "[old.lua] old stop\t1" in [r.getMessage() for r in caplog.records]


def test_a_clients_call_into_a_script_that_stops_returns_then_stops(tmp_path):
    """simxCallScriptFunction into a function that calls sim.stopSimulation: the function's
    values come back (the simulation still running inside it), and the simulation is stopped
    when the call has returned."""
    server = ServerProcess(str(write_scene(tmp_path)), ports=[free_port()], renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
    try:
        assert cid >= 0
        wait = vrep.simx_opmode_blocking
        rc, ints, _, strings, _ = vrep.simxCallScriptFunction(cid, "Box", vrep.sim_scripttype_childscript,
                                                              "stopFromClient", [], [], [], bytearray(), wait)
        assert rc == vrep.simx_return_ok, rc
        assert ints == [1, RUNNING] and strings == ["still running here"]
        rc, state = vrep.simxGetInMessageInfo(cid, vrep.simx_headeroffset_server_state)
        assert rc != -1 and state & 1 == 0, state  # bit 0: running; the reply after the call says stopped
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        log = server.stop()
    assert "Traceback" not in log, log[-3000:]
    assert "[box.lua] cleanup\t0" in log  # the scripts' cleanup ran once the call had returned
