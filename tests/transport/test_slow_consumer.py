"""A client that asks for much and then stops reading (SIGSTOP) must not hold up the others
(issue 23, part 2): replies queued for it fill its link, and Zenoh's blocking congestion control
made the simulation thread wait 5 s (its default ``wait_before_close``) before giving up on the
peer. The server bounds that wait (limits.MAX_BLOCKED_REPLY_SECONDS)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from conftest import SCENE, ServerProcess

import vrep
from simx_server.base import limits
from simx_server.legacy.zenoh_config import zenoh_config

STUCK = Path(__file__).resolve().parent / "stuck_consumer.py"
B = vrep.simx_opmode_blocking


def test_the_servers_zenoh_config_bounds_a_blocked_reply():
    config = zenoh_config(["tcp/127.0.0.1:7447"])
    wait = json.loads(config.get_json("transport/link/tx/queue/congestion_control/block/wait_before_close"))
    assert wait == int(limits.MAX_BLOCKED_REPLY_SECONDS * 1e6)  # microseconds


def test_a_stopped_consumer_does_not_make_another_clients_calls_time_out():
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", renderers="on-demand")
    stuck = None
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    try:
        assert cid >= 0
        stuck = subprocess.Popen([sys.executable, str(STUCK), str(srv.port)], stdout=subprocess.PIPE, text=True)
        assert stuck.stdout.readline().strip() == "sent"
        os.kill(stuck.pid, signal.SIGSTOP)  # it reads nothing more: its replies pile up
        # every blocking call of the other client is answered within its 5 s timeout; before,
        # the server blocked on the stopped peer's link for Zenoh's 5 s wait_before_close and a
        # call timed out (rc 3). Now the sending thread waits at most 2 s, once (4 s cover it).
        codes, end = [], time.monotonic() + 4
        while time.monotonic() < end:
            codes.append(vrep.simxGetObjectHandle(cid, "UR5_joint1", B)[0])
        assert codes and set(codes) == {0}, f"{sum(c != 0 for c in codes)} of {len(codes)} calls failed"
        vrep.simxFinish(cid)
        # SIGTERM still ends the server: Zenoh's close waited 11.6 s for the stopped peer's link;
        # now the server goes on after limits.ZENOH_CLOSE_SECONDS (a timer in
        # legacy.server.Server.close), and says so. The server exits by itself (status 0,
        # not the SIGKILL that ServerProcess.stop sends when its wait runs out): either Zenoh
        # dropped the stopped peer's link before (its blocked reply's wait_before_close; the log
        # then says the client disconnected) or the timer ended the close (the log says so).
        log = srv.stop(timeout=30)
        assert srv.proc.returncode == 0, srv.proc.returncode
        assert "(limits.ZENOH_CLOSE_SECONDS)" in log or log.count(" disconnected") >= 1, log[-3000:]
    finally:
        if stuck is not None:
            os.kill(stuck.pid, signal.SIGKILL)
            stuck.wait()
        vrep.simxFinish(cid)
        log = srv.stop()
    assert "Traceback" not in log
