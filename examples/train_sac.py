"""Train SAC (stable-baselines3) on simx/UR5BallReach-v0. Not run in CI.

    scripts/install-train.sh            # gymnasium, stable-baselines3, PyTorch's CPU build (docs/TRAINING.md)
    simx-server &                       # or scripts/serve.sh; port 19999
    python examples/train_sac.py --steps 20000

The policy sees a small observation: the six joint angles and the ball's and the gripper's
positions (what the dense reward is computed from), so an MLP policy suffices. The camera
images stay in the environment's observation for image-based agents (e.g. a CnnPolicy on
``obs["rgb"]`` at 84x84); they are dropped here to keep the example quick.
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import simx_client.envs  # noqa: F401  (registers simx/UR5BallReach-v0)


class SmallObservation(gym.ObservationWrapper):
    """joints (6, rad) + ball position (3, m) + gripper position (3, m), float32."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (12,), np.float32)
        self._info: dict = {}

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self._info = info
        return self.observation(obs), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._info = info
        return self.observation(obs), reward, terminated, truncated, info

    def observation(self, obs):
        info = self._info
        return np.concatenate([obs["joints"], info["ball_position"], info["gripper_position"]]).astype(np.float32)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=19999)
    parser.add_argument("--steps", type=int, default=20_000, help="environment steps to train")
    parser.add_argument("--save", default="sac_ur5_ball_reach", help="where to save the model")
    args = parser.parse_args()

    from stable_baselines3 import SAC

    env = SmallObservation(gym.make("simx/UR5BallReach-v0", host=args.host, port=args.port,
                                    width=84, height=84, max_episode_steps=100))
    model = SAC("MlpPolicy", env, verbose=1, learning_starts=500)
    model.learn(total_timesteps=args.steps)
    model.save(args.save)
    env.close()


if __name__ == "__main__":
    main()
