"""Large legacy requests (issue 48's 16 clients x 64 MiB): they are read on the intake's thread,
round robin by client, so Zenoh's receiving threads stay free for every client's small requests
(simx_server/legacy/intake.py); a request's proof is checked outside the sessions' lock (the MAC of
32 MiB held every client's service 150 ms); a message past limits.MAX_ZENOH_MESSAGE_BYTES is not
even reassembled (a 900 MiB query took a server from 106 to 1,910 MB), and simx's client refuses
to send a request past protocol.MAX_REQUEST_BYTES.

The order of service and the bounds are checked in process with stand-in queries; the message
bound and the client's refusal against a real server, by the server's peak memory (VmHWM)."""

from __future__ import annotations

import queue
import threading

import pytest
import zenoh

import vrep
from conftest import ServerProcess
from simx_client.connection import client_config
from simx_server.base import limits as L
from simx_server.legacy.intake import Intake
from simx_server.legacy.sessions import Sessions
from simx_server.legacy.zenoh_config import zenoh_config
from simx_wire import proof as PR
from simx_wire import protocol as P

pytestmark = pytest.mark.renderers_on_demand
B = vrep.simx_opmode_blocking


class _Door:
    _call_prefix = 0


def _intake(read_order: list, gate: threading.Event) -> Intake:
    """An intake whose reading thread notes each request it reads, once ``gate`` is set."""
    intake = Intake(_Door(), large=50, per_client=250, total=400)

    def read(query, key, busy=None):
        read_order.append(query)
        gate.wait(10)

    intake.read = read  # the door's read, as the intake's thread calls it
    return intake


def _until(condition, polls: int = 200) -> None:
    for _ in range(polls):
        if condition():
            return
        threading.Event().wait(0.05)
    assert condition()


def test_large_requests_wait_for_one_thread_round_robin_and_small_ones_of_others_do_not():
    order: list = []
    gate = threading.Event()
    intake = _intake(order, gate)
    try:
        assert intake.offer("x", "x1", "x", 50) == ""
        _until(lambda: order == ["x1"])  # the thread reads x1 (and waits at the gate)
        for name in ("a1", "a2", "a3"):  # a's three large requests
            assert intake.offer("a", name, "a", 50) == ""
        assert intake.offer("b", "b1", "b", 50) == ""
        assert intake.offer("a", "a-small", "a", 1) == ""  # after a's large ones: it keeps its place
        assert intake.offer("c", "c-small", "c", 1) is None  # another client's small one: read on Zenoh's thread
        gate.set()
        _until(lambda: len(order) == 6)
        assert order == ["x1", "a1", "b1", "a2", "a3", "a-small"]  # one of each client in turn
        _until(lambda: intake.offer("a", "a4", "a", 1) is None)  # nothing of a's left there: read at once
    finally:
        gate.set()
        intake.close()


def test_the_intake_bounds_a_clients_bytes_and_all_clients_bytes():
    order: list = []
    gate = threading.Event()
    intake = _intake(order, gate)
    try:
        assert intake.offer("a", "a1", "a", 150) == "" and intake.offer("a", "a2", "a", 100) == ""
        busy = intake.offer("a", "a3", "a", 100)  # a's 350 bytes would pass its 250
        assert busy.startswith(P.BUSY) and "MAX_INTAKE_BYTES" in busy
        assert intake.offer("b", "b1", "b", 140) == ""  # 390 of 400 in all
        # c has none waiting: its large request is read on Zenoh's thread, as before the intake
        assert intake.offer("c", "c1", "c", 100) is None
    finally:
        gate.set()
        intake.close()


def test_a_requests_proof_is_checked_outside_the_sessions_lock(monkeypatch):
    sessions = Sessions(queue.SimpleQueue(), prove=True)
    assert sessions.admit("c", "hello", 10, b"h", None, hello=True) is None
    secret = sessions.get("c").secret
    payload = b"x" * 1000
    held = []
    real = PR.check

    def check(*args):
        held.append(sessions._lock.locked())
        return real(*args)

    monkeypatch.setattr(PR, "check", check)
    assert sessions.admit("c", "r", 10, payload, PR.seal(secret, 1, payload)) is None
    assert held == [False]  # the MAC of up to 64 MiB never holds every client's service
    assert "not this client" in sessions.admit("c", "r", 10, payload, PR.seal(secret, 1, payload))  # a replay


def _peak_rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmHWM")) / 1024


def test_a_message_past_the_bound_is_not_reassembled_and_the_server_goes_on():
    assert zenoh_config(["tcp/127.0.0.1:7447"]).get_json("transport/link/rx/max_message_size") == \
        str(L.MAX_ZENOH_MESSAGE_BYTES)
    srv = ServerProcess("--stopped", renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    try:
        assert cid >= 0
        before = _peak_rss_mb(srv.proc.pid)
        with zenoh.open(client_config("127.0.0.1", srv.port)) as raw:
            payload = b"\x93\x04\xa1x\x90" + bytes(120 << 20)  # 120 MiB
            replies = [r for r in raw.get(P.call_key(P.DEFAULT_PREFIX, "x"), payload=payload, timeout=1)
                       if r.ok is not None]
            del payload
            # the same link's next query is answered: the server has had all of the large one
            after = [r for r in raw.get(P.call_key(P.DEFAULT_PREFIX, "y"), payload=b"\xc1", timeout=10)
                     if r.ok is not None]
        assert replies == [] and len(after) == 1  # dropped by the server's Zenoh, never read
        # before: the message was reassembled, then copied, then refused: +240 MB at its peak
        assert _peak_rss_mb(srv.proc.pid) - before < 100
        assert vrep.simxSetIntegerSignal(cid, "alive", 1, B) == 0
        # simx's client does not send what the server would drop: a local error at once
        rc = vrep.simxSetStringSignal(cid, "big", b"z" * (P.MAX_REQUEST_BYTES + 1), B)
        assert rc == vrep.simx_return_local_error_flag
        rc = vrep.simxSetStringSignal(cid, "big", b"z" * (P.MAX_REQUEST_BYTES + 1), vrep.simx_opmode_oneshot)
        assert rc == vrep.simx_return_local_error_flag
        assert vrep.simxGetIntegerSignal(cid, "alive", B) == (0, 1)
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    assert "Traceback" not in log
