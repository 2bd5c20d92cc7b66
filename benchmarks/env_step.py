"""Issue 44: one Gymnasium env's step, remote and in process, side by side in one run.

The ``envs`` suite runs its cases one after the other; on a shared machine the load moves
between them. Here the two are interleaved: blocks of ``block`` env steps of the in-process
floor (:class:`benchmarks.envs.InProcessReach`, the same env logic on MuJoCo in this process)
and of ``simx/UR5BallReach-v0`` on one simx-server (default legacy pacing, started
``--stopped``), in turns, the order shuffled every round, at 84x84 (sensors at 112x84) and
640x480. With ``--baseline DIR`` two more cases join the turns: the same env (this tree's
client) on a server of that source tree, and the same again with the client sending its outbox
apart from the trigger, as it did before issue 44
(:func:`_without_carry`): with a tree from
before it, the old client and server. Figures: the median step time of each, and its ratio
to the in-process median of the same run (issue 44's target at 84x84: <= 1.2x).
"""

from __future__ import annotations

import random
import time

import numpy as np

from benchmarks.common import Settings, client_as_before_issue44, loadavg, perf
from benchmarks.envs import SIZES, InProcessReach
from benchmarks.procs import Server
from benchmarks.stats import Figure, Target, summary


def _remote_env(port: int, width: int, height: int):
    from simx_client.envs.ur5_ball_reach import UR5BallReachEnv

    env = UR5BallReachEnv(port=port, width=width, height=height)
    env.reset(seed=0)
    env.action_space.seed(1)
    return env


def _without_carry(env) -> None:
    """``env``'s connection as the client was before issue 44 (:func:`benchmarks.common.client_as_before_issue44`)."""
    client_as_before_issue44(env.client_id)


def _measure(cases: dict, rounds: int, block: int, warmup: int, budget_s: float) -> dict[str, list[float]]:
    """``cases``: name -> (step, sample); ``rounds`` rounds of ``block`` timed steps each, in a
    shuffled order (seeded), after ``warmup`` untimed steps of each."""
    for step, sample in cases.values():
        for _ in range(warmup):
            step(sample())
    times: dict[str, list[float]] = {name: [] for name in cases}
    shuffle, deadline = random.Random(20261124).shuffle, time.monotonic() + budget_s
    names = list(cases)
    for _ in range(rounds):
        shuffle(names)
        for name in names:
            step, sample = cases[name]
            for _ in range(block):
                a = sample()
                t0 = perf()
                step(a)
                times[name].append(perf() - t0)
        if time.monotonic() > deadline:
            break
    return times


def run(s: Settings) -> list[Figure]:
    rounds, block, warmup, budget = s.n(20, 5), 10, s.n(5, 2), s.t(90.0, 25.0)
    figures: list[Figure] = []
    for width, height in s.pick(SIZES, SIZES, smoke=SIZES[:1]):
        size = f"{width}x{height}"
        load0 = loadavg()
        servers, envs = [], []
        inproc = InProcessReach(width, height)
        try:
            servers.append(Server(s.log_dir, "--stopped", name=f"envstep-{width}"))
            if s.baseline is not None:
                servers.append(Server(s.log_dir, "--stopped", name=f"envstep-base-{width}", root=s.baseline))
            envs = [_remote_env(srv.port, width, height) for srv in servers]
            if len(servers) > 1:  # the baseline server once more, with the client as it was before issue 44
                envs.append(_remote_env(servers[1].port, width, height))
                _without_carry(envs[-1])
            inproc.reset()
            rng = np.random.default_rng(1)
            cases = {"inproc": (inproc.step, lambda: rng.uniform(-5, 5, 3)),
                     "remote": (envs[0].step, envs[0].action_space.sample)}
            if len(envs) > 1:
                cases["baseline"] = (envs[1].step, envs[1].action_space.sample)
                cases["baseline_client"] = (envs[2].step, envs[2].action_space.sample)
            t = _measure(cases, rounds, block, warmup, budget)
        finally:
            for env in envs:
                env.close()
            for srv in servers:
                srv.stop()
            inproc.close()
        load1 = loadavg()
        ms = {k: {q: v * 1e3 for q, v in summary(x).items()} for k, x in t.items()}
        floor = {"label": "in-process env step, same run", "median": ms["inproc"]["median"],
                 "p10": ms["inproc"]["p10"], "p90": ms["inproc"]["p90"]}
        load = {"loadavg_before": load0, "loadavg_after": load1}
        figures.append(Figure(f"envstep.inproc.{size}", f"in-process env step (floor), {size}", "ms", ms["inproc"],
                              extra=load))
        figures.append(Figure(f"envstep.remote.{size}", f"remote env step, {size}", "ms", ms["remote"], floor=floor,
                              target=Target("ratio", "<=", 1.2, "<= 1.2x in-process") if width == 84 else None,
                              extra=load))
        if "baseline" in ms:
            figures.append(Figure(f"envstep.baseline.{size}", f"remote env step, --baseline server, {size}", "ms",
                                  ms["baseline"], floor=floor, note=f"server of {s.baseline}"))
            figures.append(Figure(f"envstep.baseline_client.{size}",
                                  f"remote env step, --baseline server and client, {size}", "ms",
                                  ms["baseline_client"], floor=floor,
                                  note=f"server of {s.baseline}; the client as before issue 44 (outbox apart from the trigger)"))
    return figures
