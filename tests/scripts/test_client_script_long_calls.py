"""A client scene's scripts and their long calls (issue 84): with ``--allow-remote-code``, a
client's script calling ``simOMPL.solve`` held every other client 10.1 s at each simulation
start, ``sim.convexDecompose`` 29.4 s (scripts were not remote callers for long calls). Now a
script that acts for a client runs them as a ZMQ client's are run (api/long_calls.py): in a
thread, off the simulation thread, the thread yielding until done (the simulation steps
meanwhile); in a callback that cannot yield, at once but stopped once it has taken what the
scripts' pass had left. The operator's scripts run them at once, as before.

In process: a client's model (sent, then loaded with options 1) whose script plans on a blocked
task, so that a planner searches until its time is up."""

from __future__ import annotations

import logging
import time

import pytest

from conftest import SCENE
from simx_server.commands.editing import EDITING_HANDLERS as H
from simx_server.scene.simulation import Simulation

pytest.importorskip("ompl")
pytestmark = pytest.mark.renderers_on_demand

#: A one-link arm that a post blocks (Joint1 cannot turn from 0 to 2.5 rad), with a script.
ARM = """<mujoco model="arm">
  <compiler angle="radian"/>
  <worldbody>
    <body name="Link1" pos="2 2 0.3">
      <joint name="Joint1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0.03 0 0 0.4 0 0" size="0.03" contype="0" conaffinity="0"/>
    </body>
    <body name="Post" pos="2 2.25 0.3"><geom type="box" size="0.03 0.03 0.2" contype="0" conaffinity="0"/></body>
  </worldbody>
  <custom><text name="simx:Link1" data="child_script=arm.lua"/></custom>
</mujoco>
"""
TASK = """
local function blocked()
  local task = simOMPL.createTask("blocked")
  simOMPL.setAlgorithm(task, simOMPL.Algorithm.RRTConnect)
  simOMPL.setStateSpaceForJoints(task, {sim.getObject("/Joint1")}, {1})
  simOMPL.setCollisionPairs(task, {sim.getObject("/Link1"), sim.getObject("/Post")})
  simOMPL.setStartState(task, {0})
  simOMPL.setGoalState(task, {2.5})
  simOMPL.setup(task)
  return task
end
"""
THREADED = TASK + """
function sysCall_thread()
  local task = blocked()
  sim.setFloatSignal("before", sim.getSimulationTime())
  simOMPL.solve(task, 0.5)
  sim.setFloatSignal("after", sim.getSimulationTime())
end
"""
INIT = TASK + """
function sysCall_init()
  simOMPL.solve(blocked(), 60)
  sim.setInt32Signal("solved", 1)
end
"""


def _sim(folder, script: str, client: bool) -> tuple[Simulation, int]:
    folder.mkdir(exist_ok=True)
    (folder / "arm.xml").write_text(ARM)
    (folder / "arm.lua").write_text(script)
    if client:  # sent by a client (its folder), loaded with its scripts
        sim = Simulation(SCENE, dt=0.05, realtime=False, allow_remote_code=True)
        for file in ("arm.xml", "arm.lua"):
            H["TransferFile"](sim, [file, (folder / file).read_bytes()])
        return sim, H["LoadModel"](sim, ["arm.xml", 1])
    sim = Simulation(SCENE, dt=0.05, realtime=False, scene_paths=[folder])
    return sim, H["LoadModel"](sim, [str(folder / "arm.xml"), 0])


def _run_until(sim: Simulation, name: str, kind: str = "float") -> int:
    """Steps until the script has set signal ``name`` (at most 30 s); how many ran."""
    end = time.monotonic() + 30
    steps = 0
    while sim.signals.get(kind, name) is None and time.monotonic() < end:
        sim.step()
        steps += 1
        time.sleep(0.01)
    return steps


def test_a_client_scripts_thread_plans_off_the_simulation_thread(tmp_path):
    """The thread yields while its solve searches: the simulation steps meanwhile (its time
    moves between the call and its return); before, the solve held the step it was called in."""
    sim, base = _sim(tmp_path / "client", THREADED, client=True)
    try:
        assert sim.editor.files.writer(sim.scripts.scripts[base].path) is not None  # a client's script
        sim.start()
        _run_until(sim, "after")
        assert sim.signals.get("float", "after") > sim.signals.get("float", "before")
    finally:
        sim.close()


def test_the_operators_script_plans_at_once_as_before(tmp_path):
    sim, _ = _sim(tmp_path / "models", THREADED, client=False)
    try:
        sim.start()
        _run_until(sim, "after")
        assert sim.signals.get("float", "after") == sim.signals.get("float", "before")
    finally:
        sim.close()


def test_a_client_scripts_callback_plans_within_what_the_pass_has_left(tmp_path, caplog):
    """sysCall_init cannot yield: its solve(task, 60) stops once the pass's 0.3 s (shrunk) are
    taken, an error naming the bound; before, it searched for 10 s (the planner's own cap)."""
    sim, _ = _sim(tmp_path / "client", INIT, client=True)
    sim.scripts.budget.seconds = 0.3
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
        assert sim.signals.get("int", "solved") is None
        errors = [r.getMessage() for r in caplog.records]
        assert any("simOMPL.solve: stopped" in m and "MAX_SCRIPTS_STEP_TIME" in m for m in errors), errors
    finally:
        sim.close()
