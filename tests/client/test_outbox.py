"""The client's outbox (issue 19 part 3), against real servers: non-blocking commands wait in the
outbox and leave together once per communication cycle (``simxStart``'s ``commThreadCycleInMs``),
the same command waiting twice runs only its newest call, different commands keep their order, a
blocking call takes what waits with it, ``simxPauseCommunication`` still holds the outbox, and a
request the server answers "busy" is kept and sent again, so that nothing is lost.

Observables: a string signal appended to (each call must run, in order), the client's message
ids (``simxGetOutMessageInfo``: one per request on the wire) and the server's error list
(``simxGetLastErrors``: one entry per execution of a failing command)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import threading
import time
import uuid
from pathlib import Path

import pytest
import zenoh

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client import api as simx_api
from simx_client import protocol as P
from simx_client.connection import client_config
from simx_client.outbox import MAX_BATCH_COMMANDS, Outbox

B, ONESHOT = vrep.simx_opmode_blocking, vrep.simx_opmode_oneshot
CYCLE_MS = 5
HEAVY = Path(__file__).resolve().parents[1] / "scenes" / "heavy_step.xml"


def message_id(cid: int) -> int:
    rc, value = vrep.simxGetOutMessageInfo(cid, vrep.simx_headeroffset_message_id)
    assert rc == 1
    return value


def requests_sent(cid: int, body) -> tuple[int, float]:
    """(requests put on the wire, seconds) by ``body()`` followed by a blocking ping, the ping's
    own request left out."""
    m0, t0 = message_id(cid), time.monotonic()
    body()
    elapsed = time.monotonic() - t0
    assert vrep.simxGetPingTime(cid)[0] == 0
    return message_id(cid) - m0 - 1, elapsed


def string_signal(cid: int, name: str) -> bytes:
    rc, value = vrep.simxGetStringSignal(cid, name, B)
    assert rc == 0, name
    return value


def handle(cid: int, name: str) -> int:
    rc, h = vrep.simxGetObjectHandle(cid, name, B)
    assert rc == 0, name
    return h


# ------------------------------------------------------------------ a loop cannot flood
def test_20000_oneshot_appends_lose_nothing_and_leave_in_few_requests(vrep_client):
    cid, n = vrep_client, 20_000
    digits = "0123456789"

    def loop() -> None:
        for i in range(n):
            assert vrep.simxAppendStringSignal(cid, "loop", digits[i % 10], ONESHOT) in (0, 1)

    vrep.simxClearStringSignal(cid, "loop", B)
    sent, elapsed = requests_sent(cid, loop)
    assert string_signal(cid, "loop") == (digits * (n // 10)).encode(), "appends lost or out of order"
    # At most one request per communication cycle (+ the one a blocking call flushes), except
    # that an outbox of more than MAX_BATCH_COMMANDS leaves in several: a loop that runs the
    # 20,000 calls within a few cycles still needs n / MAX_BATCH_COMMANDS requests.
    assert sent <= elapsed / (CYCLE_MS / 1000) + 2 + n // MAX_BATCH_COMMANDS, f"{sent} requests in {elapsed:.2f} s"


def test_the_final_target_of_a_20000_oneshot_loop_is_the_last_one_set():
    """A position-controlled joint ends at the last target of 20,000 oneshot calls."""
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port()], renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, CYCLE_MS)
    try:
        assert cid >= 0 and vrep.simxSynchronous(cid, True) == 0
        j = handle(cid, "UR5_joint1")
        for i in range(20_000):
            vrep.simxSetJointTargetPosition(cid, j, (i % 50) * 1e-3 - 0.025, ONESHOT)
        vrep.simxSetJointTargetPosition(cid, j, 0.4, ONESHOT)
        for _ in range(200):  # 10 s of simulation at most; the joint turns at 1 rad/s or faster
            assert vrep.simxSynchronousTrigger(cid) == 0
            rc, q = vrep.simxGetJointPosition(cid, j, B)
            if abs(q - 0.4) < 1e-3:
                break
        assert q == pytest.approx(0.4, abs=1e-3), "the last target was not the one that ran"
    finally:
        vrep.simxFinish(cid)
        srv.stop()


# ------------------------------------------------------------------ collapsing and order
def test_the_same_command_waiting_twice_runs_once(vrep_client):
    """A failing command leaves one server error per execution: 200 calls of one identity in a
    loop run once per request that carried them, not 200 times."""
    cid = vrep_client
    table = handle(cid, "Table")  # not a joint: every execution fails
    vrep.simxGetLastErrors(cid, B)

    def loop() -> None:
        for i in range(200):
            vrep.simxSetJointTargetPosition(cid, table, i * 1e-3, ONESHOT)

    sent, _ = requests_sent(cid, loop)
    rc, errors = vrep.simxGetLastErrors(cid, B)
    assert rc == 0 and 1 <= len(errors) <= sent < 200, (len(errors), sent)
    assert all("SetJointTargetPosition" in e for e in errors)


def test_order_is_kept_across_different_commands(vrep_client):
    cid = vrep_client
    # The newest of two waiting calls takes the place of the newest: "1", "2", "3", "4" gives
    # "34" (run in place of the older one, set "3" would come before append "2": "324").
    vrep.simxPauseCommunication(cid, True)
    for call, value in (("Set", "1"), ("Append", "2"), ("Set", "3"), ("Append", "4")):
        getattr(vrep, f"simx{call}StringSignal")(cid, "order", value, ONESHOT)
    vrep.simxPauseCommunication(cid, False)
    assert string_signal(cid, "order") == b"34"
    # A longer interleaving over many communication cycles, against a model of it.
    expected = b""
    for i in range(3000):
        if i % 7 == 0:
            vrep.simxSetStringSignal(cid, "mixed", f"<{i}>", ONESHOT)
            expected = f"<{i}>".encode()
        else:
            vrep.simxAppendStringSignal(cid, "mixed", str(i % 10), ONESHOT)
            expected += str(i % 10).encode()
        vrep.simxSetIntegerSignal(cid, "count", i, ONESHOT)
    assert string_signal(cid, "mixed") == expected
    assert vrep.simxGetIntegerSignal(cid, "count", B) == (0, 2999)


def test_the_same_command_waiting_keeps_only_the_newest_and_order_is_kept(server):
    """White-box: what waits in the outbox (a 10 s cycle: after one batch left, everything waits)."""
    cid = vrep.simxStart("127.0.0.1", server.ports[1], True, True, 5000, 10_000)
    assert cid >= 0
    try:
        vrep.simxSetIntegerSignal(cid, "newest", -1, ONESHOT)
        assert vrep.simxGetPingTime(cid)[0] == 0  # that batch has left: the next waits a cycle
        for i in range(1000):
            vrep.simxSetIntegerSignal(cid, "newest", i, ONESHOT)
        vrep.simxSetIntegerSignal(cid, "order", 1, ONESHOT)
        vrep.simxClearIntegerSignal(cid, "order", ONESHOT)
        vrep.simxSetIntegerSignal(cid, "order", 5, ONESHOT)  # replaces the first set, after the clear
        waiting = simx_api._connections[cid]._outbox.commands()
        assert [c[0] for c in waiting] == ["SetIntegerSignal", "ClearIntegerSignal", "SetIntegerSignal"], waiting
        assert [c[2] for c in waiting] == [["newest", 999], ["order"], ["order", 5]]
        assert vrep.simxGetIntegerSignal(cid, "newest", B) == (0, 999)
        assert vrep.simxGetIntegerSignal(cid, "order", B) == (0, 5)
    finally:
        vrep.simxFinish(cid)


def test_pause_communication_still_holds_the_commands_from_blocking_calls(vrep_client):
    vrep.simxPauseCommunication(vrep_client, True)
    vrep.simxSetIntegerSignal(vrep_client, "paused", 3, ONESHOT)
    assert vrep.simxGetIntegerSignal(vrep_client, "paused", B)[0] != 0  # held: not sent with the blocking call
    vrep.simxPauseCommunication(vrep_client, False)
    assert vrep.simxGetIntegerSignal(vrep_client, "paused", B) == (0, 3)


def test_pause_communication_holds_the_outbox_and_sends_it_together(vrep_client):
    cid = vrep_client
    table = handle(cid, "Table")
    vrep.simxGetLastErrors(cid, B)
    vrep.simxClearStringSignal(cid, "paused", B)
    m0 = message_id(cid)
    assert vrep.simxPauseCommunication(cid, True) == 0
    for i in range(50):
        vrep.simxAppendStringSignal(cid, "paused", "x", ONESHOT)
        vrep.simxSetJointTargetPosition(cid, table, i * 1e-3, ONESHOT)
    time.sleep(0.05)  # ten communication cycles: the paused outbox must not leave meanwhile
    assert message_id(cid) == m0, "commands left while communication was paused"
    assert vrep.simxPauseCommunication(cid, False) == 0
    requests_sent(cid, lambda: None)
    assert message_id(cid) - m0 <= 2  # the batch (alone or with the ping) and the ping
    assert string_signal(cid, "paused") == b"x" * 50
    rc, errors = vrep.simxGetLastErrors(cid, B)
    assert rc == 0 and len(errors) == 1


# ------------------------------------------------------------------ blocking calls
def test_a_blocking_call_takes_the_outbox_with_it(server):
    """With a 10 s communication cycle, only the blocking call can have sent the oneshot."""
    cid = vrep.simxStart("127.0.0.1", server.ports[1], True, True, 5000, 10_000)
    assert cid >= 0
    try:
        vrep.simxSetIntegerSignal(cid, "flush", 1, ONESHOT)  # the first batch leaves at once
        assert vrep.simxGetIntegerSignal(cid, "flush", B) == (0, 1)
        m0 = message_id(cid)
        vrep.simxSetIntegerSignal(cid, "flush", 42, ONESHOT)  # waits for the next cycle...
        assert message_id(cid) == m0
        assert vrep.simxGetIntegerSignal(cid, "flush", B) == (0, 42)  # ...or a blocking call
    finally:
        vrep.simxFinish(cid)


def test_a_oneshot_before_a_synchronous_trigger_runs_in_that_step():
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port()], renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 10_000)
    try:
        assert cid >= 0 and vrep.simxSynchronous(cid, True) == 0
        j = handle(cid, "UR5_joint1")
        assert vrep.simxSetObjectIntParameter(cid, j, vrep.sim_jointintparam_ctrl_enabled, 0, B) == 0
        q0 = vrep.simxGetJointPosition(cid, j, B)[1]
        for _ in range(3):
            vrep.simxSetJointTargetVelocity(cid, j, 1.0, ONESHOT)
            assert vrep.simxSynchronousTrigger(cid) == 0
        assert vrep.simxGetJointPosition(cid, j, B)[1] - q0 > 0.05  # 3 steps at up to 1 rad/s
    finally:
        vrep.simxFinish(cid)
        srv.stop()


def test_a_synchronous_trigger_takes_the_outbox_in_its_own_request(server):
    """With a 10 s communication cycle: what waits in the outbox travels in the trigger's
    request (one request, as V-REP's client sent it in the blocking call's message), runs
    before the trigger, and its replies land in the inbox as their own request's would."""
    cid = vrep.simxStart("127.0.0.1", server.ports[1], True, True, 5000, 10_000)
    assert cid >= 0
    try:
        assert vrep.simxSynchronous(cid, True) == 0
        vrep.simxSetIntegerSignal(cid, "carried", 1, ONESHOT)  # the first batch leaves at once
        assert vrep.simxGetIntegerSignal(cid, "carried", B) == (0, 1)
        m0 = message_id(cid)
        vrep.simxSetIntegerSignal(cid, "carried", 7, ONESHOT)
        assert vrep.simxGetIntegerSignal(cid, "carried", vrep.simx_opmode_streaming)[0] == 1  # no value yet
        assert message_id(cid) == m0  # both wait for the next cycle...
        assert vrep.simxSynchronousTrigger(cid) == 0  # ...or the trigger, which takes them along
        assert message_id(cid) - m0 == 1, "the outbox left in a request of its own"
        assert vrep.simxGetIntegerSignal(cid, "carried", vrep.simx_opmode_buffer) == (0, 7)
    finally:
        vrep.simxSynchronous(cid, False)
        vrep.simxFinish(cid)


# ------------------------------------------------------------------ busy answers
def test_requests_answered_busy_are_sent_again():
    """The server is held in a long step (heavy_step.xml: seconds per step) while this client's
    queue is filled to its bound (limits.MAX_QUEUED_REQUESTS) under its own id: its oneshots are
    answered "server busy", wait in the outbox and run, all of them and in order, once the
    server has room again."""
    srv = ServerProcess(str(HEAVY), "--stopped", "--dt", "0.05", "--pacing", "immediate", ports=[free_port()],
                        renderers="on-demand")
    raw = zenoh.open(client_config("127.0.0.1", srv.port))
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, CYCLE_MS)
    nowhere = zenoh.handlers.Callback(lambda reply: None, indirect=False)
    try:
        assert cid >= 0
        client = simx_api._connections[cid].client
        other = uuid.uuid4().hex

        conn = simx_api._connections[cid]

        def ask(who: str, commands: list, handler=nowhere) -> None:
            payload = P.request(who, commands)  # under the client's id: with its proof (simx_wire.proof)
            proof = conn._seal(payload, (next(conn._messages), 0.0)) if who == client else None
            # The client's own on its own session: they reach the server in the order of their numbers.
            (conn.session if who == client else raw).get(P.call_key("simx", who), handler, payload=payload,
                                                           timeout=120, attachment=proof)

        def in_step() -> bool:
            ping = P.request(other, [["GetPingTime", B, []]])
            return not any(r.ok is not None for r in raw.get(P.call_key("simx", other), payload=ping, timeout=0.3))

        assert vrep.simxStartSimulation(cid, B) == 0
        wait_until(in_step, timeout=30, what="the server inside a step")
        ask(other, [["StopSimulation", ONESHOT, []]])  # runs first once the step ends: no further step
        answered = threading.Semaphore(0)
        for _ in range(1024):  # limits.MAX_QUEUED_REQUESTS of this client's, all waiting
            ask(client, [["GetPingTime", ONESHOT, []]], zenoh.handlers.Callback(
                lambda reply: None, answered.release, indirect=False))
        for i in range(30):
            vrep.simxAppendStringSignal(cid, "busy", str(i % 10), ONESHOT)
            time.sleep(0.002)  # over several communication cycles
        for _ in range(1024):  # the step is over and the queue drained
            assert answered.acquire(timeout=120)
        assert string_signal(cid, "busy") == "".join(str(i % 10) for i in range(30)).encode()
        log = srv.stop()
        assert f"client {client}: request of" in log and "not queued: server busy" in log, \
            "the test did not make the server answer busy"
    finally:
        vrep.simxFinish(cid)
        raw.close()
        srv.stop()


# ------------------------------------------------------------------ the outbox alone
def _cmd(name: str, *args) -> tuple[tuple, list, bytes]:
    command = [name, ONESHOT, list(args)]
    return P.identity(name, list(args)), command, P.pack(command)



def test_outbox_collapses_keeps_order_and_requeues_refused_batches():
    box = Outbox()
    for item in (_cmd("SetIntegerSignal", "a", 1), _cmd("AppendStringSignal", "s", b"1"),
                 _cmd("SetIntegerSignal", "b", 2), _cmd("AppendStringSignal", "s", b"2"),
                 _cmd("SetIntegerSignal", "a", 3)):
        box.put(*item)
    assert len(box) == 4  # the two appends both stay; "a" only once, at its newest place
    (batch,) = box.take()
    assert [c[2] for c in batch.commands] == [["s", b"1"], ["b", 2], ["s", b"2"], ["a", 3]]
    assert not box
    # Refused: the batch waits again, ahead of what came since, except where a newer call of
    # the same command waits already.
    box.put(*_cmd("SetIntegerSignal", "b", 20))
    box.put(*_cmd("SetIntegerSignal", "c", 30))
    box.refused(batch)
    (again,) = box.take()
    assert [c[2] for c in again.commands] == [["s", b"1"], ["s", b"2"], ["a", 3], ["b", 20], ["c", 30]]


def test_busy_answers_are_recognised():
    busy = [[False, f"{P.BUSY}: this client has 1024 requests waiting"]] * 2
    assert P.busy(busy)
    assert not P.busy([[False, "no such object"]]) and not P.busy([]) and not P.busy(busy + [[True, 1]])


def test_outbox_does_not_requeue_a_command_sent_again_since():
    box = Outbox()
    box.put(*_cmd("SetIntegerSignal", "a", 1))
    (first,) = box.take()
    box.put(*_cmd("SetIntegerSignal", "a", 2))
    (second,) = box.take()  # e.g. taken by a blocking call while the first was in flight
    box.refused(first)
    assert not box, "an older call of a command would run after its newer one"
    box.answered(first)
    box.answered(second)


def test_outbox_splits_batches_at_the_servers_command_bound():
    from simx_server.base import limits

    assert MAX_BATCH_COMMANDS == limits.MAX_COMMANDS_PER_REQUEST
    box = Outbox()
    for i in range(2500):
        box.put(*_cmd("AppendStringSignal", "s", b"x"))
    assert [len(b.commands) for b in box.take()] == [1024, 1024, 452]


def test_a_program_that_ends_without_simxfinish_still_sends_its_outbox(server, tmp_path):
    """The sender thread is a daemon and dies with the program: what waits is sent at exit
    (simx_client.api closes every connection then, as simxFinish(-1); a 10 s cycle keeps the
    second call waiting until then)."""
    program = tmp_path / "no_finish.py"
    program.write_text(textwrap.dedent(f"""
        import vrep
        cid = vrep.simxStart('127.0.0.1', {server.ports[1]}, True, True, 5000, 10000)
        assert cid >= 0
        vrep.simxSetIntegerSignal(cid, 'at_exit', 1, vrep.simx_opmode_oneshot)
        vrep.simxGetPingTime(cid)
        vrep.simxSetIntegerSignal(cid, 'at_exit', 2, vrep.simx_opmode_oneshot)
    """))
    done = subprocess.run([sys.executable, str(program)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, CYCLE_MS)
    try:
        wait_until(lambda: vrep.simxGetIntegerSignal(cid, "at_exit", B) == (0, 2), what="the last call's value")
    finally:
        vrep.simxFinish(cid)
