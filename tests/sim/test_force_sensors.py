"""Force sensors read what CoppeliaSim's read (simx_server/sim/force_sensors.py): the force and
torque that what hangs below the sensor exerts on its parent, in the sensor's frame, the torque
about its origin; a hanging mass m reads m·g along gravity, and m·(g + a) while lifted with
acceleration a. One small scene per source: an MJCF scene (the site in the child body), a .ttt
file written here (a wrist sensor between an arm and a hand, an attach-point sensor under the
hand, as PyRep's grippers have them), and sensors made at run time with ``sim.createForceSensor``;
a grasped cube's weight shows in the wrist sensor and in the attach point."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from conftest import ROOT
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

sys.path.insert(0, str(ROOT / "tests" / "scene" / "ttt"))
import tttwriter as W  # noqa: E402
from simx_server.scene.ttt import convert, reader  # noqa: E402

pytestmark = pytest.mark.renderers_on_demand  # no image is read

G = 9.81
DOWN = (0.0, 1.0, 0.0, 0.0)  # half a turn about x: the sensor's z points down, as an arm's flange

# A 1 kg arm on a vertical slide; below it a 0.6 kg load (its centre of mass 0.1 m along x) whose
# body carries the site "ft", z down (MJCF's convention: the site in the child body).
MJCF = """<mujoco model="ft">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <custom><text name="simx:lift" data="mode=position max_velocity=1"/></custom>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="lift" type="slide" axis="0 0 1" range="-0.5 2"/>
      <geom type="box" size="0.05 0.05 0.05" mass="1" contype="0" conaffinity="0"/>
      <body name="load" pos="0 0 -0.2">
        <site name="ft" quat="0 1 0 0"/>
        <geom type="box" pos="0.1 0 0" size="0.03 0.03 0.03" mass="0.6" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator><general name="lift_motor" joint="lift" forcelimited="true" forcerange="-500 500"/></actuator>
  <sensor><force name="ft_force" site="ft"/><torque name="ft_torque" site="ft"/></sensor>
</mujoco>
"""

# A 0.5 kg palm on a vertical slide and a free 0.1 kg cube under it (the audit's case).
PALM = """<mujoco model="palm">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <custom><text name="simx:lift" data="mode=position max_velocity=1"/></custom>
  <worldbody>
    <body name="palm" pos="0 0 1">
      <joint name="lift" type="slide" axis="0 0 1" range="-0.5 2"/>
      <geom type="box" size="0.05 0.05 0.02" mass="0.5" contype="0" conaffinity="0"/>
    </body>
    <body name="cube" pos="0 0 0.9">
      <freejoint/>
      <geom type="box" size="0.02 0.02 0.02" mass="0.1" contype="0" conaffinity="0"/>
    </body>
    <body name="spare" pos="1 0 0.9">
      <freejoint/>
      <geom type="box" size="0.02 0.02 0.02" mass="0.25" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <actuator><general name="lift_motor" joint="lift" forcelimited="true" forcerange="-500 500"/></actuator>
</mujoco>
"""


def _sim(path):
    sim = Simulation(path, dt=0.05, realtime=False)
    sim.start()
    api = script_sim(sim.world, sim.world.objects[min(sim.world.objects)].handle, sim.signals, simulation=sim)
    return sim, api


def _steps(sim, n):
    for _ in range(n):
        sim.step()


def _accelerate(api, lift, force):
    """Velocity control toward 5 m/s with at most ``force`` N: the slide accelerates upwards."""
    api.setObjectInt32Param(lift, 2001, 0)  # sim.jointintparam_ctrl_enabled off: velocity control
    api.setJointMaxForce(lift, force)
    api.setJointTargetVelocity(lift, 5.0)


def _acceleration(sim, lift):
    w = sim.world
    return float(w.data.qacc[w.model.jnt_dofadr[w.get(lift).mj_id]])


@pytest.fixture
def mjcf(tmp_path):
    f = tmp_path / "ft.xml"
    f.write_text(MJCF)
    sim, api = _sim(f)
    yield sim, api
    sim.close()


def test_mjcf_sensor_reads_the_hanging_load_along_gravity(mjcf):
    sim, api = mjcf
    ft = api.getObject("/ft")
    _steps(sim, 4)
    state, force, torque = api.readForceSensor(ft)
    m = 0.6
    assert state == 1
    assert force == pytest.approx([0.0, 0.0, m * G], abs=1e-6)  # z down: the weight along +z
    assert torque == pytest.approx([0.0, -0.1 * m * G, 0.0], abs=1e-6)  # (0.1, 0, 0) x (0, 0, m g)
    # CoppeliaSim's MuJoCo plugin reports minus MuJoCo's own sensors on a site in the child body
    d = sim.world.data
    assert np.allclose(d.sensor("ft_force").data, -np.array(force))
    assert np.allclose(d.sensor("ft_torque").data, -np.array(torque))


def test_mjcf_sensor_reads_the_inertial_force_while_lifting(mjcf):
    sim, api = mjcf
    ft, lift = api.getObject("/ft"), api.getObject("/lift")
    _steps(sim, 2)
    _accelerate(api, lift, 30.0)
    _steps(sim, 3)
    a = _acceleration(sim, lift)
    assert a == pytest.approx(30.0 / 1.6 - G, rel=0.01)  # still accelerating: 30 N on 1.6 kg
    force = api.readForceSensor(ft)[1]
    assert force == pytest.approx([0.0, 0.0, 0.6 * (G + a)], abs=1e-6)  # 1.9 times the weight


@pytest.fixture
def gripper(tmp_path):
    """A .ttt: Base (static) -> Lift (prismatic, up) -> Arm (1 kg) -> Wrist (force sensor, z
    down) -> Hand (0.4 kg, 5 cm along the sensor's x and z) -> AttachPoint (force sensor, 5 cm
    along the hand's z, no child); a free 0.1 kg Cube on the floor."""
    body = (W.cuboid_shape(1, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.joint(2, 1, "Lift", (0, 0, 0.5), kind=11, max_force=500, limits=(-1, 2))
            + W.cuboid_shape(3, 2, "Arm", (0.1, 0.1, 0.1), (0, 0, 0), mass=1.0)
            + W.force_sensor(4, 3, "Wrist", (0, 0, -0.1), quat=DOWN)
            + W.cuboid_shape(5, 4, "Hand", (0.08, 0.08, 0.04), (0.05, 0, 0.05), mass=0.4)
            + W.force_sensor(6, 5, "AttachPoint", (0, 0, 0.05))
            + W.cuboid_shape(7, -1, "Cube", (0.04, 0.04, 0.04), (1, 0, 0.02), mass=0.1))
    f = tmp_path / "gripper.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "gripper")
    sim, api = _sim(xml)
    yield sim, api
    sim.close()


def test_ttt_sensors_keep_v_reps_tree(gripper):
    _, api = gripper
    wrist, hand, attach = (api.getObject("/" + n) for n in ("Wrist", "Hand", "AttachPoint"))
    assert api.getObjectParent(wrist) == api.getObject("/Arm")
    assert api.getObjectParent(hand) == wrist  # the hand's body carries the wrist's site in MuJoCo
    assert api.getObjectParent(attach) == hand


def test_ttt_wrist_reads_the_hand_and_the_attach_point_reads_nothing(gripper):
    sim, api = gripper
    _steps(sim, 4)
    state, force, torque = api.readForceSensor(api.getObject("/Wrist"))
    assert state == 1
    assert force == pytest.approx([0.0, 0.0, 0.4 * G], abs=1e-6)
    assert torque == pytest.approx([0.0, -0.05 * 0.4 * G, 0.0], abs=1e-6)
    assert api.readForceSensor(api.getObject("/AttachPoint")) == (0, [0.0] * 3, [0.0] * 3)  # no child


def test_grasped_cube_weighs_on_the_wrist_and_on_the_attach_point(gripper):
    sim, api = gripper
    wrist, attach, cube, lift = (api.getObject("/" + n) for n in ("Wrist", "AttachPoint", "Cube", "Lift"))
    x, y, z = api.getObjectPosition(attach, -1)
    api.setObjectPosition(cube, -1, [x, y, z - 0.02])
    api.setObjectParent(cube, attach, True)  # PyRep's Gripper.grasp
    _steps(sim, 4)
    assert api.readForceSensor(attach)[1] == pytest.approx([0.0, 0.0, 0.1 * G], rel=1e-3, abs=1e-6)
    state, force, torque = api.readForceSensor(wrist)
    assert state == 1
    assert force == pytest.approx([0.0, 0.0, 0.5 * G], rel=1e-3, abs=1e-6)  # hand and cube
    assert torque == pytest.approx([0.0, -0.05 * 0.5 * G, 0.0], rel=1e-3, abs=1e-6)
    _accelerate(api, lift, 30.0)  # lifted: the cube's inertial force too
    _steps(sim, 3)
    a = _acceleration(sim, lift)
    assert a > 5.0
    assert api.readForceSensor(wrist)[1] == pytest.approx([0.0, 0.0, 0.5 * (G + a)], rel=1e-3, abs=1e-6)
    assert api.readForceSensor(attach)[1] == pytest.approx([0.0, 0.0, 0.1 * (G + a)], rel=1e-3, abs=1e-6)
    api.setObjectParent(cube, -1, True)  # released: it falls, the sensors let it go
    _steps(sim, 1)
    assert api.readForceSensor(attach)[0] == 0
    assert api.readForceSensor(wrist)[1][2] == pytest.approx(0.4 * (G + _acceleration(sim, lift)), rel=1e-3)


@pytest.fixture
def palm(tmp_path):
    f = tmp_path / "palm.xml"
    f.write_text(PALM)
    sim, api = _sim(f)
    yield sim, api
    sim.close()


def test_created_sensor_reads_only_what_hangs_below_it(palm):
    """The audit's case: a sensor made at run time under a 0.5 kg palm, a 0.1 kg cube hung from
    it, reads the cube (0.98 N), not palm and cube (5.89 N)."""
    sim, api = palm
    hand, cube, lift = api.getObject("/palm"), api.getObject("/cube"), api.getObject("/lift")
    sensor = api.createForceSensor(0, [0, 1, 5, 0, 0], [0.02, 0, 0, 0, 0])
    assert api.readForceSensor(sensor) == (0, [0.0] * 3, [0.0] * 3)  # nothing below it yet
    api.setObjectPosition(sensor, -1, [0.0, 0.0, 0.98])  # under the palm, z up
    api.setObjectParent(sensor, hand, True)
    api.setObjectParent(cube, sensor, True)  # a dynamic shape: held by a weld
    assert api.getObjectParent(sensor) == hand and api.getObjectParent(cube) == sensor
    _steps(sim, 10)
    state, force, torque = api.readForceSensor(sensor)
    a = _acceleration(sim, lift)
    assert state == 1
    assert force == pytest.approx([0.0, 0.0, -0.1 * (G + a)], abs=1e-6)  # along gravity (-z)
    assert force[2] == pytest.approx(-0.1 * G, rel=0.01)
    assert torque == pytest.approx([0.0, 0.0, 0.0], abs=1e-6)  # the cube's centre is on the axis
    _accelerate(api, lift, 12.0)
    _steps(sim, 3)
    a = _acceleration(sim, lift)
    assert a > 5.0
    assert api.readForceSensor(sensor)[1] == pytest.approx([0.0, 0.0, -0.1 * (G + a)], abs=1e-6)
    assert api.getObjectPosition(cube, -1)[2] > 1.0  # it rose with the palm


def test_created_sensor_on_the_world_holds_and_weighs_a_cube(palm):
    """A force sensor fixed to the world holds its dynamic child, as CoppeliaSim's (a dynamic
    shape hangs from a force sensor rigidly): the cube stays, the sensor reads its weight."""
    sim, api = palm
    spare = api.getObject("/spare")
    sensor = api.createForceSensor(0, [0, 1, 5, 0, 0], [0.02, 0, 0, 0, 0])
    api.setObjectPosition(sensor, -1, [1.0, 0.0, 0.95])
    api.setObjectParent(spare, sensor, True)
    _steps(sim, 10)
    assert api.getObjectPosition(spare, -1)[2] == pytest.approx(0.9, abs=1e-4)
    state, force, torque = api.readForceSensor(sensor)
    assert state == 1
    assert force == pytest.approx([0.0, 0.0, -0.25 * G], abs=1e-6)
    assert torque == pytest.approx([0.0, 0.0, 0.0], abs=1e-6)


def test_created_sensor_between_arm_and_hand_weighs_the_grasp(palm):
    """A wrist sensor made at run time under the palm, a dynamic shape hung from it (the hand,
    held by its weld), a cube grasped by that hand (held to it): the wrist reads both."""
    sim, api = palm
    hand_body = api.getObject("/palm")
    cube, spare = api.getObject("/cube"), api.getObject("/spare")
    wrist = api.createForceSensor(0, [0, 1, 5, 0, 0], [0.02, 0, 0, 0, 0])
    api.setObjectPosition(wrist, -1, [0.0, 0.0, 0.98])
    api.setObjectParent(wrist, hand_body, True)
    hand = api.createPrimitiveShape(3, [0.05, 0.05, 0.02])  # sim.primitiveshape_cuboid, dynamic
    api.setShapeMass(hand, 0.3)
    api.setObjectPosition(hand, -1, [0.0, 0.0, 0.96])
    api.setObjectParent(hand, wrist, True)
    api.setObjectParent(cube, hand, True)  # grasped by the hand
    _steps(sim, 10)
    a = _acceleration(sim, api.getObject("/lift"))
    assert api.readForceSensor(wrist)[1] == pytest.approx([0.0, 0.0, -0.4 * (G + a)], abs=1e-6)
    # the palm's acceleration at the read is that of mj_forward after the held parts were put
    # back on their holders (simx_server/sim/grasps.follow): a soft weld there carries 99 %
    assert api.readForceSensor(wrist)[1][2] == pytest.approx(-0.4 * G, rel=0.02)
    api.setObjectParent(spare, hand_body, True)  # a part held by the palm, above the wrist
    _steps(sim, 2)
    a = _acceleration(sim, api.getObject("/lift"))
    assert api.readForceSensor(wrist)[1] == pytest.approx([0.0, 0.0, -0.4 * (G + a)], abs=1e-6)


# A 0.2 kg bob 0.5 m out on an arm that turns about z: the sensor (in the bob's body) reads the
# centripetal force m w^2 r as well as the weight.
SPIN = """<mujoco model="spin">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="turn" type="hinge" axis="0 0 1" damping="0"/>
      <geom type="box" size="0.02 0.02 0.02" mass="1" contype="0" conaffinity="0"/>
      <body name="bob" pos="0.5 0 0">
        <site name="ft"/>
        <geom type="sphere" size="0.02" mass="0.2" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <sensor><force name="ft_force" site="ft"/></sensor>
</mujoco>
"""


def test_a_reading_is_kept_only_while_the_state_is_the_same(mjcf, tmp_path):
    """child_wrench keeps its answer per state: a second read of the same state is the first,
    every write that changes what the sensor reads (with or without a step or World.changed)
    gives a new one, equal to one computed afresh."""
    from simx_server.sim import force_sensors

    sim, api = mjcf
    ft, load = api.getObject("/ft"), api.getObject("/load")
    _steps(sim, 4)
    d = sim.world.data

    def read_fresh():
        force_sensors._wrenches(d).clear()
        return api.readForceSensor(ft)

    first = api.readForceSensor(ft)
    assert api.readForceSensor(ft) == first == read_fresh()
    api.setArrayParam(0, [0.0, 0.0, -5.0])  # sim.arrayparam_gravity: no step, no World.changed
    lighter = api.readForceSensor(ft)
    assert lighter[1][2] == pytest.approx(0.6 * 5.0, abs=1e-6)
    assert lighter == read_fresh()
    api.addForce(load, [0.0, 0.0, 0.0], [0.0, 0.0, 1.0])  # applied for the next step, read now
    pushed = api.readForceSensor(ft)
    assert pushed[1][2] == pytest.approx(0.6 * 5.0 - 1.0, abs=1e-6)
    assert pushed == read_fresh()

    f = tmp_path / "spin.xml"
    f.write_text(SPIN)
    spin, sapi = _sim(f)
    try:
        sensor, w = sapi.getObject("/ft"), spin.world
        still = sapi.readForceSensor(sensor)[1]
        w.data.qvel[w.model.jnt_dofadr[w.get(sapi.getObject("/turn")).mj_id]] = 2.0
        w.changed()  # a write of the state: a new version
        turning = sapi.readForceSensor(sensor)[1]
        assert still[0] == pytest.approx(0.0, abs=1e-9)
        assert turning[0] == pytest.approx(0.2 * 2.0**2 * 0.5, rel=1e-6)  # pulled in, towards -x
    finally:
        spin.close()


def test_one_root_sums_as_numpy_sums():
    """_transmitted's plain-float path for one root gives the bits of numpy's (signed zeros too:
    numpy's sum of one row adds it to 0.0)."""
    from simx_server.sim.force_sensors import _cross_rows, _Side, _transmitted

    rng = np.random.default_rng(5)
    one = _Side(np.ones(4, bool), np.array([1]), np.array([2]), frozenset())
    for case in range(200):
        cfrc, com, site = rng.normal(size=(4, 6)), rng.normal(size=(4, 3)), rng.normal(size=3)
        if case % 3 == 0:
            cfrc[1, rng.integers(0, 6, 3)] = -0.0
            com[2], site[:] = 0.0, -0.0
        rows = cfrc[[1]]
        numpy_sum = np.concatenate([(rows[:, :3] + _cross_rows(com[[2]] - site, rows[:, 3:])).sum(axis=0),
                                    rows[:, 3:].sum(axis=0)])
        assert _transmitted(site, com, cfrc, one).tobytes() == numpy_sum.tobytes()
