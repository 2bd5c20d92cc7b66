"""2. Streaming: joint positions streamed from the UR5 scene (real time, dt 50 ms).

The server is benchmarks/instrumented_server.py: simx-server unchanged but for a probe that
records the wall time (CLOCK_MONOTONIC, system-wide) at the end of each simulation step. The
client streams ``simxGetJointPosition`` of the six UR5 joints (``simx_opmode_streaming``) and

* counts, with a second subscriber on its own stream key, how many stream updates carry each
  step's simulation time: updates per simulation step, which must be exactly one;
* polls ``simx_opmode_buffer`` every ~0.2 ms, as a legacy program would, and stamps the moment a
  new value becomes readable (``simxGetLastCmdTime`` changes): the delay from the end of that
  step on the server to the value in ``buffer`` (includes up to one poll period, ~0.25 ms);
* for diagnosis, the delay from step end to the update reaching the client's Zenoh callback.
"""

from __future__ import annotations

import collections
import json
import time

from benchmarks.common import Settings, connect, connection
from benchmarks.procs import Server
from benchmarks.stats import Figure, Target, summary
from simx_client import api
from simx_client import constants as C
from simx_client import protocol as P

B, STREAM, BUFFER = C.simx_opmode_blocking, C.simx_opmode_streaming, C.simx_opmode_buffer


def run(s: Settings) -> list[Figure]:
    probe_log = s.log_dir / "streaming-probe.json"
    s.log_dir.mkdir(parents=True, exist_ok=True)
    window = s.t(10.0, 3.0)
    received: list[tuple[int, float]] = []  # (sim ms, monotonic) per stream update
    seen: list[tuple[int, float]] = []  # (sim ms, monotonic) per new buffer value
    entries: list[int] = []  # commands carried by each stream update
    srv = Server(s.log_dir, probe_log=probe_log, name="streaming")
    try:
        cid = connect(srv.port)
        conn = connection(cid)
        try:
            joints = [api.simxGetObjectHandle(cid, f"UR5_joint{i}", B)[1] for i in range(1, 7)]

            def on_sample(sample) -> None:
                now = time.monotonic()
                t, update = P.unpack_stream_update(sample.payload.to_bytes())
                received.append((t, now))
                entries.append(len(update))

            counter = conn.session.declare_subscriber(P.stream_key(conn.prefix, conn.client), on_sample)
            for h in joints:
                api.simxGetJointPosition(cid, h, STREAM)
            deadline = time.monotonic() + 10
            while api.simxGetJointPosition(cid, joints[-1], BUFFER)[0] != 0:
                if time.monotonic() > deadline:
                    raise RuntimeError("no streamed value within 10 s")
                time.sleep(0.001)
            received.clear()
            entries.clear()
            last = api.simxGetLastCmdTime(cid)
            end = time.monotonic() + window
            while time.monotonic() < end:
                rc, _ = api.simxGetJointPosition(cid, joints[-1], BUFFER)
                t = api.simxGetLastCmdTime(cid)
                if rc == 0 and t != last:
                    seen.append((t, time.monotonic()))
                    last = t
                time.sleep(0.0002)
            for h in joints:
                api.simxGetJointPosition(cid, h, C.simx_opmode_discontinue)
            counter.undeclare()
        finally:
            api.simxFinish(cid)
    finally:
        srv.stop()
    steps = {ms: t for ms, t in json.loads(probe_log.read_text())["steps"]}

    # Updates per step, over the steps the window covered (first and last partial ones excluded).
    per_t = collections.Counter(ms for ms, _ in received)
    lo, hi = min(per_t) + 1, max(per_t) - 1
    window_steps = sorted(ms for ms in steps if lo <= ms <= hi)
    counts = [per_t.get(ms, 0) for ms in window_steps]
    missed = sum(1 for c in counts if c == 0)
    extra = sum(c - 1 for c in counts if c > 1)
    buffer_delay = [(t - steps[ms]) * 1e3 for ms, t in seen if ms in steps]
    callback_delay = [(t - steps[ms]) * 1e3 for ms, t in received if ms in steps]
    sim_rate = (len(window_steps) - 1) / (steps[window_steps[-1]] - steps[window_steps[0]]) if len(window_steps) > 1 else float("nan")
    updates = Figure("streaming.updates_per_step", "streamed joint positions: updates per sim step", "1/step",
                     summary(counts), target=Target("value", "==", 1, "exactly 1 every step"),
                     note=f"{len(window_steps)} steps, {missed} missed, {extra} extra; {sim_rate:.1f} steps/s",
                     extra={"steps": len(window_steps), "missed": missed, "duplicates": extra,
                            "steps_per_s": sim_rate, "entries_per_update": summary(entries)})
    updates.met = bool(counts) and min(counts) == 1 and max(counts) == 1
    return [
        updates,
        Figure("streaming.step_to_buffer", "streamed: step end -> value readable in buffer", "ms",
               summary(buffer_delay), note=f"{len(buffer_delay)} updates; polled every ~0.25 ms"),
        Figure("streaming.step_to_callback", "  of which: step end -> update in client callback", "ms",
               summary(callback_delay), note="server publish + Zenoh + delivery"),
    ]
