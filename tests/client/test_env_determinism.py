"""simx/UR5BallReach-v0 is reproducible: two rollouts with the same seed and the same actions,
on two servers started as examples/train_ddpg.py starts them (``--speed 0``), give the same
observations and rewards bit for bit, and every step's observation is that step's.

Issue 44: ``train_ddpg.py --quick`` diverged from its documented episodes before learning
began. The environment read a step's streamed values (joints, depth, the ball's and the
gripper's positions) after ``simxSynchronousTrigger`` + ``simxGetPingTime``, and the server had
dropped that step's update about once in 300 steps (Zenoh's "drop" congestion control on a
loaded machine): the reward and observation were the previous step's. The servers here get an
operator's Zenoh config that makes every link congested (batches of 4 KB, a queue of one, a 1
microsecond drop wait), so that a dropped update shows in every run, not once in 300 steps
(before the fix: every step's observation was the previous one's).
"""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

import simx_client.envs  # noqa: E402,F401  (registers simx/UR5BallReach-v0)
from simx_client.envs import ENV_ID  # noqa: E402

try:
    from conftest import SCENE, ServerProcess
except ImportError:  # tests/ imported as a package
    from tests.conftest import SCENE, ServerProcess

CONGESTED = ("{transport: {link: {tx: {batch_size: 4096, queue: {size: {data: 1}, congestion_control: {drop: "
             "{wait_before_drop: 1, max_wait_before_drop_fragments: 1}}}}}}}")
STEPS, EPISODE_STEPS = 60, 20  # three episodes, the second and third reset without a seed


def rollout(port: int, seed: int) -> list[tuple[dict, float]]:
    """``(observation, reward)`` of a reset and ``STEPS`` steps of seeded random actions, as
    examples/train_ddpg.py's environments see them (tutorial state, 84x84)."""
    env = gymnasium.make(ENV_ID, port=port, width=84, height=84, joints=3, tutorial_state=True,
                         max_episode_steps=EPISODE_STEPS)
    actions = np.random.default_rng(seed).uniform(-5.0, 5.0, (STEPS, 3)).astype(np.float32)
    try:
        obs, _ = env.reset(seed=seed)
        out = [(obs, 0.0)]
        for action in actions:
            obs, reward, terminated, truncated, _ = env.step(action)
            out.append((obs, reward))
            if terminated or truncated:
                obs, _ = env.reset()
                out.append((obs, 0.0))
    finally:
        env.close()
    return out


def test_same_seed_same_rollout_bit_for_bit(tmp_path):
    config = tmp_path / "zenoh.json5"
    config.write_text(CONGESTED)
    servers = [ServerProcess(str(SCENE), "--speed", "0", "--zenoh-config", str(config)) for _ in range(2)]
    try:
        first, second = (rollout(srv.port, seed=3) for srv in servers)
    finally:
        for srv in servers:
            srv.stop()
    assert len(first) == len(second) == STEPS + 1 + STEPS // EPISODE_STEPS
    # every step moved the joints (random offsets of up to 5 degrees): a step that reads the
    # previous step's streamed joints is stale
    for run in (first, second):
        stale = [i for i in range(1, len(run)) if np.array_equal(run[i][0]["joints"], run[i - 1][0]["joints"])]
        assert stale == [], f"observations of the previous step at steps {stale[:10]} ({len(stale)} in all)"
    differ = [(i, key) for i, ((a, ra), (b, rb)) in enumerate(zip(first, second))
              for key in [*a, "reward"] if not (ra == rb if key == "reward" else np.array_equal(a[key], b[key]))]
    assert differ == [], f"the two rollouts differ at (step, key) {differ[:10]}"
