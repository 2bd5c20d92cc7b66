"""World in-process: registry, joint motors with V-REP's semantics, poses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import SCENE
from simx_client.protocol import ArgumentError, ObjectTypeError, UnknownObjectError
from simx_server.sim.world import JOINT, SHAPE, VISION_SENSOR, World

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


@pytest.fixture
def world():
    return World(SCENE, dt=0.05)


def test_registry_tree_and_types(world):
    j1, ur5 = world.resolve("UR5_joint1"), world.resolve("UR5")
    assert j1.type == JOINT and ur5.type == SHAPE and world.resolve("kinect_rgb").type == VISION_SENSOR
    assert j1.parent == ur5.handle  # V-REP's tree: UR5 -> UR5_joint1 -> UR5_link1 -> UR5_joint2 ...
    assert world.resolve("/UR5/UR5_joint1/UR5_joint2").name == "UR5_joint2"
    assert sorted(world.objects) == list(range(1, len(world.objects) + 1))
    with pytest.raises(UnknownObjectError):
        world.resolve("nope")
    with pytest.raises(ObjectTypeError):
        world.joint_position(ur5.handle)
    with pytest.raises(ArgumentError):
        world.set_joint_target_position(j1.handle, float("nan"))


def test_position_mode_respects_max_velocity_and_reaches_target(world):
    h = world.resolve("UR5_joint1").handle
    world.set_joint_target_position(h, math.radians(90))
    q, vmax = [], math.pi
    for _ in range(20):  # 1 s
        world.step()
        q.append(world.joint_position(h))
    speeds = np.abs(np.diff(q)) / world.dt
    assert speeds.max() <= vmax * 1.02, f"faster than 180 deg/s: {speeds.max()}"
    assert q[-1] == pytest.approx(math.radians(90), abs=math.radians(0.2))
    assert 0.4 < np.argmax(np.array(q) > math.radians(89)) * world.dt < 0.8  # ~0.5 s at 180 deg/s


def test_velocity_mode_and_torque_control_trick(world):
    g = world.resolve("RG2_openCloseJoint").handle
    q0 = world.joint_position(g)
    world.set_joint_force(g, 20.0)
    world.set_joint_target_velocity(g, -0.05)
    for _ in range(4):
        world.step()
    assert world.joint_position(g) == pytest.approx(q0 - 0.05 * 4 * world.dt, abs=0.003)
    world.set_joint_target_position(g, 0.01)  # stored, as V-REP does; the loop is off: no effect
    assert world.target_position[world.motor(g)] == 0.01
    world.step()
    assert world.joint_position(g) == pytest.approx(q0 - 0.05 * 5 * world.dt, abs=0.003)
    # A huge target velocity with a small max force: the motor applies exactly that force.
    world.set_joint_force(g, 3.0)
    world.set_joint_target_velocity(g, 100.0)
    world.step()
    assert world.joint_force(g) == pytest.approx(3.0, rel=1e-6)


def test_reset_restores_initial_state(world):
    h = world.resolve("UR5_joint2").handle
    world.set_joint_target_position(h, 0.5)
    world.set_joint_force(world.resolve("RG2_openCloseJoint").handle, 5.0)
    for _ in range(10):
        world.step()
    assert world.time == world.data.time == pytest.approx(10 * world.dt)  # noted at each step
    world.reset()
    assert world.joint_position(h) == 0.0 and world.time == 0.0 == world.data.time
    assert world.joint_max_force(world.resolve("RG2_openCloseJoint").handle) == pytest.approx(40.0)


def test_orientation_convention(world):
    # Euler angles read back rebuild the rotation as Rx(a) Ry(b) Rz(g).
    h = world.resolve("UR5_joint5").handle
    world.set_joint_position(world.resolve("UR5_joint2").handle, 0.4)
    world.set_joint_position(world.resolve("UR5_joint1").handle, 0.7)
    a, b, g = world.orientation(h, -1)
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(g), -math.sin(g), 0], [math.sin(g), math.cos(g), 0], [0, 0, 1]])
    _, r = world.frame(h)
    assert np.allclose(rx @ ry @ rz, r, atol=1e-9)
    x, y, z, w = world.quaternion(h, -1)
    assert np.linalg.norm([x, y, z, w]) == pytest.approx(1.0)
    # Relative to itself: identity.
    assert np.allclose(world.position(h, h), 0, atol=1e-12)


def test_reply_stamp_follows_the_run_state():
    """Simulation.stamp(), read once per reply: sim time in ms, state bits, scene id."""
    from simx_client import protocol as P
    from simx_server.scene.simulation import Simulation

    sim = Simulation(SCENE, 0.05)
    try:
        seen, scenes = [], set()
        for action in (lambda: None, sim.start, sim.step, sim.pause, sim.stop):
            action()
            seen.append(sim.stamp()[:2])
            scenes.add(sim.stamp()[2])
        assert seen == [(0, P.STATE_REALTIME), (0, 5), (50, 5), (50, 7), (0, P.STATE_REALTIME)]
        assert len(scenes) == 1 and 0 <= scenes.pop() <= 0xFFFF  # one scene, a 16-bit id
        sim.realtime = False
        assert sim.stamp()[1] == 0
    finally:
        sim.close()


def _state(data) -> dict:
    """Every array of an MjData, copied."""
    return {k: np.array(getattr(data, k)) for k in dir(data)
            if not k.startswith("_") and isinstance(getattr(data, k, None), np.ndarray)}


def test_one_change_leaves_the_state_of_one_change_per_write(world):
    """Joints placed inside World.one_change get one mj_forward at the end (PyRep's
    set_joint_positions): every array of MjData is what a forward after each write leaves."""
    import mujoco
    import threading

    for _ in range(3):  # moving, with contacts and constraint forces
        world.step()
    saved = mujoco.MjData(world.model)
    mujoco.mj_copyData(saved, world.model, world.data)
    joints = [world.resolve(f"UR5_joint{i}").handle for i in range(1, 7)]
    values = [0.3, -0.4, 0.5, -0.2, 0.1, 0.7]
    v0 = world.version
    for h, q in zip(joints, values):
        world.set_joint_position(h, q)
    each, each_version = _state(world.data), world.version - v0
    mujoco.mj_copyData(world.data, world.model, saved)
    v0 = world.version
    with world.one_change():
        with world.one_change():  # nests
            for h, q in zip(joints[:3], values[:3]):
                world.set_joint_position(h, q)
        assert world.version == v0  # held back until the outer block ends
        for h, q in zip(joints[3:], values[3:]):
            world.set_joint_position(h, q)
        other = threading.Thread(target=world.changed)  # another thread's change is not held back
        other.start()
        other.join()
        assert world.version == v0 + 1
    assert world.version == v0 + 2 and each_version == 6
    once = _state(world.data)
    assert sorted(once) == sorted(each)
    for k in each:
        assert np.array_equal(once[k], each[k], equal_nan=True), k
    with pytest.raises(ArgumentError):  # a block that raises still recomputes what it wrote
        with world.one_change():
            world.set_joint_position(joints[0], 0.0)
            world.set_joint_position(joints[1], float("inf"))
    assert world.version == v0 + 3 and world.joint_position(joints[0]) == 0.0
    poses = world.data.xpos.copy()
    mujoco.mj_forward(world.model, world.data)
    np.testing.assert_array_equal(world.data.xpos, poses)
