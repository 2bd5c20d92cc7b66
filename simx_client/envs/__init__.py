"""Gymnasium environments on the legacy remote API (needs the ``envs`` extra: gymnasium).

``import simx_client.envs`` registers ``simx/UR5BallReach-v0``; then
``gymnasium.make("simx/UR5BallReach-v0", port=19999)`` connects to a running simx-server (or a
V-REP with the tutorial's scene) and gives :class:`UR5BallReachEnv`. ``simx_client`` itself
never imports this package, so it stays importable without gymnasium.
"""

from __future__ import annotations

from typing import Any

ENV_ID = "simx/UR5BallReach-v0"

__all__ = ["ENV_ID", "UR5BallReachEnv", "register"]


def register() -> None:
    """Register ``simx/UR5BallReach-v0`` with Gymnasium (done on import; harmless twice)."""
    import gymnasium

    if ENV_ID not in gymnasium.registry:
        gymnasium.register(id=ENV_ID, entry_point="simx_client.envs.ur5_ball_reach:UR5BallReachEnv")


def __getattr__(name: str) -> Any:
    if name == "UR5BallReachEnv":
        from simx_client.envs.ur5_ball_reach import UR5BallReachEnv

        return UR5BallReachEnv
    raise AttributeError(name)


register()
