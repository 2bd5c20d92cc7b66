"""Table functions and parameters added for ``pyrep`` (docs/PYREP.md), through the API table as
any caller uses them: configuration trees, force-sensor creation, per-shape friction, light and
vision-sensor parameters, distances from a dummy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_wire.protocol import ArgumentError, UnsupportedError

SCENE = """<mujoco model="table_for_pyrep">
  <compiler angle="radian"/>
  <option timestep="0.01"/>
  <worldbody>
    <light name="spot" pos="0 0 3" dir="0 0 -1" cutoff="40" exponent="5" castshadow="false"/>
    <geom name="floor" type="plane" size="2 2 0.05"/>
    <body name="cube" pos="0.5 0 0.3">
      <freejoint/>
      <geom type="box" size="0.05 0.05 0.05" mass="0.5" friction="0.4 0.005 0.0001"/>
    </body>
    <site name="marker" pos="0.5 0 1.0"/>
    <body name="anchor" pos="-0.5 0 1">
      <body name="link1"><joint name="ball1" type="ball" damping="0.01"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" mass="0.05"/>
        <body name="link2" pos="0.2 0 0"><joint name="ball2" type="ball" damping="0.01"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" mass="0.05"/>
        </body>
      </body>
    </body>
    <camera name="cam" pos="0 -1.5 0.8" xyaxes="1 0 0 0 0.5 1" resolution="64 32" fovy="30"/>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE)
    simulation = Simulation(path)
    yield simulation, client_context(simulation, "test").sim
    simulation.close()


def test_configuration_tree_restores_poses(sim):
    simulation, api = sim
    cube = api.getObject("/cube")
    saved, pos = api.getConfigurationTree(cube), api.getObjectPosition(cube, -1)
    simulation.start()
    for _ in range(10):
        simulation.step()
    assert api.getObjectPosition(cube, -1)[2] < pos[2]
    api.setConfigurationTree(saved)
    assert np.allclose(api.getObjectPosition(cube, -1), pos)
    with pytest.raises(ArgumentError):
        api.setConfigurationTree(b"not a tree")


def test_configuration_tree_restores_spherical_joints(sim):
    """A rope of spherical joints (RLBench's straighten_rope restores one each reset): the tree
    keeps each spherical joint's rotation (coppeliaSimLib ``CMemorizedConf_old``), and its links,
    moved by those joints, come back with them."""
    simulation, api = sim
    anchor, tip = api.getObject("/anchor"), api.getObject("/link2")
    saved, pos = api.getConfigurationTree(anchor), api.getObjectPosition(tip, -1)
    simulation.start()
    for _ in range(30):  # the horizontal rope falls
        simulation.step()
    assert api.getObjectPosition(tip, -1)[2] < pos[2] - 0.05
    assert api.setConfigurationTree(saved) == 1
    assert np.allclose(api.getObjectPosition(tip, -1), pos, atol=1e-9)


def test_create_force_sensor_reads(sim):
    _, api = sim
    h = api.createForceSensor(0, [0, 1, 5, 0, 0], [0.02, 0, 0, 0, 0])
    assert api.getObjectType(h) == 12  # sim_object_forcesensor_type
    state, force, torque = api.readForceSensor(h)
    assert len(force) == 3 and len(torque) == 3
    with pytest.raises(ArgumentError):
        api.createForceSensor(0, [0, 1, 5, 0, 0], [0.0, 0, 0, 0, 0])


def test_body_friction_is_mujocos_sliding_friction(sim):
    simulation, api = sim
    cube = api.getObject("/cube")
    assert api.getEngineFloatParam(6003, cube) == pytest.approx(0.4)
    api.setEngineFloatParam(6003, cube, 0.9)
    assert api.getEngineFloatParam(15001, cube) == pytest.approx(0.9)  # ODE's id: the same friction
    with pytest.raises(ArgumentError):
        api.setEngineFloatParam(6003, cube, -1.0)


def test_light_parameters(sim):
    _, api = sim
    spot = api.getObject("/spot")
    assert api.getObjectInt32Param(spot, 8000) == 0
    api.setObjectInt32Param(spot, 8000, 1)
    assert api.getObjectInt32Param(spot, 8000) == 1
    assert api.getObjectFloatParam(spot, 8001) == pytest.approx(5)
    assert api.getObjectFloatParam(spot, 8002) == pytest.approx(math.radians(40))
    api.setObjectFloatParam(spot, 8002, 0.3)
    assert api.getObjectFloatParam(spot, 8002) == 0.3
    with pytest.raises(UnsupportedError):
        api.setObjectFloatParam(spot, 8003, 1.0)


def test_vision_sensor_projection_and_sizes(sim):
    _, api = sim
    cam = api.getObject("/cam")
    assert api.getObjectInt32Param(cam, 1018) == 1  # perspective
    angle = api.getObjectFloatParam(cam, 1004)
    api.setObjectFloatParam(cam, 1005, 2.0)  # kept for when it turns orthographic
    api.setObjectInt32Param(cam, 1018, 0)
    assert api.getObjectFloatParam(cam, 1005) == pytest.approx(2.0)
    api.setObjectInt32Param(cam, 1018, 1)
    assert api.getObjectFloatParam(cam, 1004) == pytest.approx(angle)  # the angle came back
    api.setObjectInt32Param(cam, 1004, 640)
    assert api.getObjectInt32Param(cam, 1004) == 640
    assert api.getObjectInt32Param(cam, 1008) == -1
    with pytest.raises(UnsupportedError):
        api.setObjectInt32Param(cam, 1008, cam)
    made = api.createVisionSensor(1, [64, 32, 0, 0], [0.01, 10.0, math.radians(35)])
    assert math.degrees(api.getObjectFloatParam(made, 1004)) == pytest.approx(35.0, abs=1e-3)


def test_check_distance_from_a_dummy(sim):
    _, api = sim
    marker, cube = api.getObject("/marker"), api.getObject("/cube")
    result, data, pair = api.checkDistance(marker, cube)
    assert data[6] == pytest.approx(1.0 - 0.35, abs=1e-3)  # from z 1.0 down to the cube's top at 0.35
    assert np.allclose(data[3:6], [0.5, 0.0, 0.35], atol=1e-3)
    assert pair == [marker, cube]
