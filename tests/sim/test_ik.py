"""IK groups (``simx:ik:NAME``, simx_server/sim/ik.py): the tip follows its target dummy through the
chain's joint motors, limits and maximum velocities hold, scripts solve explicit groups
(``sim.handleIkGroup``, CoppeliaSim 4.x's ``simIK``), bad declarations are refused by name.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

import vrep

try:
    from conftest import ROOT, ServerProcess, free_port, wait_until
except ImportError:  # tests/ imported as a package
    from tests.conftest import ROOT, ServerProcess, free_port, wait_until

from simx_server.sim import ik
from simx_server.scene.simulation import Simulation
from simx_server.sim.world import matrix_from_euler

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

IK_SCENE = ROOT / "scenes" / "ur5_ik.xml"
BLOCK = vrep.simx_opmode_blocking
DOWN = (math.pi / 2, 0.0, math.pi / 2)

# A planar two-link arm (links 0.3 m, joints about y): the tip reaches x^2 + z^2 <= 0.36.
ARM = """<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002" gravity="0 0 0"/>
  <worldbody>
    <site name="target" pos="0.3 0 0.3" size="0.01"/>
    <site name="target2" pos="0.3 0 0.3" size="0.01"/>
    <body name="base">
      <body name="link1">
        <joint name="j1" type="hinge" axis="0 1 0" range="-3 {high}" damping="1" armature="0.1"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02" mass="1"/>
        <body name="link2" pos="0 0 0.3">
          <joint name="j2" type="hinge" axis="0 1 0" range="-3 3" damping="1" armature="0.1"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02" mass="1"/>
          <site name="tip" pos="0 0 0.3" size="0.01"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <velocity joint="j1" kv="50" forcerange="-100 100"/>
    <velocity joint="j2" kv="50" forcerange="-100 100"/>
  </actuator>
  <custom>
    <text name="simx:j1" data="mode=position max_velocity={vmax}"/>
    <text name="simx:j2" data="mode=position max_velocity={vmax}"/>
    <text name="simx:ik:arm" data="tip=tip target=target base=base constraints=position {extra}"/>
    {texts}
  </custom>
</mujoco>
"""


def _arm(tmp_path, high=3.0, vmax=2.0, extra="", texts="", script=None):
    scene = tmp_path / "arm.xml"
    if script is not None:
        (tmp_path / "ik.lua").write_text(script)
        texts += '<text name="simx:base" data="child_script=ik.lua"/>'
    scene.write_text(ARM.format(high=high, vmax=vmax, extra=extra, texts=texts))
    return Simulation(scene, dt=0.05, realtime=False)


def _distance(world, a: str, b: str) -> float:
    return float(np.linalg.norm(np.subtract(world.position(world.resolve(a).handle, -1),
                                            world.position(world.resolve(b).handle, -1))))


@pytest.fixture(scope="module")
def ik_server():
    srv = ServerProcess(str(IK_SCENE), "--speed", "0", ports=[free_port()], renderers="on-demand")
    yield srv
    log = srv.stop()
    assert "Traceback" not in log, log


def test_tip_follows_target_within_2mm_at_rest(ik_server):
    """simxSetObjectPosition/Orientation on UR5_target only: UR5_tip rests on it (2 mm, 0.01 rad)."""
    cid = vrep.simxStart("127.0.0.1", ik_server.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        _, target = vrep.simxGetObjectHandle(cid, "UR5_target", BLOCK)
        _, tip = vrep.simxGetObjectHandle(cid, "UR5_tip", BLOCK)
        vrep.simxStartSimulation(cid, BLOCK)

        def errors():
            _, p = vrep.simxGetObjectPosition(cid, tip, target, BLOCK)
            _, e = vrep.simxGetObjectOrientation(cid, tip, target, BLOCK)
            return float(np.linalg.norm(p)), float(np.linalg.norm(e))

        worst = []
        # workspace corners, the gripper turned; moves that do not sweep the arm through the
        # table (the arm collides with it, and a blocked arm does not reach its target)
        for position, turn in (([-0.5, 0.0, 0.3], 0.0), ([-0.65, 0.18, 0.08], 0.8),
                               ([-0.35, -0.2, 0.12], -1.2), ([-0.7, -0.2, 0.05], -0.4)):
            assert vrep.simxSetObjectPosition(cid, target, -1, position, BLOCK) == vrep.simx_return_ok
            assert vrep.simxSetObjectOrientation(cid, target, -1, [DOWN[0], turn, DOWN[2]], BLOCK) == 0
            last = []

            def on_target():
                last[:] = errors()
                return last[0] < 0.002 and last[1] < 0.01

            wait_until(on_target, timeout=20, what=lambda: f"tip on the target at {position} (errors {last})")
            at_rest = [errors() for _ in range(10)]  # and it stays there
            assert max(e[0] for e in at_rest) < 0.002, at_rest
            assert max(e[1] for e in at_rest) < 0.01, at_rest
            worst.append(max(e[0] for e in at_rest))
            _, p = vrep.simxGetObjectPosition(cid, tip, -1, BLOCK)
            assert np.allclose(p, position, atol=0.002)
        print(f"tip error at rest, worst of 10 readings per pose (mm): {[round(w * 1000, 4) for w in worst]}")
    finally:
        vrep.simxStopSimulation(cid, BLOCK)
        vrep.simxFinish(cid)


def test_joint_limits_and_maximum_velocity_hold(tmp_path):
    """An unreachable target: the chain stops at its joint limit; the joints never exceed max_velocity."""
    sim = _arm(tmp_path, high=0.5, vmax=1.0)
    w = sim.world
    j1, j2 = w.resolve("j1").handle, w.resolve("j2").handle
    sim.start()
    # the target wants j1 near 1.3 rad (the arm bent down towards +x), its range ends at 0.5
    w.set_pose(w.resolve("target").handle, -1, [0.55, 0.0, 0.05])
    speeds, q1 = [], []
    for _ in range(60):
        before = np.array([w.joint_position(j1), w.joint_position(j2)])
        sim.step()
        after = np.array([w.joint_position(j1), w.joint_position(j2)])
        speeds.append(np.abs(after - before).max() / w.dt)
        q1.append(after[0])
    assert max(q1) <= 0.5 + 0.01, max(q1)  # the limit holds (within the motor's tracking)
    assert max(q1) > 0.45  # and the arm went there
    # max_velocity 1 rad/s, as the joints' position control enforces it (5 % for the servo's transient)
    print(f"fastest joint over a step: {max(speeds):.3f} rad/s (max_velocity 1)")
    assert max(speeds) <= 1.0 * 1.05, max(speeds)
    assert w.target_position[w.motor_index[j1]] == pytest.approx(0.5)  # the solution is clamped
    sim.close()


@pytest.mark.parametrize("extra", ["", "method=damped_least_squares"], ids=["plain", "general solver"])
def test_old_group_moves_a_joint_off_its_upper_limit(tmp_path, extra):
    """V-REP 4.1's old IK differentiates analytically (coppeliaSimLib 4.1 ``CIkRoutine::getJacobian``):
    a joint at its upper limit keeps its Jacobian column, and ``sim.checkIkGroup`` brings it back
    inside for a target that needs it there (simIK's numeric Jacobian would leave it at the limit),
    with the plain solver and the general one alike."""
    sim = _arm(tmp_path, high=0.5, extra=extra)
    w = sim.world
    j1, j2 = w.resolve("j1").handle, w.resolve("j2").handle
    goal = [0.3 * math.sin(0.2) + 0.3 * math.sin(0.8), 0.0, 0.3 * math.cos(0.2) + 0.3 * math.cos(0.8)]
    w.set_pose(w.resolve("target").handle, -1, goal)  # the tip with j1 = 0.2, j2 = 0.6
    w.set_joint_position(j1, 0.5)  # j1 at its upper limit
    w.set_joint_position(j2, 0.3)
    groups = ik.groups(w)
    result, (q1, q2) = groups.check(groups.group("arm"), [j1, j2])
    assert result == ik.IK_SUCCESS
    assert q1 < 0.45 and (q1, q2) == pytest.approx((0.2, 0.6), abs=0.01)
    sim.close()


def test_reachable_target_position_only(tmp_path):
    """constraints=position: the tip reaches a reachable point (orientation free)."""
    sim = _arm(tmp_path)
    w = sim.world
    sim.start()
    w.set_pose(w.resolve("target").handle, -1, [0.35, 0.0, 0.2])
    for _ in range(100):
        sim.step()
    assert _distance(w, "tip", "target") < 0.002
    sim.close()


def test_explicit_group_is_left_to_scripts_and_simik_solves_it(tmp_path):
    """explicit=true: not solved by the step; a Lua script's simIK.handleGroup (4.x) solves it,
    and sim.handleIkGroup answers sim.ikresult_success (1)."""
    script = """
local env, group
function sysCall_init()
    env = simIK.createEnvironment()
    group = simIK.getGroupHandle(env, 'arm')
end
function sysCall_actuation()
    if sim.getIntegerSignal('solve') == 1 then
        simIK.handleGroup(env, group, {syncWorlds = true})
    end
end
function solveOnce(ints, floats, strings, buffer)
    return {sim.handleIkGroup(sim.getIkGroupHandle('arm'))}, {}, {}, ''
end
"""
    sim = _arm(tmp_path, extra="explicit=true", script=script)
    w = sim.world
    sim.start()
    w.set_pose(w.resolve("target").handle, -1, [0.35, 0.0, 0.2])
    start = _distance(w, "tip", "target")
    for _ in range(20):
        sim.step()
    assert _distance(w, "tip", "target") == pytest.approx(start, abs=1e-3)  # explicit: untouched
    sim.signals.set_int("solve", 1)
    for _ in range(100):
        sim.step()
    assert _distance(w, "tip", "target") < 0.002
    # the 3.x call from a remote function: success on a reachable target
    w.set_pose(w.resolve("target").handle, -1, [0.3, 0.0, 0.25])
    ints, *_ = sim.scripts.call("base", 1, "solveOnce", [], [], [], b"")
    assert ints == [ik.IK_SUCCESS]
    sim.close()


def test_handle_ik_group_errors_name_the_group(tmp_path):
    script = """
function badGroup(ints, floats, strings, buffer)
    return {sim.handleIkGroup('nosuchgroup')}, {}, {}, ''
end
"""
    sim = _arm(tmp_path, script=script)
    sim.start()
    with pytest.raises(Exception, match="no IK group 'nosuchgroup'"):
        sim.scripts.call("base", 1, "badGroup", [], [], [], b"")
    sim.step()  # the server goes on
    sim.close()


@pytest.mark.parametrize("data, reason", [
    ("tip=tip target=target size=3", "unknown key"),
    ("tip=link1 target=target", "is not a dummy"),
    ("tip=tip", "target= is missing"),
    ("tip=tip target=target iterations=100000", "MAX_IK_ITERATIONS"),
    ("tip=tip target=target constraints=twist", "constraints must be pose, position, orientation"),
    ("tip=tip target=target constraints=32", "bits (1-31)"),
    ("tip=tip target=target tip2=tip", "target2= is missing"),
    ("tip=target target=tip", "no motorised hinge or slide joint"),
])
def test_bad_declarations_are_logged_and_ignored(tmp_path, caplog, data, reason):
    """A bad simx:ik text: one error line naming the group and why; the scene loads, the good
    group still works."""
    caplog.set_level(logging.ERROR, logger="simx.ik")
    sim = _arm(tmp_path, texts=f'<text name="simx:ik:bad" data="{data}"/>')
    w = sim.world
    sim.start()
    w.set_pose(w.resolve("target").handle, -1, [0.35, 0.0, 0.2])
    for _ in range(40):
        sim.step()
    lines = [r.getMessage() for r in caplog.records if "'bad'" in r.getMessage()]
    assert len(lines) == 1 and reason in lines[0], lines
    assert sorted(ik.groups(w).groups) == ["arm"]
    assert _distance(w, "tip", "target") < 0.002
    sim.close()


def test_ur5_pose_group_settings_and_reach():
    """The UR5's pose group as the scene sets it (10 iterations) brings the tip onto a turned
    target. (Its cost per step is not a test's business: benchmarks/.)"""
    sim = Simulation(IK_SCENE, dt=0.05, realtime=False)
    w = sim.world
    sim.start()
    for _ in range(20):
        sim.step()
    assert ik.groups(w).groups["UR5"].iterations == 10
    w.set_pose(w.resolve("UR5_target").handle, -1, [-0.6, 0.1, 0.1],
               matrix_from_euler(DOWN[0], 0.5, DOWN[2]))
    for _ in range(40):
        sim.step()
    assert _distance(w, "UR5_tip", "UR5_target") < 0.002
    sim.close()


def test_a_chain_joint_in_velocity_mode_does_not_stop_the_simulation(ik_server):
    """A client turns a chain joint's control loop off (sim_jointintparam_ctrl_enabled = 0,
    velocity mode): the IK goes on with the other joints, the simulation keeps running; with
    the loop back on, the tip reaches the target again."""
    cid = vrep.simxStart("127.0.0.1", ik_server.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        _, target = vrep.simxGetObjectHandle(cid, "UR5_target", BLOCK)
        _, tip = vrep.simxGetObjectHandle(cid, "UR5_tip", BLOCK)
        _, joint1 = vrep.simxGetObjectHandle(cid, "UR5_joint1", BLOCK)
        vrep.simxStartSimulation(cid, BLOCK)
        assert vrep.simxSetObjectIntParameter(cid, joint1, 2001, 0, BLOCK) == vrep.simx_return_ok
        vrep.simxSetObjectPosition(cid, target, -1, [-0.45, 0.15, 0.2], BLOCK)
        vrep.simxGetPingTime(cid)
        t0 = vrep.simxGetLastCmdTime(cid)
        wait_until(lambda: vrep.simxGetPingTime(cid)[0] == 0 and vrep.simxGetLastCmdTime(cid) > t0 + 500,
                   timeout=10, what="the simulation advancing 0.5 s")
        rc, running = vrep.simxGetInMessageInfo(cid, vrep.simx_headeroffset_server_state)
        assert rc != -1 and running & 1, running  # not stopped by a step fault
        assert vrep.simxSetObjectIntParameter(cid, joint1, 2001, 1, BLOCK) == vrep.simx_return_ok

        def distance():
            _, p = vrep.simxGetObjectPosition(cid, tip, target, BLOCK)
            return float(np.linalg.norm(p))

        wait_until(lambda: distance() < 0.002, timeout=20, what="tip on the target again")
    finally:
        vrep.simxStopSimulation(cid, BLOCK)
        vrep.simxFinish(cid)


# A planar three-link arm: V-REP's two-element group of the youBot's kind, the tip's position
# (x and z, bits 1 + 4) and a second tip's rotation about the target's z alone (gamma, bit 16).
ARM3 = """<mujoco>
  <compiler angle="radian"/>
  <option timestep="0.002" gravity="0 0 0"/>
  <worldbody>
    <site name="target" pos="0.35 0 0.3" size="0.01"/>
    <site name="target_o" pos="0 0.5 0" quat="{quat}" size="0.01"/>
    <body name="base">
      <body name="l1"><joint name="j1" type="hinge" axis="0 1 0" damping="1" armature="0.1"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02" mass="1"/>
        <body name="l2" pos="0 0 0.3"><joint name="j2" type="hinge" axis="0 1 0" damping="1" armature="0.1"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02" mass="1"/>
          <body name="l3" pos="0 0 0.3"><joint name="j3" type="hinge" axis="0 1 0" damping="1" armature="0.1"/>
            <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.02" mass="1"/>
            <site name="tip" pos="0 0 0.3" size="0.01"/>
            <site name="tip_o" pos="0 0 0.15" quat="0.70710678 -0.70710678 0 0" size="0.01"/>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <velocity joint="j1" kv="50" forcerange="-100 100"/>
    <velocity joint="j2" kv="50" forcerange="-100 100"/>
    <velocity joint="j3" kv="50" forcerange="-100 100"/>
  </actuator>
  <custom>
    <text name="simx:j1" data="mode=position max_velocity=2"/>
    <text name="simx:j2" data="mode=position max_velocity=2"/>
    <text name="simx:j3" data="mode=position max_velocity=2"/>
    <text name="simx:ik:arm" data="tip=tip target=target base=base constraints=5 {second}"/>
  </custom>
</mujoco>
"""


@pytest.mark.parametrize("second", [True, False], ids=["two elements", "position alone"])
def test_a_group_of_two_elements_holds_both(tmp_path, second):
    """The second element (tip2/target2, constraints2=16) turns the last link to the target's
    angle while the first keeps the tip on its target; without it the angle is whatever the
    redundant arm ends at."""
    import mujoco

    angle = 0.5  # the last link's angle from vertical, about y
    about_y = np.array([math.cos(angle / 2), 0, math.sin(angle / 2), 0])
    quat = np.empty(4)
    mujoco.mju_mulQuat(quat, about_y, np.array([math.sqrt(0.5), -math.sqrt(0.5), 0, 0]))
    scene = tmp_path / "arm3.xml"
    scene.write_text(ARM3.format(quat=" ".join(f"{v:.9f}" for v in quat),
                                 second="tip2=tip_o target2=target_o base2=base constraints2=16" if second else ""))
    sim = Simulation(scene, dt=0.05, realtime=False)
    try:
        sim.start()
        for _ in range(80):  # 4 s
            sim.step()
        w = sim.world
        assert _distance(w, "tip", "target") < 2e-3
        link = sum(float(w.data.joint(j).qpos[0]) for j in ("j1", "j2", "j3"))
        if second:
            assert link == pytest.approx(angle, abs=2e-3)
        else:
            assert abs(link - angle) > 0.05  # the position alone leaves the angle free
    finally:
        sim.close()
