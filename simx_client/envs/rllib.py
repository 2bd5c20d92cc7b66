"""``simx/UR5BallReach-v0`` on Ray RLlib (needs the ``ray`` extra: ``scripts/install-train.sh ray``).

    from simx_client.envs import rllib
    rllib.register()                      # the env name rllib.ENV_NAME, on the driver
    config = PPOConfig().environment(rllib.ENV_NAME, env_config={"servers": "local"}) ...

RLlib's env runners make their environments with :func:`env_creator` on whatever node Ray
placed them. With ``servers="local"`` (the default) every environment starts a simx-server of
its own there (:class:`simx_server.pool.ServerPool`, 127.0.0.1, a free port) and talks to it on
that node's loopback only; the server stops with the environment's ``close()`` and, through the
pool's ``PR_SET_PDEATHSIG``, when the env runner's process dies (killed, or replaced by Ray's
fault tolerance, which then makes a new env runner and so new servers). Nothing crosses between
nodes but Ray's own traffic: a cluster needs Ray and simx installed on every node, nothing more.

:func:`servers_of` tells, for an env runner, which servers its environments stepped (for
``algo.env_runner_group.foreach_env_runner(servers_of, local_env_runner=False)``).

Ray runs its workers, env runners included, at nice 15 (its ``worker_niceness``, so that its
own daemons stay responsive), and a server an environment starts inherits it. On a node whose
CPUs other work keeps busy, a nice-15 process gets about 1/30 of the share of a nice-0 one:
a step, or the GL context of a server's first render, then takes tens of seconds, and a
Zenoh session can lose its lease. Start such nodes with ``RAY_worker_niceness=0`` in
``ray start``'s environment (tests/e2e/test_ray_cluster.py does); :func:`servers_of` reports
the nice values (``env_nice``, ``server_nice``).
"""

from __future__ import annotations

import os
from typing import Any

import gymnasium as gym

from simx_client.envs.ur5_ball_reach import UR5BallReachEnv
from simx_client.envs.wrappers import TutorialStateObservation

ENV_NAME = "simx-ur5-ball-reach"

#: env_config defaults: small renders (the policy sees the tutorial state, not the images),
#: a local server, episodes of 100 steps, calls that wait up to 20 s (an env runner shares its
#: node's CPUs with the learner and the other runners: a first step that made a GL context took
#: over 5 s on a loaded 2-core CI machine).
DEFAULTS: dict[str, Any] = {"servers": "local", "width": 84, "height": 84, "tutorial_state": True,
                            "max_episode_steps": 100, "observation": "tutorial", "timeout_ms": 20_000}


def env_creator(config: dict | None = None) -> gym.Env:
    """One environment from an RLlib ``env_config`` (an ``EnvContext``, a dict): the keyword
    arguments of :class:`UR5BallReachEnv` over :data:`DEFAULTS`, and ``observation``:
    ``"tutorial"`` (default: :class:`TutorialStateObservation`, a (7,) vector) or ``"dict"``
    (the environment's own observation, images included)."""
    kwargs = {**DEFAULTS, **{k: v for k, v in dict(config or {}).items() if k != "num_envs"}}
    observation = kwargs.pop("observation")
    if observation not in ("tutorial", "dict"):
        raise ValueError(f"observation must be 'tutorial' or 'dict', not {observation!r}")
    env = UR5BallReachEnv(**kwargs)
    return TutorialStateObservation(env) if observation == "tutorial" else env


def register(name: str = ENV_NAME) -> str:
    """Register :func:`env_creator` with Ray under ``name`` (on the driver; RLlib ships it to
    the env runners); returns ``name``."""
    from ray.tune.registry import register_env

    register_env(name, env_creator)
    return name


def servers_of(env_runner: Any) -> list[dict[str, Any]]:
    """For each environment of ``env_runner`` (an RLlib ``SingleAgentEnvRunner``): its
    :meth:`UR5BallReachEnv.server_info`, with the node's IP address as Ray sees it
    (``node_ip``), the nice values of the env runner's process (``env_nice``) and of the server
    (``server_nice``, None without a server of its own) and, on Linux, the network namespace
    the server runs in (``server_netns``, e.g. ``"net:[4026532289]"``). An env runner without
    environments (the driver's) gives []."""
    import ray

    vector = getattr(env_runner, "env", None)
    if vector is None:
        return []
    node_ip = ray.util.get_node_ip_address()
    infos = []
    for info in vector.unwrapped.call("server_info"):
        info = dict(info, node_ip=node_ip, env_nice=os.getpriority(os.PRIO_PROCESS, 0), server_nice=None)
        pid = info.get("server_pid")
        if pid is not None:
            try:
                info["server_nice"] = os.getpriority(os.PRIO_PROCESS, pid)
            except OSError:
                pass
            try:
                info["server_netns"] = os.readlink(f"/proc/{pid}/ns/net")
            except OSError:
                info["server_netns"] = None
        infos.append(info)
    return infos
