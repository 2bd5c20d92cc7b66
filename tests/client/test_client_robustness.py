"""The drop-in client survives its server and its caller (issue 11, defects 10 and 11).

Defect 10: when the server goes (killed, or stopped longer than Zenoh's lease), the client
clears its inbox as the legacy client did (extApi.c, ``_communicationThread``: on disconnection
``_messageReceived_dataSize = 0`` and the connection id turns -1), so ``buffer`` reads answer
"no value" instead of stale data; a client started with ``doNotReconnectOnceDisconnected``
stays disconnected, a reconnecting one gets fresh stream data once the server is back.

Defect 11: no argument a legacy program passes makes a ``simx*`` function raise, and none makes
the server answer with an internal error.
"""

from __future__ import annotations

import inspect
import os
import signal

import msgpack
import numpy as np
import pytest

import simx_client
import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client import constants as C
from simx_client import protocol as P
from simx_client.connection import Connection

B = vrep.simx_opmode_blocking
S = vrep.simx_opmode_streaming
BUF = vrep.simx_opmode_buffer
LEASE_MS = 1000  # Zenoh lease of the server under test: it is seen gone 1 s after it froze


def _lease_config(tmp_path, ports: list[int]) -> str:
    """A server Zenoh config with a short lease (the default is 10 s), loopback only. It names
    its endpoints: the server keeps a file's listen endpoints (Zenoh's defaults if it has none)."""
    path = tmp_path / "lease.json5"
    endpoints = ", ".join(f'"tcp/127.0.0.1:{p}"' for p in ports)
    path.write_text(f'{{ listen: {{ endpoints: [{endpoints}] }}, scouting: {{ multicast: {{ enabled: false }} }},'
                    f' transport: {{ link: {{ tx: {{ lease: {LEASE_MS}, keep_alive: 4 }} }} }} }}')
    return str(path)


def _start(port: int, reconnect: bool) -> int:
    # simxStart(address, port, waitUntilConnected, doNotReconnectOnceDisconnected, timeOutInMs,
    # commThreadCycleInMs); a negative time out is the blocking-call time out (here 1 s).
    cid = vrep.simxStart("127.0.0.1", port, True, not reconnect, -1000, 5)
    assert cid >= 0, f"could not connect to the server on port {port}"
    return cid


def _joint(cid: int) -> int:
    rc, j = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)
    assert rc == 0
    return j


def _streamed(cid: int, j: int, value: float) -> None:
    """Wait until the buffered stream of joint j carries ``value`` (set by a blocking call)."""
    assert vrep.simxSetJointPosition(cid, j, value, B) == 0
    wait_until(lambda: (lambda r: r[0] == 0 and abs(r[1] - value) < 1e-4)(
        vrep.simxGetJointPosition(cid, j, BUF)), 10, 0.01, f"the stream showing {value}")


def _outage_reads(cid: int, j: int) -> tuple[int, ...]:
    """What a disconnected client answers: buffer read, oneshot, streaming, blocking, remove."""
    return (vrep.simxGetJointPosition(cid, j, BUF)[0], vrep.simxGetJointPosition(cid, j, vrep.simx_opmode_oneshot)[0],
            vrep.simxGetJointPosition(cid, j, S)[0], vrep.simxGetJointPosition(cid, j, B)[0],
            vrep.simxGetJointPosition(cid, j, vrep.simx_opmode_remove)[0])


NOVALUE, TIMEOUT = C.simx_return_novalue_flag, C.simx_return_timeout_flag | C.simx_return_novalue_flag
OUTAGE = (NOVALUE, NOVALUE, NOVALUE, TIMEOUT, NOVALUE)  # legacy codes of a client with an empty inbox


def _check_outage(stays: int, back: int, j: int, what: str) -> None:
    """Both clients see the server gone: connection id -1, no stale value, legacy codes."""
    for cid in (stays, back):
        wait_until(lambda: vrep.simxGetConnectionId(cid) == -1, 10, 0.02, f"connection id -1 ({what})")
        # The inbox was cleared: the last streamed value is not handed out as fresh.
        assert vrep.simxGetJointPosition(cid, j, BUF)[0] == NOVALUE
        assert vrep.simxGetInMessageInfo(cid, vrep.simx_headeroffset_server_time)[0] == -1
    assert _outage_reads(stays, j) == OUTAGE
    assert vrep.simxGetJointPosition(back, j, BUF)[0] == NOVALUE


def _check_recovery(stays: int, back: int, j: int, first_id: int) -> None:
    """The reconnecting client streams fresh data again; the other one stays disconnected."""
    stale = []

    def reconnected() -> bool:
        rc, _ = vrep.simxGetJointPosition(back, j, BUF)
        if vrep.simxGetConnectionId(back) == -1 and rc == 0:
            stale.append(rc)  # a value while disconnected can only be stale
        return vrep.simxGetConnectionId(back) not in (-1, first_id)

    wait_until(reconnected, 20, 0.02, "the reconnecting client's new connection id")
    assert not stale
    _streamed(back, j, -0.25)  # its stream resumed by itself and carries values set now
    assert vrep.simxGetConnectionId(stays) == -1
    assert _outage_reads(stays, j) == OUTAGE  # a server that is back answers nothing to it
    assert vrep.simxSetJointPosition(stays, j, 0.1, B) == TIMEOUT
    assert vrep.simxGetJointPosition(back, j, B)[0] == 0  # ... so the joint did not move
    assert abs(vrep.simxGetJointPosition(back, j, B)[1] + 0.25) < 1e-4


def _two_streaming_clients(ports: list[int]) -> tuple[int, int, int, int]:
    """A client that must not reconnect (on ports[0]) and one that may (ports[1]), both streaming
    joint 1, the latter's joint set to 0.5: ``(stays, back, joint, back's connection id)``."""
    stays, back = _start(ports[0], reconnect=False), _start(ports[1], reconnect=True)
    j = _joint(back)
    first_id = vrep.simxGetConnectionId(back)
    for cid in (stays, back):
        assert vrep.simxGetJointPosition(cid, j, S)[0] in (0, 1)
    _streamed(back, j, 0.5)
    wait_until(lambda: vrep.simxGetJointPosition(stays, j, BUF)[0] == 0, 10, 0.01, "the other stream")
    return stays, back, j, first_id


def test_killed_and_restarted_server(tmp_path):
    """SIGKILL, then a new server on the same ports: the inbox is cleared at once; the
    reconnecting client streams again (values of the new server), the other stays at -1."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", ports=ports, renderers="on-demand")
    stays = back = -1
    try:
        stays, back, j, first_id = _two_streaming_clients(ports)
        assert vrep.simxPauseCommunication(back, True) == 0
        assert vrep.simxSetJointPosition(back, j, 0.9, vrep.simx_opmode_oneshot) == NOVALUE  # held
        srv.proc.kill()
        srv.proc.wait()
        _check_outage(stays, back, j, "after SIGKILL")
        srv.stop()
        srv = ServerProcess(str(SCENE), "--stopped", ports=ports, renderers="on-demand")
        # The new server starts from the scene: joint 1 at 0, never the old 0.5.
        wait_until(lambda: vrep.simxGetConnectionId(back) not in (-1, first_id), 20, 0.02, "reconnection")
        wait_until(lambda: vrep.simxGetJointPosition(back, j, BUF)[0] == 0, 10, 0.01, "fresh stream data")
        assert abs(vrep.simxGetJointPosition(back, j, BUF)[1]) < 1e-4
        # The command held before the server went was dropped with the outbox, as the legacy
        # client dropped it: had it been sent, this later blocking call would run after it.
        assert vrep.simxPauseCommunication(back, False) == 0
        rc, q = vrep.simxGetJointPosition(back, j, B)
        assert rc == 0 and abs(q) < 1e-4
        assert vrep.simxGetJointPosition(back, j, S)[0] in (0, 1)  # the blocking call ended the stream
        _check_recovery(stays, back, j, first_id)
    finally:
        vrep.simxFinish(stays)
        vrep.simxFinish(back)
        srv.stop()


def test_server_frozen_past_its_lease(tmp_path):
    """SIGSTOP for longer than the Zenoh lease: the clients see the server gone and clear their
    inbox; after SIGCONT the reconnecting client streams again, the other stays at -1."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(SCENE), "--stopped", "--zenoh-config", _lease_config(tmp_path, ports), ports=ports,
                        renderers="on-demand")
    stays = back = -1
    try:
        stays, back, j, first_id = _two_streaming_clients(ports)
        os.kill(srv.proc.pid, signal.SIGSTOP)
        try:
            _check_outage(stays, back, j, "while the server is stopped")
        finally:
            os.kill(srv.proc.pid, signal.SIGCONT)
        _check_recovery(stays, back, j, first_id)
    finally:
        if srv.proc.poll() is None:
            os.kill(srv.proc.pid, signal.SIGCONT)
        vrep.simxFinish(stays)
        vrep.simxFinish(back)
        srv.stop()


# ------------------------------------------------------------------ defect 11
BAD_VALUES = [{"a": 1}, None, float("nan"), float("inf"), 1e39, -1e39, 2**70, -2**70, "abc", "\ud800",
              [[1, [2, [3]]]], b"\xff\x00bad", np.zeros((2, 3)), np.array([]), [1e39] * 12]
MODES = [vrep.simx_opmode_oneshot, B, S, vrep.simx_opmode_oneshot_split + 100,
         vrep.simx_opmode_streaming_split + 100, vrep.simx_opmode_discontinue, BUF, vrep.simx_opmode_remove]
FLAGS = 0x7F  # every simx_return_* bit
NO_SERVER = 10**6  # a handle no object has: a call that reaches the server fails there, harmlessly
# Pure helpers without a return code: they raise LocalError, as the legacy ones raised.
HELPERS = {"simxPackInts", "simxUnpackInts", "simxPackFloats", "simxUnpackFloats", "simxCreateBuffer"}


def _identity_cases():
    deep = []
    for _ in range(1000):
        deep = [deep, {"k": b"\x00"}]
    return [{"a": 1, "b": [1, {"c": None}]}, [[1, [2, [3]]]], b"\x00\xff", deep, {1: {2: 3}}, "name", 7]


@pytest.mark.parametrize("value", _identity_cases(), ids=["dict", "nested", "bytes", "deep", "int-keys", "str", "int"])
def test_identity_of_any_msgpack_value(value):
    """Any msgpack value gives a hashable identity, the same one again after a trip through
    msgpack (what a stream update carries back), without deep recursion."""
    ident = P.identity("GetJointPosition", [value, 1.0])
    assert ident == P.identity("GetJointPosition", [value, 1.0])
    assert hash(ident) == hash(P.identity("GetJointPosition", [value, 1.0]))
    wire = msgpack.unpackb(msgpack.packb(list(ident[1:])), raw=False, strict_map_key=False)
    assert ("GetJointPosition", *(P._hashable(a) for a in wire)) == ident
    assert len(repr(ident)) > 0  # printable: no level is deeper than IDENTITY_DEPTH + 1


def _good(name: str, cid: int, tmp: str):
    """A well-typed value for each legacy parameter name (objects that do not exist, so that
    the calls that reach the server change nothing)."""
    table = {"clientID": cid, "connectionAddress": "127.0.0.1", "connectionPort": free_port(),
             "waitUntilConnected": False, "doNotReconnectOnceDisconnected": True, "timeOutInMs": 100,
             "commThreadCycleInMs": 5, "enable": False, "filePathAndName": tmp, "timeOut": 100,
             "fileName_serverSide": "robustness.txt", "modelPathAndName": "missing.xml",
             "scenePathAndName": "missing.xml", "options": 0, "functionName": "missing",
             "scriptDescription": "missing", "inputInts": [1], "inputFloats": [1.0], "inputStrings": ["a"],
             "inputBuffer": b"", "image": [0, 0, 0], "color": None, "size": 0.1, "txt": "x",
             "intList": [1], "floatList": [1.0], "intsPackedInString": b"\x00" * 4,
             "floatsPackedInString": b"\x00" * 4, "bufferSize": 4, "buffer": None, "infoType": 0,
             "signalValue": b"v", "retSignalName": "robustness_none", "objectHandles": [NO_SERVER],
             "position": 0.0, "eulerAngles": [0.0] * 3, "quaternion": [0.0, 0.0, 0.0, 1.0],
             "matrix": [0.0] * 12, "paramValues": [0.0, 0.0, -9.81], "keepInPlace": True, "showState": True,
             "relativeToObjectHandle": -1, "parentObject": NO_SERVER, "objectType": NO_SERVER,
             "dataType": NO_SERVER, "paramIdentifier": NO_SERVER, "parameterID": NO_SERVER,
             "childIndex": 0, "maxLines": 1, "mode": 0, "dialogType": 0, "prop": 0}
    if name in table:
        return table[name]
    if name.endswith(("Handle", "ButtonID", "entity1", "entity2")) or name in ("uiHandle", "parentObjectHandle"):
        return NO_SERVER
    if name.endswith(("Name", "Text", "Label", "title", "message")):
        return "robustness_none"
    if name in ("force", "targetPosition", "targetVelocity", "paramValue", "parameterValue"):
        return 0.5
    if name.endswith(("Colors", "Color")):
        return None
    raise AssertionError(f"no good value for parameter {name!r}: add one to the table")


def _legacy_result(fname: str, result) -> None:
    """The result has a legacy return code (or the helper's legacy value)."""
    if fname == "simxStart":
        assert result == -1 or (type(result) is int and result >= 0), result
        if result >= 0:
            vrep.simxFinish(result)
        return
    if fname in HELPERS:
        return  # a value from input it could read (bytes are ints, a str is bytes)
    if fname in ("simxFinish", "simxReleaseBuffer"):
        assert result is None
        return
    if fname in ("simxGetConnectionId", "simxGetLastCmdTime"):
        assert type(result) is int
        return
    if fname in ("simxGetInMessageInfo", "simxGetOutMessageInfo"):
        assert result[0] in (-1, 1)
        return
    rc = result[0] if isinstance(result, tuple) else result
    assert type(rc) is int and rc & ~FLAGS == 0, f"{fname} returned {result!r}"


def test_no_argument_makes_a_simx_function_raise(tmp_path, caplog):
    """Every simx* function, every parameter given each bad value, in every operation mode:
    nothing raises, the code is a legacy flag, the server answers no internal error and keeps
    serving."""
    caplog.set_level("ERROR", logger="simx.client")  # the thousands of warnings are expected
    tmp = tmp_path / "robustness.txt"
    tmp.write_bytes(b"data")
    srv = ServerProcess(str(SCENE), "--stopped", renderers="on-demand")
    cid = _start(srv.port, reconnect=False)
    calls = 0
    try:
        names = [n for n in simx_client.__all__ if n.startswith("simx") and callable(getattr(simx_client, n))]
        assert len(names) > 120
        for fname in names:
            fn = getattr(vrep, fname)
            params = list(inspect.signature(fn).parameters)
            good = {p: _good(p, cid, str(tmp)) for p in params if p != "operationMode"}
            modes = MODES if "operationMode" in params else [None]
            for bad_param in params:
                for bad in BAD_VALUES:
                    for mode in modes:
                        args = dict(good)
                        if mode is not None:
                            args["operationMode"] = mode
                        args[bad_param] = bad
                        calls += 1
                        try:
                            result = fn(**args)
                        except P.LocalError:
                            assert fname in HELPERS, f"{fname}({bad_param}={bad!r}) raised"
                            continue
                        except Exception as exc:  # the defect: report which call raised
                            pytest.fail(f"{fname}({bad_param}={bad!r}, mode {mode}) raised {exc!r}")
                        _legacy_result(fname, result)
                    if fname == "simxPauseCommunication":
                        vrep.simxPauseCommunication(cid, False)
        assert vrep.simxGetConnectionId(cid) > 0
        assert vrep.simxSynchronous(cid, False) == 0
        rc, j = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)
        assert rc == 0 and vrep.simxSetJointPosition(cid, j, 0.3, B) == 0
        assert vrep.simxGetJointPosition(cid, j, B)[0] == 0
    finally:
        vrep.simxFinish(cid)
        log = srv.stop()
    assert calls > 20000
    assert "internal error" not in log and "Traceback" not in log, log[-3000:]


@pytest.mark.parametrize("value", [1e39, -1e39, 2**70, {"a": 1}, None, np.zeros((2, 3)), "\ud800"])
def test_bad_numbers_are_local_errors(server, vrep_client, value):
    """simxSetJointPosition(cid, h, 1e39, mode) raised OverflowError: now flag 32 in every
    mode that sends, and nothing reaches the server."""
    rc, j = vrep.simxGetObjectHandle(vrep_client, "UR5_joint1", B)
    local = C.simx_return_local_error_flag
    as_float = not (type(value) is int and value == 2**70)  # 2**70 is a fine float32 (1.2e21), not an int32
    for mode in MODES[:6]:
        assert vrep.simxGetJointPosition(vrep_client, value, mode)[0] == local
        assert vrep.simxGetObjectHandle(vrep_client, value, mode)[0] == local
        assert vrep.simxCallScriptFunction(vrep_client, "UR5", 6, "f", [value], [], [], b"", mode)[0] == local
        if as_float:
            assert vrep.simxSetJointPosition(vrep_client, j, value, mode) == local
            assert vrep.simxSetFloatSignal(vrep_client, "x", value, mode) == local
            assert vrep.simxSetObjectPosition(vrep_client, j, -1, [0.0, value, 0.0], mode) == local
            assert vrep.simxCallScriptFunction(vrep_client, "UR5", 6, "f", [], [value], [], b"", mode)[0] == local
    assert vrep.simxGetJointPosition(vrep_client, j, B)[0] == 0


def test_non_finite_values_are_remote_errors(server, vrep_client):
    """NaN and inf travel as the legacy client sent them; the server refuses them where they
    would break the physics (flag 8) and keeps them as data in a float signal."""
    rc, j = vrep.simxGetObjectHandle(vrep_client, "UR5_joint1", B)
    before = vrep.simxGetJointPosition(vrep_client, j, B)
    for value in (float("nan"), float("inf"), -float("inf")):
        assert vrep.simxSetJointPosition(vrep_client, j, value, B) == C.simx_return_remote_error_flag
        assert vrep.simxSetObjectPosition(vrep_client, j, -1, [value, 0, 0], B) == C.simx_return_remote_error_flag
        assert vrep.simxSetFloatSignal(vrep_client, "robustness", value, B) == 0
    rc, after = vrep.simxGetJointPosition(vrep_client, j, B)
    assert rc == 0 and after == after  # not NaN


def test_raw_arguments_are_argument_errors(tmp_path):
    """A client of the protocol (not the facade) sends dicts, nested lists, bytes, huge ints,
    deep nesting as arguments of every command, in every mode: each is answered, as a remote
    error and never as an internal error; the server logs no traceback."""
    srv = ServerProcess(str(SCENE), "--stopped", renderers="on-demand")
    deep = []
    for _ in range(1000):
        deep = [deep]
    values = [{"a": 1}, [[1, [2]]], b"\x00\xff", 2**63, -2**63, deep, None, float("nan")]
    conn = Connection("127.0.0.1", srv.port, blocking_timeout=2.0)
    answered = 0
    try:
        for name in P.COMMANDS:
            if name in ("Hello", "Bye"):
                continue
            for value in values:
                args = [value] * 4
                for mode in (vrep.simx_opmode_oneshot, S, vrep.simx_opmode_discontinue):
                    rc, _ = conn.call(name, args, mode)
                    assert rc & ~FLAGS == 0
                rc, message = conn.call(name, args, B)
                if rc == C.simx_return_remote_error_flag:
                    answered += 1
                    assert "internal error" not in message, (name, message)
        assert answered > 500
        # A streamed command with such arguments: the server's error comes back in the stream
        # update under the identity the client computed (dict and 1,000-deep list included).
        for value in ({"a": [1, {"b": 2}]}, [deep]):  # values not sent before: no reply left over
            assert conn.call("GetJointPosition", [value], S)[0] in (C.simx_return_novalue_flag, 8)
            for what in ("the reply", "a stream update"):  # removed between: the second is streamed
                wait_until(lambda: conn.call("GetJointPosition", [value], BUF)[0] == 8, 10, 0.01, what)
                assert conn.call("GetJointPosition", [value], vrep.simx_opmode_remove)[0] == 0
            conn.call("GetJointPosition", [value], vrep.simx_opmode_discontinue)
        assert conn.call("GetObjectHandle", ["UR5_joint1"], B)[0] == 0
    finally:
        conn.close()
        log = srv.stop()
    assert "Traceback" not in log and "internal error" not in log, log[-3000:]


def test_pure_helpers_raise_local_errors_only():
    """The helpers without a return code raise LocalError on input they cannot read (the legacy
    ones raised struct.error or TypeError), and unpacking ignores a trailing partial value, as
    the legacy helpers' ``range(len // 4)`` loops did."""
    assert vrep.simxUnpackInts(b"\x01\x00\x00\x00\x02") == [1]
    assert vrep.simxUnpackFloats(vrep.simxPackFloats([0.5]) + b"\x00") == [0.5]
    for call in (lambda: vrep.simxPackInts([2**40]), lambda: vrep.simxPackInts(None),
                 lambda: vrep.simxPackFloats([1e39]), lambda: vrep.simxPackFloats([{"a": 1}]),
                 lambda: vrep.simxUnpackInts(1.5), lambda: vrep.simxCreateBuffer(-1)):
        with pytest.raises(P.LocalError):
            call()
