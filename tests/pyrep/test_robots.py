"""PyRep's robots on simx: PyRep's own Panda and PandaGripper models (../shared/pyrep/robot_ttms,
skipped without it, failing under CI) imported into the small scene."""

from __future__ import annotations

import numpy as np
import pytest

from pyrep.const import PrimitiveShape
from pyrep.errors import CoppeliaSimError
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


@pytest.mark.xfail(raises=CoppeliaSimError, strict=False,
                   reason="sim.setObjectParent of a free (dynamic) shape to a moving parent is being made "
                          "to work in the engine on another branch (h50-grasp)")
def test_panda_gripper_grasps_a_cube(pr):
    gripper = _gripper(pr)
    tip = Shape("Panda_gripper").get_objects_in_tree()[1]  # Panda_tip
    cube = Shape.create(PrimitiveShape.CUBOID, [0.02, 0.02, 0.02], mass=0.05, position=tip.get_position())
    pr.start()
    assert gripper.grasp(cube)
    assert cube.get_parent() is not None


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
