"""Robustness parts e to h (issue 23): what a viewer-model query loop and a client that stops
reading cost another client's blocking calls. Run with the rest of ``--only robustness``.

* e. viewer flood: 16 threads query ``simx/viewer/model`` back to back for 20 s (5 s quick)
  while the suite makes blocking ``simxGetJointPosition`` calls every ~5 ms: their p99 against
  the same calls unloaded just before, models answered and refused, bytes pulled.
* f. stuck consumer: a process asks for 16 viewer models and 60 640x480 RGB images without
  reading the answers, then is stopped (SIGSTOP) for 8 s (4 s): the other client's longest
  blocking call and its p99, and the calls that timed out.
* g. big image streams: 10 client ids stream a 4096x4096 sensor's image and depth buffer while
  another client makes blocking 640x480 depth calls: their latency against unloaded, server RSS.
* h. reconnect soak: 4 processes connect, make ~30 mixed calls and disconnect, over and over for
  3 minutes: the server's RSS and its slope.
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
from benchmarks.procs import Server, child_env, proc_status
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


def big_image_streams(s: Settings) -> list[Figure]:
    """g. 10 connections of another process stream kinect_rgb's RGB image and depth buffer at
    4096x4096 (sim_visionintparam_resolution_x/_y set at run time) for 20 s (8 s quick) while
    another client asks, blocking, for kinect_depth's 640x480 depth buffer."""
    seconds = s.t(20.0, 8.0)
    side = s.pick(4096, 4096, smoke=256)  # --smoke: that the part runs, not what 4096x4096 costs
    with Server(s.log_dir, "--pacing", "immediate", name="robustness-big-streams") as srv:
        other = connect(srv.port)
        depth = api.simxGetObjectHandle(other, "kinect_depth", B)[1]

        def depth_calls(duration: float) -> list[tuple[float, int]]:
            out, end = [], time.monotonic() + duration
            while time.monotonic() < end:
                t = time.perf_counter()
                rc, _, _ = api.simxGetVisionSensorDepthBuffer(other, depth, B)
                out.append((time.perf_counter() - t, rc))
            return out

        depth_calls(1.0)
        unloaded = depth_calls(s.t(5.0, 3.0))
        rss_before = proc_status(srv.pid)["rss_mb"]
        rgb = api.simxGetObjectHandle(other, "kinect_rgb", B)[1]
        assert api.simxSetObjectIntParameter(other, rgb, 1002, side, B) == 0
        assert api.simxSetObjectIntParameter(other, rgb, 1003, side, B) == 0
        # ten streaming clients in a process of their own, each reading its updates (raw ids of
        # one session: one process cannot simxStart twice)
        streamer = subprocess.Popen([sys.executable, "-c", _STREAMER, str(srv.port), str(rgb)], stdin=subprocess.PIPE,
                                    stdout=subprocess.PIPE, text=True, env=child_env())
        try:
            setup_s = float(streamer.stdout.readline())
            loaded = depth_calls(seconds)
            streamer.stdin.close()  # the streamer counts until then
            count, size = map(int, streamer.stdout.readline().split())
        finally:
            streamer.kill()
            streamer.wait()
        rss_after = proc_status(srv.pid)["rss_mb"]
        api.simxFinish(other)
    lat = [x * 1e3 for x, _ in loaded]
    failed = sum(rc != 0 for _, rc in loaded)
    return [Figure("robustness.big_streams.depth", f"g. 10 streams of a {side}x{side} sensor: another client's "
                   "640x480 depth call", "ms", summary(lat),
                   floor={"label": "the same calls unloaded", **summary(x * 1e3 for x, _ in unloaded)},
                   note=(f"p99 {np.percentile(lat, 99):.0f} ms, max {max(lat):.0f} ms over {len(lat)} calls "
                         f"({failed} not ok); server RSS {rss_before:.0f} -> {rss_after:.0f} MB; the 10 streaming "
                         f"calls took {setup_s:.1f} s; the 10 streaming clients got {count / seconds:.2f} "
                         f"updates/s ({size / seconds / 1e6:.0f} MB/s) in all"))]



#: g's streaming clients: ``python -c _STREAMER PORT HANDLE``: 10 raw ids stream the sensor's
#: image and depth buffer; prints the seconds that took, then (at EOF on stdin) the number of
#: stream updates received and their bytes.
_STREAMER = """
import os, sys, threading, time
import zenoh
from simx_client import protocol as P
from simx_client.connection import client_config
port, rgb = int(sys.argv[1]), int(sys.argv[2])
session = zenoh.open(client_config("127.0.0.1", port))
received, lock = [0, 0], threading.Lock()
def count(sample):
    with lock:
        received[0] += 1
        received[1] += len(sample.payload)
streams = [["GetVisionSensorImage", P.MODE_STREAMING, [rgb, 0]], ["GetVisionSensorDepthBuffer", P.MODE_STREAMING, [rgb]]]
subscribers, started = [], time.monotonic()
for i in range(10):  # each streaming call's first answer carries a frame
    client = f"bigstream{i}{os.getpid()}"
    subscribers.append(session.declare_subscriber(P.stream_key(P.DEFAULT_PREFIX, client), count))
    list(session.get(P.call_key(P.DEFAULT_PREFIX, client), timeout=30, payload=P.request(client, streams)))
print(time.monotonic() - started, flush=True)
with lock:
    received[:] = [0, 0]
sys.stdin.read()
with lock:
    print(*received, flush=True)
session.close()
"""


_RECONNECT = """
import sys, time
import vrep
port, until = int(sys.argv[1]), float(sys.argv[2])
B, S, O = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming, vrep.simx_opmode_oneshot
n = 0
while time.time() < until:
    cid = vrep.simxStart('127.0.0.1', port, True, True, 5000, 5)
    if cid < 0:
        continue
    j = vrep.simxGetObjectHandle(cid, 'UR5_joint1', B)[1]
    cam = vrep.simxGetObjectHandle(cid, 'kinect_rgb', B)[1]
    vrep.simxGetJointPosition(cid, j, S)
    vrep.simxGetVisionSensorImage(cid, cam, 0, B)
    for i in range(25):
        vrep.simxSetJointTargetPosition(cid, j, 0.01 * (i % 5), O)
        vrep.simxSetStringSignal(cid, 'soak%d' % (i % 3), b'x' * 1000, O)
        vrep.simxGetPingTime(cid)
    vrep.simxClearStringSignal(cid, 'soak0', O)
    vrep.simxFinish(cid)
    n += 1
print(n)
"""


def reconnect_soak(s: Settings) -> list[Figure]:
    """h. 4 processes connect, make ~30 mixed calls (streams, an image, signals, oneshot
    targets) and disconnect, over and over for 180 s (30 s quick): server RSS every 5 s."""
    seconds, count, every = s.t(180.0, 30.0, smoke=2.0), s.pick(4, 4, smoke=2), s.t(5.0, 5.0, smoke=0.5)
    with Server(s.log_dir, name="robustness-reconnect") as srv:
        until = time.time() + seconds
        workers = [subprocess.Popen([sys.executable, "-c", _RECONNECT, str(srv.port), repr(until)],
                                    stdout=subprocess.PIPE, text=True, env=child_env()) for _ in range(count)]
        t0, samples = time.monotonic(), []
        while any(w.poll() is None for w in workers):
            samples.append((time.monotonic() - t0, proc_status(srv.pid)["rss_mb"]))
            time.sleep(every)
        connections = sum(int(w.stdout.read().strip() or 0) for w in workers)
    t, rss = zip(*samples)
    slope = float(np.polyfit(t, rss, 1)[0]) * 60 if len(t) > 2 else float("nan")
    return [Figure("robustness.reconnect.rss", f"h. {seconds:.0f} s of {count} reconnecting clients: server RSS",
                   "MB", summary(rss), floor={"label": "RSS at the start", **summary([rss[0]])},
                   note=f"{connections} connections; slope {slope:+.1f} MB/min; last {rss[-1]:.0f} MB",
                   extra={"connections": connections, "slope_mb_per_min": slope})]
