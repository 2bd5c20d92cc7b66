"""simx/UR5BallReach-v0 (simx_client.envs) against a real simx-server on the bundled scene."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import vrep  # noqa: E402
import simx_client.envs  # noqa: E402,F401  (registers simx/UR5BallReach-v0)
from simx_client.envs import ENV_ID  # noqa: E402
from simx_client.envs.ur5_ball_reach import BALL_X, BALL_Y, TUTORIAL_POSE_DEG, image_reward  # noqa: E402

try:
    from conftest import ROOT, SCENE, ServerProcess
except ImportError:  # tests/ imported as a package
    from tests.conftest import ROOT, SCENE, ServerProcess

B = vrep.simx_opmode_blocking


@pytest.fixture(scope="module")
def env_server():
    srv = ServerProcess(str(SCENE), "--stopped")
    yield srv
    srv.stop()


@pytest.fixture
def make(env_server):
    made = []

    def _make(**kwargs):
        env = gymnasium.make(ENV_ID, port=env_server.port, **kwargs)
        made.append(env)
        return env

    yield _make
    for env in made:
        env.close()


def red_pixels(rgb: np.ndarray) -> int:
    r, g, b = (rgb[:, :, i].astype(int) for i in range(3))
    return int(((r > 150) & (g < 80) & (b < 80)).sum())


def test_check_env_passes(make):
    from gymnasium.utils.env_checker import check_env

    env = make(render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)


def test_reset_seeds_the_ball_and_shows_it(make):
    env = make(width=640, height=480)
    positions = []
    for seed in (7, 7, 8):
        obs, info = env.reset(seed=seed)
        positions.append(info["ball_position"])
        x, y, _ = info["ball_position"]
        assert BALL_X[0] - 0.01 <= x <= BALL_X[1] + 0.01 and BALL_Y[0] - 0.01 <= y <= BALL_Y[1] + 0.01
        assert red_pixels(obs["rgb"]) > 200, "the ball is not in the Kinect's view after reset"
        np.testing.assert_allclose(np.degrees(obs["joints"]), TUTORIAL_POSE_DEG, atol=0.1)
    np.testing.assert_allclose(positions[0], positions[1], atol=1e-6)
    assert np.linalg.norm(positions[0][:2] - positions[2][:2]) > 1e-3


def test_step_moves_joints_1_to_3_by_the_clipped_offsets(make):
    env = make(sim_steps=10, max_offset_deg=5.0)
    obs, _ = env.reset(seed=0)
    before = np.degrees(obs["joints"].astype(float))
    obs, *_ = env.step(np.array([2.0, -30.0, 100.0], dtype=np.float32))
    cid = env.unwrapped.client_id
    after = []
    for i in range(1, 7):
        rc, h = vrep.simxGetObjectHandle(cid, f"UR5_joint{i}", B)
        rc2, q = vrep.simxGetJointPosition(cid, h, B)
        assert rc == rc2 == 0
        after.append(math.degrees(q))
    np.testing.assert_allclose(np.subtract(after, before), [2.0, -5.0, 5.0, 0, 0, 0], atol=0.2)
    np.testing.assert_allclose(np.degrees(obs["joints"]), after, atol=1e-3)


def test_six_joint_action(make):
    env = make(joints=6)
    assert env.action_space.shape == (6,)
    env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(np.zeros(6, dtype=np.float32))
    assert reward == pytest.approx(-info["distance"])


@pytest.mark.parametrize("width,height", [(84, 84), (640, 480)])
def test_observation_shapes_and_types(make, width, height):
    env = make(width=width, height=height, render_mode="rgb_array")
    obs, _ = env.reset(seed=3)
    assert obs["rgb"].shape == (height, width, 3) and obs["rgb"].dtype == np.uint8
    assert obs["depth"].shape == (height, width) and obs["depth"].dtype == np.float32
    assert obs["joints"].shape == (6,) and obs["joints"].dtype == np.float32
    assert env.observation_space.contains(obs)
    assert red_pixels(obs["rgb"]) > 0
    # Depth in metres: the table under a camera about 0.6 m above it, nothing beyond far.
    assert 0.2 < float(np.median(obs["depth"])) < 3.5
    frame = env.render()
    assert frame.shape == (height, width, 3) and frame.dtype == np.uint8


def test_terminated_when_the_gripper_reaches_the_ball(make):
    env = make(max_episode_steps=50)
    _, info = env.reset(seed=1)
    assert info["distance"] > 0.3
    cid = env.unwrapped.client_id
    rc, ball = vrep.simxGetObjectHandle(cid, "Sphere", B)
    assert rc == 0
    assert vrep.simxSetObjectPosition(cid, ball, -1, list(info["gripper_position"]), B) == 0
    _, reward, terminated, truncated, info = env.step(np.zeros(3, dtype=np.float32))
    assert terminated and not truncated, info
    assert info["distance"] <= 0.05 and reward == pytest.approx(-info["distance"])


def test_truncated_after_max_episode_steps(make):
    env = make(max_episode_steps=2)
    env.reset(seed=0)
    assert env.step(np.zeros(3, dtype=np.float32))[3] is False
    assert env.step(np.zeros(3, dtype=np.float32))[3] is True


def test_image_reward_has_no_division_by_zero():
    img = np.full((84, 84, 3), 120, dtype=np.uint8)
    assert image_reward(img) == -1.0  # no ball pixel
    img[40:44, 40:44] = (230, 20, 20)
    assert -0.05 < image_reward(img) <= 0.0
    img[:] = 120
    img[0:4, 0:4] = (230, 20, 20)
    assert image_reward(img) < -0.9


def test_simx_client_imports_without_gymnasium():
    code = ("import sys; sys.modules['gymnasium'] = None; import simx_client, vrep; "
            "assert 'simx_client.envs' not in sys.modules; print('ok')")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "ok", out.stderr


def test_given_connection_is_used_and_left_open(env_server):
    from simx_client.envs import UR5BallReachEnv

    cid = vrep.simxStart("127.0.0.1", env_server.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        env = UR5BallReachEnv(client_id=cid)
        obs, _ = env.reset(seed=0)
        obs2, *_ = env.step(np.array([np.nan, 0.0, 0.0], dtype=np.float32))  # NaN: no move
        np.testing.assert_allclose(obs2["joints"], obs["joints"], atol=np.radians(0.1))
        env.close()
        assert vrep.simxGetConnectionId(cid) != -1
    finally:
        vrep.simxSynchronous(cid, False)
        vrep.simxFinish(cid)


def test_the_whole_ball_region_is_in_view(make):
    """Each corner of the region reset draws from: the whole ball inside the 640x480 image."""
    env = make(width=640, height=480)
    env.reset(seed=0)
    cid = env.unwrapped.client_id
    rc, ball = vrep.simxGetObjectHandle(cid, "Sphere", B)
    assert rc == 0
    for x in BALL_X:
        for y in BALL_Y:
            assert vrep.simxSetObjectPosition(cid, ball, -1, [x, y, 0.78], B) == 0
            obs, *_ = env.step(np.zeros(3, dtype=np.float32))
            r, g, b = (obs["rgb"][:, :, i].astype(int) for i in range(3))
            rows, cols = np.nonzero((r > 150) & (g < 80) & (b < 80))
            assert len(rows) > 200, f"ball at ({x}, {y}) not seen"
            assert rows.min() > 5 and cols.min() > 5 and rows.max() < 474 and cols.max() < 634, (x, y)


def test_pose_noise_is_seeded_and_bounded(make):
    env = make(pose_noise_deg=2.0)
    a = np.degrees(env.reset(seed=5)[0]["joints"].astype(float))
    b = np.degrees(env.reset(seed=5)[0]["joints"].astype(float))
    c = np.degrees(env.reset(seed=6)[0]["joints"].astype(float))
    np.testing.assert_allclose(a, b, atol=1e-4)
    assert np.abs(a - TUTORIAL_POSE_DEG).max() <= 2.1 and np.abs(a - TUTORIAL_POSE_DEG).max() > 0.05
    assert np.abs(a - c).max() > 0.05


def test_tutorial_state_from_the_colour_coded_render(make):
    """The tutorial's 2 numbers (pixel distance of the ball's centre from the image centre,
    depth there) come from the colour-coded-handle render: they agree with the red ball seen in
    the RGB observation and its depth; with the ball out of view they say so."""
    from gymnasium.utils.env_checker import check_env

    env = make(width=640, height=480, tutorial_state=True)
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=3)
    assert info["ball_visible"] and obs["state"].dtype == np.float32 and obs["state"].shape == (2,)
    r, g, b = (obs["rgb"][:, :, i].astype(int) for i in range(3))
    rows, cols = np.nonzero((r > 150) & (g < 80) & (b < 80))
    centre = np.hypot(cols.mean() - 319.5, rows.mean() - 239.5)
    assert obs["state"][0] == pytest.approx(centre, abs=2.0)  # pixels
    depth_here = obs["depth"][int(round(rows.mean())), int(round(cols.mean()))]
    assert obs["state"][1] == pytest.approx(depth_here, abs=0.01)  # metres
    assert 0.2 < obs["state"][1] < 1.5  # the ball on the table, in front of the eye-in-hand Kinect
    cid = env.unwrapped.client_id
    rc, ball = vrep.simxGetObjectHandle(cid, "Sphere", B)
    assert rc == 0 and vrep.simxSetObjectPosition(cid, ball, -1, [5.0, 5.0, 0.78], B) == 0
    obs, _, _, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert not info["ball_visible"]
    assert obs["state"][0] == pytest.approx(400.0) and obs["state"][1] == pytest.approx(3.5, abs=1e-3)
    # The sensor renders the scene again afterwards (render mode 0).
    assert red_pixels(env.unwrapped._rgb()) == 0 and vrep.simxGetObjectIntParameter(
        cid, env.unwrapped._rgb_sensor, vrep.sim_visionintparam_render_mode, B) == (0, 0)


def test_small_observations_render_small_and_show_the_same_view(make):
    """84x84: the sensors render at 112x84 (the scene's 4:3 at the smallest size covering the
    observation, set through the resolution parameters), the observation is the same view as
    the 640x480 render resized, and the tutorial state stays in 640x480 pixels."""
    native = make(width=84, height=84, sensor_resolution="native", tutorial_state=True)
    obs_native, info_native = native.reset(seed=5)
    cid = native.unwrapped.client_id
    rgb_sensor = native.unwrapped._rgb_sensor
    assert vrep.simxGetObjectIntParameter(cid, rgb_sensor, vrep.sim_visionintparam_resolution_x, B) == (0, 640)
    small = make(width=84, height=84, tutorial_state=True)  # the same server and connection
    obs, info = small.reset(seed=5)
    for sensor in (rgb_sensor, small.unwrapped._depth_sensor):
        assert vrep.simxGetObjectIntParameter(cid, sensor, vrep.sim_visionintparam_resolution_x, B) == (0, 112)
        assert vrep.simxGetObjectIntParameter(cid, sensor, vrep.sim_visionintparam_resolution_y, B) == (0, 84)
    np.testing.assert_allclose(info["ball_position"], info_native["ball_position"], atol=1e-6)
    assert obs["rgb"].shape == obs_native["rgb"].shape == (84, 84, 3)
    diff = np.abs(obs["rgb"].astype(float) - obs_native["rgb"].astype(float)).mean()
    mirrored = np.abs(obs["rgb"][:, ::-1].astype(float) - obs_native["rgb"].astype(float)).mean()
    assert diff < 6 and mirrored > 2 * diff, (diff, mirrored)  # the same view, not just similar colours
    assert np.abs(obs["depth"] - obs_native["depth"]).mean() < 0.02  # metres
    assert info["ball_visible"] and info_native["ball_visible"]
    assert obs["state"][0] == pytest.approx(obs_native["state"][0], abs=6.0)  # 640x480 pixels
    assert obs["state"][1] == pytest.approx(obs_native["state"][1], abs=0.02)  # metres
    assert small.unwrapped._render_size == (112, 84)
