"""Issue 20 part 3: idle servers cost nothing.

* **lone**: one ``simx-server --speed 0`` and ``simx/UR5BallReach-v0`` (84x84) stepped on it.
* **pool**: four ``--speed 0`` servers, the same env on one of them, three with no client.
* **idle share**: the CPU share of one idle ``--speed 0`` server (no client) over a window.

Figures: the env's steps/s in each case (throughput of the timed loop; the median per-step rate
as the row's statistics) and the pool's over the lone server's (target: within 10 %, i.e.
>= 0.9); the idle server's share of one core (before the idle rule: 44-77 %).
"""

from __future__ import annotations

import os
import time

from benchmarks.common import Settings, perf
from benchmarks.procs import Server
from benchmarks.stats import Figure, Target, summary

_TICK = os.sysconf("SC_CLK_TCK")


def _cpu(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICK


def _env_rate(port: int, steps: int, warmup: int) -> tuple[list[float], float]:
    from simx_client.envs.ur5_ball_reach import UR5BallReachEnv

    env = UR5BallReachEnv(port=port, width=84, height=84)
    try:
        env.reset(seed=0)
        env.action_space.seed(1)
        for _ in range(warmup):
            env.step(env.action_space.sample())
        times, start = [], perf()
        for _ in range(steps):
            a = env.action_space.sample()
            t0 = perf()
            env.step(a)
            times.append(perf() - t0)
        return times, perf() - start
    finally:
        env.close()


def run(s: Settings) -> list[Figure]:
    steps, warmup = s.n(200, 40), s.n(10, 3)
    with Server(s.log_dir, "--speed", "0", name="idle-share") as idle:
        time.sleep(1.0)  # let it finish starting before the window opens
        c0, w0 = _cpu(idle.pid), time.monotonic()
        time.sleep(s.t(5.0, 2.0))  # the measurement window
        share = (_cpu(idle.pid) - c0) / (time.monotonic() - w0)
    with Server(s.log_dir, "--speed", "0", name="idle-lone") as lone:
        t_lone, wall_lone = _env_rate(lone.port, steps, warmup)
    pool = s.pick(4, 4, smoke=2)
    servers = [Server(s.log_dir, "--speed", "0", name=f"idle-pool{i}") for i in range(pool)]
    try:
        t_pool, wall_pool = _env_rate(servers[0].port, steps, warmup)
    finally:
        for srv in servers:
            srv.stop()
    rate_lone, rate_pool = len(t_lone) / wall_lone, len(t_pool) / wall_pool
    lone_stats = summary([1 / t for t in t_lone])
    return [
        Figure("idle.share", "CPU share of an idle --speed 0 server (no client)", "core", summary([share]),
               target=Target("value", "<", 0.05, "< 5 % of a core"), note=f"idle server: {share:.1%} of a core"),
        Figure("idle.lone", "env steps/s, 84x84, lone --speed 0 server", "1/s", lone_stats,
               extra={"throughput_wall": rate_lone}),
        Figure("idle.pool", f"env steps/s, 84x84, one of {pool} --speed 0 servers ({pool - 1} idle)", "1/s",
               summary([1 / t for t in t_pool]),
               floor={"label": "lone server steps/s", "median": lone_stats["median"]},
               target=Target("ratio", ">=", 0.9, ">= 0.9x the lone server"),
               extra={"throughput_wall": rate_pool, "throughput_wall_over_lone": rate_pool / rate_lone},
               note=f"env on a pool of {pool}: {rate_pool:.1f} steps/s, lone: {rate_lone:.1f} "
                    f"({rate_pool / rate_lone:.2f}x)"),
    ]
