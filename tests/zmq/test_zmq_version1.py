"""CoppeliaSim 4.3/4.4's ZMQ client (protocol version 1: ``{func, args}`` requests, ``{success, ret,
error}`` replies, ``setStepping``/``step`` with the client's uuid and a step counter on the next
port) served beside protocol version 2 on the same port (issue 43), driven by the minimal client of
``zmq43_client.py``; plus the codec's side in-process."""

from __future__ import annotations

import socket
import struct
import threading
from pathlib import Path

import cbor2
import pytest

from conftest import ServerProcess, free_port
from simx_server.zmq import codec
from zmq43_client import Client43

SCENES = Path(__file__).resolve().parents[1] / "scenes" / "zmq"
DT = 0.05  # the server's step (V-REP's default)


def free_pair() -> int:
    """A port whose next port is free too (the step counter's)."""
    for _ in range(50):
        port = free_port()
        with socket.socket() as s:
            try:
                s.bind(("127.0.0.1", port + 1))
            except OSError:
                continue
        return port
    pytest.fail("no two free ports in a row")


@pytest.fixture(scope="module")
def zmq_server():
    port = free_pair()
    srv = ServerProcess(str(SCENES / "scripted.xml"), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    srv.zmq_port = port
    yield srv
    log = srv.stop()
    assert "Traceback" not in log, log[-3000:]


@pytest.fixture
def client(zmq_server):
    c = Client43(zmq_server.zmq_port)
    yield c
    try:
        c.call("sim.stopSimulation", [])
    finally:
        c.close()


def test_get_object_and_get_object_handle(client):
    sim = client.getObject("sim")
    joint = sim.getObject("/ArmJoint")
    assert isinstance(joint, int) and joint >= 0
    assert sim.getObjectHandle("./ArmJoint") == joint  # every form sim.getObject takes
    assert sim.getObjectHandle("ArmJoint") == joint
    assert sim.getObjectAlias(joint) == "ArmJoint"
    assert sim.getObjectPosition(joint, -1) == pytest.approx([0, 0.5, 0.1])
    assert sim.setObjectPosition(joint, -1, [0, 0.5, 0.1]) is None  # no return values: None


def test_stepping_with_set_stepping_and_step(client):
    """Stepped, the simulation advances one step per client.step(), which returns after it and
    after the step counter was published; setStepping returns nothing, as CoppeliaSim 4.4's."""
    sim = client.getObject("sim")
    assert client.setStepping(True) is None
    assert sim.startSimulation() == 1
    t0 = sim.getSimulationTime()
    for n in range(1, 4):
        client.step()
        assert sim.getSimulationTime() == pytest.approx(t0 + n * DT)
    assert len(client.counts) == 3
    counts = [struct.unpack("<I", c)[0] for c in client.counts]  # sim.packUInt32Table{count}
    assert counts == sorted(counts) and counts[-1] - counts[0] == 2
    client.setStepping(False)
    sim.stopSimulation()
    client.stepping = True  # step() while stopped returns at once, as the counter is published then
    client.step()
    assert sim.getSimulationState() == sim.simulation_stopped


def test_call_script_function(client):
    sim = client.getObject("sim")
    sim.startSimulation()  # child scripts run while the simulation runs
    values = [1, 2.5, "three", [4, 5], {"six": 6}]
    assert sim.callScriptFunction("echo@/LuaBox", sim.scripttype_childscript, *values) == tuple(values)
    assert sim.callScriptFunction("echo@/PyBox", sim.scripttype_childscript, "py") == "py"


@pytest.mark.parametrize("func,args,expected", [
    ("sim.getObject", ["/NoSuchObject"], "sim.getObject: object '/NoSuchObject' does not exist"),
    ("sim.noSuchFunction", [], "sim.noSuchFunction: no such function"),
    ("sim.getJointPosition", [], "missing a required argument"),
    ("sim.callScriptFunction", ["fail@/LuaBox", 1], "failing on purpose"),
    ("sim.wait", [1.0], "needs protocol version 2"),
    ("_*executed*_", [], "protocol version 2"),
])
def test_errors_reach_the_client_as_text(client, func, args, expected):
    client.call("sim.startSimulation", [])
    with pytest.raises(Exception, match="^.*" + expected.replace("(", r"\(").replace("*", r"\*")) as err:
        client.call(func, args)
    assert str(err.value) != "None"


@pytest.mark.parametrize("message,expected", [
    (b"not CBOR at all", "a request is a CBOR map"),
    ({"eval": "os.exit()"}, "eval requests are refused"),
    ({"func": "sim.getObject", "args": "/ArmJoint"}, "args must be an array"),
    ({"func": "sim.step", "args": [], "ver": 2}, "needs a uuid"),
])
def test_refusals_reach_the_client_as_text(client, message, expected):
    """What the server refuses before serving it comes back in version 1's shape; a message it
    cannot read at all comes back with both versions' keys (each client reads its own)."""
    reply = client.raw(message)
    assert reply["success"] is False and expected in reply["error"], reply
    if message == b"not CBOR at all":
        assert reply["err"] == reply["error"]


def test_both_versions_on_one_port(client, zmq_server, official):
    """A 4.3/4.4 client and the official 2.x client on the same port, each answered in its shape."""
    sim2 = official(zmq_server.zmq_port).require("sim")
    sim1 = client.getObject("sim")
    assert sim1.getObject("/Arm") == sim2.getObject("/Arm")
    with pytest.raises(Exception, match="does not exist"):
        sim2.getObject("/Nothing")
    with pytest.raises(Exception, match="does not exist"):
        sim1.getObject("/Nothing")


def test_stepped_clients_of_both_versions_share_one_barrier(client, zmq_server, official):
    """A stepped 2.x client's sim.step() and a stepped 4.3/4.4 client's client.step() make one
    simulation step together: each returns after it, and time advanced by one step, not two."""
    sim2 = official(zmq_server.zmq_port).require("sim")
    sim1 = client.getObject("sim")
    sim2.setStepping(True)
    client.setStepping(True)
    try:
        sim1.startSimulation()
        t0 = sim1.getSimulationTime()
        stepper = threading.Thread(target=sim2.step)
        stepper.start()
        client.step()
        stepper.join(20)
        assert not stepper.is_alive()
        assert sim1.getSimulationTime() == pytest.approx(t0 + DT)
    finally:
        sim2.setStepping(False)
        client.setStepping(False)


def test_codec_reads_version_1_and_answers_in_its_shape():
    request = codec.read_request(cbor2.dumps({"func": "sim.getObject", "args": ["/A"]}))
    assert (request.func, request.args, request.version) == ("sim.getObject", ["/A"], codec.VERSION_1)
    request = codec.read_request(codec.encode_request("sim.getObject", ["/A"], "u", first=True))
    assert request.version == codec.PROTOCOL_VERSION
    assert cbor2.loads(codec.to_version_1(codec.encode_reply([1, b"\0" * 70000]))) == {
        "success": True, "ret": [1, b"\0" * 70000]}
    assert cbor2.loads(codec.to_version_1(codec.encode_error("sim.x: no"))) == {"success": False, "error": "sim.x: no"}
    assert cbor2.loads(codec.to_version_1(codec.encode_reply([]))) == {"success": True, "ret": []}
    assert "no form in protocol version 1" in cbor2.loads(codec.to_version_1(codec.encode_wait()))["error"]
    with pytest.raises(codec.RequestError) as refused:
        codec.read_request(cbor2.dumps({"eval": "print(1)"}))
    assert refused.value.version == codec.VERSION_1


def test_no_version_2_request_names_a_version_1_clients_uuid():
    """A version-1 client's uuid is its connection's routing id (``zmq43-`` and libzmq's counter,
    one per connection): a version-2 request naming one would have acted as that client."""
    with pytest.raises(codec.RequestError, match="zmq43-"):
        codec.read_request(codec.encode_request("sim.getObject", ["/A"], "zmq43-0080000001", first=True))
    assert codec.read_request(codec.encode_request("sim.getObject", ["/A"], "zmq-43", first=True)).uuid == "zmq-43"


def test_a_taken_counter_port_is_told():
    """With the port after the ZMQ port in use, the server logs it and serves on; a 4.3/4.4 client's
    setStepping(True) then answers an error that names the step counter, instead of a step() that
    would wait for ever."""
    port = free_pair()
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", port + 1))
        taken.listen()
        srv = ServerProcess(str(SCENES / "scripted.xml"), "--stopped", "--zmq-port", str(port),
                            renderers="on-demand")
        client = Client43(port)
        try:
            sim = client.getObject("sim")
            assert sim.getObject("/ArmJoint") >= 0
            with pytest.raises(Exception, match="step counter"):
                client.setStepping(True)
        finally:
            client.close()
            log = srv.stop()
    assert "step counter of CoppeliaSim 4.3-4.5's clients not served" in log, log[-2000:]
