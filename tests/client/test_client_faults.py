"""Issue 11: a client that dies does not cost the server or the other clients anything.

A legacy client in a process of its own streams both Kinect images and six joint positions
and is killed with SIGKILL (no simxFinish, no Bye, no clean Zenoh close). The server must
notice (its liveliness token goes), say so in its log, and stop evaluating and publishing that
client's streams from then on, observed from outside on ``simx/stream/*`` with a raw
Zenoh session (loopback, multicast scouting off); meanwhile another legacy client makes
blocking calls and keeps receiving its own stream.
"""

from __future__ import annotations

import os
import select
import subprocess
import sys
import tempfile
import textwrap
import threading
import time

import zenoh

import vrep
from conftest import ROOT, SCENE, ServerProcess, wait_until
from simx_client import api
from simx_client import protocol as P
from simx_client.connection import client_config

B = vrep.simx_opmode_blocking

VICTIM = textwrap.dedent("""
    import sys, time
    import vrep
    from simx_client import api

    B, S, BUF = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming, vrep.simx_opmode_buffer
    cid = vrep.simxStart("127.0.0.1", int(sys.argv[1]), True, True, 5000, 5)
    if cid < 0:
        sys.exit("connect failed")
    rgb = vrep.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
    depth = vrep.simxGetObjectHandle(cid, "kinect_depth", B)[1]
    joints = [vrep.simxGetObjectHandle(cid, f"UR5_joint{i}", B)[1] for i in range(1, 7)]
    vrep.simxGetVisionSensorImage(cid, rgb, 0, S)
    vrep.simxGetVisionSensorDepthBuffer(cid, depth, S)
    for h in joints:
        vrep.simxGetJointPosition(cid, h, S)
    deadline = time.monotonic() + 30
    while vrep.simxGetVisionSensorImage(cid, rgb, 0, BUF)[0] != 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    print("streaming", api._connections[cid].client, flush=True)
    deadline = time.monotonic() + 60  # bounded: the test kills it long before
    while time.monotonic() < deadline:
        vrep.simxGetVisionSensorImage(cid, rgb, 0, BUF)
        vrep.simxGetVisionSensorDepthBuffer(cid, depth, BUF)
        for h in joints:
            vrep.simxGetJointPosition(cid, h, BUF)
        time.sleep(0.01)
""")


def _log_text(srv: ServerProcess) -> str:
    """The server's log so far, read through a file description of its own (seeking the
    shared one would move the server's write position)."""
    with open(f"/proc/self/fd/{srv.log.fileno()}", errors="replace") as f:
        return f.read()


def _start_victim(port: int) -> tuple[subprocess.Popen, str]:
    """The streaming legacy client process and its client id, once its first image arrived."""
    err = tempfile.TemporaryFile(mode="w+")
    env = dict(os.environ, PYTHONUNBUFFERED="1", MUJOCO_GL="egl",
               PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p))
    proc = subprocess.Popen([sys.executable, "-c", VICTIM, str(port)], stdout=subprocess.PIPE, stderr=err,
                            env=env, cwd=ROOT, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if select.select([proc.stdout], [], [], 0.2)[0]:
            line = proc.stdout.readline()
            if line.startswith("streaming "):
                return proc, line.split()[1]
    proc.kill()
    proc.wait()
    err.seek(0)
    raise RuntimeError(f"the streaming client did not start:\n{err.read()[-2000:]}")


def test_killed_streaming_client_is_freed_while_another_keeps_working():
    srv = ServerProcess(str(SCENE))
    session = zenoh.open(client_config("127.0.0.1", srv.port))
    last: dict[str, float] = {}
    counts: dict[str, int] = {}

    def on_update(sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        last[key] = time.monotonic()
        counts[key] = counts.get(key, 0) + 1

    session.declare_subscriber(P.stream_key("simx", "*"), zenoh.handlers.Callback(on_update, indirect=False))
    other = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    victim = None
    stop = threading.Event()
    calls: list[tuple[int, float]] = []
    try:
        assert other >= 0
        rc, joint = vrep.simxGetObjectHandle(other, "UR5_joint1", B)
        assert rc == 0
        rc, called = vrep.simxGetObjectHandle(other, "UR5_joint2", B)  # not the streamed one: a blocking
        assert rc == 0  # call of the streamed command would end its stream, as in V-REP
        vrep.simxGetJointPosition(other, joint, vrep.simx_opmode_streaming)
        other_key = P.stream_key("simx", api._connections[other].client)
        victim, victim_id = _start_victim(srv.port)
        victim_key = P.stream_key("simx", victim_id)
        wait_until(lambda: counts.get(victim_key, 0) >= 5, timeout=20, what="updates of the streaming client")

        def keep_calling() -> None:  # the other client, throughout
            while not stop.is_set():
                t0 = time.perf_counter()
                rc, _ = vrep.simxGetJointPosition(other, called, B)
                calls.append((rc, time.perf_counter() - t0))
                time.sleep(0.01)

        caller = threading.Thread(target=keep_calling, daemon=True)
        caller.start()
        wait_until(lambda: len(calls) >= 5, what="the other client's first calls")
        killed = time.monotonic()
        victim.kill()  # SIGKILL, by its own PID
        victim.wait(timeout=10)
        # In order, not in seconds: the server notices (the killed client's liveliness token
        # goes with its link) and says so; from then on, while the other client's stream goes
        # on step after step, the killed client's gets nothing more. (Both streams come from the
        # server's one session in the order published.)
        wait_until(lambda: f"client {victim_id} left" in _log_text(srv), timeout=30,
                   what="the server's log line saying the killed client left")
        seen = counts[other_key]
        wait_until(lambda: counts[other_key] >= seen + 5, what="the other client's stream after the kill")
        seen, dead = counts[other_key], counts[victim_key]
        wait_until(lambda: counts[other_key] >= seen + 5, what="the other client's stream, 5 steps on")
        assert counts[victim_key] == dead, "the killed client's stream went on after the server said it left"
        freed = last[victim_key] - killed  # only printed: the wall clock is the machine's
        stop.set()
        caller.join(timeout=10)
        failed = [rc for rc, _ in calls if rc != 0]
        assert not failed, f"{len(failed)} of the other client's {len(calls)} blocking calls failed: {failed[:5]}"
        assert vrep.simxGetJointPosition(other, joint, vrep.simx_opmode_buffer)[0] == 0
        assert srv.proc.poll() is None
        print(f"killed client's last update {freed:+.3f} s after SIGKILL; other client: {len(calls)} blocking "
              f"calls, slowest {max(t for _, t in calls) * 1e3:.1f} ms")
    finally:
        stop.set()
        if victim is not None and victim.poll() is None:
            victim.kill()
            victim.wait()
        if other >= 0:
            vrep.simxFinish(other)
        session.close()
        srv.stop()
