"""Issue 23 parts 2 and 3: budgets for the work and memory one request can cause.

* Only reads and settings stream: scene loads, edits and file transfers answer a remote error
  in a streaming mode (a streamed LoadScene re-ran after every step and held every client).
* An append to a string signal is checked against its bound before ``old + value`` is built.
* A request's decoded size is bounded: at most ``protocol.MAX_REQUEST_ITEMS`` values
  (60 MiB of empty arrays took a server to 4.7 GB); tests/transport/test_memory_budgets.py has the rest.
"""

from __future__ import annotations

import uuid

import msgpack
import pytest
import zenoh

import vrep
from conftest import SCENE, ServerProcess, free_port
from simx_client import protocol as P
from simx_client.connection import client_config
from simx_server.base import limits as L
from simx_server.commands import HANDLERS, NOT_STREAMABLE
from simx_server.commands.editing import EDITING_HANDLERS

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

B, STREAMING = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming


@pytest.fixture(scope="module")
def server():
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port()], renderers="on-demand")
    yield srv
    srv.stop()


@pytest.fixture
def cid(server):
    c = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
    assert c >= 0
    yield c
    vrep.simxFinish(c)


def raw_call(session: zenoh.Session, client: str, payload: bytes, timeout: float = 30.0):
    for reply in session.get(P.call_key("simx", client), payload=payload, timeout=timeout):
        if reply.ok is not None:
            return msgpack.unpackb(reply.ok.payload.to_bytes(), raw=False)
    return None


def test_scene_loads_edits_and_transfers_do_not_stream(cid):
    assert NOT_STREAMABLE == set(EDITING_HANDLERS) and NOT_STREAMABLE <= set(HANDLERS)
    rc = vrep.simxLoadScene(cid, "ur5_rg2_kinect.xml", 0, STREAMING)  # answered at its next read
    vrep.simxGetPingTime(cid)
    rc, errors = vrep.simxGetLastErrors(cid, B)
    assert rc == 0 and any("simxLoadScene cannot be streamed" in e for e in errors), errors
    dummies = vrep.simxGetObjects(cid, vrep.sim_object_dummy_type, B)[1]
    vrep.simxCreateDummy(cid, 0.05, None, STREAMING)
    vrep.simxGetPingTime(cid)
    rc, errors = vrep.simxGetLastErrors(cid, B)
    assert any("simxCreateDummy cannot be streamed" in e for e in errors), errors
    assert vrep.simxGetObjects(cid, vrep.sim_object_dummy_type, B)[1] == dummies  # none was made
    assert vrep.simxGetObjectHandle(cid, "UR5", B)[0] == 0  # reads still stream and work


def test_an_append_beyond_the_signal_bound_is_refused_before_it_is_built(cid, monkeypatch):
    from simx_server.commands.signals import append_string_signal
    from simx_server.api.signals import Signals

    class Sim:  # the handler reads the store only
        signals = Signals(max_bytes=10)

    Sim.signals.set("string", "s", b"x" * 8)
    built = []
    monkeypatch.setattr(Sim.signals, "set", lambda *a, **k: built.append(a))
    with pytest.raises(P.ArgumentError, match="MAX_SIGNAL_BYTES"):
        append_string_signal(Sim, ["s", b"abc"])
    assert built == []  # refused before old + value was made or stored
    append_string_signal(Sim, ["s", b"ab"])
    assert built == [("string", "s", b"x" * 8 + b"ab")]
    # and on a real server, the bound holds for appends too
    big = b"y" * L.MAX_SIGNAL_BYTES
    assert vrep.simxSetStringSignal(cid, "full", big, B) == 0
    assert vrep.simxAppendStringSignal(cid, "full", b"z", B) == vrep.simx_return_remote_error_flag
    assert vrep.simxGetStringSignal(cid, "full", B)[1] == big
    vrep.simxClearStringSignal(cid, "full", B)


def test_a_request_of_millions_of_empty_arrays_is_refused_and_harms_nobody(server, cid):
    n = P.MAX_REQUEST_ITEMS + 10
    payload = msgpack.packb([P.PROTOCOL_VERSION, "bomber", [["GetPingTime", B, [[]] * n]]])
    with pytest.raises(P.ProtocolError, match="MAX_REQUEST_ITEMS"):
        P.parse_request(payload, L.MAX_COMMANDS_PER_REQUEST)
    session = zenoh.open(client_config("127.0.0.1", server.port))
    try:
        reply = raw_call(session, "bomber", payload)
        assert isinstance(reply, dict) and "MAX_REQUEST_ITEMS" in reply["err"], reply
        client = uuid.uuid4().hex  # one under the bound is read as usual
        ok = raw_call(session, client, P.request(client, [["GetPingTime", B, []]]))
        assert ok[5] == [[True, None]]
    finally:
        session.close()
    assert vrep.simxGetObjectHandle(cid, "UR5", B)[0] == 0 and server.proc.poll() is None


def test_one_user_cannot_take_every_client_slot(server):
    """Part 4: one session declaring tokens and sending a request under many ids of one user
    fills that user's share (limits.MAX_CLIENTS_PER_USER), not the server's."""
    session = zenoh.open(client_config("127.0.0.1", server.port))
    tokens = []
    try:
        ids = [f"mallory-{uuid.uuid4().hex}" for _ in range(L.MAX_CLIENTS_PER_USER + 6)]
        answers = []
        for client in ids:
            tokens.append(session.liveliness().declare_token(P.client_token_key("simx", client)))
            answers.append(raw_call(session, client, P.request(client, [["GetPingTime", B, []]]))[5][0])
        assert answers[:L.MAX_CLIENTS_PER_USER] == [[True, None]] * L.MAX_CLIENTS_PER_USER
        # Beyond her share a new id is refused, or takes the place of one of her own idle ids
        # whose token does not protect it (this session answers no peer check: MAX_CLIENTS_PER_PEER).
        for ok, why in answers[L.MAX_CLIENTS_PER_USER:]:
            assert ok or ("user mallory has" in why and "MAX_CLIENTS_PER_USER" in why), why
        for newcomer in (uuid.uuid4().hex, f"alice-{uuid.uuid4().hex}"):  # room for the others
            assert raw_call(session, newcomer, P.request(newcomer, [["GetPingTime", B, []]]))[5] == [[True, None]]
    finally:
        for token in tokens:
            token.undeclare()
        session.close()


def test_the_per_user_count_follows_departures():
    import queue

    from simx_server.legacy.sessions import Sessions

    sessions = Sessions(queue.SimpleQueue(), max_clients=10, max_per_user=2)
    assert sessions.admit("bob-1", "r", 1) is None and sessions.admit("bob-2", "r", 1) is None
    sessions.tokens.update({"bob-1", "bob-2"})
    assert "MAX_CLIENTS_PER_USER" in sessions.admit("bob-3", "r", 1)
    for client in ("bob-1", "bob-2"):  # their requests served, their tokens gone: they may leave
        s = sessions.get(client)
        sessions.take(s)
        sessions.tokens.discard(client)
    sessions.remove("bob-1")
    assert sessions.admit("bob-3", "r", 1) is None  # room again
    assert "MAX_CLIENTS_PER_USER" not in (sessions.admit("bob-4", "r", 1) or "")  # bob-2 (idle) evicted
    assert sessions.get("bob-2") is None and "bob-2" in sessions.evicted


#: A scene whose load takes SLOW_LOAD_SECONDS of the simulation thread's CPU by construction: its
#: customization script (run as the scene loads) spins until os.clock() (CPU time) has advanced
#: that much. The bundled scene loaded 20 times inside MAX_REQUEST_SECONDS on a fast machine.
SLOW_LOAD_SECONDS = 0.5
SLOW_SCENE = """<mujoco model="slow">
  <worldbody><body name="Slow" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body></worldbody>
  <custom><text name="simx:Slow" data="customization_script=slow.lua"/></custom>
</mujoco>
"""
SLOW_SCRIPT = f"""
local start = os.clock()
while os.clock() - start < {SLOW_LOAD_SECONDS} do end
"""


def test_a_request_of_many_scene_loads_is_cut_at_its_time_budget_and_the_client_at_its_share(tmp_path):
    """100 LoadScene in one request held every client 71.5 s: the request stops executing after
    limits.MAX_REQUEST_SECONDS, and the client's loads and edits past limits.EDIT_SHARE of the
    simulation thread answer busy, while another client is served in between. Each load takes
    SLOW_LOAD_SECONDS of CPU by construction, whatever the machine's speed: one load reaches the
    request's budget, and a few more the client's share; the outcome is stated as counts and
    order."""
    assert SLOW_LOAD_SECONDS >= L.MAX_REQUEST_SECONDS  # the request is cut after its first load
    (tmp_path / "slow.xml").write_text(SLOW_SCENE)
    (tmp_path / "slow.lua").write_text(SLOW_SCRIPT)
    srv = ServerProcess(str(SCENE), "--stopped", "--pacing", "immediate", "--scene-path", str(tmp_path),
                        ports=[free_port()], renderers="on-demand")
    session = zenoh.open(client_config("127.0.0.1", srv.port))
    try:
        loader = uuid.uuid4().hex
        loads = [["LoadScene", B, [str(tmp_path / "slow.xml"), 0]]] * 20
        results = raw_call(session, loader, P.request(loader, loads), timeout=60)[5]
        done = [ok for ok, _ in results if ok]
        cut = [why for ok, why in results if not ok]
        assert len(done) == 1 and len(cut) == 19, results
        assert all("MAX_REQUEST_SECONDS" in why for why in cut), cut
        # loads one after the other take more than the client's share: refused after about
        # EDIT_DEBT_SECONDS / (1 - EDIT_SHARE) / SLOW_LOAD_SECONDS (14) of them, at once
        answers: list = []
        while len(answers) < 40 and (not answers or answers[-1][0]):
            answers.append(raw_call(session, loader, P.request(loader, loads[:1]))[5][0])
        answers += [raw_call(session, loader, P.request(loader, loads[:1]))[5][0] for _ in range(3)]
        oks = [ok for ok, _ in answers]
        assert False in oks and oks == [True] * oks.index(False) + [False] * (len(oks) - oks.index(False)), answers
        assert all("EDIT_SHARE" in why for ok, why in answers if not ok), answers  # still refused: the debt
        # falls slower than loads add to it
        # ...and another client is served as usual
        other = uuid.uuid4().hex
        assert raw_call(session, other, P.request(other, [["GetObjectHandle", B, ["Slow"]]]))[5][0][0] is True
    finally:
        session.close()
        srv.stop()


def test_the_time_budget_counts_the_threads_work_not_a_loaded_machines_wait(monkeypatch):
    """MAX_REQUEST_SECONDS is simulation-thread time: on a loaded 2-core CI machine a Ray env
    runner's batch of five streaming reads was cut after 0.5 s of *wall* time (the thread was
    descheduled, not busy) and the runner died. Waiting counts only past the wall bound
    (MAX_REQUEST_WALL_SECONDS); work counts at once."""
    import time

    import zenoh as _zenoh

    from simx_server.scene.simulation import Simulation
    from simx_server.legacy.server import LegacyDoor
    from simx_server.loop.core import Loop

    sim = Simulation(SCENE, dt=0.05, realtime=False)
    try:
        server = LegacyDoor(Loop(sim), _zenoh.Config())

        def waits(client, name, mode, args):  # descheduled: wall time, no CPU
            time.sleep(0.3)
            return [True, name]

        def works(client, name, mode, args):  # busy: CPU time
            end = time.thread_time() + 0.3
            while time.thread_time() < end:
                pass
            return [True, name]

        commands = [["GetPingTime", B, []]] * 3
        monkeypatch.setattr(server, "_execute", waits)
        monkeypatch.setattr(L, "MAX_REQUEST_WALL_SECONDS", 60.0)  # 0.9 s (or more, loaded) of waiting: not work
        assert [ok for ok, _ in server._run("c", commands)] == [True, True, True]
        monkeypatch.setattr(L, "MAX_REQUEST_WALL_SECONDS", 0.5)
        results = server._run("c", commands)  # past the wall bound by the third (0.6 s waited)
        assert results[0][0] and not results[2][0] and "MAX_REQUEST_WALL_SECONDS" in results[2][1]
        monkeypatch.setattr(server, "_execute", works)
        monkeypatch.setattr(L, "MAX_REQUEST_WALL_SECONDS", 60.0)  # the work alone (a loaded machine)
        results = server._run("c", commands)
        assert [ok for ok, _ in results] == [True, True, False]  # 0.6 s of work > 0.5 s
        assert "MAX_REQUEST_SECONDS" in results[2][1]
    finally:
        server.courier.close()
        sim.close()
