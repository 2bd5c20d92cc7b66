"""Issue 19 part 3: V-REP's command batching. A program's tight loop of non-blocking calls, and
what reaches the server.

* **oneshot loop**: 20,000 ``simxSetJointTargetPosition(h, q, simx_opmode_oneshot)`` (a new
  ``q`` each time), then one blocking call: requests on the wire (the client's message ids) and
  whether the server got the last target.
* **appends**: 20,000 ``simxAppendStringSignal(cid, 'log', b'x', simx_opmode_oneshot)`` (a
  command that is never merged), then the signal read back: commands lost = 20,000 - its length.
* **blocking call**: ``simxGetJointPosition`` blocking, median round trip, ``--pacing immediate``
  (the floor for the ratio before/after is the same call in the same run with an empty outbox).

Targets: at most one request per ``commThreadCycleInMs`` (5 ms) on average, 0 commands lost.
"""

from __future__ import annotations

from benchmarks.common import Settings, connection, perf
from benchmarks.procs import Server
from benchmarks.stats import Figure, Target, summary
from simx_client import api

N = 20_000
B, ONESHOT = 0x010000, 0x000000


def _loop(cid: int, n: int, send) -> tuple[int, float]:
    """``send(i)`` n times; returns (requests sent, wall s) measured with the message ids."""
    conn = connection(cid)
    before = conn._out[0]
    t0 = perf()
    for i in range(n):
        send(i)
    wall = perf() - t0
    api.simxGetPingTime(cid)  # a blocking call: what waits leaves with it
    return conn._out[0] - before - 1, wall


def run(s: Settings) -> list[Figure]:
    n = s.n(N, 5_000)
    with Server(s.log_dir, "--pacing", "immediate", name="outbox") as srv:
        cid = api.simxStart("127.0.0.1", srv.port, True, True, 10000, 5)
        try:
            _, h = api.simxGetObjectHandle(cid, "UR5_joint1", B)
            requests, wall = _loop(cid, n, lambda i: api.simxSetJointTargetPosition(cid, h, i * 1e-5, ONESHOT))
            api.simxClearStringSignal(cid, "log", B)
            app_requests, app_wall = _loop(cid, n, lambda i: api.simxAppendStringSignal(cid, "log", b"x", ONESHOT))
            rc, data = api.simxGetStringSignal(cid, "log", B)
            delivered = len(data) if rc == 0 else 0
            last_ok = rc == 0
            times = []
            for _ in range(s.n(400, 100)):
                t0 = perf()
                api.simxGetJointPosition(cid, h, B)
                times.append(perf() - t0)
        finally:
            api.simxFinish(cid)
    cycles = wall / 0.005
    ms = {k: v * 1e3 for k, v in summary(times).items()}
    return [
        Figure("outbox.requests", f"requests on the wire for {n} oneshot calls", "requests",
               summary([requests]), target=Target("value", "<=", max(1.0, cycles) + 2, "<= 1 per 5 ms cycle"),
               extra={"loop_s": wall, "cycles_5ms": cycles, "requests_per_s": requests / wall},
               note=f"{n} oneshots in {wall:.2f} s: {requests} requests ({requests / wall:.0f}/s)"),
        Figure("outbox.lost", f"appends lost of {n} oneshot simxAppendStringSignal", "commands",
               summary([n - delivered]), target=Target("value", "==", 0, "0 lost"),
               extra={"requests": app_requests, "loop_s": app_wall, "signal_read": last_ok},
               note=f"appends: {delivered}/{n} delivered in {app_requests} requests"),
        Figure("outbox.blocking", "blocking simxGetJointPosition round trip", "ms", ms),
    ]
