"""Start-up refusals (issue 60): how soon ``simx-server`` says that its port is taken.

``python -m simx_server.cli --port P`` with P held by a listening socket of this process, and
``--zmq-port N`` with N held, each run to its exit (status 2, the one line); wall time from the
spawn to the exit. Floor, interleaved in the same rounds: ``python -c "import simx_server.cli"``,
the interpreter's start and the command line's own imports, which any refusal pays. Before issue
60 the refusal came after MuJoCo, OpenCV and the API table had loaded (1.4-1.7 s on 2 cores);
with ``--baseline DIR`` that tree's refusal joins the rounds (before and after in one run).
tests/transport/test_startup_checks.py tests that the refusal comes before those imports and
what it says; this suite only times it.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

from benchmarks.common import Settings
from benchmarks.procs import LOOPBACK, ROOT, child_env, free_port
from benchmarks.stats import Figure, Target, scaled, summary


def _timed(cmd: list[str], env: dict[str, str], cwd: Path, want: int) -> float:
    """Wall seconds from spawning ``cmd`` to its exit; RuntimeError unless it exits ``want``."""
    t0 = time.perf_counter()
    out = subprocess.run(cmd, env=env, cwd=cwd, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                         timeout=120)
    dt = time.perf_counter() - t0
    if out.returncode != want:
        raise RuntimeError(f"{' '.join(cmd[2:])}: exit status {out.returncode}, not {want}: {out.stderr[-500:]}")
    return dt


def run(s: Settings) -> list[Figure]:
    rounds = s.n(10, 4, smoke=1)
    env = child_env()
    with socket.socket() as legacy, socket.socket() as zmq:
        for sock in (legacy, zmq):
            sock.bind((LOOPBACK, 0))
            sock.listen()
        port, zmq_port = legacy.getsockname()[1], zmq.getsockname()[1]
        server = [sys.executable, "-m", "simx_server.cli"]
        cases = {
            "floor": ([sys.executable, "-c", "import simx_server.cli"], ROOT, 0),
            "port": ([*server, "--port", str(port), "--no-zmq"], ROOT, 2),
            "zmq_port": ([*server, "--port", str(free_port()), "--zmq-port", str(zmq_port)], ROOT, 2),
        }
        envs = {name: env for name in cases}
        if s.baseline is not None:
            cases["baseline_port"] = ([*server, "--port", str(port), "--no-zmq"], s.baseline, 2)
            envs["baseline_port"] = dict(env, PYTHONPATH=os.pathsep.join(
                p for p in (str(s.baseline), os.environ.get("PYTHONPATH", "")) if p))
        for name, (cmd, cwd, want) in cases.items():  # warm-up: the bytecode caches written
            _timed(cmd, envs[name], cwd, want)
        times: dict[str, list[float]] = {name: [] for name in cases}
        for r in range(rounds):
            order = list(cases)[r % len(cases):] + list(cases)[:r % len(cases)]
            for name in order:
                cmd, cwd, want = cases[name]
                times[name].append(_timed(cmd, envs[name], cwd, want))
    ms = {k: scaled(summary(v), 1e3) for k, v in times.items()}
    floor = {"label": "python -c 'import simx_server.cli'", **ms["floor"]}
    target = Target("value", "<", 1000.0, "< 1 s")
    figures = [
        Figure("startup.floor", "python -c 'import simx_server.cli' (the floor)", "ms", ms["floor"]),
        Figure("startup.port_taken", "simx-server --port P, P taken: spawn to exit", "ms", ms["port"],
               floor=floor, target=target, note="status 2, one line: the port is already in use"),
        Figure("startup.zmq_port_taken", "simx-server --zmq-port N, N taken: spawn to exit", "ms", ms["zmq_port"],
               floor=floor, target=target),
    ]
    if "baseline_port" in ms:
        figures.append(Figure("startup.baseline_port_taken", "  the same, --baseline tree's server", "ms",
                              ms["baseline_port"], floor=floor, note=f"server of {s.baseline}"))
    return figures
