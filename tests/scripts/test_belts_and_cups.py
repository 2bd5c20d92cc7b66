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
  <option timestep="0.005" cone="{cone}"/>
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


@pytest.mark.parametrize("cone", ["pyramidal", "elliptic"])  # MJCF's default, and a converted .ttt's
def test_a_conveyor_carries_a_box_at_its_velocity_and_not_what_lies_beside_it(tmp_path, caplog, cone):
    (tmp_path / "belt.lua").write_text(BELT_LUA)
    (tmp_path / "belt.json").write_text('[{"name": "beltVelocity", "value": "0.1", "unit": "m/s"}]')
    (tmp_path / "scene.xml").write_text(BELT_SCENE.replace("{cone}", cone))
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


# ---------------------------------------------------------------- suction cup
CUP_SCENE = """<mujoco model="cup">
  <option timestep="0.005"/>
  <worldbody>
    <geom name="Floor" type="plane" size="3 3 0.1"/>
    <body name="Cup" mocap="true" pos="0 0 0.2">
      <geom type="cylinder" size="0.02 0.02" rgba="0.2 0.2 0.8 1"/>
      <site name="Cup_sensor" pos="0 0 -0.02" euler="180 0 0" size="0.005"/>
      <site name="Cup_loopClosureDummy1" pos="0 0 -0.02" size="0.005"/>
      <site name="Cup_loopClosureDummy2" pos="0 0 -0.02" size="0.005"/>
    </body>
    <body name="Part" pos="0 0 0.03"><freejoint/><geom type="box" size="0.03 0.03 0.03" mass="0.1"/></body>
    <body name="Other" pos="0.5 0 0.03"><freejoint/><geom type="box" size="0.03 0.03 0.03" mass="0.1"/></body>
  </worldbody>
  <sensor><rangefinder name="Cup_range" site="Cup_sensor" cutoff="0.03"/></sensor>
  <custom><text name="simx:Cup" data="child_script=cup.lua script_parameters=cup.json"/></custom>
</mujoco>
"""
# V-REP's suction pad script pattern (its model library's suction pad and Baxter vacuum cup): the
# cup's loop-closure dummy sits on the cup's other dummy; active, it moves onto the respondable
# shape the sensor detects and is linked to the other dummy; inactive, it comes back.
CUP_LUA = """function sysCall_init()
    s=sim.getObjectHandle('Cup_sensor')
    l=sim.getObjectHandle('Cup_loopClosureDummy1')
    l2=sim.getObjectHandle('Cup_loopClosureDummy2')
    b=sim.getObjectHandle('Cup')
    sim.setLinkDummy(l,-1)
    sim.setObjectParent(l,b,true)
    sim.setObjectMatrix(l,-1,sim.getObjectMatrix(l2,-1))
end
function sysCall_sensing()
    local parent=sim.getObjectParent(l)
    if sim.getScriptSimulationParameter(sim.handle_self,'active')==false then
        if parent~=b then
            sim.setLinkDummy(l,-1)
            sim.setObjectParent(l,b,true)
            sim.setObjectMatrix(l,-1,sim.getObjectMatrix(l2,-1))
        end
    elseif parent==b then
        local index=0
        while true do
            local shape=sim.getObjects(index,sim.object_shape_type)
            if shape==-1 then break end
            if shape~=b and sim.getObjectInt32Param(shape,sim.shapeintparam_respondable)~=0
               and sim.checkProximitySensor(s,shape)==1 then
                sim.setObjectParent(l,shape,true)
                sim.setLinkDummy(l,l2)
                break
            end
            index=index+1
        end
    end
end
function setActive(ints, floats, strings, buffer)
    sim.setScriptSimulationParameter(sim.handle_self,'active',ints[1]==1 and 'true' or 'false')
    return {sim.getLinkDummy(l), sim.getObjectParent(l)}
end
"""


def _move(sim: Simulation, cup: int, to: tuple, steps: int) -> None:
    start = np.asarray(sim.world.position(cup, -1))
    for i in range(1, steps + 1):
        sim.world.set_pose(cup, -1, list(start + (np.asarray(to) - start) * i / steps))
        sim.step()


def test_a_suction_cup_picks_carries_and_releases_a_part(tmp_path, caplog):
    (tmp_path / "cup.lua").write_text(CUP_LUA)
    (tmp_path / "cup.json").write_text('[{"name": "active", "value": "false", "unit": ""}]')
    (tmp_path / "scene.xml").write_text(CUP_SCENE)
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    world = sim.world
    cup, part, other = (world.resolve(n).handle for n in ("Cup", "Part", "Other"))
    l1, l2 = (world.resolve(n).handle for n in ("Cup_loopClosureDummy1", "Cup_loopClosureDummy2"))
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            sim.start()
            _move(sim, cup, (0, 0, 0.081), 10)  # down onto the part
            assert sim.scripts.call("Cup", 1, "setActive", [1], [], [], b"")[0] == [-1, cup]
            sim.step()  # the sensing pass links the dummy, moved onto the part
            assert sim.scripts.call("Cup", 1, "setActive", [1], [], [], b"")[0] == [l2, part]
            _move(sim, cup, (0, 0, 0.4), 20)  # up
            _move(sim, cup, (0.3, 0.2, 0.4), 20)  # across
            held = np.asarray(world.position(part, -1))
            assert held == pytest.approx([0.3, 0.2, 0.4 - 0.051], abs=0.005)  # hanging under the cup
            assert sim.scripts.call("Cup", 1, "setActive", [0], [], [], b"")[0] == [l2, part]
            for _ in range(20):  # let go: it falls onto the floor below
                sim.step()
            assert sim.scripts.call("Cup", 1, "setActive", [0], [], [], b"")[0] == [-1, cup]
            dropped = np.asarray(world.position(part, -1))
        assert not caplog.records, [r.getMessage() for r in caplog.records]
        assert dropped == pytest.approx([0.3, 0.2, 0.03], abs=0.01)
        assert world.position(other, -1) == pytest.approx([0.5, 0, 0.03], abs=1e-3)  # never touched
    finally:
        sim.stop()
        sim.close()
