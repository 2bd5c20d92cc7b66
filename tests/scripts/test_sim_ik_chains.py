"""simIK's joints and chains (simx_server/api/simik/chains.py): computeJacobian against finite
differences of the environment's forward kinematics, joint matrices and transformations,
spherical joints' rotations, linear joint dependencies coupling joints in a solve, and saving and
loading an environment (simx_server/api/simik/storage.py); through the Python API, a Lua child
script and CoppeliaSim's official ZMQ client, on tests/scenes/simik_chains/chain.xml."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from conftest import ROOT
from simx_client.protocol import ArgumentError, UnknownObjectError, UnsupportedError
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

CHAIN = ROOT / "tests" / "scenes" / "simik_chains" / "chain.xml"
CHILD = 1
Q = {"j1": 0.3, "j2": -0.4, "j3": 0.05, "j4": 0.7}
WRIST = [0.1, -0.2, 0.3]  # Euler angles of the ball joint


@pytest.fixture
def rig():
    s = Simulation(CHAIN, realtime=False)
    sim = script_sim(s.world, s.world.resolve("Chains").handle, s.signals, simulation=s)
    ik = sim.context.simik
    h = {n: sim.getObject("/" + n) for n in ("j1", "j2", "j3", "j4", "wristJoint", "tip", "target", "base", "link2", "link3")}
    env = ik.createEnvironment()
    for name, q in Q.items():
        ik.setJointPosition(env, h[name], q)
    ik.setSphericalJointRotation(env, h["wristJoint"], WRIST)
    yield s, sim, ik, env, h
    s.close()


def _rot(pose):
    r = np.empty(9)
    x, y, z, w = pose[3:]
    mujoco.mju_quat2Mat(r, np.array([w, x, y, z]))
    return r.reshape(3, 3)


def _rotvec(r):
    q, v = np.empty(4), np.empty(3)
    mujoco.mju_mat2Quat(q, r.reshape(9).copy())
    mujoco.mju_quat2Vel(v, q, 1.0)
    return v


def _axis_angle(axis, angle):
    q, r = np.empty(4), np.empty(9)
    mujoco.mju_axisAngle2Quat(q, np.asarray(axis, float), angle)
    mujoco.mju_quat2Mat(r, q)
    return r.reshape(3, 3)


def _finite_differences(ik, env, h, step=1e-6):
    """Columns (6,) of the tip's motion (world position, rotation in the tip's frame) per joint:
    j1..j4 by their positions, the wrist by rotations about its own x, y, z."""
    p0 = ik.getObjectPose(env, h["tip"])
    r0 = _rot(p0)
    cols = []

    def column():
        p1 = ik.getObjectPose(env, h["tip"])
        return np.concatenate([(np.array(p1[:3]) - p0[:3]) / step, _rotvec(r0.T @ _rot(p1)) / step])

    for name in ("j1", "j2", "j3", "j4"):
        q = ik.getJointPosition(env, h[name])
        ik.setJointPosition(env, h[name], q + step)
        cols.append(column())
        ik.setJointPosition(env, h[name], q)
    m = np.array(ik.getJointMatrix(env, h["wristJoint"])).reshape(3, 4)[:, :3]
    for k in range(3):
        axis = np.eye(3)[k]
        ik.setSphericalJointMatrix(env, h["wristJoint"], np.hstack([m @ _axis_angle(axis, step), np.zeros((3, 1))]).reshape(12).tolist())
        cols.append(column())
    ik.setSphericalJointMatrix(env, h["wristJoint"], np.hstack([m, np.zeros((3, 1))]).reshape(12).tolist())
    return np.array(cols).T


def test_compute_jacobian_matches_finite_differences_of_the_kinematics(rig):
    _, sim, ik, env, h = rig
    tip = ik.getObjectPose(env, h["tip"])
    jac, err = ik.computeJacobian(env, -1, h["wristJoint"], ik.constraint_pose, tip)
    jac = np.array(jac).reshape(6, 7)  # x y z alpha beta gamma by j1 j2 j3 j4 and the wrist's 3
    assert jac == pytest.approx(_finite_differences(ik, env, h), abs=1e-4)
    assert err == [0.0] * 6  # no target: the target is the tip
    # the tip as a 12-number matrix gives the same; the environment's positions are unchanged
    matrix = ik.getObjectMatrix(env, h["tip"])
    assert np.array(ik.computeJacobian(env, -1, h["wristJoint"], 31, matrix)[0]) == pytest.approx(jac.reshape(-1))
    assert ik.getJointPosition(env, h["j4"]) == Q["j4"]


def test_compute_jacobian_rows_frames_error_and_chain(rig):
    _, sim, ik, env, h = rig
    tip = ik.getObjectPose(env, h["tip"])
    r_tip = _rot(tip)
    fd = _finite_differences(ik, env, h)
    # x, z and gamma only, position rows in a constraint base turned 0.5 rad about z
    cb = _axis_angle([0, 0, 1], 0.5)
    cb_pose = [0.1, 0.2, 0.3, 0.0, 0.0, math.sin(0.25), math.cos(0.25)]
    target_p = np.array(tip[:3]) + [0.01, -0.02, 0.03]
    target_r = r_tip @ _axis_angle([0, 0, 1], 0.2)  # turned about the tip's z: a gamma error
    target = np.hstack([target_r, target_p.reshape(3, 1)]).reshape(12).tolist()
    jac, err = ik.computeJacobian(env, -1, h["wristJoint"], 1 + 4 + 16, tip, target, cb_pose)
    expected = np.vstack([(cb.T @ fd[:3])[[0, 2]], fd[5:6]])
    assert np.array(jac).reshape(3, 7) == pytest.approx(expected, abs=1e-4)
    assert err == pytest.approx([*(cb.T @ (target_p - tip[:3]))[[0, 2]], 0.2], abs=1e-9)
    # a shorter chain: from link2 (link3's joints j3, j4 and the wrist), rows in link2's frame ...
    jac, _ = ik.computeJacobian(env, h["link2"], h["wristJoint"], 7, tip)
    r_base = _rot(ik.getObjectPose(env, h["link2"]))
    assert np.array(jac).reshape(3, 5) == pytest.approx(r_base.T @ fd[:3, 2:], abs=1e-4)
    # (link3 moves with its own joints: from it, the wrist alone)
    assert len(ik.computeJacobian(env, h["link3"], h["wristJoint"], 7, tip)[0]) == 3 * 3
    # ... up to j3, the first of link3's two joints: j4 and the wrist are not in it
    jac, _ = ik.computeJacobian(env, -1, h["j3"], 7, tip)
    assert np.array(jac).reshape(3, 3) == pytest.approx(fd[:3, :3], abs=1e-4)
    # a passive joint has no column
    ik.setJointMode(env, h["j2"], ik.jointmode_passive)
    jac, _ = ik.computeJacobian(env, -1, h["j4"], 7, tip)
    assert np.array(jac).reshape(3, 3) == pytest.approx(fd[:3, [0, 2, 3]], abs=1e-4)
    with pytest.raises(ArgumentError):
        ik.computeJacobian(env, h["link3"], h["j1"], 7, tip)  # j1 is above link3
    with pytest.raises(ArgumentError):
        ik.computeJacobian(env, -1, h["j4"], 0, tip)
    with pytest.raises(ArgumentError):
        ik.computeJacobian(env, -1, h["j4"], 7, tip[:5])
    with pytest.raises(UnknownObjectError):
        ik.computeJacobian(env + 9, -1, h["j4"], 7, tip)


def test_joint_matrix_and_transformation_are_the_intrinsic_motion(rig):
    _, sim, ik, env, h = rig
    m = np.array(ik.getJointMatrix(env, h["j1"])).reshape(3, 4)
    assert m == pytest.approx(np.hstack([_axis_angle([0, 0, 1], Q["j1"]), np.zeros((3, 1))]))
    pos, quat, euler = ik.getJointTransformation(env, h["j3"])  # a slide: along its z
    assert pos == pytest.approx([0, 0, Q["j3"]]) and quat == pytest.approx([0, 0, 0, 1]) and euler == pytest.approx([0, 0, 0])
    pos, quat, euler = ik.getJointTransformation(env, h["wristJoint"])
    assert pos == [0.0, 0.0, 0.0] and euler == pytest.approx(WRIST)
    assert sim.getJointPosition(h["j1"]) == 0.0  # the scene's joints did not move


def test_spherical_joint_rotation_moves_the_environment_s_tip_only(rig):
    _, sim, ik, env, h = rig
    wrist = h["wristJoint"]
    scene = sim.getObjectQuaternion(h["tip"], -1)
    ik.setSphericalJointRotation(env, wrist, [0, 0, 0, 1])
    before = ik.getObjectPose(env, h["tip"])
    r = _axis_angle(np.array([1.0, 2.0, 3.0]) / math.sqrt(14), 0.6)
    ik.setSphericalJointRotation(env, wrist, [*_quat_xyzw(r[:, :3])])  # a quaternion (x, y, z, w)
    assert np.array(ik.getJointMatrix(env, wrist)).reshape(3, 4)[:, :3] == pytest.approx(r)
    assert _rot(ik.getObjectPose(env, h["tip"])) == pytest.approx(_rot(before) @ r)  # the tip turned with it
    # a 12-number matrix (its translation ignored, its rotation normalised)
    ik.setSphericalJointMatrix(env, wrist, np.hstack([2 * r.T, np.ones((3, 1))]).reshape(12).tolist())
    assert np.array(ik.getJointMatrix(env, wrist)).reshape(3, 4) == pytest.approx(np.hstack([r.T, np.zeros((3, 1))]))
    assert ik.getJointType(env, wrist) == ik.jointtype_spherical
    assert sim.getObjectQuaternion(h["tip"], -1) == scene  # the scene's tip did not turn
    with pytest.raises(ArgumentError):
        ik.setSphericalJointRotation(env, h["j1"], [0, 0, 0])  # not spherical
    with pytest.raises(ArgumentError):
        ik.setSphericalJointRotation(env, wrist, [0, 0])
    with pytest.raises(ArgumentError):
        ik.setSphericalJointRotation(env, wrist, [0, 0, 0, 0])
    with pytest.raises(ArgumentError):
        ik.setSphericalJointMatrix(env, wrist, [0.0] * 12)


def _quat_xyzw(r):
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(r).reshape(9))
    return [q[1], q[2], q[3], q[0]]


def _arm_group(ik, env, h, constraints=7):
    g = ik.createGroup(env, "arm")
    ik.setGroupCalculation(env, g, ik.method_damped_least_squares, 0.02, 300)
    ik.addElementFromScene(env, g, -1, h["tip"], h["target"], constraints)
    return g


def test_joint_dependency_couples_the_joints_in_a_solve(rig):
    s, sim, ik, env, h = rig
    j1, j2 = h["j1"], h["j2"]
    ik.setJointDependency(env, j2, j1, 0.1, 0.5)
    assert ik.getJointDependency(env, j2) == (j1, 0.1, 0.5)
    assert ik.getJointPosition(env, j2) == pytest.approx(0.1 + 0.5 * Q["j1"])  # follows at once
    ik.setJointPosition(env, j1, 0.4)
    assert ik.getJointPosition(env, j2) == pytest.approx(0.3)
    # a reachable target only with the coupling: the tip where (0.4, 0.3, 0.05, -0.2) puts it
    ik.setJointPosition(env, h["j3"], 0.05)
    ik.setJointPosition(env, h["j4"], -0.2)
    sim.setObjectPosition(h["target"], -1, ik.getObjectPose(env, h["tip"])[:3])
    for name in ("j1", "j3", "j4"):
        ik.setJointPosition(env, h[name], 0.0)
    g = _arm_group(ik, env, h)
    assert ik.getGroupJoints(env, g) == [j1, h["j3"], h["j4"]]  # the dependent joint is not solved for
    # the group's Jacobian: j1's column moves j2 with it (j2's column times 0.5, by differences)
    jac, _ = ik.computeGroupJacobian(env, g)
    p0 = np.array(ik.getObjectPose(env, h["tip"])[:3])
    ik.setJointPosition(env, j1, 1e-6)
    assert np.array(jac).reshape(3, 3)[:, 0] == pytest.approx((np.array(ik.getObjectPose(env, h["tip"])[:3]) - p0) / 1e-6, abs=1e-4)
    ik.setJointPosition(env, j1, 0.0)
    result, _, precision = ik.handleGroup(env, g, {"syncWorlds": True})
    q1, q2 = ik.getJointPosition(env, j1), ik.getJointPosition(env, j2)
    assert result == ik.result_success and precision[0] < 1e-3
    assert q2 == pytest.approx(0.1 + 0.5 * q1)
    assert ik.getObjectPose(env, h["tip"])[:3] == pytest.approx(sim.getObjectPosition(h["target"], -1), abs=1e-3)
    # the scene's motors got both, the dependent joint's from its master
    assert sim.getJointTargetPosition(j1) == pytest.approx(q1) and sim.getJointTargetPosition(j2) == pytest.approx(q2)


def test_joint_dependency_forms_loops_and_refusals(rig):
    _, sim, ik, env, h = rig
    j1, j2, j3 = h["j1"], h["j2"], h["j3"]
    ik.setJointDependency(env, j2, j1)  # defaults: offset 0, mult 1
    assert ik.getJointDependency(env, j2) == (j1, 0.0, 1.0)
    ik.setJointDependency(env, j3, "/j2", 0.01, 0.1)  # a slave of a slave, by path
    assert ik.getJointPosition(env, j3) == pytest.approx(0.01 + 0.1 * Q["j1"])
    ik.setJointDependency(env, j1, j3)  # a loop: j2 (which followed j1) follows nothing any more
    assert ik.getJointDependency(env, j2)[0] == -1 and ik.getJointDependency(env, j1)[0] == j3
    ik.setJointDependency(env, j1, -1)
    assert ik.getJointDependency(env, j1)[0] == -1
    assert ik.getJointPosition(env, j1) == pytest.approx(Q["j1"])
    with pytest.raises(UnsupportedError):
        ik.setJointDependency(env, j2, j1, 0, 1, "myCallback")
    with pytest.raises(ArgumentError):
        ik.setJointDependency(env, h["wristJoint"], j1)
    with pytest.raises(UnknownObjectError):
        ik.setJointDependency(env, j2, 999)


def test_lua_child_script_jacobian_and_dependency(rig):
    s, sim, ik, env, h = rig
    s.start()
    try:
        floats = [Q["j1"], Q["j2"], Q["j3"], Q["j4"], *WRIST]
        (n_jac, n_err), out, _, _ = s.scripts.call("Chains", CHILD, "jacobian", [], floats, [], b"")
        assert (n_jac, n_err) == (42, 6)
        fd = _finite_differences(ik, env, h)  # the Python environment is in the same configuration
        assert np.array(out[:42]).reshape(6, 7) == pytest.approx(fd, abs=1e-4)
        tip = ik.getObjectPose(env, h["tip"])
        target = sim.getObjectPosition(h["target"], -1)
        assert out[42:45] == pytest.approx(np.array(target) - tip[:3], abs=1e-9)
        ints, floats, _, _ = s.scripts.call("Chains", CHILD, "coupled", [], [0.05, -0.5], [], b"")
        assert ints == [ik.result_success, 3, h["j1"]]
        q1, q2, offset, mult = floats
        assert (offset, mult) == (0.05, -0.5) and q2 == pytest.approx(0.05 - 0.5 * q1)
        assert sim.getJointTargetPosition(h["j2"]) == pytest.approx(q2)
        (size, copied_group), pose, kinds, _ = s.scripts.call("Chains", CHILD, "saved", [], [0.4, 0.1, 0.2], [], b"")
        assert size > 100 and copied_group >= 1000 and pose == pytest.approx([0.4, 0.1, 0.2]) and kinds == ["string"]
    finally:
        s.stop()


def test_save_and_load_an_environment(rig):
    s, sim, ik, env, h = rig
    ik.setJointDependency(env, h["j2"], h["j1"], 0.1, 0.5)
    ik.setJointWeight(env, h["j4"], 0.25)
    ik.setJointMode(env, h["j3"], ik.jointmode_passive)
    g = _arm_group(ik, env, h)
    el = ik.addElementFromScene(env, g, -1, h["tip"], h["target"], 7)[0]
    ik.setElementPrecision(env, g, el, [0.002, 0.01])
    data = ik.save(env)
    assert isinstance(data, bytes)
    other = ik.createEnvironment()
    ik.load(other, data)
    assert ik.getGroupHandle(other, "arm") == g and ik.getGroupCalculation(other, g) == (1, 0.02, 300)
    assert ik.getGroupJoints(other, g) == ik.getGroupJoints(env, g) == [h["j1"], h["j4"]]
    assert ik.getJointDependency(other, h["j2"]) == (h["j1"], 0.1, 0.5)
    assert ik.getJointWeight(other, h["j4"]) == 0.25 and ik.getElementPrecision(other, g, el) == [0.002, 0.01]
    assert ik.getJointMatrix(other, h["wristJoint"]) == pytest.approx(ik.getJointMatrix(env, h["wristJoint"]))
    assert ik.getObjectPose(other, h["tip"]) == pytest.approx(ik.getObjectPose(env, h["tip"]))
    # both solve alike, and a new group of the loaded one takes a new handle
    assert ik.handleGroup(other, g)[0] == ik.handleGroup(env, g)[0]
    assert [ik.getJointPosition(other, j) for j in (h["j1"], h["j2"], h["j4"])] == pytest.approx(
        [ik.getJointPosition(env, j) for j in (h["j1"], h["j2"], h["j4"])])
    assert ik.createGroup(other, "more") not in (g,)
    # refusals: an environment with groups, CoppeliaSim's format, another scene's names, garbage
    with pytest.raises(ArgumentError, match="empty"):
        ik.load(other, data)
    fresh = ik.createEnvironment()
    with pytest.raises(ArgumentError, match="simx"):
        ik.load(fresh, b"\x00\x01CoppeliaSim IK data")
    with pytest.raises(ArgumentError, match="another scene"):
        ik.load(fresh, data.replace(b'"j1"', b'"elbow"'))
    with pytest.raises(ArgumentError):
        ik.load(fresh, data[:-5])
    with pytest.raises(ArgumentError):
        ik.load(fresh, data.replace(b'"iterations":300', b'"iterations":1e9'))
    assert ik.doesGroupExist(fresh, "arm") is False and ik.getJointDependency(fresh, h["j2"])[0] == -1  # unchanged


def test_zmq_client_jacobian_dependency_and_buffer(rig, official):
    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    from conftest import ServerProcess, free_port

    _, sim, ik, env, h = rig
    port = free_port()
    srv = ServerProcess(str(CHAIN), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    try:
        simIK = official(port).require("simIK")  # noqa: N806 (CoppeliaSim's name)
        remote = simIK.createEnvironment()
        for name, q in Q.items():
            simIK.setJointPosition(remote, "/" + name, q)  # object paths, as CoppeliaSim 4.3+
        simIK.setSphericalJointRotation(remote, h["wristJoint"], WRIST)
        tip = simIK.getObjectPose(remote, h["tip"], -1)
        jac, err = simIK.computeJacobian(remote, -1, h["wristJoint"], simIK.constraint_pose, tip)
        assert np.array(jac).reshape(6, 7) == pytest.approx(_finite_differences(ik, env, h), abs=1e-4)
        simIK.setJointDependency(remote, h["j2"], h["j1"], 0.1, 0.5)
        assert simIK.getJointPosition(remote, h["j2"]) == pytest.approx(0.1 + 0.5 * Q["j1"])
        pos, quat, euler = simIK.getJointTransformation(remote, h["wristJoint"])
        assert euler == pytest.approx(WRIST)
        data = simIK.save(remote)  # bytes both ways
        copy = simIK.createEnvironment()
        simIK.load(copy, data)
        assert list(simIK.getJointDependency(copy, h["j2"])) == [h["j1"], 0.1, 0.5]
        with pytest.raises(Exception, match="simIK.setJointDependency: .*callback"):
            simIK.setJointDependency(remote, h["j2"], h["j1"], 0, 1, "cb")
    finally:
        srv.stop()


def _reachable(ik, env, h, q):
    """The tip's world position at joint positions ``q`` (j1..j4), the environment put back."""
    saved = {n: ik.getJointPosition(env, h[n]) for n in q}
    for n, v in q.items():
        ik.setJointPosition(env, h[n], v)
    p = ik.getObjectPose(env, h["tip"])[:3]
    for n, v in saved.items():
        ik.setJointPosition(env, h[n], v)
    return p


def test_environment_dummies_as_target_and_tip(rig):
    s, sim, ik, env, h = rig
    assert ik.createDummy(env) != ik.createDummy(env, "goal")
    goal = ik.getObjectHandle(env, "goal")
    assert ik.getObjectHandle(env, "dummy0") not in (goal, h["tip"]) and ik.doesObjectExist(env, "goal")
    assert ik.getObjectType(env, goal) == ik.objecttype_dummy and ik.getObjectParent(env, goal) == -1
    assert not ik.doesObjectExist(ik.createEnvironment(), "goal")  # the environment's own
    with pytest.raises(ArgumentError):
        ik.createDummy(env, "goal")
    with pytest.raises(ArgumentError):
        ik.createDummy(env, "tip")  # a scene object's name
    # a target of the environment only: the scene's target and joints do not move
    scene_target, scene_q = sim.getObjectPosition(h["target"], -1), sim.getJointPosition(h["j1"])
    g = ik.createGroup(env, "byHand")
    ik.setGroupCalculation(env, g, ik.method_damped_least_squares, 0.02, 300)
    el = ik.addElement(env, g, h["tip"])
    ik.setElementConstraints(env, g, el, ik.constraint_position)
    ik.setTargetDummy(env, h["tip"], goal)
    assert ik.getTargetDummy(env, h["tip"]) == goal
    p = _reachable(ik, env, h, {"j1": -0.3, "j2": 0.2, "j3": 0.1, "j4": -0.5})
    ik.setObjectPose(env, goal, [*p, 0, 0, 0, 1])
    assert ik.getObjectPose(env, goal)[:3] == pytest.approx(p)
    assert ik.handleGroup(env, g)[0] == ik.result_success
    assert ik.getObjectPose(env, h["tip"])[:3] == pytest.approx(p, abs=1e-3)
    assert sim.getObjectPosition(h["target"], -1) == scene_target and sim.getJointPosition(h["j1"]) == scene_q
    # a tip of the environment only, carried by the scene's wrist body 0.1 m ahead of it
    tool = ik.createDummy(env, "tool")
    ik.setObjectParent(env, tool, "/wrist", False)
    ik.setObjectPose(env, tool, [0.1, 0, 0, 0, 0, 0, 1], ik.handle_parent)
    wrist = np.array(ik.getObjectMatrix(env, "/wrist")).reshape(3, 4)
    assert ik.getObjectPose(env, tool)[:3] == pytest.approx(wrist[:, 3] + wrist[:, 0] * 0.1)
    g2 = ik.createGroup(env, "tool")
    ik.setGroupCalculation(env, g2, ik.method_damped_least_squares, 0.02, 300)
    el2 = ik.addElement(env, g2, tool)
    ik.setElementConstraints(env, g2, el2, ik.constraint_position)
    goal2 = ik.createDummy(env, "goal2")
    ik.setTargetDummy(env, tool, goal2)
    ik.setObjectPose(env, goal2, [*(np.array(p) + [0.0, 0.05, -0.05]), 0, 0, 0, 1])
    jac, err = ik.computeGroupJacobian(env, g2)  # the tool's point, by differences
    before = np.array(ik.getObjectPose(env, tool)[:3])
    ik.setJointPosition(env, h["j2"], ik.getJointPosition(env, h["j2"]) + 1e-6)
    assert np.array(jac).reshape(3, 4)[:, 1] == pytest.approx((np.array(ik.getObjectPose(env, tool)[:3]) - before) / 1e-6, abs=1e-4)
    assert ik.handleGroup(env, g2)[0] == ik.result_success
    assert ik.getObjectPose(env, tool)[:3] == pytest.approx(ik.getObjectPose(env, goal2)[:3], abs=1e-3)


def test_environment_dummies_parents_erasing_and_saving(rig):
    s, sim, ik, env, h = rig
    a, b = ik.createDummy(env, "a"), ik.createDummy(env, "b")
    ik.setObjectPose(env, a, [0.1, 0.2, 0.3, 0, 0, 0, 1])
    ik.setObjectParent(env, a, h["link3"])  # kept in place, then carried by link3
    assert ik.getObjectPose(env, a)[:3] == pytest.approx([0.1, 0.2, 0.3]) and ik.getObjectParent(env, a) == h["link3"]
    ik.setObjectParent(env, b, a, False)  # b keeps its pose relative to a (the origin): it goes to a
    assert ik.getObjectPose(env, b) == pytest.approx(ik.getObjectPose(env, a))
    ik.setJointPosition(env, h["j4"], 0.0)
    moved = ik.getObjectPose(env, b)[:3]
    assert moved != pytest.approx([0.1, 0.2, 0.3], abs=1e-3)  # j4 turned link3, and a and b with it
    with pytest.raises(ArgumentError):
        ik.setObjectParent(env, a, b)  # a loop
    with pytest.raises(ArgumentError):
        ik.setObjectParent(env, h["tip"], a)  # the scene's
    with pytest.raises(ArgumentError):
        ik.eraseObject(env, h["tip"])
    # saved and loaded with the rest
    g = ik.createGroup(env, "g")
    ik.setTargetDummy(env, h["tip"], b)
    el = ik.addElement(env, g, h["tip"])
    ik.setTargetDummy(env, h["tip"], b)
    other = ik.createEnvironment()
    ik.load(other, ik.save(env))
    assert ik.getObjectHandle(other, "b") == b and ik.getObjectPose(other, b) == pytest.approx(ik.getObjectPose(env, b))
    assert ik.getTargetDummy(other, h["tip"]) == b
    # erasing a: b goes to link3 and stays in place; erasing b: the element has no target
    ik.eraseObject(env, a)
    assert ik.getObjectParent(env, b) == h["link3"] and ik.getObjectPose(env, b)[:3] == pytest.approx(moved)
    ik.eraseObject(env, b)
    assert not ik.doesObjectExist(env, "b") and ik.getTargetDummy(env, h["tip"]) == -1
    assert ik.getElementConstraints(env, g, el) == 31  # the element stays (its tip is the scene's)
    with pytest.raises(UnknownObjectError):
        ik.getObjectPose(env, b)


def test_a_deep_line_of_dummies_and_the_bound(rig):
    _, sim, ik, env, h = rig
    parent = h["link3"]
    for _ in range(1023):
        d = ik.createDummy(env)
        ik.setObjectParent(env, d, parent, False)
        ik.setObjectPose(env, d, [0.001, 0, 0, 0, 0, 0, 1], ik.handle_parent)
        parent = d
    link3 = np.array(ik.getObjectMatrix(env, h["link3"])).reshape(3, 4)
    assert ik.getObjectPose(env, parent)[:3] == pytest.approx(link3[:, 3] + 1.023 * link3[:, 0])
    d = ik.createDummy(env)
    with pytest.raises(ArgumentError, match="at most 1024"):
        ik.createDummy(env)
    ik.eraseObject(env, d)
    assert ik.getObjectType(env, ik.createDummy(env, "last")) == ik.objecttype_dummy
