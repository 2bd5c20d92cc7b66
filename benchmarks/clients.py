"""6. Many clients: 1, 4 and 16 client processes making blocking calls at once.

One simx server (real time, dt 50 ms). For each count, that many benchmarks/client_worker.py
processes connect, report ready, and start together at a shared CLOCK_MONOTONIC instant; each
makes blocking ``simxGetObjectHandle`` calls on a rotation of the scene's names (offset per
worker) for ``window`` s (and at most ``max_calls``), checking every returned handle.

* aggregate throughput: calls completed by all workers per 0.25 s bin, in calls/s; median and
  spread over the bins; compared with the 1-client figure of the same run;
* latency: p99 per bin (median and spread over bins), overall p50/p99 in the JSON;
* lost (return code != 0, e.g. a timeout) and mismatched (wrong handle) replies: must be 0;
* CPU time per call, all threads of every process: the workers' own (getrusage over their
  window) plus the server's (or the echo's) over the run (/proc/PID/stat, which also counts
  its idle ticks around the window: about 2 % of a core). On a machine whose cores are all
  busy, aggregate throughput is the cores divided by this.

Floor, same run: the same numbers of bare Zenoh clients (client_worker.py --echo-port) making
query/replies of simxGetObjectHandle's sizes to benchmarks/zenoh_echo.py, so that what the
machine's cores allow at all is measured next to what simx reaches.
"""

from __future__ import annotations

import json
import os
import sys
import time

import numpy as np

from benchmarks.common import Settings, connect, wire_sizes
from benchmarks.procs import Echo, Proc, Server, child_env
from benchmarks.stats import Figure, Target, scaled, summary
from simx_client import api
from simx_client import constants as C

BIN = 0.25  # s
NAMES = ["UR5", "UR5_joint1", "UR5_joint2", "UR5_joint3", "UR5_joint4", "UR5_joint5", "UR5_joint6",
         "RG2", "RG2_openCloseJoint", "kinect_rgb", "kinect_depth", "Table", "Sphere"]


def _cpu_s(pid: int) -> float:
    """CPU time (user + system, all threads) a process has used so far, in s."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _run_count(s: Settings, port: int, names: list, count: int, window: float, server_pid: int,
               echo_sizes: tuple[int, int] | None = None) -> dict:
    """``count`` workers against the simx server on ``port``, or (``echo_sizes``) bare Zenoh
    workers against the echo on ``port``; ``server_pid`` is the process they query."""
    workers: list[Proc] = []
    tag = "bare" if echo_sizes else "simx"
    outs = [s.log_dir / f"clients-{tag}-{count}-{i}.json" for i in range(count)]
    target = (["--echo-port", str(port), "--sizes", f"{echo_sizes[0]},{echo_sizes[1]}"] if echo_sizes
              else ["--port", str(port)])
    try:
        for i in range(count):
            cmd = [sys.executable, "-m", "benchmarks.client_worker", *target, "--index", str(i),
                   "--names", json.dumps(names), "--window", str(window), "--max-calls", "200000",
                   "--out", str(outs[i])]
            workers.append(Proc(f"client-{tag}-{count}-{i}", cmd, s.log_dir, timeout=120, env=child_env(),
                                stdin_pipe=True))
        start = time.monotonic() + 0.3
        for w in workers:
            w.proc.stdin.write(f"{start!r}\n")
            w.proc.stdin.flush()
        server_cpu = _cpu_s(server_pid)
        for w in workers:
            w.proc.wait(timeout=window + 60)
        server_cpu = _cpu_s(server_pid) - server_cpu
    finally:
        for w in workers:
            w.stop()
    results = [json.loads(p.read_text()) for p in outs]
    done = np.concatenate([r["done"] for r in results])
    lat = np.concatenate([r["lat"] for r in results])
    keep = done <= window
    nbins = int(window / BIN)
    bins = np.minimum((done[keep] / BIN).astype(int), nbins - 1)
    counts = np.bincount(bins, minlength=nbins)
    p99 = [float(np.percentile(lat[keep][bins == b], 99)) for b in range(nbins) if counts[b]]
    calls = int(sum(r["calls"] for r in results))
    client_cpu = sum(r["cpu_s"] for r in results)
    return {"throughput": summary(counts / BIN), "p99_ms": scaled(summary(p99), 1e3),
            "lat_ms": scaled(summary(lat), 1e3), "p99_all_ms": float(np.percentile(lat, 99)) * 1e3,
            "calls": calls, "lost": sum(r["lost"] for r in results),
            "mismatched": sum(r["mismatched"] for r in results),
            "cpu_us_per_call": {"server": server_cpu / calls * 1e6, "clients": client_cpu / calls * 1e6,
                                "total": (server_cpu + client_cpu) / calls * 1e6}}


def run(s: Settings) -> list[Figure]:
    window = s.t(4.0, 1.5)
    counts = s.pick((1, 4, 16), (1, 4, 16), smoke=(1, 2))
    got, bare = {}, {}
    with Server(s.log_dir, "--pacing", "immediate", name="clients") as srv, Echo(s.log_dir) as echo:
        cid = connect(srv.port)
        try:
            names = [[n, api.simxGetObjectHandle(cid, n, C.simx_opmode_blocking)[1]] for n in NAMES]
            sizes = wire_sizes(cid, [["GetObjectHandle", C.simx_opmode_blocking, ["UR5_joint1"]]])
        finally:
            api.simxFinish(cid)
        for n in counts:  # simx and bare side by side, count by count
            got[n] = _run_count(s, srv.port, names, n, window, srv.proc.pid)
            bare[n] = _run_count(s, echo.port, names, n, window, echo.proc.pid, echo_sizes=sizes)
    figs = []
    one = got[1]["throughput"]
    for n in counts:
        g, b = got[n], bare[n]
        plural = "s" if n > 1 else ""
        note = (f"{g['calls']} calls, {g['lost']} lost, {g['mismatched']} mismatched; latency p50 "
                f"{g['lat_ms']['median']:.2f} ms, p99 (all) {g['p99_all_ms']:.2f} ms")
        target = Target("ratio", ">=", 3.0, ">= 3x 1 client") if n == 16 else None
        figs.append(Figure(f"clients.{n}.throughput", f"{n} client{plural}: aggregate calls/s",
                           "1/s", g["throughput"], floor=None if n == 1 else {"label": "1 simx client", **one},
                           target=target, note=note, extra=g))
        figs.append(Figure(f"clients.{n}.bare_throughput", f"  {n} bare Zenoh client{plural}: aggregate calls/s",
                           "1/s", b["throughput"],
                           floor=None if n == 1 else {"label": "1 bare Zenoh client", **bare[1]["throughput"]},
                           note="" if n > 1 else "what the cores allow with no simx code; ratio = its own scaling",
                           extra=b))
        figs.append(Figure(f"clients.{n}.vs_bare", f"  {n} client{plural}: simx / bare Zenoh throughput", "1/s",
                           g["throughput"], floor={"label": f"{n} bare Zenoh clients", **b["throughput"]}))
        figs.append(Figure(f"clients.{n}.p99", f"  {n} client{plural}: p99 latency (per 0.25 s bin)",
                           "ms", g["p99_ms"], floor={"label": f"{n} bare Zenoh clients p99", **b["p99_ms"]}))
    for n in (1, counts[-1]):
        g, b = got[n]["cpu_us_per_call"], bare[n]["cpu_us_per_call"]
        figs.append(Figure(
            f"clients.{n}.cpu", f"  {n} client{'s' if n > 1 else ''}: CPU per call, all processes", "us",
            summary([g["total"]]), floor={"label": "bare Zenoh, same clients", **summary([b["total"]])},
            note=f"simx server {g['server']:.0f} + clients {g['clients']:.0f} us; "
                 f"bare echo {b['server']:.0f} + clients {b['clients']:.0f} us",
            extra={"simx": g, "bare": b}))
    most = got[counts[-1]]
    bad = most["lost"] + most["mismatched"]
    f = Figure(f"clients.{counts[-1]}.errors", f"{counts[-1]} clients: lost + mismatched replies", "count",
               summary([bad]), target=Target("value", "==", 0, "0"),
               note=f"lost {most['lost']}, mismatched {most['mismatched']} of {most['calls']}")
    figs.append(f)
    return figs
