"""The client's outbox (issue 19 part 3): non-blocking commands wait and leave together once per
``commThreadCycleInMs``, the same command waiting twice keeps only the newest, order is kept
otherwise, a blocking call sends what waits first, ``simxPauseCommunication`` still holds them,
and commands the server could not queue are sent again: a tight loop loses nothing."""

from __future__ import annotations

import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port
from simx_client import api
from simx_client import protocol as P

B, ONESHOT = vrep.simx_opmode_blocking, vrep.simx_opmode_oneshot


@pytest.fixture(scope="module")
def port():
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port()])
    yield srv.port
    srv.stop()


@pytest.fixture
def client(port):
    cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
    assert cid >= 0
    yield cid
    vrep.simxFinish(cid)


def requests_sent(cid: int) -> int:
    return api._connections[cid]._out[0]  # the last message id: one per request


def test_a_tight_oneshot_loop_loses_nothing_and_leaves_in_few_requests(client):
    n = 20_000
    vrep.simxClearStringSignal(client, "log", B)
    before = requests_sent(client)
    for _ in range(n):
        vrep.simxAppendStringSignal(client, "log", b"x", ONESHOT)  # never merged: all must arrive
    rc, data = vrep.simxGetStringSignal(client, "log", B)  # blocking: what waits leaves first
    assert rc == 0 and len(data) == n
    assert requests_sent(client) - before < n // 50, "each oneshot went as a request of its own"


def test_the_same_command_waiting_keeps_only_the_newest_and_order_is_kept(port):
    cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 100)  # a long cycle: all wait together
    try:
        before = requests_sent(cid)
        for i in range(1000):
            vrep.simxSetIntegerSignal(cid, "newest", i, ONESHOT)
        vrep.simxSetIntegerSignal(cid, "order", 1, ONESHOT)
        vrep.simxClearIntegerSignal(cid, "order", ONESHOT)
        vrep.simxSetIntegerSignal(cid, "order", 5, ONESHOT)  # replaces the first set, after the clear
        conn = api._connections[cid]
        waiting = [c[0] for c in conn._outbox.values()]
        assert waiting[-3:] == ["SetIntegerSignal", "ClearIntegerSignal", "SetIntegerSignal"], waiting
        assert len(waiting) <= 4  # at most one "newest" waits: the 1,000 sets replaced each other
        assert vrep.simxGetIntegerSignal(cid, "newest", B) == (0, 999)
        assert vrep.simxGetIntegerSignal(cid, "order", B) == (0, 5)
        assert requests_sent(cid) - before <= 4  # a cycle's batch or two, the rest, the blocking call
    finally:
        vrep.simxFinish(cid)


def test_pause_communication_still_holds_the_commands(client):
    vrep.simxPauseCommunication(client, True)
    vrep.simxSetIntegerSignal(client, "paused", 3, ONESHOT)
    assert vrep.simxGetIntegerSignal(client, "paused", B)[0] != 0  # held: not sent with the blocking call
    vrep.simxPauseCommunication(client, False)  # sent now, as one batch
    assert vrep.simxGetIntegerSignal(client, "paused", B) == (0, 3)


def test_busy_answers_put_the_commands_back_unless_a_newer_one_waits(client):
    conn = api._connections[client]
    old = ["SetIntegerSignal", ONESHOT, ["x", 1]]
    other = ["SetIntegerSignal", ONESHOT, ["y", 2]]
    newer = ["SetIntegerSignal", ONESHOT, ["x", 3]]
    appended = ["AppendStringSignal", ONESHOT, ["z", b"a"]]
    vrep.simxPauseCommunication(client, True)  # nothing leaves while the outbox is inspected
    try:
        with conn._lock:
            conn._hold(newer, P.identity(*newer[::2]))
            conn._requeue([old, other, appended])  # the server answered "busy" to these
            assert list(conn._outbox.values()) == [other, appended, newer]
    finally:
        vrep.simxPauseCommunication(client, False)
    assert vrep.simxGetIntegerSignal(client, "x", B) == (0, 3)
    assert vrep.simxGetIntegerSignal(client, "y", B) == (0, 2)
    busy = [[False, f"{P.BUSY}: this client has 64 requests waiting"]] * 2
    from simx_client.connection import _busy
    assert _busy(busy) and not _busy([[False, "no such object"]]) and not _busy([])
