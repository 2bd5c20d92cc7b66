"""PyRep's robots on simx: PyRep's own Panda, PandaGripper and Baxter models (../shared/pyrep/robot_ttms,
skipped without it, failing under CI) imported into the small scene."""

from __future__ import annotations

import numpy as np
import pytest

from pyrep.const import PrimitiveShape
from pyrep.objects import Shape

try:
    from conftest import SHARED, require_shared
except ImportError:
    from tests.conftest import SHARED, require_shared

MODELS = SHARED / "pyrep" / "robot_ttms"


def test_panda_reaches_a_pose_through_get_path_and_step(pr):
    from pyrep.robots.arms.panda import Panda

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "arms" / "Panda.ttm")))
    pr.start()
    arm = Panda()
    tip = arm.get_tip()
    goal = tip.get_position() + np.array([0.1, 0.1, -0.1])
    path = arm.get_path(goal, quaternion=tip.get_quaternion())
    assert len(path) > 1
    steps = 0
    while not path.step():
        pr.step()
        steps += 1
        assert steps < 1000
    for _ in range(20):  # the position controllers settle on the last configuration
        pr.step()
    assert np.linalg.norm(tip.get_position() - goal) < 0.01
    # the IK solution for the goal is where the arm went
    assert np.allclose(arm.solve_ik_via_jacobian(goal, quaternion=tip.get_quaternion()),
                       arm.get_joint_positions(), atol=0.05)


def _gripper(pr):
    from pyrep.robots.end_effectors.panda_gripper import PandaGripper

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "end_effectors" / "PandaGripper.ttm")))
    return PandaGripper()


def test_baxters_arms_do_not_collide_with_its_torso_in_their_start_pose(pr):
    """Baxter's upper arm links lie 1.4 mm from its torso: their convex hulls overlap, their
    triangles do not (CoppeliaSim tests the triangles), so its arms start collision-free."""
    from pyrep.robots.arms.baxter import BaxterLeft, BaxterRight

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "arms" / "Baxter.ttm")))
    pr.start()
    for arm in (BaxterLeft(), BaxterRight()):
        assert not arm.check_arm_collision()


def test_panda_gripper_closes_and_opens(pr):
    from pyrep.backend import sim

    gripper = _gripper(pr)
    sim.call("setArrayParam", sim.sim_arrayparam_gravity, [0.0, 0.0, 0.0])  # the hand floats
    pr.start()
    assert np.allclose(gripper.get_open_amount(), [1.0, 1.0], atol=0.01)
    for target, check in ((0.0, lambda a: max(a) < 0.1), (1.0, lambda a: min(a) > 0.9)):
        steps = 0
        while not gripper.actuate(target, 0.04):
            pr.step()
            steps += 1
            assert steps < 200
        assert check(gripper.get_open_amount())


@pytest.fixture
def panda_scene():
    """PyRep's Panda (with its gripper) in the empty scene, a static table below its tip and a
    4 cm cube of 50 g on it, under the tip."""
    from pyrep import PyRep
    from pyrep.robots.arms.panda import Panda
    from pyrep.robots.end_effectors.panda_gripper import PandaGripper

    pr = PyRep()
    pr.launch("", headless=True)
    try:
        pr.import_model(str(require_shared(MODELS / "arms" / "Panda.ttm")))
        arm, gripper = Panda(), PandaGripper()
        centre = arm.get_tip().get_position() + np.array([0.0, 0.0, -0.25])
        top = centre[2] - 0.02
        Shape.create(PrimitiveShape.CUBOID, [0.3, 0.3, top], static=True, position=[centre[0], centre[1], top / 2])
        cube = Shape.create(PrimitiveShape.CUBOID, [0.04, 0.04, 0.04], mass=0.05, position=list(centre))
        pr.start()
        yield pr, arm, gripper, cube
    finally:
        pr.shutdown()


def _move_tip(pr, arm, position, quaternion) -> None:
    """``get_path`` to ``position`` (m), followed with ``step()`` until its end, then settled."""
    path = arm.get_path(position, quaternion=quaternion)
    steps = 0
    while not path.step():
        pr.step()
        steps += 1
        assert steps < 500
    for _ in range(10):
        pr.step()


def test_panda_gripper_grasps_lifts_and_releases_a_cube(panda_scene):
    pr, arm, gripper, cube = panda_scene
    tip = arm.get_tip()
    down = tip.get_quaternion()
    start = cube.get_position()
    _move_tip(pr, arm, start + [0.0, 0.0, 0.1], down)
    _move_tip(pr, arm, start, down)
    steps = 0
    while not gripper.actuate(0.0, 0.1):  # the fingers stop on the cube's sides
        pr.step()
        steps += 1
        assert steps < 200
    assert 0.3 < np.mean(gripper.get_open_amount()) < 0.7  # 4 cm of the 8 cm opening
    assert gripper.grasp(cube)
    assert cube.get_parent() is not None and gripper.get_grasped_objects() == [cube]
    _move_tip(pr, arm, start + [0.0, 0.0, 0.2], down)
    lifted = cube.get_position()
    assert lifted[2] == pytest.approx(start[2] + 0.2, abs=0.01)  # it rose with the hand
    assert np.linalg.norm(lifted - tip.get_position()) < 0.01  # between the fingers
    gripper.release()
    assert cube.get_parent() is None and gripper.get_grasped_objects() == []
    steps = 0
    while not gripper.actuate(1.0, 0.1):
        pr.step()
        steps += 1
        assert steps < 200
    for _ in range(20):
        pr.step()
    assert cube.get_position()[2] == pytest.approx(start[2], abs=0.005)  # fell back onto the table
    assert tip.get_position()[2] > start[2] + 0.15  # and the hand stayed up


def test_panda_wrist_sensor_weighs_a_grasped_cube(panda_scene):
    """PyRep's Panda has a force sensor between its flange and its hand (``Panda_attachment``)
    and one for the grasped part (``Panda_gripper_attachPoint``): with the cube grasped and
    lifted, the wrist reads the hand's weight plus the cube's (as CoppeliaSim's sensor, the
    weight along gravity in the sensor's frame); the attach point reads the cube's share that
    the fingers' friction does not carry."""
    from pyrep.objects import ForceSensor

    pr, arm, gripper, cube = panda_scene
    wrist, attach = ForceSensor("Panda_attachment"), ForceSensor("Panda_gripper_attachPoint")
    tip = arm.get_tip()
    down = tip.get_quaternion()
    start = cube.get_position()
    weight = 0.05 * 9.81

    def settled_wrist():
        for _ in range(60):
            pr.step()
        return np.array(wrist.read()[0])

    _move_tip(pr, arm, start + [0.0, 0.0, 0.2], down)
    hand = settled_wrist()
    assert attach.read() == ([0.0] * 3, [0.0] * 3)  # nothing hangs from it yet
    gravity = wrist.get_matrix()[:3, :3].T @ [0.0, 0.0, -1.0]  # in the sensor's frame
    assert hand @ gravity == pytest.approx(np.linalg.norm(hand), rel=1e-3)  # the hand's weight, along gravity
    _move_tip(pr, arm, start, down)
    steps = 0
    while not gripper.actuate(0.0, 0.1):
        pr.step()
        steps += 1
        assert steps < 200
    assert gripper.grasp(cube)
    _move_tip(pr, arm, start + [0.0, 0.0, 0.2], down)
    extra = settled_wrist() - hand
    assert extra @ gravity == pytest.approx(weight, rel=0.03)  # the cube's weight, along gravity
    assert np.linalg.norm(extra) == pytest.approx(weight, rel=0.03)
    assert 0.0 < np.array(attach.read()[0]) @ gravity <= weight * 1.03


def test_panda_reaches_a_dummy_through_get_path_and_step(panda_scene):
    """RLBench's waypoints are dummies: the tip goes to one's position and orientation."""
    from pyrep.objects import Dummy

    pr, arm, _, cube = panda_scene
    tip = arm.get_tip()
    waypoint = Dummy.create(0.01)
    waypoint.set_position(tip.get_position() + np.array([-0.1, 0.15, -0.05]))
    waypoint.set_orientation(tip.get_orientation() + np.array([0.0, 0.0, 0.4]))
    _move_tip(pr, arm, waypoint.get_position(), waypoint.get_quaternion())
    assert np.linalg.norm(tip.get_position() - waypoint.get_position()) < 0.01
    relative = tip.get_quaternion(relative_to=waypoint)
    assert abs(relative[3]) > np.cos(0.05 / 2)  # within 0.05 rad of the dummy's orientation


def test_turtlebot_drives_forward_on_its_wheels(pr):
    from pyrep.robots.mobiles.turtlebot import TurtleBot

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "mobiles" / "turtlebot.ttm")))
    bot = TurtleBot()
    pr.start()
    bot.set_2d_pose([1.0, 1.0, 0.0])
    start = bot.get_2d_pose()
    bot.set_base_angular_velocites([5.0, 5.0])
    for _ in range(40):
        pr.step()
    x, y, yaw = bot.get_2d_pose() - start
    assert x > 0.1 and abs(y) < 0.02 and abs(yaw) < 0.05  # straight ahead along its x axis
    linear, angular = bot.get_base_velocities()
    assert linear > 0 and abs(angular) < 0.05


def test_panda_in_the_empty_scene_follows_joint_velocities():
    """The empty scene steps physics at CoppeliaSim's 5 ms: velocity control of an arm is stable."""
    from pyrep import PyRep
    from pyrep.robots.arms.panda import Panda

    pr = PyRep()
    pr.launch("", headless=True)
    try:
        pr.import_model(str(require_shared(MODELS / "arms" / "Panda.ttm")))
        pr.start()
        arm = Panda()
        arm.set_control_loop_enabled(False)
        arm.set_joint_target_velocities([0.1] * 7)
        for _ in range(20):
            pr.step()
        assert np.allclose(arm.get_joint_velocities(), 0.1, atol=0.01)
    finally:
        pr.shutdown()


def test_baxter_suction_cup_grasp_is_a_second_child_that_nothing_holds(pr):
    """PyRep's suction-cup ``grasp`` parents the part to the cup's connection force sensor, whose
    child is already the cup's loop-closure dummy: a force sensor of two children links nothing
    (simExtDynamics 4.1 ``CRigidBodyContainerDyn::_addOrUpdateForceSensorConstraint``:
    ``forceSensorChildListSize==1``), so the part is grasped in V-REP's tree but falls when lifted
    off, as on CoppeliaSim; release gives it back to its parent."""
    from pyrep.objects.proximity_sensor import ProximitySensor
    from pyrep.robots.end_effectors.baxter_suction_cup import BaxterSuctionCup

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "end_effectors" / "BaxterSuctionCup.ttm")))
    cup = BaxterSuctionCup()
    cup.set_dynamic(False)  # held in the air, as on an arm
    cup.set_position([0.5, 0.5, 0.5])
    tip = ProximitySensor("BaxterSuctionCup_sensor").get_position()  # it looks up, along +z
    part = Shape.create(PrimitiveShape.CUBOID, [0.04, 0.04, 0.04], position=[tip[0], tip[1], tip[2] + 0.025],
                        static=True)
    far = Shape.create(PrimitiveShape.CUBOID, [0.04, 0.04, 0.04], position=[0, 0, 0.02], static=True)
    pr.start()
    pr.step()
    part.set_dynamic(True)
    assert not cup.grasp(far) and cup.grasp(part) and cup.get_grasped_objects() == [part]
    start = part.get_position()
    part.set_position(start + np.array([0.0, 0.0, 0.05]))  # lifted 5 cm off the cup: held, it would stay
    for _ in range(10):
        pr.step()
    assert part.get_position()[2] < start[2] + 0.005  # nothing holds it: it fell back onto the cup
    cup.release()
    assert cup.get_grasped_objects() == [] and part.get_parent() is None


def test_panda_ik_via_jacobian_is_its_groups_own(pr):
    """PyRep's ``solve_ik_via_jacobian`` is ``simCheckIkGroup`` on the model's ``Panda_ik`` group:
    6 pseudo-inverse iterations to 0.5 mm, as the model saved it. A tip 0.1 m lower is found
    (the arm and its target's solution stay apart: the arm is not moved); 0.4 m is too far for
    those 6 steps, the IKError PyRep's example_panda_ik falls back on."""
    from pyrep.errors import IKError
    from pyrep.robots.arms.panda import Panda

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "arms" / "Panda.ttm")))
    pr.start()
    arm = Panda()
    start = arm.get_joint_positions()
    (x, y, z), q = arm.get_tip().get_position(), arm.get_tip().get_quaternion()
    near = arm.solve_ik_via_jacobian([x, y, z - 0.1], quaternion=q)
    assert np.allclose(arm.get_joint_positions(), start) and not np.allclose(near, start, atol=0.05)
    with pytest.raises(IKError):
        arm.solve_ik_via_jacobian([x, y, z - 0.4], quaternion=q)


def test_a_joint_set_by_its_narrowed_interval_leads_the_ik_as_in_rlbenchs_erjointviaik(pr):
    """RLBench's ``ERJointViaIK``: joint 0 is commanded to an angle by narrowing its interval
    around it (CoppeliaSim moves a joint outside a new interval into it), the IK then holds it
    (``locked_joints``: left out of ``simCheckIkGroup``) and solves the others for a tip 5 cm
    further along its z; once every joint has reached its target the tip is there. Held where
    it was, joint 0 turning afterwards swept the tip 0.14 m away."""
    from pyrep.robots.arms.panda import Panda

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "arms" / "Panda.ttm")))
    pr.start()
    arm = Panda()
    tip, j0 = arm.get_tip(), arm.joints[0]
    goal = tip.get_position() + tip.get_matrix()[:3, 2] * 0.05
    angle, eps = j0.get_joint_position() + 0.5, 1e-3
    cyclic, interval = j0.get_joint_interval()
    j0.set_joint_interval(cyclic, [angle - eps, 2 * eps])
    assert j0.get_joint_position() == pytest.approx(angle - eps)
    others = arm.solve_ik_via_jacobian(goal, quaternion=tip.get_quaternion(), locked_joints=[0])
    j0.set_joint_interval(cyclic, interval)
    arm.set_joint_target_positions([angle, *others])
    for _ in range(50):
        pr.step()
    assert np.linalg.norm(tip.get_position() - goal) < 0.01


@pytest.mark.parametrize("max_velocity", [1.0, 8.0])
def test_a_path_is_timed_by_its_length_as_pyreps_reflexxes_motion(pr, max_velocity):
    """PyRep moves along a path by its length in joint space, at the arm's ``max_velocity``
    (rad/s) and ``max_acceleration`` (4 rad/s2), slowed where a joint would exceed its own
    velocity limit, one simulation step per ``step()`` (``_get_rml_handle``, ``_step_motion``):
    a 0.8 rad move of one joint at 1 rad/s is done in 1.05 s of motion (0.8 / 1 + 1 / 4)
    whatever the number of its points, not one point per step; asked 8 rad/s, the Panda's
    joint limit (2.175 rad/s) bounds it."""
    from pyrep.robots.arms.panda import Panda
    from pyrep.robots.configuration_paths.arm_configuration_path import ArmConfigurationPath

    pr.stop()
    pr.import_model(str(require_shared(MODELS / "arms" / "Panda.ttm")))
    pr.start()
    arm = Panda(max_velocity=max_velocity)
    start = np.array(arm.get_joint_positions())
    end = start.copy()
    end[3] += 0.8
    dt = 0.05
    for points in (2, 200):
        path = ArmConfigurationPath(arm, np.linspace(start, end, points))
        targets = [start]
        while True:
            done = path.step()
            targets.append(np.array(arm.get_joint_target_positions()))
            if done:
                break
        speeds = np.abs(np.diff(targets, axis=0)).max(axis=1) / dt
        limit = min(max_velocity, arm.joints[3].get_joint_upper_velocity_limit())
        assert np.allclose(targets[-1], end)
        assert speeds.max() <= limit * 1.002
        # 0.8 / v + v / a where the top speed is reached (0.8 > v^2 / a), else 2 sqrt(0.8 / a);
        # the jerk limit (1000 rad/s3) adds 4 ms
        duration = 0.8 / limit + limit / 4.0 if 0.8 > limit ** 2 / 4.0 else 2 * np.sqrt(0.8 / 4.0)
        assert len(targets) - 1 in (int(np.ceil(duration / dt)), int(np.ceil(duration / dt)) + 1)
        path.set_to_start()
