"""A part grasped by re-parenting (PyRep's ``Gripper.grasp``: ``sim.setObjectParent(part,
attachPoint, true)``) belongs to the robot's collections while it is held, as CoppeliaSim
actualizes every collection when the tree changes: the robot's ``tree`` collection then leaves
out the part against the gripper holding it (``checkCollision(collection, sim.handle_all)``), and
simOMPL's collision check carries the part with the arm, so a state where only the part hits an
obstacle is invalid (issue 58: RLBench's stack_blocks found no path after a grasp)."""

from __future__ import annotations

import math

import pytest

from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

# An arm turning about z; its link reaches 0.32 m, the attach site at 0.345 m where a free 5 cm
# box touches the link's end. A pillar at 90 degrees, 0.38 m out, misses the link and overlaps
# where the box goes when the arm turns there. No gravity: the box stays where it is put.
SCENE = """<mujoco model="carry">
  <option gravity="0 0 0"/>
  <compiler angle="radian"/>
  <worldbody>
    <body name="Arm" pos="0 0 0.3">
      <joint name="Turn" type="hinge" axis="0 0 1"/>
      <geom name="LinkGeom" type="capsule" fromto="0.03 0 0 0.3 0 0" size="0.02"/>
      <site name="Attach" pos="0.345 0 0"/>
    </body>
    <body name="Box" pos="0.345 0 0.3"><freejoint/><geom type="box" size="0.025 0.025 0.025" mass="0.1"/></body>
    <body name="Pillar" pos="0 0.38 0.3"><geom type="box" size="0.02 0.02 0.1"/></body>
  </worldbody>
  <custom><text name="simx:collection:Robot" data="items=+tree:Arm"/></custom>
</mujoco>
"""


@pytest.fixture
def rig(tmp_path):
    (tmp_path / "carry.xml").write_text(SCENE)
    s = Simulation(tmp_path / "carry.xml", realtime=False)
    s.start()
    sim = script_sim(s.world, s.world.resolve("Pillar").handle, s.signals, simulation=s)
    yield s, sim
    s.close()


def test_a_grasped_part_joins_the_robots_collections_until_released(rig):
    _, sim = rig
    robot, box = sim.getCollectionHandle("Robot"), sim.getObject("/Box")
    arm, attach = sim.getObject("/Arm"), sim.getObject("/Attach")
    mine = sim.createCollection()  # a run-time collection keeps its element, not its objects
    sim.addItemToCollection(mine, sim.handle_tree, arm, 0)
    assert box not in sim.getCollectionObjects(robot)
    result, pair = sim.checkCollision(robot, sim.handle_all)  # the box touches the link's end
    assert result == 1 and box in pair
    sim.setObjectParent(box, attach, True)
    for c in (robot, mine):
        assert box in sim.getCollectionObjects(c)
        assert sim.checkCollision(c, sim.handle_all) == (0, [-1, -1])  # held: part of the robot
    sim.setObjectParent(box, -1, True)
    for c in (robot, mine):
        assert box not in sim.getCollectionObjects(c)
        assert sim.checkCollision(c, sim.handle_all)[0] == 1
    sim.removeObjects([box])  # an element's removed object stands for nothing
    single = sim.createCollection()
    sim.addItemToCollection(single, sim.handle_single, sim.getObject("/Pillar"), 0)
    sim.removeObjects([sim.getObject("/Pillar")])
    assert sim.getCollectionObjects(single) == []


def test_planning_carries_the_grasped_part_with_the_arm(rig):
    pytest.importorskip("ompl")
    _, sim = rig
    ompl = sim.context.simompl
    turn = sim.getObject("/Turn")
    sim.setObjectParent(sim.getObject("/Box"), sim.getObject("/Attach"), True)
    task = ompl.createTask("carry")
    ompl.setStateSpace(task, [ompl.createStateSpace("turn", 50005, turn, [-math.pi], [math.pi], 1)])
    ompl.setCollisionPairs(task, [sim.getCollectionHandle("Robot"), sim.handle_all])
    ompl.setStartState(task, [0.0])
    ompl.setGoalState(task, [-math.pi / 2])
    ompl.setup(task)
    assert ompl.isStateValid(task, [0.0])  # the held box is not tested against its holder
    assert not ompl.isStateValid(task, [math.pi / 2])  # the carried box hits the pillar there
    assert ompl.isStateValid(task, [-math.pi / 2])
    sim.setJointPosition(turn, math.pi / 2)  # the same in the scene, for the check's own answer
    assert sim.checkCollision(sim.getCollectionHandle("Robot"), sim.handle_all)[0] == 1
    ompl.destroyTask(task)
