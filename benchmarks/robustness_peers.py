"""Robustness parts e and f (issue 23): what a viewer-model query loop and a client that stops
reading cost another client's blocking calls. Run with the rest of ``--only robustness``.

* e. viewer flood: 16 threads query ``simx/viewer/model`` back to back for 20 s (5 s quick)
  while the suite makes blocking ``simxGetJointPosition`` calls every ~5 ms: their p99 against
  the same calls unloaded just before, models answered and refused, bytes pulled.
* f. stuck consumer: a process asks for 16 viewer models and 60 640x480 RGB images without
  reading the answers, then is stopped (SIGSTOP) for 8 s (4 s): the other client's longest
  blocking call and its p99, and the calls that timed out.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import zenoh

from benchmarks.common import Settings, connect
from benchmarks.procs import Server, child_env
from benchmarks.stats import Figure, summary
from simx_client import api
from simx_client import constants as C
from simx_client import protocol as P
from simx_client.connection import client_config

B = C.simx_opmode_blocking
STUCK = Path(__file__).resolve().parents[1] / "tests" / "transport" / "stuck_consumer.py"


def _calls(cid: int, joint: int, seconds: float) -> list[tuple[float, int]]:
    """Blocking calls every ~5 ms for ``seconds``: (latency s, return code) each."""
    out, end = [], time.monotonic() + seconds
    while time.monotonic() < end:
        t = time.perf_counter()
        rc, _ = api.simxGetJointPosition(cid, joint, B)
        out.append((time.perf_counter() - t, rc))
        time.sleep(0.005)
    return out


def _p99_ms(calls: list[tuple[float, int]]) -> float:
    return float(np.percentile([lat for lat, _ in calls], 99)) * 1e3


def viewer_flood(s: Settings) -> list[Figure]:
    seconds, unloaded_s = s.t(20.0, 5.0), s.t(6.0, 3.0)
    answered, refused, pulled = [0], [0], [0]
    stop = threading.Event()
    with Server(s.log_dir, "--pacing", "immediate", name="robustness-viewer-flood") as srv:
        cid = connect(srv.port)
        joint = api.simxGetObjectHandle(cid, "UR5_joint3", B)[1]
        _calls(cid, joint, 0.5)
        unloaded = _calls(cid, joint, unloaded_s)
        session = zenoh.open(client_config("127.0.0.1", srv.port))

        def loop() -> None:
            while not stop.is_set():
                for reply in session.get(P.viewer_model_key(), timeout=5.0):
                    if reply.ok is None:
                        continue
                    payload = reply.ok.payload.to_bytes()
                    try:
                        P.unpack_viewer_model(payload)
                        answered[0] += 1
                        pulled[0] += len(payload)
                    except P.ProtocolError:
                        refused[0] += 1

        threads = [threading.Thread(target=loop, daemon=True) for _ in range(16)]
        for t in threads:
            t.start()
        loaded = _calls(cid, joint, seconds)
        stop.set()
        for t in threads:
            t.join(10)
        session.close()
        api.simxFinish(cid)
    note = (f"{answered[0]} models answered ({pulled[0] / 2**20:.0f} MiB), {refused[0]} refused busy in "
            f"{seconds:.0f} s; unloaded p99 {_p99_ms(unloaded):.1f} ms")
    lat = [x * 1e3 for x, _ in loaded]
    return [Figure("robustness.viewer_flood.p99", "e. viewer-model flood: another client's blocking call", "ms",
                   summary(lat), floor={"label": "the same calls unloaded", **summary(x * 1e3 for x, _ in unloaded)},
                   note=note + f"; p99 during the flood {_p99_ms(loaded):.1f} ms",
                   extra={"answered": answered[0], "refused": refused[0], "bytes": pulled[0]})]


def stuck_consumer(s: Settings) -> list[Figure]:
    seconds = s.t(8.0, 4.0)
    with Server(s.log_dir, "--pacing", "immediate", name="robustness-stuck") as srv:
        cid = connect(srv.port)
        joint = api.simxGetObjectHandle(cid, "UR5_joint3", B)[1]
        unloaded = _calls(cid, joint, s.t(3.0, 2.0))
        stuck = subprocess.Popen([sys.executable, str(STUCK), str(srv.port)], stdout=subprocess.PIPE,
                                 text=True, env=child_env())
        try:
            assert stuck.stdout.readline().strip() == "sent"
            os.kill(stuck.pid, signal.SIGSTOP)
            loaded = _calls(cid, joint, seconds)
        finally:
            os.kill(stuck.pid, signal.SIGKILL)
            stuck.wait()
        api.simxFinish(cid)
    worst = max(x for x, _ in loaded)
    timeouts = sum(rc != 0 for _, rc in loaded)
    return [Figure("robustness.stuck.worst", "f. stopped consumer: another client's longest blocking call", "ms",
                   summary([worst * 1e3]), note=(f"p99 {_p99_ms(loaded):.1f} ms over {len(loaded)} calls "
                                                 f"(unloaded {_p99_ms(unloaded):.1f} ms); {timeouts} not answered ok"),
                   extra={"timeouts": timeouts, "calls": len(loaded)})]
