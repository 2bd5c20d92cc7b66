"""``pyrep``'s objects over simx's API table, on a small MJCF scene (PyRep's own suite in
../shared covers the rest: test_pyrep_suite.py)."""

from __future__ import annotations

import numpy as np
import pytest

from pyrep import PyRep
from pyrep.const import JointType, ObjectType
from pyrep.errors import PyRepError, WrongObjectTypeError
from pyrep.objects import Dummy, Joint, Object, Shape, VisionSensor


def test_launch_step_stop_moves_and_resets_the_world(pr):
    cube = Shape("cube")
    start = cube.get_position()
    for _ in range(20):
        pr.step()
    assert cube.get_position()[2] < start[2]  # it falls
    pr.stop()
    assert np.allclose(cube.get_position(), start)  # the scene's initial state
    pr.step()  # stopped: nothing moves
    assert np.allclose(cube.get_position(), start)


def test_a_physics_blow_up_reaches_the_program_as_pyreps_error(tmp_path):
    """simx's PhysicsError is not one of PyRep's: a program catching RuntimeError (what PyRep's
    backend raises) catches it; the simulation is stopped and reset."""
    from pyrep.errors import CoppeliaSimError

    scene = tmp_path / "blow_up.xml"
    scene.write_text('<mujoco><option gravity="0 0 -1e20"/><worldbody><body name="ball" pos="0 0 1">'
                     '<freejoint/><geom type="sphere" size="0.1"/></body></worldbody></mujoco>')
    pr = PyRep()
    pr.launch(str(scene), headless=True)
    try:
        pr.start()
        with pytest.raises(CoppeliaSimError, match="physics became unstable") as caught:
            pr.step()
        assert type(caught.value).__module__ == "pyrep.errors" and isinstance(caught.value, RuntimeError)
        assert not pr.running and np.allclose(Shape("ball").get_position(), [0, 0, 1])
    finally:
        pr.shutdown()


def test_object_lookup_types_and_errors(pr):
    assert isinstance(Object.get_object("hinge"), Joint)
    assert Object.get_object_type("tip") == ObjectType.DUMMY
    assert Object.exists("cube") and not Object.exists("no_such_object")
    with pytest.raises(WrongObjectTypeError):
        Joint("cube")
    with pytest.raises(RuntimeError):
        Shape("no_such_object")
    assert [o.get_name() for o in Shape("base").get_objects_in_tree(exclude_base=False)] == \
        ["base", "hinge", "link", "tip"]


def test_pose_round_trips(pr):
    cube = Shape("cube")
    cube.set_position([0.1, 0.2, 0.5])
    assert np.allclose(cube.get_position(), [0.1, 0.2, 0.5])
    cube.set_orientation([0.1, -0.2, 0.3])
    assert np.allclose(cube.get_orientation(), [0.1, -0.2, 0.3])
    q = np.array([0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5)])
    cube.set_quaternion(q)
    assert np.allclose(cube.get_quaternion(), q) or np.allclose(cube.get_quaternion(), -q)
    m = cube.get_matrix()
    assert m.shape == (4, 4) and np.allclose(m[3], [0, 0, 0, 1])
    tip = Dummy("tip")
    assert np.allclose(tip.get_position(relative_to=Shape("link")), [0.4, 0, 0])


def test_rotate_about_own_axes(pr):
    cube = Shape("cube")
    cube.set_orientation([0.0, 0.0, 0.0])
    cube.rotate([0.02, 0.04, 0.06])
    assert np.allclose(cube.get_orientation(), [0.02, 0.04, 0.06])


def test_joint_control_reaches_target(pr):
    hinge = Joint("hinge")
    assert hinge.get_joint_type() == JointType.REVOLUTE
    hinge.set_joint_target_position(0.5)
    for _ in range(200):
        pr.step()
    assert hinge.get_joint_position() == pytest.approx(0.5, abs=0.02)
    hinge.set_joint_position(-0.3)
    assert hinge.get_joint_position() == pytest.approx(-0.3)
    cyclic, interval = hinge.get_joint_interval()
    assert not cyclic and np.allclose(interval, [-2, 4])


def test_shape_properties_and_configuration_tree(pr):
    cube = Shape("cube")
    cube.set_mass(0.8)
    assert cube.get_mass() == pytest.approx(0.8)
    cube.set_color([0.2, 0.4, 0.6])
    assert np.allclose(cube.get_color(), [0.2, 0.4, 0.6])
    assert np.allclose(cube.get_bounding_box(), [-0.05, 0.05] * 3)
    cube.set_bullet_friction(0.7)
    assert cube.get_bullet_friction() == pytest.approx(0.7)
    saved, pos = cube.get_configuration_tree(), cube.get_position()
    for _ in range(10):
        pr.step()
    assert not np.allclose(cube.get_position(), pos)
    pr.set_configuration_tree(saved)
    assert np.allclose(cube.get_position(), pos)


def test_vision_sensor_images_top_down(pr):
    cam = VisionSensor("cam")
    rgb, depth = cam.capture_rgb(), cam.capture_depth()
    assert rgb.shape == (24, 32, 3) and rgb.dtype == np.float32 and 0 <= rgb.min() and rgb.max() <= 1
    assert depth.shape == (24, 32)
    assert depth[0].mean() > depth[-1].mean()  # the top row sees farther than the floor below
    cam.set_resolution([16, 8])
    assert cam.capture_rgb().shape == (8, 16, 3)
    made = VisionSensor.create([8, 8])
    assert made.capture_rgb().sum() == 0  # not handled yet, as in CoppeliaSim
    pr.step()
    assert made.capture_rgb().shape == (8, 8, 3)
    # RLBench's gym render: a sensor made at run time, not explicit, placed at a dummy's pose,
    # shows the scene once a step has handled it (here the red cube below it, along its +z)
    above = VisionSensor.create([16, 16], view_angle=20.0, position=[0.5, 0.0, 0.9], orientation=[np.pi, 0, 0])
    pr.step()
    r, g, b = above.capture_rgb()[8, 8]
    assert r > 0.6 and g < r / 2 and b < r / 2


@pytest.fixture
def two(pyrep_scene):
    """Two PyRep instances of the small scene, launched and started; shut down after the test."""
    a, b = PyRep(), PyRep()
    a.launch(str(pyrep_scene), headless=True)
    b.launch(str(pyrep_scene), headless=True)
    try:
        a.start()
        b.start()
        yield a, b
    finally:
        a.shutdown()
        b.shutdown()


def test_two_instances_have_their_own_worlds(two):
    a, b = two
    b.make_current()
    Shape("cube").set_position([0.0, 0.0, 1.0])
    a.make_current()
    assert Shape("cube").get_position()[2] == pytest.approx(0.3)
    for _ in range(5):
        a.step()
    b.make_current()
    assert Shape("cube").get_position()[2] == pytest.approx(1.0)  # b did not step
    a.shutdown()
    b.shutdown()
    with pytest.raises(PyRepError):
        Shape("cube")


def test_objects_act_on_the_world_of_the_pyrep_they_were_made_in(two):
    """A Gymnasium SyncVectorEnv of RLBench environments: each environment's objects were made
    while its PyRep was current, and its action reaches them after another environment stepped
    (before, it moved the other environment's arm: the PyRep whose method was called last)."""
    a, b = two
    a.make_current()
    cube_a, hinge_a = Shape("cube"), Joint("hinge")
    b.make_current()
    cube_b, hinge_b = Shape("cube"), Joint("hinge")
    b.step()  # b is current
    cube_a.set_position([0.0, 0.0, 1.0])
    hinge_a.set_joint_position(0.7)
    assert cube_b.get_position()[2] < 0.31 and hinge_b.get_joint_position() == pytest.approx(0.0, abs=1e-6)
    assert cube_a.get_position()[2] == pytest.approx(1.0) and hinge_a.get_joint_position() == pytest.approx(0.7)
    looked_up = Shape("cube")  # a lookup goes to the current PyRep: a, whose object acted last
    assert looked_up.get_position()[2] == pytest.approx(1.0)


def test_a_spherical_joints_position_reads_zero_as_pyrep_gives_it(tmp_path):
    """CoppeliaSim 4.1 refuses simGetJointPosition on a spherical joint and PyRep's binding does
    not check the code: get_joint_position gives its zeroed buffer, 0.0 (RLBench's state vector of a
    rope); a revolute joint's refusal (none here) would still raise."""
    scene = tmp_path / "rope.xml"
    scene.write_text('<mujoco><worldbody><body name="link" pos="0 0 1"><joint name="ball_joint" type="ball"/>'
                     '<geom type="capsule" size="0.01 0.05" pos="0 0 -0.05"/></body></worldbody></mujoco>')
    pr = PyRep()
    pr.launch(str(scene), headless=True)
    try:
        pr.start()
        pr.step()
        joint = Joint("ball_joint")
        assert joint.get_joint_type() == JointType.SPHERICAL
        assert joint.get_joint_position() == 0.0
    finally:
        pr.shutdown()
