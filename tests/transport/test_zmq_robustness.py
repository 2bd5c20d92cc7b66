"""Bad ZMQ remote API requests, sent with raw pyzmq sockets: each is answered with ``{err}`` naming
what is wrong, the server goes on, and nothing of the simulation changes. Plus the protocol's own
exchanges (``_*wait*_`` / ``_*executed*_``, ``_*end*_``) and the codec's bounds in-process."""

from __future__ import annotations

from pathlib import Path

import cbor2
import pytest
import zmq

from conftest import ServerProcess, free_port
from simx_client.protocol import ProtocolError
from simx_server.zmq import codec

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
SCENES = Path(__file__).resolve().parents[1] / "scenes" / "zmq"
UUID = "robustness-test"


@pytest.fixture(scope="module")
def zmq_server():
    port = free_port()
    srv = ServerProcess(str(SCENES / "scripted.xml"), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    srv.zmq_port = port
    yield srv
    log = srv.stop()
    assert "Traceback" not in log, log[-3000:]


@pytest.fixture
def req(zmq_server):
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.RCVTIMEO, 20000)
    sock.setsockopt(zmq.LINGER, 0)
    sock.connect(f"tcp://127.0.0.1:{zmq_server.zmq_port}")
    yield sock
    sock.close()
    ctx.term()


def raw(sock, payload: bytes) -> dict:
    sock.send(payload)
    return cbor2.loads(sock.recv())


def call(sock, func: str, *args) -> dict:
    return raw(sock, codec.encode_request(func, list(args), UUID))


def state(sock) -> tuple:
    """What a request must not change: run state, time, the joint, the objects."""
    joint = call(sock, "sim.getObject", "/ArmJoint")["ret"][0]
    return (call(sock, "sim.getSimulationState")["ret"], call(sock, "sim.getSimulationTime")["ret"],
            call(sock, "sim.getJointPosition", joint)["ret"], call(sock, "sim.getObjectsInTree", -12)["ret"])


def _nested(depth: int) -> bytes:
    return b"\x81" * depth + b"\x01"


BAD = {
    "not CBOR": (b"this is not CBOR", "not CBOR"),
    "a break code": (b"\xff\xfe", "indefinite lengths"),
    "empty": (b"", "not CBOR"),
    "an array": (cbor2.dumps([1, 2, 3]), "a request is a CBOR map"),
    "another version": (cbor2.dumps({"func": "sim.step", "args": [], "uuid": UUID, "ver": 1}), "protocol version 1"),
    "func not a string": (cbor2.dumps({"func": 7, "args": [], "uuid": UUID}), "func must be"),
    "args not an array": (cbor2.dumps({"func": "sim.getObject", "args": "/Arm", "uuid": UUID}), "args must be an array"),
    "uuid not a string": (cbor2.dumps({"func": "sim.step", "uuid": 5}), "uuid must be"),
    "a CBOR tag": (cbor2.dumps({"func": "sim.getObject", "args": [cbor2.CBORTag(1, 0)], "uuid": UUID}), "tags"),
    "indefinite length": (b"\xbf" + cbor2.dumps("func") + cbor2.dumps("x") + b"\xff", "indefinite"),
    "integer map key": (cbor2.dumps({1: 2}), "map keys must be strings"),
    "trailing bytes": (cbor2.dumps({"func": "sim.step", "uuid": UUID}) + b"\x00", "after the message"),
    "length beyond the message": (b"\x5a\xff\xff\xff\xff", "longer than the message"),
    "nested 100 deep": (b"\xa3" + cbor2.dumps("func") + cbor2.dumps("sim.getObject") + cbor2.dumps("uuid")
                        + cbor2.dumps(UUID) + cbor2.dumps("args") + _nested(100), "nested deeper"),
    "two million items": (codec.encode_request("sim.getObject", [[0] * 2_000_000], UUID), "more than"),
}


@pytest.mark.parametrize("name", list(BAD))
def test_bad_requests_are_answered_with_err_and_change_nothing(req, name):
    before = state(req)
    payload, expected = BAD[name]
    reply = raw(req, payload)
    assert set(reply) == {"err"} and expected in reply["err"], reply
    assert state(req) == before


@pytest.mark.parametrize("func,args,expected", [
    ("sim.noSuchFunction", [], "sim.noSuchFunction: no such function"),
    ("os.execute", ["rm -rf /"], "os.execute: no such function"),
    ("sim.generateTextShape", ["simx"], "not implemented by simx"),
    ("sim.getJointPosition", [], "missing a required argument"),
    ("sim.getJointPosition", [1, 2, 3], "too many positional arguments"),
    ("sim.getJointPosition", ["x" * 100000], "object path of 100000 characters refused"),
    ("sim.setObjectPosition", [1, -1, [float("nan"), 0, 0]], "finite"),
    ("sim.getObject", [{"deep": [[[[1]]]]}], "must be a string"),
    ("sim.loadScene", ["../../../../etc/passwd"], "refused"),
    ("sim.callScriptFunction", ["x@/Nowhere", 1], "does not exist"),
    ("zmqRemoteApi.require", ["simSurfRec"], "not available in simx"),
    ("zmqRemoteApi.info", [["sim"]], "no module"),
    ("_*executed*_", [], "nothing waits for it"),
])
def test_bad_calls_are_answered_with_err_and_change_nothing(req, func, args, expected):
    before = state(req)
    reply = call(req, func, *args)
    assert set(reply) == {"err"} and expected in reply["err"], reply
    assert len(reply["err"]) <= 1000
    assert state(req) == before


def test_huge_arguments(req, zmq_server):
    """A request just over codec.MAX_REQUEST_BYTES (within the message bound) is refused by its
    size; the server reads the next one as usual."""
    before = state(req)
    big = codec.MAX_REQUEST_BYTES + (256 << 10)
    reply = raw(req, codec.encode_request("sim.setStringSignal", ["big", b"\0" * big], UUID))
    assert "bytes refused" in reply["err"]
    reply = call(req, "sim.setStringSignal", "big", b"\0" * (16 << 20) + b"\0")  # under the request bound, over the signal's
    assert "limits.MAX_SIGNAL_BYTES" in reply["err"]
    assert call(req, "sim.getStringSignal", "big") == {"ret": [None]}
    assert state(req) == before


def test_one_request_at_a_time_per_connection(zmq_server):
    """A raw DEALER that sends a second request before the first's reply gets an error for it.
    The first is a scene edit (a rename: the scene is compiled again, milliseconds), served by
    the simulation thread once the door has seen the call edit (``ZmqService.edit_calls``: one
    rename and back first); a quick call would be served and answered by the socket thread
    before it reads the second."""
    ctx = zmq.Context()
    dealer = ctx.socket(zmq.DEALER)
    dealer.setsockopt(zmq.RCVTIMEO, 20000)
    dealer.connect(f"tcp://127.0.0.1:{zmq_server.zmq_port}")
    try:
        dealer.send_multipart([b"", codec.encode_request("sim.getObject", ["/ArmJoint"], UUID)])
        joint = cbor2.loads(dealer.recv_multipart()[-1])["ret"][0]
        for alias in ("ArmJointRenamed", "ArmJoint"):  # the door learns that the call edits
            dealer.send_multipart([b"", codec.encode_request("sim.setObjectAlias", [joint, alias], UUID)])
            assert "ret" in cbor2.loads(dealer.recv_multipart()[-1])
        first = codec.encode_request("sim.setObjectAlias", [joint, "ArmJointRenamed"], UUID)
        for _ in range(2):
            dealer.send_multipart([b"", first])
        replies = [cbor2.loads(dealer.recv_multipart()[-1]) for _ in range(2)]
        dealer.send_multipart([b"", codec.encode_request("sim.setObjectAlias", [joint, "ArmJoint"], UUID)])
        assert "ret" in cbor2.loads(dealer.recv_multipart()[-1])  # the scene as the other tests know it
        assert sorted(list(r) for r in replies) == [["err"], ["ret"]]
        assert any("one request at a time" in r.get("err", "") for r in replies)
    finally:
        dealer.close(0)
        ctx.term()


def test_wait_and_executed_exchange(req):
    """sim.step answers _*wait*_; the client's _*executed*_ gets the step's (empty) return."""
    assert call(req, "sim.setStepping", True) == {"ret": [0]}
    assert call(req, "sim.startSimulation") == {"ret": [1]}
    t0 = call(req, "sim.getSimulationTime")["ret"][0]
    assert call(req, "sim.step") == {"func": "_*wait*_", "args": []}
    assert call(req, "_*executed*_") == {"ret": []}
    assert call(req, "sim.getSimulationTime")["ret"][0] > t0
    waits = 0
    reply = call(req, "sim.wait", 0.2)  # a call that lasts 4 steps: _*wait*_ at each
    while reply == {"func": "_*wait*_", "args": []}:
        waits += 1
        reply = call(req, "_*executed*_")
    assert waits == 4 and reply["ret"][0] == pytest.approx(0.0, abs=1e-6)
    assert call(req, "sim.stopSimulation") == {"ret": []}
    assert call(req, "_*end*_") == {}


def test_codec_bounds_in_process():
    with pytest.raises(ProtocolError, match="nested deeper"):
        codec.scan(_nested(codec.MAX_DEPTH + 1))
    codec.scan(_nested(codec.MAX_DEPTH - 1))
    with pytest.raises(ProtocolError, match="more than 10 CBOR items"):
        codec.scan(cbor2.dumps(list(range(20))), max_items=10)
    with pytest.raises(ProtocolError, match="simple values"):
        codec.scan(b"\xf8\x20")
    r = codec.read_request(codec.encode_request("sim.getObject", ["/A", codec.NIL, None], "u", first=True))
    assert (r.func, r.args, r.uuid, r.lang, r.timeout) == ("sim.getObject", ["/A", None, None], "u", "python", 600.0)


def test_fresh_client_ids_do_not_grow_the_server(monkeypatch):
    """Requests under ever new uuids: past limits.MAX_CLIENTS the longest silent client that holds
    nothing makes room, so the count of clients stays bounded (in-process check of the rule)."""
    from simx_server.base import limits
    from simx_server.zmq.frontend import Incoming
    from simx_server.loop.clients import Clients
    from simx_server.zmq.service import ZmqService

    from types import SimpleNamespace

    from simx_server.scene.client_files import ClientFiles

    class Server:  # what the service needs of the server for these calls: clients, and each client's files
        sim = SimpleNamespace(editor=SimpleNamespace(files=ClientFiles(SCENES / "scripted.xml")))
        clients = Clients()

        def hold_pass(self, client, seconds):  # the loop's service window: no loop here
            pass

    class Frontend:
        def __init__(self):
            self.sent = []

        def send(self, envelope, payload):
            self.sent.append(cbor2.loads(payload))

    monkeypatch.setattr(limits, "MAX_CLIENTS", 5)
    frontend = Frontend()
    service = ZmqService(Server(), frontend)
    for i in range(20):
        service.handle("zmq", Incoming([f"id-{i}".encode()], codec.read_request(codec.encode_request(
            "zmqRemoteApi.require", ["sim"], f"client-{i}")), i, 10))
    assert len(service.clients) == 5 and all(r == {"ret": []} for r in frontend.sent)
    assert "client-19" in service.clients and "client-0" not in service.clients


def test_scene_edits_past_the_share_wait_their_turn(monkeypatch):
    """A client's scene edits beyond limits.EDIT_SHARE of the simulation thread are not refused
    (the official client would fail the program) but wait; in-process, with a real simulation."""
    import time

    from conftest import wait_until
    from simx_server.base import limits
    from simx_server.scene.simulation import Simulation
    from simx_server.loop.clients import Clients
    from simx_server.zmq.frontend import Incoming
    from simx_server.zmq.service import ZmqService

    monkeypatch.setattr(limits, "EDIT_DEBT_SECONDS", 0.0)  # no burst: the second edit waits at once
    monkeypatch.setattr(limits, "EDIT_SHARE", 0.5)
    sim = Simulation(SCENES / "scripted.xml", allow_python_scripts=True)
    try:
        server = type("Server", (), {"sim": sim, "clients": Clients(),
                                     "hold_pass": lambda self, client, seconds: None})()
        sent = []
        frontend = type("Frontend", (), {"send": lambda self, env, payload: sent.append(cbor2.loads(payload))})()
        service = ZmqService(server, frontend)

        def edit():
            service.handle("zmq", Incoming([b"id"], codec.read_request(codec.encode_request(
                "sim.createDummy", [0.01], "editor")), 1, 10))

        edit()
        assert len(sent) == 1 and isinstance(sent[0]["ret"][0], int)
        assert service.connections[b"id"].debt > 0  # the first edit's duration, owed by its connection
        edit()
        assert len(sent) == 1 and len(service._deferred) == 1  # waiting, not refused
        wait_until(lambda: service.housekeeping(time.monotonic()) or len(sent) == 2, timeout=30,
                   what="the waiting edit served")
        assert isinstance(sent[1]["ret"][0], int) and not service._deferred
    finally:
        sim.close()
