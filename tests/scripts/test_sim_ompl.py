"""simOMPL on OMPL's Python bindings: a planar two-link arm must fold past a pillar that the
straight joint-space line hits. Planned from Python (the table in-process), from a Lua child
script (collision pairs and a Lua validation callback), and from the official ZMQ client
against a real server; the simulation's state is not moved by planning."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import ServerProcess, free_port
from simx_client.protocol import ArgumentError, UnsupportedError
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read here
pytest.importorskip("ompl")

#: Link1 (0.4 m) and Link2 (0.3 m) turn about z at the origin; the pillar stands at 0.5 m on +y,
#: so turning Joint1 from 0 to 2.5 rad with the arm stretched hits it, folded (Joint2 near
#: ±2.5 rad, the elbow within 0.43 m) it passes.
SCENE = """<mujoco model="ompl">
  <compiler angle="radian"/>
  <worldbody>
    <body name="Link1" pos="0 0 0.3">
      <joint name="Joint1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0.03 0 0 0.4 0 0" size="0.03"/>
      <body name="Link2" pos="0.4 0 0">
        <joint name="Joint2" type="hinge" axis="0 0 1" range="-2.8 2.8" limited="true"/>
        <geom type="capsule" fromto="0.04 0 0 0.3 0 0" size="0.03"/>
      </body>
    </body>
    <body name="Pillar" pos="0 0.5 0.3"><geom type="box" size="0.03 0.03 0.2"/></body>
  </worldbody>
  <custom>{script}</custom>
</mujoco>
"""
START, GOAL = [0.0, 0.0], [2.5, 0.0]
JOINT_POSITION, RRT_CONNECT = 50005, 30017  # simOMPL.StateSpaceType.joint_position, Algorithm.RRTConnect

LUA = """
function sysCall_init()
    local j1, j2 = sim.getObject('/Joint1'), sim.getObject('/Link1/Joint2')
    local pillar = sim.getObject('/Pillar')
    local task = simOMPL.createTask('t')
    simOMPL.setAlgorithm(task, simOMPL.Algorithm.RRTConnect)
    simOMPL.setStateSpace(task, {
        simOMPL.createStateSpace('j1', simOMPL.StateSpaceType.joint_position, j1, {-3}, {3}, 1),
        simOMPL.createStateSpace('j2', simOMPL.StateSpaceType.joint_position, j2, {-2.8}, {2.8}, 1)})
    simOMPL.setCollisionPairs(task, {sim.getObject('/Link1'), pillar, sim.getObject('/Link1/Link2'), pillar})
    simOMPL.setStartState(task, {0, 0})
    simOMPL.setGoalState(task, {2.5, 0})
    simOMPL.setup(task)
    local solved, path = simOMPL.compute(task, 10, -1, 0)
    sim.setInt32Signal('solved', solved and 1 or 0)
    sim.setInt32Signal('states', simOMPL.getPathStateCount(task, path))
    local last = simOMPL.getPathState(task, path, -1)
    sim.setFloatSignal('lastJoint1', last[1])
    sim.setStringSignal('path', sim.packDoubleTable(path))
    -- a Lua callback instead of the pairs: Joint2 must stay at or below 0.1 rad
    simOMPL.setStateValidationCallback(task, function(state) return state[2] <= 0.1 end)
    simOMPL.setup(task)
    local ok, path2 = simOMPL.compute(task, 10, -1, 20)
    local highest = -10
    for i = 2, #path2, 2 do highest = math.max(highest, path2[i]) end
    sim.setFloatSignal('highestJoint2', ok and highest or 99)
    simOMPL.destroyTask(task)
end
"""


def _collides(sim, joints, q) -> bool:
    for j, v in zip(joints, q):
        sim.setJointPosition(j, float(v))
    return any(sim.checkCollision(sim.getObject(link), sim.getObject("/Pillar"))[0]
               for link in ("/Link1", "/Link1/Link2"))


@pytest.fixture
def rig(tmp_path):
    (tmp_path / "ompl.xml").write_text(SCENE.format(script=""))
    s = Simulation(tmp_path / "ompl.xml", realtime=False)
    sim = script_sim(s.world, s.world.resolve("Pillar").handle, s.signals, simulation=s)
    yield s, sim, sim.context.simompl
    s.close()


def _task(sim, ompl, pairs=True):
    joints = [sim.getObject("/Joint1"), sim.getObject("/Link1/Joint2")]
    task = ompl.createTask("arm")
    ompl.setAlgorithm(task, ompl.Algorithm["RRTConnect"])
    ompl.setStateSpace(task, [ompl.createStateSpace("j1", JOINT_POSITION, joints[0], [-3], [3], 1),
                              ompl.createStateSpaceForJoint("j2", joints[1], 1)])
    if pairs:
        pillar = sim.getObject("/Pillar")
        ompl.setCollisionPairs(task, [sim.getObject("/Link1"), pillar, sim.getObject("/Link1/Link2"), pillar])
    ompl.setStartState(task, START)
    ompl.setGoalState(task, GOAL)
    return task, joints


def test_a_path_folds_past_the_pillar_that_the_straight_line_hits(rig):
    s, sim, ompl = rig
    task, joints = _task(sim, ompl)
    assert ompl.getStateSpaceDimension(task) == 2
    ompl.setup(task)
    qpos = s.world.data.qpos.copy()
    solved, states = ompl.compute(task, 10.0, -1.0, 0)  # 0: the states OMPL checked along the path
    assert np.array_equal(s.world.data.qpos, qpos)  # planning left the simulation as it was
    assert solved and ompl.hasExactSolution(task) and ompl.getGoalDistance(task) == 0
    path = np.array(states).reshape(-1, 2)
    assert path[0] == pytest.approx(START) and path[-1] == pytest.approx(GOAL)
    assert max(abs(path[:, 1])) > 1.0  # it folded
    straight = [np.add(START, f * np.subtract(GOAL, START)) for f in np.linspace(0, 1, 60)]
    assert any(_collides(sim, joints, q) for q in straight)
    assert not any(_collides(sim, joints, q) for q in path)
    count = 10 * len(path)
    ompl.interpolatePath(task, count)
    states = ompl.getPath(task)
    assert ompl.getPathStateCount(task, states) == count
    assert ompl.getPathState(task, states, -1) == pytest.approx(GOAL)
    assert np.array(ompl.getReversedPath(task, states)).reshape(-1, 2)[0] == pytest.approx(GOAL)
    assert not ompl.isStateValid(task, [math.pi / 2, 0.0]) and ompl.isStateValid(task, [math.pi / 2, 2.5])
    ompl.destroyTask(task)
    with pytest.raises(ArgumentError, match="no simOMPL task"):
        ompl.solve(task, 1.0)


def test_each_of_the_bound_planners_solves_it(rig):
    _, sim, ompl = rig
    task, joints = _task(sim, ompl)
    for name in ("BKPIECE1", "KPIECE1", "LBKPIECE1", "PRM", "RRT"):
        ompl.setAlgorithm(task, ompl.Algorithm[name])
        ompl.setup(task)
        assert ompl.solve(task, 10.0) and ompl.hasExactSolution(task), name
        ompl.simplifyPath(task)
        ompl.interpolatePath(task)
        assert not any(_collides(sim, joints, q) for q in np.array(ompl.getPath(task)).reshape(-1, 2)), name


def test_a_python_validation_callback_replaces_the_pairs(rig):
    _, sim, ompl = rig
    task, _ = _task(sim, ompl, pairs=False)
    seen = []
    ompl.setStateValidationCallback(task, lambda q: seen.append(q) or q[1] <= 0.1)
    ompl.setup(task)
    solved, states = ompl.compute(task, 10.0, -1.0, 30)
    assert solved and max(np.array(states).reshape(-1, 2)[:, 1]) <= 0.1
    assert seen and all(len(q) == 2 for q in seen)
    ompl.setStateValidationCallback(task, lambda q: 1 / 0)
    ompl.setup(task)
    with pytest.raises(ArgumentError, match="validation callback failed: division by zero"):
        ompl.solve(task, 1.0)


def test_errors_name_what_is_wrong(rig):
    _, sim, ompl = rig
    task, joints = _task(sim, ompl)
    with pytest.raises(UnsupportedError, match="no SBL planner; they have .*RRTConnect"):
        ompl.setAlgorithm(task, ompl.Algorithm["SBL"])
    with pytest.raises(ArgumentError, match="Invalid motion planning algorithm: 7"):
        ompl.setAlgorithm(task, 7)
    with pytest.raises(ArgumentError, match="Expected 2, got 3"):
        ompl.setStartState(task, [0, 0, 0])
    with pytest.raises(UnsupportedError, match="type pose2d is not supported"):
        ompl.createStateSpace("p", ompl.StateSpaceType["pose2d"], joints[0], [0, 0], [1, 1], 0)
    with pytest.raises(ArgumentError, match="must be below"):
        ompl.createStateSpace("j", JOINT_POSITION, joints[0], [1], [-1], 0)
    with pytest.raises(ArgumentError, match="setup"):
        ompl.solve(task, 1.0)
    empty = ompl.createTask("empty")
    with pytest.raises(ArgumentError, match="no state space"):
        ompl.setup(empty)


def test_a_lua_child_script_plans_with_pairs_and_a_callback(tmp_path):
    (tmp_path / "plan.lua").write_text(LUA)
    (tmp_path / "ompl.xml").write_text(SCENE.format(script='<text name="simx:Pillar" data="child_script=plan.lua"/>'))
    s = Simulation(tmp_path / "ompl.xml", realtime=False)
    try:
        s.start()
        sim = script_sim(s.world, s.world.resolve("Pillar").handle, s.signals, simulation=s)
        assert s.signals.get_int("solved") == 1 and s.signals.get_int("states") > 30
        assert sim.getFloatSignal("lastJoint1") == pytest.approx(2.5)
        path = np.array(sim.unpackDoubleTable(sim.getStringSignal("path"))).reshape(-1, 2)
        joints = [sim.getObject("/Joint1"), sim.getObject("/Link1/Joint2")]
        assert not any(_collides(sim, joints, q) for q in path)
        assert sim.getFloatSignal("highestJoint2") <= 0.1
    finally:
        s.close()


def test_a_zmq_client_plans_with_the_official_client(tmp_path, official):
    (tmp_path / "ompl.xml").write_text(SCENE.format(script=""))
    port = free_port()
    srv = ServerProcess(str(tmp_path / "ompl.xml"), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    try:
        client = official(port)
        sim, simOMPL = client.require("sim"), client.require("simOMPL")  # noqa: N806 (CoppeliaSim's name)
        j1, j2, pillar = sim.getObject("/Joint1"), sim.getObject("/Link1/Joint2"), sim.getObject("/Pillar")
        task = simOMPL.createTask("t")
        simOMPL.setAlgorithm(task, simOMPL.Algorithm.RRTConnect)
        simOMPL.setStateSpaceForJoints(task, [j1, j2], [1, 1])
        simOMPL.setCollisionPairs(task, [sim.getObject("/Link1"), pillar, sim.getObject("/Link1/Link2"), pillar])
        simOMPL.setStartState(task, START)
        simOMPL.setGoalStates(task, [GOAL, [-2.5, 0.0]])
        simOMPL.setup(task)
        solved, states = simOMPL.compute(task, 10.0, -1.0, 0)
        path = np.array(states).reshape(-1, 2)
        assert solved and len(path) > 30 and path[-1, 0] == pytest.approx(2.5 if path[-1, 0] > 0 else -2.5)
        assert not any(_collides(sim, [j1, j2], q) for q in path)
        with pytest.raises(Exception, match=r"simOMPL\.setAlgorithm: .*no SBL planner"):
            simOMPL.setAlgorithm(task, simOMPL.Algorithm.SBL)
        with pytest.raises(Exception, match="ZMQ client cannot pass"):
            simOMPL.setStateValidationCallback(task, "valid")
    finally:
        srv.stop()
