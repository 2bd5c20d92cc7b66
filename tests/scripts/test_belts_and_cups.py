"""V-REP's model-library mechanisms that work through the dynamics engine, on the project's own
small scenes with scripts of V-REP's patterns, in-process (no wall clock, no network):

* a conveyor: a static respondable pad reset at each pass with an initial velocity
  (``sim.shapefloatparam_init_velocity_x``...) carries what lies on it at that velocity;
* a suction cup: its script moves a loop-closure dummy onto the shape its proximity sensor
  detects and links it to the cup's dummy (``sim.setLinkDummy``): the cup picks the shape up,
  carries it and lets it go.
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

# ---------------------------------------------------------------- conveyor
BELT_SCENE = """<mujoco model="belt">
  <option timestep="0.005"/>
  <worldbody>
    <geom name="Floor" type="plane" size="3 3 0.1"/>
    <body name="Belt" pos="0 0 0.1">
      <geom type="box" size="0.6 0.15 0.1" contype="0" conaffinity="0"/>
      <body name="Belt_forwarder" pos="0 0 0.1" euler="0 0 90">
        <geom type="box" size="0.15 0.6 0.005"/>
      </body>
    </body>
    <body name="Carried" pos="0.1 0 0.26"><freejoint/><geom type="box" size="0.04 0.04 0.04" mass="0.2"/></body>
    <body name="Beside" pos="0.1 0.5 0.04"><freejoint/><geom type="box" size="0.04 0.04 0.04" mass="0.2"/></body>
  </worldbody>
  <custom><text name="simx:Belt" data="child_script=belt.lua script_parameters=belt.json"/></custom>
</mujoco>
"""
# V-REP's conveyor belt script pattern: the forwarder reset at each pass, its initial velocity the
# belt's velocity along the forwarder's y axis, in world axes.
BELT_LUA = """function sysCall_init()
    forwarder=sim.getObjectHandle('Belt_forwarder')
end
function sysCall_actuation()
    local v=sim.getScriptSimulationParameter(sim.handle_self,'beltVelocity')
    sim.resetDynamicObject(forwarder)
    local m=sim.getObjectMatrix(forwarder,-1)
    m[4]=0 m[8]=0 m[12]=0
    local w=sim.multiplyVector(m,{0,v,0})
    sim.setObjectFloatParameter(forwarder,sim.shapefloatparam_init_velocity_x,w[1])
    sim.setObjectFloatParameter(forwarder,sim.shapefloatparam_init_velocity_y,w[2])
    sim.setObjectFloatParameter(forwarder,sim.shapefloatparam_init_velocity_z,w[3])
end
"""


def test_a_conveyor_carries_a_box_at_its_velocity_and_not_what_lies_beside_it(tmp_path, caplog):
    (tmp_path / "belt.lua").write_text(BELT_LUA)
    (tmp_path / "belt.json").write_text('[{"name": "beltVelocity", "value": "0.1", "unit": "m/s"}]')
    (tmp_path / "scene.xml").write_text(BELT_SCENE)
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    world = sim.world
    carried, beside = world.resolve("Carried").handle, world.resolve("Beside").handle
    pad = world.resolve("Belt_forwarder").handle
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
            for _ in range(20):  # 1 s: the box settles and takes the belt's speed
                sim.step()
            x0, b0, p0 = (world.position(h, -1) for h in (carried, beside, pad))
            for _ in range(20):
                sim.step()
            x1, b1, p1 = (world.position(h, -1) for h in (carried, beside, pad))
        assert not caplog.records, [r.getMessage() for r in caplog.records]
        speed = (np.asarray(x1) - np.asarray(x0)) / (20 * world.dt)
        assert speed[0] == pytest.approx(-0.1, abs=0.01)  # the forwarder's y axis is the world's -x
        assert abs(speed[1]) < 0.01 and abs(x1[2] - 0.245) < 0.01  # on the belt, along it
        assert np.allclose(b0, b1, atol=1e-4) and np.allclose(p0, p1, atol=1e-9)  # nothing else moves
    finally:
        sim.stop()
        sim.close()
    assert world.init_velocities == {}  # forgotten at the stop, as CoppeliaSim restores them
