"""Shape flags and joint modes switched at run time through the API table (issue 51, for
``pyrep``): ``sim_shapeintparam_static`` / ``_respondable`` (3003, 3004), ``sim.setJointMode``
(kinematic modes) and ``sim_jointintparam_velocity_lock`` (2030), as any caller uses them."""

from __future__ import annotations

import pytest

from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_wire.protocol import UnsupportedError

SCENE = """<mujoco model="modes">
  <compiler angle="radian"/>
  <option timestep="0.005"/>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.05"/>
    <body name="cube" pos="0 0 0.3">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="0.5"/>
    </body>
    <body name="shelf" pos="1 0 0.5">
      <geom type="box" size="0.1 0.1 0.01"/>
    </body>
    <body name="arm" pos="-1 0 1">
      <joint name="hinge" type="hinge" axis="0 1 0" damping="0.01"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="hinge_motor" joint="hinge" gear="1" forcerange="-0.5 0.5" forcelimited="true"/>
  </actuator>
  <custom><text name="simx:hinge" data="mode=velocity"/></custom>
</mujoco>
"""


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE)
    simulation = Simulation(path)
    simulation.start()
    yield simulation, client_context(simulation, "test").sim
    simulation.close()


def steps(simulation, n):
    for _ in range(n):
        simulation.step()


def test_respondable_off_lets_a_shape_fall_through_and_on_gives_its_bits_back(sim):
    simulation, api = sim
    cube = api.getObject("/cube")
    assert api.getObjectInt32Param(cube, api.shapeintparam_respondable) == 1
    api.setObjectInt32Param(cube, api.shapeintparam_respondable, 0)
    assert api.getObjectInt32Param(cube, api.shapeintparam_respondable) == 0
    steps(simulation, 10)
    assert api.getObjectPosition(cube, -1)[2] < 0  # through the floor
    api.setObjectInt32Param(cube, api.shapeintparam_respondable, 1)
    assert api.getObjectInt32Param(cube, api.shapeintparam_respondable) == 1
    m = simulation.world.model
    geoms = m.geom_bodyid == simulation.world.resolve("cube").mj_id
    assert (m.geom_contype[geoms] == 1).all() and (m.geom_conaffinity[geoms] == 1).all()
    simulation.stop()
    assert api.getObjectInt32Param(cube, api.shapeintparam_respondable) == 1  # a flag, kept by stop


def test_static_and_dynamic_switch_through_a_rebuild(sim):
    simulation, api = sim
    cube, shelf = api.getObject("/cube"), api.getObject("/shelf")
    steps(simulation, 2)
    z = api.getObjectPosition(cube, -1)[2]
    assert api.getObjectInt32Param(cube, api.shapeintparam_static) == 0
    api.setObjectInt32Param(cube, api.shapeintparam_static, 1)
    assert api.getObjectInt32Param(cube, api.shapeintparam_static) == 1
    assert api.getObject("/cube") == cube  # same handle
    steps(simulation, 20)
    assert api.getObjectPosition(cube, -1)[2] == pytest.approx(z, abs=1e-9)  # hangs where it was
    api.setObjectInt32Param(cube, api.shapeintparam_static, 0)
    steps(simulation, 10)
    assert api.getObjectPosition(cube, -1)[2] < z - 0.05  # falls again
    api.setObjectInt32Param(shelf, api.shapeintparam_static, 0)  # a static shape at the root
    steps(simulation, 20)
    assert api.getObjectPosition(shelf, -1)[2] < 0.4
    simulation.stop()
    assert api.getObjectPosition(shelf, -1) == pytest.approx([1, 0, 0.5])  # back at the start
    assert api.getObjectInt32Param(shelf, api.shapeintparam_static) == 0  # the flag stays


def test_a_shape_on_joints_cannot_be_switched(sim):
    _, api = sim
    with pytest.raises(UnsupportedError, match="joints"):
        api.setObjectInt32Param(api.getObject("/arm"), api.shapeintparam_static, 1)


def test_kinematic_joint_holds_where_it_is_put(sim):
    simulation, api = sim
    hinge = api.getObject("/hinge")
    api.setObjectInt32Param(hinge, api.jointintparam_motor_enabled, 0)
    assert api.getJointMode(hinge) == (5, 0)
    api.setJointMode(hinge, 2, 0)  # 4.1's sim_jointmode_ik
    assert api.getJointMode(hinge) == (2, 0)
    steps(simulation, 20)
    assert api.getJointPosition(hinge) == pytest.approx(0.0, abs=1e-12)  # gravity does not move it
    api.setJointPosition(hinge, 0.7)
    steps(simulation, 20)
    assert api.getJointPosition(hinge) == pytest.approx(0.7, abs=1e-12)
    api.setJointMode(hinge, 5, 0)
    steps(simulation, 20)
    assert api.getJointPosition(hinge) > 0.8  # free again: it swings down
    api.setJointMode(hinge, 0, 0)
    simulation.stop()
    assert api.getJointMode(hinge) == (5, 0)  # the mode at the start
    with pytest.raises(UnsupportedError, match="setJointDependency"):
        api.setJointMode(hinge, 4, 0)


def test_velocity_lock_holds_a_stopped_joint_beyond_its_force(sim):
    simulation, api = sim
    hinge = api.getObject("/hinge")
    api.setJointTargetVelocity(hinge, 0.0)  # 0.5 N·m cannot hold 1 kg at 0.15 m (1.5 N·m)
    steps(simulation, 20)
    assert api.getJointPosition(hinge) > 0.1
    simulation.stop()
    simulation.start()
    assert api.getObjectInt32Param(hinge, api.jointintparam_velocity_lock) == 0
    api.setObjectInt32Param(hinge, api.jointintparam_velocity_lock, 1)
    assert api.getObjectInt32Param(hinge, api.jointintparam_velocity_lock) == 1
    api.setJointTargetVelocity(hinge, 0.0)
    steps(simulation, 40)
    assert abs(api.getJointPosition(hinge)) < 1e-3  # locked where it stopped
    api.setJointTargetVelocity(hinge, -0.5)  # moving again: the lock lets go
    steps(simulation, 10)
    assert api.getJointPosition(hinge) > 0.01 or api.getJointPosition(hinge) < -0.01
    simulation.stop()
    assert api.getObjectInt32Param(hinge, api.jointintparam_velocity_lock) == 0  # CJoint::simulationEnded


LUA = """
function sysCall_init()
  local cube, hinge = sim.getObject('/cube'), sim.getObject('/hinge')
  sim.setObjectInt32Param(cube, sim.shapeintparam_static, 1)
  sim.setJointMode(hinge, sim.jointmode_kinematic, 0)
  sim.setObjectInt32Param(hinge, sim.jointintparam_velocity_lock, 1)
  local v, i = sim.getDecimatedMesh({0,0,0, 1,0,0, 0,1,0, 1,1,0}, {0,1,2, 1,3,2}, 0.5)
  triangles = #i // 3
end
function report()
  local hinge = sim.getObject('/hinge')
  return sim.getObjectInt32Param(sim.getObject('/cube'), sim.shapeintparam_static), sim.getJointMode(hinge),
         sim.getObjectInt32Param(hinge, sim.jointintparam_velocity_lock), triangles
end
"""


def test_a_lua_script_reaches_the_same_calls(tmp_path):
    """The calls live in the table: a child script's ``sim`` has them as the ZMQ door and pyrep do."""
    (tmp_path / "shelf.lua").write_text(LUA)
    path = tmp_path / "scene.xml"
    path.write_text(SCENE.replace('<custom><text name="simx:hinge" data="mode=velocity"/></custom>',
                                  '<custom><text name="simx:hinge" data="mode=velocity"/>'
                                  '<text name="simx:shelf" data="child_script=shelf.lua"/></custom>'))
    simulation = Simulation(path)
    try:
        simulation.start()
        simulation.step()
        api = client_context(simulation, "test").sim
        assert api.callScriptFunction("report", api.getScript(api.scripttype_childscript, api.getObject("/shelf"))) \
            == (1, 0, 1, 1)  # static, kinematic, locked, one triangle of two
    finally:
        simulation.close()
