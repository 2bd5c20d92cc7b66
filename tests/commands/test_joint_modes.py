"""Joint control as V-REP does it, on MJCF written in other people's styles (issue 12, part 1).

The physics runs in-process (World) on the test scenes of tests/scenes/joints, each written for
simx in the style of a well-known model family; the legacy API runs against real servers.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

import vrep
from conftest import ServerProcess
from simx_client.protocol import ObjectTypeError
from simx_server.sim.world import World

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCENES = Path(__file__).resolve().parents[1] / "scenes" / "joints"
B = vrep.simx_opmode_blocking
MOTOR, LOOP, PID_P, VMAX = 2000, 2001, 2002, 2017  # sim_jointintparam_motor_enabled, _ctrl_enabled, ...
#: Transient overshoot of the maximum velocity allowed while the other joints of a chain
#: accelerate at the same time (their reaction torques reach a servo one step late).
SPEED_MARGIN = 1.15


def _motorised(world: World) -> list[int]:
    """Handles of the joints whose motor is enabled (the scene's actuated joints)."""
    mo = world.motors
    return [h for h, i in mo.index.items() if mo.enabled[i]]


def _hold_floating_base(world: World) -> None:
    """Enable the added (passive) motors in position control: the planar runner's torso is
    held in the air by its root joints, as a V-REP program can enable any passive joint's motor."""
    for h, i in world.motors.index.items():
        if not world.motors.enabled[i]:
            world.set_motor_flags(h, enabled=True, loop=True)


def _target(world: World, h: int, offset: float) -> float:
    """Current position + offset, kept inside the joint's limits."""
    j, q0 = world.objects[h].mj_id, world.joint_position(h)
    t = q0 + offset
    if world.model.jnt_limited[j]:
        lo, hi = world.model.jnt_range[j]
        if not lo + 0.05 <= t <= hi - 0.05:
            t = q0 - offset
    return t


MODELS = ["acrobot.xml", "cart_slider.xml", "planar_runner.xml", "arm6_position.xml", "arm7_general.xml",
          "arm7_torque.xml", "tendon_pair.xml", "activation_arm.xml"]


@pytest.mark.parametrize("scene", MODELS)
def test_every_actuated_joint_settles_on_its_target(scene):
    world = World(SCENES / scene, dt=0.05)
    joints = _motorised(world)
    if scene == "planar_runner.xml":
        _hold_floating_base(world)
    assert joints, "the scene has actuated joints"
    targets = {h: _target(world, h, 0.3) for h in joints}
    for h, t in targets.items():
        world.set_joint_target_position(h, t)
    m, steps = world.model, int(3.0 / world.dt)
    q, speed = np.empty((steps, len(joints))), np.zeros(len(joints))
    for k in range(steps):
        world.step()
        q[k] = [world.joint_position(h) for h in joints]
        speed = np.maximum(speed, [abs(world.data.qvel[world._scalar_joints[h][1]]) for h in joints])
    tail = q[-int(round(0.5 / world.dt)):]
    for n, h in enumerate(joints):
        name, i, j = world.objects[h].name, world.motors.index[h], world.objects[h].mj_id
        worst = np.abs(tail[:, n] - targets[h]).max()
        assert worst < 0.01, f"{scene} {name}: {worst:.4f} rad from its target {targets[h]:.4f} over the last 0.5 s"
        # No sustained oscillation (the acrobot's elbow carries its passive shoulder's swing: 2 mrad)
        assert np.ptp(tail[:, n]) < 0.005, f"{scene} {name}: still oscillating ({np.ptp(tail[:, n]):.4f} rad)"
        assert speed[n] <= world.max_velocity[i] * SPEED_MARGIN, f"{scene} {name}: {speed[n]:.2f} rad/s"
        if m.jnt_limited[j]:
            lo, hi = m.jnt_range[j]
            assert lo - 0.02 <= q[:, n].min() and q[:, n].max() <= hi + 0.02, f"{scene} {name}: beyond its limits"


@pytest.mark.parametrize("scene", MODELS)
def test_every_actuated_joint_follows_velocity_and_force(scene):
    """Motor on, control loop off: the target velocity with at most the maximum force; a huge
    target velocity with a small maximum force is torque control (the motor applies exactly it)."""
    world = World(SCENES / scene, dt=0.05)
    joints = _motorised(world)
    if scene == "planar_runner.xml":
        _hold_floating_base(world)
    directions = {h: float(np.sign(_target(world, h, 0.3) - world.joint_position(h))) for h in joints}
    for h in joints:
        world.set_motor_flags(h, loop=False)
        world.set_joint_target_velocity(h, 0.5 * directions[h])
    q0 = [world.joint_position(h) for h in joints]
    for _ in range(4):  # 0.2 s: accelerate
        world.step()
    q1 = [world.joint_position(h) for h in joints]
    world.step()
    world.step()  # 0.1 s at speed
    q2 = [world.joint_position(h) for h in joints]
    for n, h in enumerate(joints):
        name = world.objects[h].name
        assert (q1[n] - q0[n]) * directions[h] > 0, f"{scene} {name} did not move"
        speed = (q2[n] - q1[n]) / (2 * world.dt)
        # 10%: the acrobot's elbow also carries its free shoulder's swing (7% off at worst)
        assert speed == pytest.approx(0.5 * directions[h], rel=0.1), f"{scene} {name}: {speed:.3f} rad/s"
    for h in joints:
        force = min(world.joint_max_force(h), 1.0)
        world.set_joint_force(h, force)
        world.set_joint_target_velocity(h, 1e3 * directions[h])
    world.step()
    for h in joints:
        assert world.joint_force(h) == pytest.approx(min(world.joint_max_force(h), 1.0) * directions[h], rel=1e-6)


def test_force_limits_come_from_the_model():
    """forcerange x gear, ctrlrange x gear for a torque actuator, the joint's actuatorfrcrange."""
    w = World(SCENES / "planar_runner.xml")
    assert w.joint_max_force(w.resolve("bthigh").handle) == pytest.approx(120.0)  # ctrlrange 1 x gear 120
    assert w.joint_max_force(w.resolve("ffoot").handle) == pytest.approx(30.0)
    w = World(SCENES / "arm7_torque.xml")
    assert w.joint_max_force(w.resolve("a1").handle) == pytest.approx(320.0)  # ctrlrange (N·m)
    assert w.joint_max_force(w.resolve("a7").handle) == pytest.approx(40.0)  # joint actuatorfrcrange
    w = World(SCENES / "arm6_position.xml")
    assert w.joint_max_force(w.resolve("wrist_1").handle) == pytest.approx(28.0)  # forcerange
    # The motor of a slider with gear 10: 3 N asked on the joint is 0.3 in actuator units.
    w = World(SCENES / "cart_slider.xml")
    h = w.resolve("slider").handle
    w.set_motor_flags(h, loop=False)
    w.set_joint_force(h, 3.0)
    w.set_joint_target_velocity(h, 100.0)
    w.step()
    assert w.joint_force(h) == pytest.approx(3.0) and w.data.actuator_force[0] == pytest.approx(0.3)


def test_passive_joint_gets_a_disabled_motor_and_unchanged_physics(tmp_path):
    """A hinge without an actuator gets one through MjSpec, disabled: the pendulum swings
    exactly as in MuJoCo alone, until a program enables the motor, which then holds it."""
    xml = tmp_path / "pendulum.xml"
    xml.write_text("""<mujoco><option timestep="0.002"/><worldbody><body name="bob" pos="0 0 1">
      <joint name="swing" type="hinge" axis="0 1 0" damping="0.02"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 -0.3" size="0.03"/></body></worldbody></mujoco>""")
    world = World(xml, dt=0.05)
    h = world.resolve("swing").handle
    assert world.model.nu == 1 and world.motors.names[h] == "simx_motor:swing"
    assert vars_of(world, h) == (0, 1)  # motor off, loop on (V-REP's defaults for a passive joint)
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    for _ in range(20):
        world.step()
        mujoco.mj_step(model, data, nstep=world.substeps)
    assert world.joint_position(h) == pytest.approx(float(data.qpos[0]), abs=1e-9)
    assert abs(world.joint_position(h)) > 0.2  # it did swing
    world.set_joint_target_position(h, 0.0)
    world.set_motor_flags(h, enabled=True)
    for _ in range(40):
        world.step()
    assert abs(world.joint_position(h)) < 0.01


def vars_of(world: World, h: int) -> tuple[int, int]:
    i = world.motors.index[h]
    return int(world.motors.enabled[i]), int(world.motors.loop[i])


def test_tendon_driven_joints_answer_naming_the_tendon():
    world = World(SCENES / "tendon_pair.xml")
    finger = world.resolve("finger_a").handle
    for call in (world.set_joint_target_position, world.set_joint_target_velocity, world.set_joint_force):
        with pytest.raises(ObjectTypeError, match="tendon 'grip'"):
            call(finger, 0.1)
    assert finger not in world.motors.index  # no motor added on top of the tendon's actuator


def test_legacy_program_switches_modes_through_the_api():
    """simxSetJointTargetVelocity(j, 1.0) then simxSetObjectIntParameter(j, 2001, 0) moves the
    joint at 1 rad/s; the stored target position acts again once the loop is back on; motor off
    frees the joint. Through a real server, stepped."""
    srv = ServerProcess(str(SCENES / "arm6_position.xml"), "--speed", "0", renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    try:
        assert cid >= 0
        rc, j = vrep.simxGetObjectHandle(cid, "shoulder_pan", B)
        assert rc == 0
        assert vrep.simxSynchronous(cid, True) == 0
        assert vrep.simxStartSimulation(cid, B) == 0

        def steps(n: int) -> float:
            for _ in range(n):
                assert vrep.simxSynchronousTrigger(cid) == 0
            assert vrep.simxGetPingTime(cid)[0] == 0  # the triggered steps are done
            rc, q = vrep.simxGetJointPosition(cid, j, B)
            assert rc == 0
            return q

        assert [vrep.simxGetObjectIntParameter(cid, j, p, B) for p in (MOTOR, LOOP)] == [(0, 1), (0, 1)]
        assert vrep.simxGetObjectFloatParameter(cid, j, PID_P, B) == (0, pytest.approx(0.1))
        assert vrep.simxSetJointTargetVelocity(cid, j, 1.0, B) == 0  # stored while in position control
        q0 = steps(4)
        assert abs(q0) < 1e-3  # position control still holds the joint at its target (0)
        assert vrep.simxSetObjectIntParameter(cid, j, LOOP, 0, B) == 0
        q1 = steps(4)
        q2 = steps(10)
        assert (q2 - q1) / (10 * 0.05) == pytest.approx(1.0, rel=0.02)
        assert vrep.simxSetJointTargetPosition(cid, j, 0.2, B) == 0  # stored while in velocity control
        assert abs(steps(2) - q2 - 0.1) < 0.01  # still 1 rad/s
        assert vrep.simxSetObjectIntParameter(cid, j, LOOP, 1, B) == 0
        assert steps(30) == pytest.approx(0.2, abs=0.005)  # back to the stored target
        assert vrep.simxSetObjectIntParameter(cid, j, MOTOR, 0, B) == 0
        assert vrep.simxGetObjectIntParameter(cid, j, MOTOR, B) == (0, 0)
        # Motor off frees the joint: the lifted upper arm falls under gravity.
        rc, lift = vrep.simxGetObjectHandle(cid, "shoulder_lift", B)
        assert rc == 0 and vrep.simxSetJointTargetPosition(cid, lift, 0.6, B) == 0
        steps(30)
        rc, held = vrep.simxGetJointPosition(cid, lift, B)
        assert rc == 0 and held == pytest.approx(0.6, abs=0.005)
        assert vrep.simxSetObjectIntParameter(cid, lift, MOTOR, 0, B) == 0
        steps(10)
        rc, fallen = vrep.simxGetJointPosition(cid, lift, B)
        assert rc == 0 and fallen > held + 0.2
        assert vrep.simxSetObjectIntParameter(cid, j, LOOP, 3, B) == vrep.simx_return_remote_error_flag
        rc, shape = vrep.simxGetObjectHandle(cid, "base", B)  # a shape, not a joint: V-REP's error
        assert rc == 0 and vrep.simxSetJointTargetPosition(cid, shape, 0.1, B) == vrep.simx_return_remote_error_flag
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    assert "Traceback" not in log


def test_simx_mode_setting_gives_the_initial_motor_state(tmp_path):
    """``simx:JOINT mode=``: passive turns an actuator's motor off, velocity enables the motor
    simx added to a bare joint in velocity control; stop (reset) restores them."""
    xml = tmp_path / "modes.xml"
    xml.write_text("""<mujoco><worldbody>
      <body name="a" pos="0 0 1"><joint name="driven" axis="0 0 1"/><geom size="0.1" mass="1"/></body>
      <body name="b" pos="1 0 1"><joint name="bare" axis="0 0 1"/><geom size="0.1" mass="1"/></body>
      </worldbody><actuator><position joint="driven" kp="50"/></actuator>
      <custom><text name="simx:driven" data="mode=passive"/><text name="simx:bare" data="mode=velocity"/></custom>
      </mujoco>""")
    world = World(xml)
    driven, bare = world.resolve("driven").handle, world.resolve("bare").handle
    assert vars_of(world, driven) == (0, 1) and vars_of(world, bare) == (1, 0)
    world.set_joint_target_velocity(bare, 2.0)
    world.set_motor_flags(driven, enabled=True)
    for _ in range(10):
        world.step()
    assert world.data.qvel[world._scalar_joints[bare][1]] == pytest.approx(2.0, rel=0.01)
    world.reset()
    assert vars_of(world, driven) == (0, 1) and world.target_velocity[world.motors.index[bare]] == 0.0


def test_scene_edits_keep_motor_state_and_add_motors_once(tmp_path):
    """A model loaded into the scene (scene editing through MjSpec) gets motors for its bare
    joints; the motors of the scene keep their flags and targets, and none is added twice."""
    from simx_server.commands.editing import EDITING_HANDLERS
    from simx_server.scene.simulation import Simulation

    model = tmp_path / "flap.xml"
    model.write_text("""<mujoco><worldbody><body name="flap" pos="0 0 2">
      <joint name="flap_hinge" axis="1 0 0"/><geom type="box" size="0.1 0.02 0.1" mass="0.2"/>
      </body></worldbody></mujoco>""")
    sim = Simulation(SCENES / "arm6_position.xml", dt=0.05, realtime=False, scene_paths=[tmp_path])
    try:
        w = sim.world
        pan = w.resolve("shoulder_pan").handle
        w.set_motor_flags(pan, loop=False)
        w.set_joint_target_velocity(pan, 0.7)
        w.set_joint_target_position(pan, -0.4)
        for _ in range(2):
            EDITING_HANDLERS["LoadModel"](sim, [str(model), 0])
        names = [mujoco.mj_id2name(w.model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in range(w.model.nu)]
        assert names.count("simx_motor:flap_hinge") == 1 and names.count("simx_motor:flap_hinge#0") == 1
        flap = w.resolve("flap_hinge").handle
        assert vars_of(w, flap) == (0, 1) and vars_of(w, pan) == (1, 0)
        i = w.motor_index[pan]
        assert (w.target_velocity[i], w.target_position[i]) == (0.7, -0.4)
    finally:
        sim.close()


@pytest.mark.parametrize("scene", ["ur5_rg2_kinect.xml", "ur5_ik.xml", "pendulum", "tendon"])
def test_motors_read_from_the_spec_give_the_twice_compiled_model(scene, tmp_path):
    """compile_spec reads the joints that need a motor from the spec and compiles once; the
    model is byte for byte the one of compiling, adding the motors of the joints the compiled
    model shows undriven (in joint order) and compiling again; a joint driven through a tendon
    gets none."""
    from simx_server.sim import motor_spec, motors, urdf

    if scene == "pendulum":  # a nested joint listed before its parent's in no particular order
        path = tmp_path / "p.xml"
        path.write_text("""<mujoco><worldbody><body name="a"><joint name="j2" type="slide"/>
          <geom size="0.1"/><body name="b"><joint name="j1"/><geom size="0.1"/></body></body>
          <body name="c"><joint name="j0" type="hinge"/><geom size="0.1"/></body></worldbody>
          <actuator><motor joint="j1"/></actuator></mujoco>""")
    elif scene == "tendon":
        path = tmp_path / "t.xml"
        path.write_text("""<mujoco><worldbody><body><joint name="p"/><geom size="0.1"/>
          <body><joint name="q"/><geom size="0.1"/></body></body></worldbody>
          <tendon><fixed name="t"><joint joint="p" coef="1"/></fixed></tendon>
          <actuator><motor tendon="t"/></actuator></mujoco>""")
    else:
        path = Path(motors.__file__).resolve().parents[2] / "scenes" / scene

    def blob(m):
        out = np.empty(mujoco.mj_sizeModel(m), np.uint8)
        mujoco.mj_saveModel(m, None, out)
        return out.tobytes()

    spec = urdf.load_spec(path)
    twice = spec.compile()
    undriven = [mujoco.mj_id2name(twice, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(twice.njnt)
                if int(twice.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
                and j not in {int(twice.actuator_trnid[a, 0]) for a in range(twice.nu)
                              if int(twice.actuator_trntype[a]) == int(mujoco.mjtTrn.mjTRN_JOINT)}]
    if scene == "tendon":
        undriven.remove("p")  # through the tendon
    for name in undriven:
        spec.add_actuator(name=motor_spec.ADDED_PREFIX + name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                          gear=[1, 0, 0, 0, 0, 0], ctrllimited=0, forcelimited=0)
    twice = spec.compile()
    once = motor_spec.compile_spec(urdf.load_spec(path))
    assert undriven and blob(once) == blob(twice)
