"""Command batching (issue 19 part 3): what a program's loop of non-blocking calls puts on the
wire, what it loses, and what a blocking call costs beside it.

One simx server (benchmarks/instrumented_server.py, whose probe records every request that
reaches a client's queue and whether it was queued or answered "server busy"; real time,
``--pacing immediate`` so that blocking calls are plain round trips) and one echo process for
the bare Zenoh floor. The client connects as legacy programs do (``simxStart(..., 5)``: a
5 ms communication cycle). Measured:

* **the set loop**: 20,000 (quick 5,000) oneshot ``simxSetJointTargetPosition`` on one joint
  as fast as the program can call: the loop's duration, the requests the server received for
  it (until the client's outbox is empty), requests per second and per 5 ms cycle, the
  requests answered "server busy" (each one's commands were lost before the outbox retried
  them);
* **the append loop**: as many oneshot ``simxAppendStringSignal(cid, "outbox", b"x")`` (never
  collapsed: each call must run): the same figures, and the commands lost, counted exactly as
  N minus the signal's final length (read with a blocking call after a blocking
  ``simxGetPingTime``, which sends whatever still waits);
* **blocking calls**: ``simxGetJointPosition`` blocking alone, and one oneshot
  ``simxSetJointTargetPosition`` followed by that blocking call, interleaved with their bare
  Zenoh floors (one query of the blocking call's sizes; an unawaited query of the oneshot's
  sizes followed by an awaited one).
"""

from __future__ import annotations

import json
import time

from benchmarks.common import Floor, Settings, connect, floor_pipelined, interleaved, wire_sizes
from benchmarks.procs import Echo, Server
from benchmarks.stats import Figure, Target, scaled, summary
from simx_client import api
from simx_client import constants as C

B, ONESHOT = C.simx_opmode_blocking, C.simx_opmode_oneshot
CYCLE_S = 0.005  # the commThreadCycleInMs legacy programs pass (5 ms)
SIGNAL = "outbox"


def _one(value: float) -> dict[str, float]:
    return summary([value])


def _loop(cid: int, n: int, call) -> tuple[float, float, float]:
    """Run ``call(i)`` n times; then a blocking ping (the outbox leaves with it at the latest).
    Returns (start, loop end, after the ping) in time.monotonic()."""
    t0 = time.monotonic()
    for i in range(n):
        call(i)
    t1 = time.monotonic()
    if api.simxGetPingTime(cid)[0] != 0:
        raise RuntimeError("simxGetPingTime failed after the loop")
    return t0, t1, time.monotonic()


def _wire(requests: list, t0: float, t2: float) -> tuple[int, int, int]:
    """(requests received, of which answered busy, commands in the busy ones) between t0 and t2,
    the final ping's request left out."""
    inside = [r for r in requests if t0 <= r[0] <= t2]
    inside = inside[:-1]  # the blocking ping that ended the loop
    busy = [r for r in inside if not r[2]]
    return len(inside), len(busy), sum(r[1] for r in busy)


def run(s: Settings) -> list[Figure]:
    n = s.n(20_000, 5_000)
    probe_log = s.log_dir / "outbox-probe.json"
    s.log_dir.mkdir(parents=True, exist_ok=True)
    srv = Server(s.log_dir, "--pacing", "immediate", probe_log=probe_log, name="outbox")
    try:
        with Echo(s.log_dir) as echo:
            cid = connect(srv.port)
            floor = Floor(echo.port)
            try:
                rc, j1 = api.simxGetObjectHandle(cid, "UR5_joint1", B)
                if rc:
                    raise RuntimeError("UR5_joint1 not found")
                api.simxClearStringSignal(cid, SIGNAL, B)
                set_loop = _loop(cid, n, lambda i: api.simxSetJointTargetPosition(cid, j1, (i % 100) * 1e-3, ONESHOT))
                time.sleep(0.5)  # leave the server's queue empty between the loops
                append_loop = _loop(cid, n, lambda i: api.simxAppendStringSignal(cid, SIGNAL, b"x", ONESHOT))
                rc, value = api.simxGetStringSignal(cid, SIGNAL, B)
                appended = len(value) if rc == 0 else 0
                blocking = _blocking(s, cid, j1, floor)
            finally:
                floor.close()
                api.simxFinish(cid)
    finally:
        srv.stop()
    requests = json.loads(probe_log.read_text())["requests"]
    figures = []
    for key, label, (t0, t1, t2) in (("set", "oneshot simxSetJointTargetPosition", set_loop),
                                     ("append", "oneshot simxAppendStringSignal", append_loop)):
        sent, busy, refused = _wire(requests, t0, t2)
        span = t2 - t0
        figures += [
            Figure(f"outbox.{key}.loop", f"{n:,} x {label}: loop time", "s", _one(t1 - t0),
                   note="the program's loop alone (the calls return before anything is sent)"),
            Figure(f"outbox.{key}.requests", f"  requests on the wire for the loop", "1", _one(sent),
                   note=f"from the loop's start until the outbox is empty ({span:.2f} s)",
                   extra={"span_s": span}),
            Figure(f"outbox.{key}.rate", f"  requests per second on the wire", "1/s", _one(sent / span)),
            Figure(f"outbox.{key}.per_cycle", f"  requests per 5 ms cycle", "1", _one(sent / (span / CYCLE_S)),
                   target=Target("value", "<=", 1.0, "<= 1 per cycle")),
            Figure(f"outbox.{key}.busy", f"  requests answered 'server busy'", "1", _one(busy),
                   note=f"{refused} command(s) in them"),
        ]
    figures.append(Figure("outbox.append.lost", f"  commands lost (N - signal length)", "1", _one(n - appended),
                          target=Target("value", "==", 0, "0 lost"), extra={"appended": appended, "n": n}))
    return figures + blocking


def _blocking(s: Settings, cid: int, j1: int, floor: Floor) -> list[Figure]:
    size = {"jp": wire_sizes(cid, [["GetJointPosition", B, [j1]]]),
            "st": wire_sizes(cid, [["SetJointTargetPosition", ONESHOT, [j1, 0.0]]])}

    def ok(result) -> None:
        if result[0] != 0:
            raise RuntimeError(f"simx call failed with return code {result[0]}")

    def set_get() -> None:
        api.simxSetJointTargetPosition(cid, j1, 0.0, ONESHOT)
        ok(api.simxGetJointPosition(cid, j1, B))

    cases = {
        "floor_jp": lambda: floor.call(size["jp"][1], size["jp"][0]),
        "jp": lambda: ok(api.simxGetJointPosition(cid, j1, B)),
        "floor_set_get": lambda: floor_pipelined(floor, size["st"], size["jp"]),
        "set_get": set_get,
    }
    t = interleaved(s.n(40, 8), 25, cases, budget_s=s.t(60, 20))
    ms = {k: scaled(summary(v), 1e3) for k, v in t.items()}
    return [
        Figure("outbox.blocking", "simxGetJointPosition (blocking)", "ms", ms["jp"],
               floor={"label": "bare Zenoh query/reply, same sizes", **ms["floor_jp"]},
               target=Target("ratio", "<=", 1.25, "p50 <= 1.25x floor")),
        Figure("outbox.set_then_blocking", "oneshot set + blocking simxGetJointPosition", "ms", ms["set_get"],
               floor={"label": "bare: unawaited oneshot-size query + awaited get-size query", **ms["floor_set_get"]},
               note="the oneshot waits in the outbox and leaves with the blocking call"),
    ]
