"""simIK on MuJoCo (issue 32): environments, groups and elements from the scene, solving with
damped least squares, configurations, paths; in-process on the bundled UR5 IK scene through the
one facade that serves scripts and ZMQ clients."""

from __future__ import annotations

import math

import pytest

from conftest import ROOT
from simx_client.protocol import ArgumentError, UnknownObjectError
from simx_server.scene.simulation import Simulation
from simx_server.api import script_sim
from simx_server.api import SIMIK

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

UR5 = ROOT / "scenes" / "ur5_ik.xml"


@pytest.fixture
def rig():
    s = Simulation(UR5, realtime=False)
    sim = script_sim(s.world, s.world.resolve("UR5").handle, s.signals, simulation=s)
    yield s, sim, sim.context.simik
    s.close()


def _group(sim, ik, constraints=31):
    env = ik.createEnvironment()
    g = ik.createGroup(env, "arm")
    ik.setGroupCalculation(env, g, 1, 0.05, 100)  # simIK.method_damped_least_squares
    el, sim_to_ik, ik_to_sim = ik.addElementFromScene(env, g, sim.getObject("/UR5"), sim.getObject("/UR5_tip"),
                                                      sim.getObject("/UR5_target"), constraints)
    assert sim_to_ik[sim.getObject("/UR5_tip")] == sim.getObject("/UR5_tip")
    return env, g, el


def _target_moved(sim, ik):
    """A full-pose group, its joints, the UR5's tip and target, and where the target was before
    it moved 6 cm along y."""
    env, g, _ = _group(sim, ik)
    tip, target = sim.getObject("/UR5_tip"), sim.getObject("/UR5_target")
    pos = sim.getObjectPosition(target, -1)
    sim.setObjectPosition(target, -1, [pos[0], pos[1] + 0.06, pos[2]])
    return env, g, ik.getGroupJoints(env, g), tip, target, pos


def test_handle_group_reaches_a_moved_target_and_syncs_the_scene(rig):
    s, sim, ik = rig
    env, g, el = _group(sim, ik)
    target, tip = sim.getObject("/UR5_target"), sim.getObject("/UR5_tip")
    pos = sim.getObjectPosition(target, -1)
    sim.setObjectPosition(target, -1, [pos[0] + 0.05, pos[1] - 0.04, pos[2] - 0.03])
    joints = ik.getGroupJoints(env, g)
    assert len(joints) == 6 and all(sim.getObjectType(j) == sim.object_joint_type for j in joints)
    result, flags, precision = ik.handleGroup(env, g, {"syncWorlds": True})
    assert result == 1 and flags == 0 and precision[0] < 1e-3
    assert ik.getObjectPose(env, tip)[:3] == pytest.approx(sim.getObjectPosition(target, -1), abs=1e-3)
    # the scene's motors got the solution as their target positions
    assert [sim.getJointTargetPosition(j) for j in joints] == pytest.approx([ik.getJointPosition(env, j) for j in joints])


def test_element_settings_round_trip_and_errors(rig):
    _, sim, ik = rig
    env, g, el = _group(sim, ik, 7)
    assert ik.getElementConstraints(env, g, el) == 7
    ik.setElementWeights(env, g, el, [1, 0.5])
    ik.setElementPrecision(env, g, el, [0.002, 0.01])
    assert ik.getElementWeights(env, g, el) == [1, 0.5] and ik.getElementPrecision(env, g, el) == [0.002, 0.01]
    assert ik.getGroupCalculation(env, g) == (1, 0.05, 100)
    assert ik.getGroupHandle(env, "arm") == g and ik.doesGroupExist(env, "UR5")  # the scene's group too
    ik.setElementFlags(env, g, el, 0)  # disabled: nothing to solve
    assert ik.handleGroup(env, g)[0] == 0
    with pytest.raises(UnknownObjectError):
        ik.handleGroup(env + 7, g)
    with pytest.raises(ArgumentError):
        ik.setGroupCalculation(env, g, 9, 0.1, 10)


def test_find_configs_and_generate_path(rig):
    _, sim, ik = rig
    env, g, joints, tip, target, pos = _target_moved(sim, ik)
    configs = ik.findConfigs(env, g, joints, {"maxTime": 2, "findMultiple": False})
    assert len(configs) == 1 and len(configs[0]) == 6
    for j, q in zip(joints, configs[0]):
        ik.setJointPosition(env, j, q)
    assert ik.getObjectPose(env, tip)[:3] == pytest.approx(sim.getObjectPosition(target, -1), abs=1e-3)
    sim.setObjectPosition(target, -1, [pos[0], pos[1] + 0.12, pos[2]])
    path = ik.generatePath(env, g, joints, tip, 5)
    assert len(path) == 5 * 6
    assert path[:6] == pytest.approx(configs[0], abs=1e-3)  # it starts where the arm is
    assert ik.getJointPosition(env, joints[0]) == pytest.approx(configs[0][0])  # the environment is unchanged
    jac, err = ik.computeGroupJacobian(env, g)
    assert len(jac) == 6 * len(err) and len(err) == 6


def test_find_config_gates_its_restarts_by_the_tips_distance(rig, monkeypatch):
    """CoppeliaSim 4.1's simIK.findConfig (coppeliaKinematicsRoutines ``ikGetConfigForTipPose``)
    runs IK only from random configurations whose tip lies within ``thresholdDist`` of the
    target, measured with ``metric`` {x, y, z, angle}: a 4-value metric on a 6-joint arm is
    valid (simx had read it as a joint metric and refused it)."""
    from simx_server.api.simik import environments
    from simx_server.sim import ik_batch

    s, sim, ik = rig
    env, g, _ = _group(sim, ik)
    joints = ik.getGroupJoints(env, g)
    target = sim.getObject("/UR5_target")
    pos = sim.getObjectPosition(target, -1)
    sim.setObjectPosition(target, -1, [pos[0], pos[1] + 0.06, pos[2]])
    config = ik.findConfig(env, g, joints, 0.65, 0.5, [1, 1, 1, 0.1])
    assert config is not None and len(config) == 6
    solves, batched = [], []
    real, real_batch = environments.solve, ik_batch.Chain.solve
    monkeypatch.setattr(environments, "solve", lambda *a, **k: solves.append(1) or real(*a, **k))
    monkeypatch.setattr(ik_batch.Chain, "solve", lambda self, q, *a, **k: batched.append(len(q)) or real_batch(self, q, *a, **k))
    sim.setObjectPosition(target, -1, [pos[0] + 3.0, pos[1], pos[2]])  # out of reach: every solve fails
    assert ik.findConfig(env, g, joints, 0.0, 0.2) is None
    assert len(solves) == 1 and not batched  # the first, from the current configuration; no random one is near
    solves.clear()
    assert ik.findConfig(env, g, joints, 0.0, 0.2, [0, 0, 0, 0]) is None  # every distance weighs 0
    assert len(solves) == 1 and sum(batched) > 1  # random starts, solved together
    with pytest.raises(ArgumentError, match="metric"):
        ik.findConfig(env, g, joints, 0.1, 0.1, [1, 1, -1, 0.1])


def test_find_configs_from_random_starts_only_finds_many(rig, monkeypatch):
    """simx's own findConfigs parameters, PyRep's sampling search: ``fromCurrent = false`` solves
    no IK from the current configuration, ``thresholdDist`` gates the random starts as
    findConfig's; with ``findMultiple`` every distinct configuration found in ``maxTime``
    comes back, each reaching the target, nearest the current configuration first."""
    from simx_server.api.simik import environments

    _, sim, ik = rig
    env, g, joints, tip, target, pos = _target_moved(sim, ik)
    current = [ik.getJointPosition(env, j) for j in joints]
    starts = []
    real = environments.solve
    monkeypatch.setattr(environments, "solve", lambda *a, **k: starts.append(list(k["q0"])) or real(*a, **k))
    configs = ik.findConfigs(env, g, joints, {"maxTime": 0.5, "findMultiple": True, "fromCurrent": False,
                                              "thresholdDist": 0.65, "seed": 3})
    assert len(configs) >= 2
    assert all(start != pytest.approx(current) for start in starts)  # every exact solve confirms a batch's find
    distances = [math.dist(c, current) for c in configs]
    assert distances == sorted(distances)
    for config in configs:
        for j, q in zip(joints, config):
            ik.setJointPosition(env, j, q)
        assert ik.getObjectPose(env, tip)[:3] == pytest.approx(sim.getObjectPosition(target, -1), abs=1e-3)
    for j, q in zip(joints, current):
        ik.setJointPosition(env, j, q)
    assert ik.findConfigs(env, g, joints, {"maxTime": 0.1, "fromCurrent": False, "thresholdDist": 0.0}) == []


def test_a_search_over_some_of_the_groups_joints_holds_the_others(rig):
    """CoppeliaSim 4.1's simGetConfigForTipPose / simGenerateIkPath set the group's joints
    passive and only the given ones to IK mode (PyRep's Baxter arm passes its 7 joints to a group
    that also holds the torso's): the others keep their positions; a joint outside the group is
    refused."""
    _, sim, ik = rig
    env, g, _ = _group(sim, ik, 7)  # position only: five joints can reach it
    joints = ik.getGroupJoints(env, g)
    tip, target = sim.getObject("/UR5_tip"), sim.getObject("/UR5_target")
    pos = sim.getObjectPosition(target, -1)
    sim.setObjectPosition(target, -1, [pos[0], pos[1] + 0.06, pos[2]])
    held = joints[-1]
    before = ik.getJointPosition(env, held)
    moving = list(reversed(joints[:-1]))  # any order: the result follows it
    configs = ik.findConfigs(env, g, moving, {"maxTime": 2})
    assert len(configs) == 1 and len(configs[0]) == 5
    for j, q in zip(moving, configs[0]):
        ik.setJointPosition(env, j, q)
    assert ik.getJointPosition(env, held) == before
    assert ik.getObjectPose(env, tip)[:3] == pytest.approx(sim.getObjectPosition(target, -1), abs=1e-3)
    sim.setObjectPosition(target, -1, [pos[0], pos[1] + 0.1, pos[2]])
    path = ik.generatePath(env, g, moving, tip, 4)
    assert len(path) == 4 * 5 and ik.getJointPosition(env, held) == before
    for bad in ([*moving, moving[0]], [*moving, sim.getObject("/UR5_target")], []):
        with pytest.raises(ArgumentError, match="joints of the group"):
            ik.findConfigs(env, g, bad)
    assert ik.getGroupJoints(env, g) == joints  # the held joint is in the group again


def test_every_simik_function_has_coppeliasim_s_name():
    from simx_server.api import names
    listed = names.coppeliasim_functions("simIK")
    assert set(SIMIK) <= listed, set(SIMIK) - listed


def test_joint_weights_and_margins_shape_the_solution(rig):
    _, sim, ik = rig
    env, g, _ = _group(sim, ik, 7)
    joints = ik.getGroupJoints(env, g)
    target = sim.getObject("/UR5_target")
    pos = sim.getObjectPosition(target, -1)
    sim.setObjectPosition(target, -1, [pos[0] + 0.05, pos[1], pos[2]])
    start = [ik.getJointPosition(env, j) for j in joints]
    ik.setJointWeight(env, joints[0], 1e-4)  # the base joint hardly moves
    assert ik.getJointWeight(env, joints[0]) == 1e-4
    assert ik.handleGroup(env, g)[0] == 1
    moved = [abs(ik.getJointPosition(env, j) - s) for j, s in zip(joints, start)]
    assert moved[0] < 0.1 * max(moved[1:])
    ik.setJointLimitMargin(env, joints[1], 0.1)
    assert ik.getJointLimitMargin(env, joints[1]) == 0.1 and ik.getJointScrewLead(env, joints[1]) == 0.0
    position, quat, euler = ik.getObjectTransformation(env, sim.getObject("/UR5_tip"))
    assert position == pytest.approx(ik.getObjectPose(env, sim.getObject("/UR5_tip"))[:3])


def test_alternate_configs_of_the_environment_match_the_scenes(rig):
    """simIK.getAlternateConfigs answers sim.getAlternateConfigs' configurations (whole turns of
    hinges within their ranges) for the environment's joint positions."""
    _, sim, ik = rig
    env, g, _ = _group(sim, ik)
    joints = ik.getGroupJoints(env, g)[:2]
    ik.setJointPosition(env, joints[0], 0.5)
    ik.setJointPosition(env, joints[1], -0.25)
    low, ranges = [-7.0, -1.0], [14.0, 2.0]  # the first turns twice more each way, the second not
    flat = ik.getAlternateConfigs(env, joints, low, ranges)
    assert flat == sim.getAlternateConfigs(joints, [0.5, -0.25], -1, low, ranges)
    configs = [tuple(flat[i:i + 2]) for i in range(0, len(flat), 2)]
    assert sorted(round(a, 6) for a, _ in configs) == [round(0.5 + 2 * 3.141592653589793 * k, 6) for k in (-1, 0, 1)]
    assert {round(b, 9) for _, b in configs} == {-0.25}


def test_a_new_group_is_coppeliasims_and_ignores_max_step_sizes(rig):
    """``simIK.createGroup`` gives CoppeliaSim's ``CikGroup``: pseudo-inverse, damping 0.1, 3
    iterations, ``group_enabled | group_ignoremaxsteps``; so one iteration may turn a joint more
    than its max step size (10 degrees), and without that flag it may not."""
    _, sim, ik = rig
    env = ik.createEnvironment()
    fresh = ik.createGroup(env)
    assert ik.getGroupCalculation(env, fresh) == (ik.method_pseudo_inverse, 0.1, 3)
    env, g, _ = _group(sim, ik)
    assert ik.getGroupFlags(env, g) == ik.group_enabled | ik.group_ignoremaxsteps
    ik.setGroupCalculation(env, g, ik.method_damped_least_squares, 0.05, 1)
    target = sim.getObject("/UR5_target")
    pos = sim.getObjectPosition(target, -1)
    sim.setObjectPosition(target, -1, [pos[0] + 0.15, pos[1] - 0.15, pos[2] - 0.1])
    joints = ik.getGroupJoints(env, g)
    start = [ik.getJointPosition(env, j) for j in joints]

    def largest_step(flags):
        for j, q in zip(joints, start):
            ik.setJointPosition(env, j, q)
        ik.setGroupFlags(env, g, flags)
        ik.handleGroup(env, g)  # the environment only: one iteration
        return max(abs(ik.getJointPosition(env, j) - q) for j, q in zip(joints, start))

    assert largest_step(ik.group_enabled | ik.group_ignoremaxsteps) > math.radians(10) + 1e-3
    assert largest_step(ik.group_enabled) <= math.radians(10) + 1e-9


def test_synced_group_sets_positions_while_stopped_and_targets_once_the_physics_runs(rig):
    """simIK.lua's ``syncToSim``: a joint in dynamic mode that ``sim.isDynamicallyEnabled`` gets
    the solution as its target position, any other as its position. CoppeliaSim's engine marks
    objects dynamically simulated at its first step of a run, so while the simulation is stopped
    and in the first pass (a ``sysCall_nonSimulation``, a ``sysCall_init``) the arm itself moves."""
    s, sim, ik = rig
    env, g, _ = _group(sim, ik)
    joints = ik.getGroupJoints(env, g)
    target = sim.getObject("/UR5_target")
    pos = sim.getObjectPosition(target, -1)
    sim.setObjectPosition(target, -1, [pos[0] + 0.05, pos[1] - 0.04, pos[2] - 0.03])
    assert not sim.isDynamicallyEnabled(joints[0])
    assert ik.handleGroup(env, g, {"syncWorlds": True})[0] == ik.result_success
    assert [sim.getJointPosition(j) for j in joints] == pytest.approx([ik.getJointPosition(env, j) for j in joints])
    s.start()
    assert not sim.isDynamicallyEnabled(joints[0])  # the first pass, before the physics' first step
    s.step()
    assert sim.isDynamicallyEnabled(joints[0])
    before = [sim.getJointPosition(j) for j in joints]
    sim.setObjectPosition(target, -1, [pos[0] - 0.03, pos[1] + 0.04, pos[2]])
    assert ik.handleGroup(env, g, {"syncWorlds": True})[0] == ik.result_success
    solution = [ik.getJointPosition(env, j) for j in joints]
    assert [sim.getJointTargetPosition(j) for j in joints] == pytest.approx(solution)
    assert [sim.getJointPosition(j) for j in joints] == pytest.approx(before, abs=1e-3)  # the motors move them
    assert max(abs(a - b) for a, b in zip(solution, before)) > 0.02
    for _ in range(40):
        s.step()
    assert [sim.getJointPosition(j) for j in joints] == pytest.approx(solution, abs=0.01)


def test_element_weights_scale_the_error_not_the_jacobian(rig):
    """coppeliaKinematicsRoutines ``CikGroup::computeDq`` multiplies the error vector's rows by the
    element's weights and leaves the Jacobian as it is: with a position weight of 0.5 one undamped
    iteration goes half-way to a target 1 cm off (weighting both would solve the same system,
    a whole step). ``computeGroupJacobian`` answers the plain error."""
    _, sim, ik = rig
    env, g, el = _group(sim, ik, 7)
    ik.setGroupCalculation(env, g, 3, 0.0, 1)  # simIK.method_undamped_pseudo_inverse, one iteration
    ik.setElementWeights(env, g, el, [0.5, 1.0])
    for j, q in zip(ik.getGroupJoints(env, g), [0.3, -0.8, 1.2, -0.6, 0.5, 0.2]):  # away from the straight arm
        ik.setJointPosition(env, j, q)
    tip, target = sim.getObject("/UR5_tip"), sim.getObject("/UR5_target")
    goal = [a + b for a, b in zip(ik.getObjectPose(env, tip)[:3], [0.006, -0.005, 0.0055])]
    sim.setObjectPosition(target, -1, goal)
    _, error = ik.computeGroupJacobian(env, g)
    assert error == pytest.approx([0.006, -0.005, 0.0055], abs=1e-9)
    before = math.dist(ik.getObjectPose(env, tip)[:3], goal)
    ik.handleGroup(env, g)
    assert math.dist(ik.getObjectPose(env, tip)[:3], goal) == pytest.approx(0.5 * before, rel=0.1)
