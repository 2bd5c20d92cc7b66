"""UR5BallReach-v0 with ``servers="local"``: the environment starts its own simx-server and the
server never outlives it (close(), or its process killed); the tutorial-state vector wrapper;
the RLlib env creator's configuration (no Ray needed)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from simx_client.envs.ur5_ball_reach import UR5BallReachEnv  # noqa: E402
from simx_client.envs.wrappers import HALF_DIAGONAL, TutorialStateObservation  # noqa: E402

from conftest import ROOT, wait_until  # noqa: E402


def _alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie counts as gone)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def test_local_server_started_used_and_stopped_by_close():
    env = UR5BallReachEnv(servers="local", tutorial_state=True, max_episode_steps=5)
    try:
        info = env.server_info()
        pid = info["server_pid"]
        assert info["host"] == "127.0.0.1" and info["env_pid"] == os.getpid() and _alive(pid)
        assert env.local_servers.pids == [pid]
        obs, _ = env.reset(seed=1)
        for _ in range(3):
            obs, reward, terminated, truncated, step_info = env.step(np.zeros(3, np.float32))
        assert env.server_info()["steps"] == 3 and step_info["is_success"] == terminated
        assert obs["ball_offset"].shape == (2,)
        # the signed offset is the tutorial's distance with a direction
        assert np.hypot(*obs["ball_offset"]) == pytest.approx(obs["state"][0], abs=1e-3)
    finally:
        env.close()
    wait_until(lambda: not _alive(pid), timeout=15, what="the local server to stop on close()")


def test_a_dead_local_server_is_named_with_its_exit_status_and_log():
    """A Ray env runner died of "simxSynchronousTrigger failed (return code 3)" and nothing said
    why its server went: the error now carries the server's exit status and log tail."""
    env = UR5BallReachEnv(servers="local", max_episode_steps=5, timeout_ms=1000)
    try:
        env.reset(seed=1)
        pid = env.local_servers.pids[0]
        os.kill(pid, signal.SIGKILL)
        wait_until(lambda: env.local_servers.poll() != [None], timeout=10, what="the server to be reaped")
        with pytest.raises(RuntimeError, match=r"(?s)return code \d+.*its simx-server pid \d+ \(exit status -9\).*simx-server ready"):
            env.step(np.zeros(3, np.float32))
    finally:
        env.close()


CHILD = """
import sys, time
from simx_client.envs.ur5_ball_reach import UR5BallReachEnv
env = UR5BallReachEnv(servers={"args": ["--speed", "0"]})
print(env.server_info()["server_pid"], flush=True)
time.sleep(600)
"""


def test_local_server_dies_with_a_killed_process():
    """An env runner killed by Ray (SIGKILL: no close(), no atexit) leaves no server behind."""
    proc = subprocess.Popen([sys.executable, "-c", CHILD], stdout=subprocess.PIPE, text=True, cwd=ROOT,
                            env=dict(os.environ, MUJOCO_GL="egl"))
    try:
        pid = int(proc.stdout.readline())
        assert _alive(pid)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        wait_until(lambda: not _alive(pid), timeout=15, what="the server of a killed process to stop")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("servers, message", [
    ("remote", "servers must be 'local'"),
    ({"scene": None, "port": 5}, "pool spec takes 'scene' and 'args'"),
])
def test_bad_servers_are_refused(servers, message):
    with pytest.raises(ValueError, match=message):
        UR5BallReachEnv(servers=servers)


def test_tutorial_state_observation_needs_the_tutorial_state():
    class Fake(gymnasium.Env):
        observation_space = gymnasium.spaces.Dict({"joints": gymnasium.spaces.Box(-1, 1, (6,))})
        action_space = gymnasium.spaces.Box(-1, 1, (3,))

    with pytest.raises(ValueError, match="tutorial_state=True"):
        TutorialStateObservation(Fake())


def test_tutorial_state_observation_scales_the_state():
    class Fake(gymnasium.Env):
        observation_space = gymnasium.spaces.Dict({
            "state": gymnasium.spaces.Box(0, 1e4, (2,)), "ball_offset": gymnasium.spaces.Box(-1e4, 1e4, (2,)),
            "joints": gymnasium.spaces.Box(-np.inf, np.inf, (6,))})
        action_space = gymnasium.spaces.Box(-1, 1, (3,))

    wrapped = TutorialStateObservation(Fake())
    obs = wrapped.observation({"state": np.array([300.0, 0.5], np.float32),
                               "ball_offset": np.array([180.0, -240.0], np.float32),
                               "joints": np.arange(6, dtype=np.float32)})
    np.testing.assert_allclose(obs, [300 / HALF_DIAGONAL, 0.5, 180 / HALF_DIAGONAL, -240 / HALF_DIAGONAL, 0, 1, 2],
                               rtol=1e-6)
    assert obs.dtype == np.float32 and wrapped.observation_space.shape == (7,)


def test_rllib_env_creator_defaults_and_refusals():
    from simx_client.envs import rllib

    assert rllib.DEFAULTS["servers"] == "local"
    with pytest.raises(ValueError, match="observation must be"):
        rllib.env_creator({"observation": "pixels"})
    env = rllib.env_creator({"num_envs": 1, "max_episode_steps": 2})  # RLlib adds num_envs: ignored
    try:
        assert isinstance(env, TutorialStateObservation) and env.observation_space.shape == (7,)
        obs, _ = env.reset(seed=0)
        assert obs.shape == (7,) and env.unwrapped.server_info()["server_pid"] is not None
        env.step(env.action_space.sample())
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        assert terminated or truncated  # max_episode_steps from the env_config
    finally:
        env.close()


def test_a_timed_out_call_shows_the_local_servers_thread_stacks():
    """A call that timed out (return code with simx_return_timeout_flag) asks each local server
    that still runs for its threads' stacks (SIGUSR1, simx-server's faulthandler): the error
    shows what the server was doing."""
    env = UR5BallReachEnv(servers="local", max_episode_steps=5)
    try:
        env.reset(seed=1)
        assert "Thread 0x" not in env._servers_state()
        state = env._servers_state(stacks=True)
        assert "still runs" in state and "Thread 0x" in state and "File " in state, state[-3000:]
        assert env.local_servers.poll() == [None]  # the dump did not stop it
        env.step(np.zeros(3, np.float32))
    finally:
        env.close()
