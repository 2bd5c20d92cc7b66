"""Many RLBench environments: N in one process (Gymnasium's ``SyncVectorEnv``, one simx PyRep
each) against N processes (``AsyncVectorEnv``, spawned, as RLBench's ``rlbench_gym_vector``
example makes them).

Both vector environments are RLBench's own ``rlbench/reach_target-vision-v0`` (every camera's
RGB, depth, point cloud and mask at 128x128, RLBench's joint-position action), made with
``gym.make_vec(..., num_envs=N, vectorization_mode="sync" | "async")`` side by side in one run.
Rounds alternate: a block of ``--steps`` vector steps of random actions on the sync one, then on
the async one, so that a loaded, shared machine slows both alike. Each block is timed by wall
clock and by CPU time: the sync environment's process (every thread: render threads too), or the
async one's main process plus its N workers (``/proc/PID/stat``). Reports per mode the median
over rounds of environment steps (N per vector step) per second of wall time and per CPU-second
(steps/s per core: what a machine's cores give, whatever the load), and the ratio sync / async;
then the memory each holds once measured: what making the sync environment added to this
process's resident set, against the async workers' resident sets summed (``VmRSS``). Episodes
that end are reset by the vector environment itself (Gymnasium's autoreset).

Needs RLBench installed and its main scene ``rlbench/task_design.ttt``. Nothing is asserted.

Run: ``MUJOCO_GL=egl python -m benchmarks.rlbench_vector [--num-envs 2] [--steps 10] [--rounds 5]
[--task reach_target] [--obs vision]``.
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import numpy as np

from benchmarks.clients import _cpu_s
from benchmarks.stats import summary


def make(mode: str, num_envs: int, env_id: str) -> Any:
    """The vector environment of ``mode`` (``sync`` or ``async``), reset."""
    import gymnasium as gym
    import rlbench  # noqa: F401 (registers the environments)

    kwargs: dict[str, Any] = {"vector_kwargs": {"context": "spawn"}} if mode == "async" else {}
    env = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode=mode, **kwargs)
    env.reset(seed=0)
    return env


def _cpu(env: Any) -> float:
    """CPU seconds used so far by ``env``'s processes (this one, and an async env's workers)."""
    own = time.process_time()
    workers = getattr(env, "processes", None) or []
    return own + sum(_cpu_s(p.pid) for p in workers)


def _rss_mb(pid: int) -> float:
    """A process's resident set (``VmRSS``), MB."""
    with open(f"/proc/{pid}/status") as f:
        kb = next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))
    return kb / 1024


def block(env: Any, steps: int, rng: np.random.Generator) -> tuple[float, float]:
    """``(wall s, CPU s)`` of ``steps`` vector steps of random actions."""
    space = env.action_space
    actions = [rng.uniform(space.low, space.high).astype(space.dtype) for _ in range(steps)]
    wall, cpu = time.monotonic(), _cpu(env)
    for action in actions:
        env.step(action)
    return time.monotonic() - wall, _cpu(env) - cpu


def measure(num_envs: int, steps: int, rounds: int, env_id: str) -> dict:
    """Per mode, the rounds' env steps per wall second and per CPU second (summaries)."""
    rng = np.random.default_rng(0)
    before = _rss_mb(os.getpid())
    envs = {"sync": make("sync", num_envs, env_id)}
    memory = {"sync": _rss_mb(os.getpid()) - before}
    envs["async"] = make("async", num_envs, env_id)
    try:
        for env in envs.values():
            block(env, 2, rng)  # warm: the renderers, the first plans
        rates: dict[str, dict[str, list[float]]] = {m: {"wall": [], "cpu": []} for m in envs}
        for _ in range(rounds):
            for mode, env in envs.items():
                wall, cpu = block(env, steps, rng)
                rates[mode]["wall"].append(steps * num_envs / wall)
                rates[mode]["cpu"].append(steps * num_envs / cpu)
        memory["async"] = sum(_rss_mb(p.pid) for p in envs["async"].processes)
    finally:
        for env in envs.values():
            env.close()
    out = {mode: {k: summary(v) for k, v in r.items()} for mode, r in rates.items()}
    out["ratio"] = {k: summary(np.array(rates["sync"][k]) / np.array(rates["async"][k])) for k in ("wall", "cpu")}
    out["memory_mb"] = memory
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, default=2)
    parser.add_argument("--steps", type=int, default=10, help="vector steps per block")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--task", default="reach_target")
    parser.add_argument("--obs", choices=("vision", "state"), default="vision")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    env_id = f"rlbench/{args.task}-{args.obs}-v0"
    r = measure(args.num_envs, args.steps, args.rounds, env_id)
    print(f"{env_id}, {args.num_envs} envs, {args.rounds} rounds of {args.steps} vector steps, "
          f"load {os.getloadavg()[0]:.1f}")
    print("mode                     env steps/s (wall)      env steps per CPU-s     memory (MB)")
    for mode, label in (("sync", "sync (1 process)"), ("async", f"async ({args.num_envs} processes)")):
        w, c = r[mode]["wall"], r[mode]["cpu"]
        print(f"{label:<24} {w['median']:7.2f} ({w['p10']:.2f}-{w['p90']:.2f})   "
              f"{c['median']:7.2f} ({c['p10']:.2f}-{c['p90']:.2f})   {r['memory_mb'][mode]:8.0f}")
    w, c = r["ratio"]["wall"], r["ratio"]["cpu"]
    print(f"{'sync / async':<24} {w['median']:7.2f}x ({w['p10']:.2f}-{w['p90']:.2f})  "
          f"{c['median']:7.2f}x ({c['p10']:.2f}-{c['p90']:.2f})")


if __name__ == "__main__":
    main()
