"""gymnasium.make_vec(..., vectorization_mode="async") on a ServerPool: each environment of the
vector connects to its own server, and closing the vector stops the servers. The environment
here is a minimal one of this test (simx_client.envs is not needed)."""

from __future__ import annotations

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium", reason="gymnasium is not installed (pip install gymnasium)")

import vrep  # noqa: E402
from conftest import SCENE  # noqa: E402
from simx_server.pool import ServerPool  # noqa: E402

ENV_ID = "SimxPoolTest-v0"


class JointEnv(gym.Env):
    """Observation: UR5_joint1's position on this env's server; action: a position to set."""

    observation_space = gym.spaces.Box(-np.pi, np.pi, (1,), np.float32)
    action_space = gym.spaces.Box(-np.pi, np.pi, (1,), np.float32)

    def __init__(self, servers):
        self.servers = servers
        self.address = servers.claim()
        self.cid = vrep.simxStart(*self.address, True, True, 5000, 5)
        assert self.cid >= 0
        rc, self.joint = vrep.simxGetObjectHandle(self.cid, "UR5_joint1", vrep.simx_opmode_blocking)
        assert rc == 0

    def _obs(self):
        rc, q = vrep.simxGetJointPosition(self.cid, self.joint, vrep.simx_opmode_blocking)
        return np.array([q], np.float32), {"port": self.address[1], "rc": rc}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return self._obs()

    def step(self, action):
        vrep.simxSetJointPosition(self.cid, self.joint, float(action[0]), vrep.simx_opmode_blocking)
        obs, info = self._obs()
        return obs, 0.0, False, False, info

    def close(self):
        vrep.simxFinish(self.cid)
        self.servers.release(self.address)


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_make_vec_async_each_env_its_own_server_and_close_stops_them():
    if ENV_ID not in gym.registry:
        gym.register(ENV_ID, entry_point=JointEnv)
    pool = ServerPool(2, SCENE, "--stopped", "--pacing", "immediate", "--renderers", "on-demand")  # no image read
    pids = pool.pids
    envs = pool.close_with(gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="async",
                                         vector_kwargs={"context": "spawn"}, servers=pool.claims))
    try:
        obs, info = envs.reset(seed=0)
        assert sorted(info["port"]) == sorted(pool.ports)  # one server each
        obs, _, _, _, info = envs.step(np.array([[0.3], [-0.6]], np.float32))
        assert np.allclose(obs[:, 0], [0.3, -0.6], atol=1e-6)  # separate simulations
    finally:
        envs.close()
    assert not any(_alive(pid) for pid in pids)


def test_make_vec_of_ur5_ball_reach_on_a_pool():
    """The issue's form: ``gymnasium.make_vec("simx/UR5BallReach-v0", num_envs=2,
    vectorization_mode="async", ...)`` on a ServerPool; each environment has its own
    simulation (its own ball), steps move them, closing the vector stops the servers."""
    import simx_client.envs  # noqa: F401  (registers simx/UR5BallReach-v0)

    pool = ServerPool(2, SCENE, "--stopped")
    pids = pool.pids
    envs = pool.close_with(gym.make_vec("simx/UR5BallReach-v0", num_envs=2, vectorization_mode="async",
                                         vector_kwargs={"context": "spawn"}, servers=pool.claims))
    try:
        obs, info = envs.reset(seed=[1, 2])
        assert obs["rgb"].shape == (2, 84, 84, 3) and obs["joints"].shape == (2, 6)
        balls = np.asarray(info["ball_position"])
        assert np.linalg.norm(balls[0][:2] - balls[1][:2]) > 1e-3  # two simulations, two seeds
        before = obs["joints"].copy()
        obs, reward, terminated, truncated, info = envs.step(np.array([[5, 0, 0], [-5, 0, 0]], np.float32))
        moved = np.degrees(obs["joints"][:, 0] - before[:, 0])
        assert moved[0] > 2 and moved[1] < -2, moved  # each server moved its own arm
    finally:
        envs.close()
    assert not any(_alive(pid) for pid in pids)
