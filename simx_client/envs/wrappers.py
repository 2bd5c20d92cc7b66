"""Observation wrappers for ``simx/UR5BallReach-v0`` (needs gymnasium).

:class:`TutorialStateObservation` turns the environment's ``Dict`` observation into the small
vector the tutorial's DDPG saw, for MLP policies (Stable-Baselines3, RLlib's default models).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

#: half the diagonal of the scene sensor's 640x480 image (pixels): the tutorial state's
#: pixel distance divided by it is in [0, 1].
HALF_DIAGONAL = math.hypot(640, 480) / 2


class TutorialStateObservation(gym.ObservationWrapper):
    """The policy's input, (7,) float32, each about in [-1, 1]:

    ``[distance / HALF_DIAGONAL, depth (m), offset_x / HALF_DIAGONAL, offset_y / HALF_DIAGONAL,
    joint1, joint2, joint3 (rad)]``: the tutorial's 2 numbers (the ball centre's pixel distance
    from the image centre and the depth there), the signed offset that gives its direction, and
    the three driven joints' angles. The environment must be made with ``tutorial_state=True``
    (ValueError otherwise).
    """

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        if "state" not in env.observation_space.spaces or "ball_offset" not in env.observation_space.spaces:
            raise ValueError("TutorialStateObservation needs the environment made with tutorial_state=True")
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (7,), np.float32)

    def observation(self, obs: dict) -> np.ndarray:
        state, offset = obs["state"], obs["ball_offset"]
        return np.concatenate([[state[0] / HALF_DIAGONAL, state[1]], offset / HALF_DIAGONAL,
                               obs["joints"][:3]]).astype(np.float32)
