"""``sysCall_contactCallback`` (issue 34): a script decides, at each MuJoCo substep, whether a pair
of shapes that may touch collides, as V-REP asked it in its engine's broad phase
(simx_server/scripts/dynamics.py, simx_server/sim/contact_filter.py)."""

from __future__ import annotations

import logging

import mujoco
import pytest

from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCENE = """<mujoco model="contact callback">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <worldbody>
    <geom name="Floor" type="plane" size="2 2 0.1"/>
    <body name="Crate" pos="0 0 0.3"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="0.2"/></body>
    <body name="Ghost" pos="0.5 0 0.3"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="0.2"/></body>
    <body name="Referee" pos="1 1 0"><geom type="box" size="0.01 0.01 0.01" contype="0" conaffinity="0"/></body>
  </worldbody>
  <custom><text name="simx:Referee" data="child_script={script}"/></custom>
</mujoco>
"""

LUA = """function sysCall_init()
    ghost=sim.getObjectHandle('Ghost')
    crate=sim.getObjectHandle('Crate')
    calls=0
end
function sysCall_contactCallback(inData)
    calls=calls+1
    sim.setIntegerSignal('calls', calls)
    sim.setIntegerSignal('engine', inData.engine)
    if inData.handle1==ghost or inData.handle2==ghost then
        sim.setIntegerSignal('ghost_pair', 1)
        return {ignoreContact=false, collisionResponse=false}
    end
    if inData.handle1==crate or inData.handle2==crate then
        sim.setIntegerSignal('crate_other', inData.handle1==crate and inData.handle2 or inData.handle1)
    end
    return {ignoreContact=%s, collisionResponse=false}
end
"""

PYTHON = '''def sysCall_init():
    global ghost
    ghost = sim.getObject("/Ghost")


def sysCall_contactCallback(inData):
    if ghost in (inData["handle1"], inData["handle2"]):
        return {"ignoreContact": False, "collisionResponse": False, "ode": {"mu": 0.1}}
    return None
'''


def run(tmp_path, name: str, source: str, seconds: float = 1.0) -> Simulation:
    (tmp_path / name).write_text(source)
    scene = tmp_path / "scene.xml"
    scene.write_text(SCENE.format(script=name))
    sim = Simulation(scene, realtime=False, allow_python_scripts=name.endswith(".py"))
    sim.start()
    for _ in range(round(seconds / sim.world.dt)):
        sim.step()
    return sim


def z(sim: Simulation, body: str) -> float:
    return float(sim.world.data.body(body).xpos[2])


def test_a_refused_pair_passes_through_and_the_others_collide(tmp_path):
    sim = run(tmp_path, "referee.lua", LUA % "true")  # the crate's pairs: left to the engine
    try:
        assert z(sim, "Crate") == pytest.approx(0.05, abs=0.01)  # resting on the floor
        assert z(sim, "Ghost") < -0.5  # fell through it
        signals = sim.signals
        assert signals.get_int("ghost_pair") == 1
        assert signals.get_int("crate_other") == -1  # the floor: the scene's static geometry
        assert signals.get_int("engine") == 4  # sim.physics_mujoco
        assert signals.get_int("calls") >= 100  # asked again at each substep while they overlap
        assert mujoco.get_mjcb_contactfilter() is not None
    finally:
        sim.stop()
        sim.close()
    assert mujoco.get_mjcb_contactfilter() is None  # removed with the script's decisions
    assert sim.world.substep_hook is None


def test_a_pair_the_script_handles_without_response_passes_through(tmp_path):
    sim = run(tmp_path, "referee.lua", LUA % "false")  # every pair: collisionResponse=false
    try:
        assert z(sim, "Crate") < -0.5 and z(sim, "Ghost") < -0.5
    finally:
        sim.close()  # closing a running simulation removes the decisions too
    assert mujoco.get_mjcb_contactfilter() is None


def test_python_callback_and_engine_tables_are_logged_once(tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="simx.scripts"):
        sim = run(tmp_path, "referee.py", PYTHON)
    try:
        assert z(sim, "Ghost") < -0.5 and z(sim, "Crate") == pytest.approx(0.05, abs=0.01)
        told = [r for r in caplog.records if "engine parameters (ode)" in r.getMessage()]
        assert len(told) == 1
    finally:
        sim.close()


def test_other_worlds_keep_mujocos_contacts_while_a_script_decides(tmp_path):
    sim = run(tmp_path, "referee.lua", LUA % "false", seconds=0.1)
    other = mujoco.MjModel.from_xml_string(SCENE.format(script="none.lua"))
    data = mujoco.MjData(other)
    try:
        assert mujoco.get_mjcb_contactfilter() is not None
        mujoco.mj_step(other, data, nstep=500)
        assert data.body("Ghost").xpos[2] == pytest.approx(0.05, abs=0.01)  # landed: default filter
        assert data.ncon >= 1  # the ghost's contacts with the floor, which the script refuses in sim
    finally:
        sim.close()


def test_an_error_in_the_callback_is_logged_and_the_contacts_stay_mujocos(tmp_path, caplog):
    source = "function sysCall_contactCallback(inData) error('referee broke') end\n"
    with caplog.at_level(logging.ERROR, logger="simx.scripts"):
        sim = run(tmp_path, "broken.lua", source)
    try:
        assert z(sim, "Ghost") == pytest.approx(0.05, abs=0.01)
        assert sum("referee broke" in r.getMessage() for r in caplog.records) == 1
    finally:
        sim.close()
