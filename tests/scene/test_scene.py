"""In-process checks of scenes/ur5_rg2_kinect.xml (no server involved).

The scene imitates the V-REP tutorial scene: UR5 (+RG2 gripper, eye-in-hand
Kinect) on a lab bench with a red ball.  These tests pin the names the server
and the client programs rely on, the UR5 kinematics (published DH values, zero
pose pointing straight up), the camera view at the tutorial pose, the motor
stability and an actual grasp-and-lift of the ball.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402  (MUJOCO_GL must be set before the import)

SCENE = Path(__file__).resolve().parents[2] / "scenes" / "ur5_rg2_kinect.xml"

# UR5 published DH parameters (metres)
D1, A2, A3, D4, D5, D6 = 0.089159, 0.425, 0.39225, 0.10915, 0.09465, 0.0823

ARM_JOINTS = [f"UR5_joint{i}" for i in range(1, 7)]
ARM_MOTORS = [f"{j}_motor" for j in ARM_JOINTS]
GRIPPER_JOINT = "RG2_openCloseJoint"
GRIPPER_MOTOR = "RG2_openCloseJoint_motor"

TUTORIAL_POSE_DEG = [90.0, -45.0, 90.0, 0.0, -100.0, 0.0]
# Computed once with a damped-least-squares IK on this scene (RG2_tcp site
# 10 cm above / at the ball centre, gripper pointing straight down, fingers
# closing along world x).  Inputs of the grasp test.
PRE_GRASP_DEG = [76.515, 39.176, 51.017, -0.193, -90.0, -13.485]
GRASP_DEG = [76.515, 41.109, 62.468, -13.577, -90.0, -13.485]

# The server's position mode: ctrl = clip(Kp*(target-q), -vmax, vmax) per substep
KP = 20.0
VMAX = np.pi  # 180 deg/s


@pytest.fixture(scope="module")
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(SCENE))


def _qadr(m, names):
    return np.array([m.jnt_qposadr[m.joint(n).id] for n in names])


def _set_arm(m, d, q_deg):
    d.qpos[_qadr(m, ARM_JOINTS)] = np.deg2rad(q_deg)
    mujoco.mj_forward(m, d)


class _Controller:
    """Steps the model like the server does in position mode."""

    def __init__(self, m, d):
        self.m, self.d = m, d
        self.qadr = _qadr(m, ARM_JOINTS)
        self.arm = np.array([m.actuator(n).id for n in ARM_MOTORS])
        self.grip = m.actuator(GRIPPER_MOTOR).id

    def run(self, seconds, target, gripper_vel=0.0):
        """target: callable(t since start) -> 6 joint angles (rad), or array."""
        m, d = self.m, self.d
        t0 = d.time
        for _ in range(int(round(seconds / m.opt.timestep))):
            tgt = target(d.time - t0) if callable(target) else target
            d.ctrl[self.arm] = np.clip(KP * (tgt - d.qpos[self.qadr]), -VMAX, VMAX)
            d.ctrl[self.grip] = gripper_vel
            mujoco.mj_step(m, d)


def _robot_bodies(m):
    """Ids of the UR5 subtree (arm, gripper, kinect)."""
    root = m.body("UR5").id
    return {b for b in range(m.nbody) if b == root or _has_ancestor(m, b, root)}


def _has_ancestor(m, b, root):
    while b != 0:
        b = m.body_parentid[b]
        if b == root:
            return True
    return False


def _text_data(m, i):
    adr, size = m.text_adr[i], m.text_size[i]
    raw = m.text_data[adr: adr + size]
    raw = raw.encode() if isinstance(raw, str) else bytes(raw)
    return raw.split(b"\0", 1)[0].decode()


# ---------------------------------------------------------------- (a) names
def test_required_names_exist(model):
    m = model
    for body in ["UR5", "RG2", "Sphere", "Table", "kinect"] + [f"UR5_link{i}" for i in range(1, 7)]:
        m.body(body)  # raises KeyError if missing
    for j in ARM_JOINTS:
        assert m.joint(j).type == mujoco.mjtJoint.mjJNT_HINGE, j
    assert m.joint(GRIPPER_JOINT).type == mujoco.mjtJoint.mjJNT_SLIDE
    assert m.joint("RG2_fingerJoint2").type == mujoco.mjtJoint.mjJNT_SLIDE
    assert m.joint(m.body("Sphere").jntadr[0]).type == mujoco.mjtJoint.mjJNT_FREE
    for cam in ("kinect_rgb", "kinect_depth"):
        c = m.camera(cam)
        assert list(m.cam_resolution[c.id]) == [640, 480]
        assert c.fovy[0] == pytest.approx(np.rad2deg(2 * np.arctan(np.tan(np.deg2rad(28.5)) * 480 / 640)), abs=0.05)
    # gripper hangs off the flange, kinect rides on the gripper
    assert m.body(m.body("RG2").parentid[0]).name == "UR5_link6"
    assert _has_ancestor(m, m.body("kinect").id, m.body("RG2").id)
    # names must be unambiguous for the server's name -> handle lookup
    names = []
    for kind, n in [(mujoco.mjtObj.mjOBJ_BODY, m.nbody), (mujoco.mjtObj.mjOBJ_JOINT, m.njnt),
                    (mujoco.mjtObj.mjOBJ_GEOM, m.ngeom), (mujoco.mjtObj.mjOBJ_CAMERA, m.ncam),
                    (mujoco.mjtObj.mjOBJ_SITE, m.nsite), (mujoco.mjtObj.mjOBJ_ACTUATOR, m.nu)]:
        names += [mujoco.mj_id2name(m, kind, i) for i in range(n)]
    names = [n for n in names if n]
    assert len(names) == len(set(names)), sorted({n for n in names if names.count(n) > 1})


def test_actuators(model):
    m = model
    expected = dict(zip(ARM_MOTORS, [150, 150, 150, 28, 28, 28]))
    expected[GRIPPER_MOTOR] = 40
    assert m.nu == len(expected)
    for name, fmax in expected.items():
        a = m.actuator(name)
        joint = name[: -len("_motor")]
        assert a.trnid[0] == m.joint(joint).id
        assert a.forcelimited[0] and list(a.forcerange) == [-fmax, fmax]
        assert not a.ctrllimited[0]
        kv = a.gainprm[0]
        assert kv > 0 and a.biasprm[2] == -kv and a.biasprm[1] == 0  # velocity servo
        # stall force with a small velocity error must reach the force limit
        assert kv * 0.5 >= fmax, name
    for j in ARM_JOINTS:
        jj = m.joint(j)
        assert jj.limited[0] and list(jj.range) == pytest.approx([-6.2832, 6.2832])
        assert jj.damping[0] > 0 and jj.armature[0] > 0
    assert m.opt.timestep <= 0.002
    assert list(m.opt.gravity) == pytest.approx([0, 0, -9.81])


def test_custom_simx_settings(model):
    m = model
    texts = {}
    for i in range(m.ntext):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXT, i)
        data = _text_data(m, i)
        texts[name] = dict(kv.split("=", 1) for kv in data.split())
    for j in ARM_JOINTS:
        assert texts[f"simx:{j}"] == {"mode": "position", "max_velocity": "3.14159265"}
    assert texts[f"simx:{GRIPPER_JOINT}"] == {"mode": "velocity", "max_velocity": "0.5"}
    assert texts["simx:kinect_rgb"] == {"image": "rgb", "near": "0.01", "far": "3.5"}
    assert texts["simx:kinect_depth"] == {"image": "depth", "near": "0.01", "far": "3.5"}
    assert texts["simx:RG2"] == {"child_script": "rg2.lua"}
    # every simx: entry must name an existing object
    for key in texts:
        name = key.split(":", 1)[1]
        assert any(mujoco.mj_name2id(m, k, name) >= 0 for k in
                   (mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_JOINT, mujoco.mjtObj.mjOBJ_CAMERA)), key


def test_depth_clip_planes(model):
    m = model
    ext = m.stat.extent
    assert m.vis.map.znear * ext == pytest.approx(0.01, rel=1e-6)
    assert m.vis.map.zfar * ext == pytest.approx(3.5, rel=1e-6)
    assert m.vis.global_.offwidth >= 640 and m.vis.global_.offheight >= 480


# ---------------------------------------------------------- (b) kinematics
def test_zero_pose_points_straight_up(model):
    m = model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    jid = [m.joint(j).id for j in ARM_JOINTS]
    anchor = d.xanchor[jid]
    axis = d.xaxis[jid]
    base = d.xpos[m.body("UR5").id]

    # axes: 1 vertical, 2/3/4 horizontal and parallel, 5 perpendicular to 4,
    # 6 perpendicular to 5 and along the flange (gripper approach) direction
    np.testing.assert_allclose(axis[0], [0, 0, 1], atol=1e-9)
    assert abs(axis[1][2]) < 1e-9
    np.testing.assert_allclose(axis[2], axis[1], atol=1e-9)
    np.testing.assert_allclose(axis[3], axis[1], atol=1e-9)
    assert abs(axis[4] @ axis[3]) < 1e-9
    assert abs(axis[5] @ axis[4]) < 1e-9
    rg2_z = d.xmat[m.body("RG2").id].reshape(3, 3)[:, 2]
    np.testing.assert_allclose(rg2_z, axis[5], atol=1e-9)

    # DH link lengths between joint origins
    assert np.linalg.norm(anchor[1] - anchor[0]) == pytest.approx(D1, abs=1e-3)
    assert np.linalg.norm(anchor[2] - anchor[1]) == pytest.approx(A2, abs=1e-3)
    assert np.linalg.norm(anchor[3] - anchor[2]) == pytest.approx(A3, abs=1e-3)
    # upper arm and forearm vertical
    np.testing.assert_allclose((anchor[2] - anchor[1])[:2], 0, atol=1e-9)
    np.testing.assert_allclose((anchor[3] - anchor[2])[:2], 0, atol=1e-9)
    # d4: offset of joint 5 along the joint-4 axis; d5: joint 6 along joint-5 axis
    assert (anchor[4] - anchor[3]) @ axis[3] == pytest.approx(D4, abs=1e-3)
    assert (anchor[5] - anchor[4]) @ axis[4] == pytest.approx(D5, abs=1e-3)

    # flange: height d1+a2+a3+d5 above the base, horizontally d4+d6 out along
    # the joint-2 axis (joint 1 axis is the base's vertical line)
    flange = d.site_xpos[m.site("UR5_flange").id] - base
    assert flange[2] == pytest.approx(D1 + A2 + A3 + D5, abs=2e-3)
    assert np.linalg.norm(flange[:2]) == pytest.approx(D4 + D6, abs=2e-3)
    assert flange[:2] @ axis[1][:2] == pytest.approx(D4 + D6, abs=2e-3)
    # the RG2 is mounted on the flange
    np.testing.assert_allclose(d.xpos[m.body("RG2").id] - base, flange, atol=1e-9)


def test_zero_pose_has_no_robot_contacts(model):
    m = model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    robot = _robot_bodies(m)
    for c in d.contact[: d.ncon]:
        b1, b2 = m.geom_bodyid[c.geom1], m.geom_bodyid[c.geom2]
        assert b1 not in robot and b2 not in robot, (m.geom(c.geom1).name, m.geom(c.geom2).name)


def test_gripper_starts_open_and_spans_0_to_11cm(model):
    m = model
    d = mujoco.MjData(m)
    j1 = m.joint(GRIPPER_JOINT)

    def opening(q):
        d.qpos[j1.qposadr[0]] = q
        d.qpos[m.joint("RG2_fingerJoint2").qposadr[0]] = q
        mujoco.mj_forward(m, d)
        p1 = d.geom_xpos[m.geom("RG2_finger1_pad").id]
        p2 = d.geom_xpos[m.geom("RG2_finger2_pad").id]
        half = m.geom("RG2_finger1_pad").size[0] + m.geom("RG2_finger2_pad").size[0]
        return np.linalg.norm(p1 - p2) - half

    lo, hi = j1.range
    assert m.qpos0[j1.qposadr[0]] == pytest.approx(hi)  # open at reset
    assert opening(lo) == pytest.approx(0.0, abs=2e-3)
    assert opening(hi) == pytest.approx(0.11, abs=5e-3)
    assert opening(hi) > opening((lo + hi) / 2) > opening(lo)  # rising = opening


def test_tutorial_pose_camera_geometry(model):
    m = model
    d = mujoco.MjData(m)
    _set_arm(m, d, TUTORIAL_POSE_DEG)
    rgb, dep = m.camera("kinect_rgb").id, m.camera("kinect_depth").id
    np.testing.assert_allclose(d.cam_xpos[rgb], d.cam_xpos[dep], atol=1e-9)
    np.testing.assert_allclose(d.cam_xmat[rgb], d.cam_xmat[dep], atol=1e-9)
    R = d.cam_xmat[rgb].reshape(3, 3)
    forward = -R[:, 2]
    # camera looks along the gripper approach direction, downward, image up ~ world up
    rg2_z = d.xmat[m.body("RG2").id].reshape(3, 3)[:, 2]
    assert forward @ rg2_z > 0.99
    assert forward[2] < -0.5 and R[2, 1] > 0.5
    # the ball is in front of the camera, near the optical axis, within 0.01..3.5 m
    v = d.xpos[m.body("Sphere").id] - d.cam_xpos[rgb]
    dist = np.linalg.norm(v)
    assert 0.3 < dist < 3.5
    assert np.degrees(np.arccos(v @ forward / dist)) < 10.0


# -------------------------------------------------------------- (c) render
def test_kinect_sees_ball_at_tutorial_pose(model):
    m = model
    d = mujoco.MjData(m)
    _set_arm(m, d, TUTORIAL_POSE_DEG)
    try:
        renderer = mujoco.Renderer(m, 480, 640)
    except Exception as exc:  # no usable EGL/OpenGL context on this machine
        pytest.skip(f"cannot create an OpenGL context (MUJOCO_GL={os.environ.get('MUJOCO_GL')}): {exc}")
    try:
        renderer.update_scene(d, camera="kinect_rgb")
        img = renderer.render().copy()
        renderer.enable_depth_rendering()
        renderer.update_scene(d, camera="kinect_depth")
        depth = renderer.render().copy()
        renderer.disable_depth_rendering()
    finally:
        renderer.close()

    assert img.shape == (480, 640, 3)
    r, g, b = (img[..., i].astype(int) for i in range(3))
    mask = ((r > 150) & (g < 80) & (b < 80)).astype(np.uint8)
    import cv2

    n, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    assert n > 1, "no ball-coloured pixels in kinect_rgb"
    biggest = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    area = stats[biggest, cv2.CC_STAT_AREA]
    cx, cy = centroids[biggest]
    assert area >= 200, area
    assert abs(cx - 320) < 160 and abs(cy - 240) < 120, (cx, cy)  # central half of the image

    # not an empty void: the table top fills a good part of the image
    assert img.std() > 10
    # depth: metres, inside the Kinect's 0.01..3.5 m, ball at ~its true distance
    ball_depth = float(np.median(depth[labels == biggest]))
    cam = m.camera("kinect_depth").id
    true_dist = np.linalg.norm(d.xpos[m.body("Sphere").id] - d.cam_xpos[cam])
    assert 0.01 < ball_depth < 3.5
    assert ball_depth == pytest.approx(true_dist, abs=0.05)
    assert float(depth.max()) <= 3.5 * 1.001


# ----------------------------------------------------------- (d) dynamics
def test_motors_hold_zero_pose_for_5s(model):
    m = model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    ball0 = d.xpos[m.body("Sphere").id].copy()
    _Controller(m, d).run(5.0, np.zeros(6))
    q = d.qpos[_qadr(m, ARM_JOINTS)]
    assert np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))
    assert np.abs(q).max() < 1e-3
    assert np.abs(d.qvel).max() < 1e-3
    assert np.linalg.norm(d.xpos[m.body("Sphere").id] - ball0) < 2e-3  # ball rests on the table


def test_motors_reach_and_hold_tutorial_pose(model):
    m = model
    d = mujoco.MjData(m)
    target = np.deg2rad(TUTORIAL_POSE_DEG)
    _Controller(m, d).run(3.0, target)  # from zero, velocity-limited at 180 deg/s
    err = np.rad2deg(d.qpos[_qadr(m, ARM_JOINTS)] - target)
    assert np.abs(err).max() < 0.5, err  # gravity droop of the P loop stays small
    assert np.abs(d.qvel[[m.joint(j).dofadr[0] for j in ARM_JOINTS]]).max() < 1e-3


def test_gripper_velocity_mode_closes_smoothly(model):
    m = model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    ctl = _Controller(m, d)
    j1, j2 = m.joint(GRIPPER_JOINT), m.joint("RG2_fingerJoint2")
    vel = []
    for _ in range(300):  # 0.3 s at -0.05 m/s, nothing between the fingers
        ctl.run(m.opt.timestep, np.zeros(6), gripper_vel=-0.05)
        vel.append(d.qvel[j1.dofadr[0]])
    vel = np.array(vel[50:])
    assert np.abs(vel + 0.05).max() < 5e-3  # tracks the target velocity, no chatter
    assert d.qpos[j2.qposadr[0]] == pytest.approx(d.qpos[j1.qposadr[0]], abs=1e-3)  # mirrored finger


def test_grasp_and_lift_ball(model):
    m = model
    d = mujoco.MjData(m)
    ball, tcp = m.body("Sphere").id, m.site("RG2_tcp").id
    grip = m.actuator(GRIPPER_MOTOR).id
    q_pre, q_grasp = np.deg2rad(PRE_GRASP_DEG), np.deg2rad(GRASP_DEG)

    _set_arm(m, d, PRE_GRASP_DEG)
    # the IK inputs still match the scene: 10 cm above the ball, pointing down
    np.testing.assert_allclose(d.site_xpos[tcp] - d.xpos[ball], [0, 0, 0.10], atol=5e-3)
    assert d.xmat[m.body("RG2").id].reshape(3, 3)[2, 2] < -0.999

    saved = m.actuator_forcerange[grip].copy()
    m.actuator_forcerange[grip] = [-20.0, 20.0]  # V-REP RG2 script: 20 N, 0.05 m/s
    try:
        ctl = _Controller(m, d)
        ctl.run(0.3, q_pre)  # settle
        ctl.run(1.3, lambda t: q_pre + (q_grasp - q_pre) * min(t / 1.0, 1.0))  # lower
        z0 = d.xpos[ball][2]
        assert np.linalg.norm(d.site_xpos[tcp] - d.xpos[ball]) < 0.01
        ctl.run(0.8, q_grasp, gripper_vel=-0.05)  # close
        opening = 2 * d.qpos[m.joint(GRIPPER_JOINT).qposadr[0]]
        assert 0.05 < opening < 0.06  # stopped on the 6 cm ball
        assert abs(d.actuator_force[grip]) == pytest.approx(20.0, abs=0.5)  # squeezing at the limit
        ctl.run(1.5, lambda t: q_grasp + (q_pre - q_grasp) * min(t / 1.0, 1.0), gripper_vel=-0.05)  # lift
    finally:
        m.actuator_forcerange[grip] = saved

    assert d.time < 6.0
    assert d.xpos[ball][2] - z0 > 0.05
    assert np.linalg.norm(d.xpos[ball] - d.site_xpos[tcp]) < 0.015  # still held between the pads
    touching = {m.geom(c.geom1).name for c in d.contact[: d.ncon]} | {m.geom(c.geom2).name for c in d.contact[: d.ncon]}
    assert {"RG2_finger1_pad", "RG2_finger2_pad", "Sphere_geom"} <= touching
    assert "Table_top" not in touching
