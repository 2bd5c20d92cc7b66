"""The wire schema round-trips and refuses what it cannot read."""

import msgpack
import pytest

from simx_client import protocol as P


def test_request_round_trip():
    payload = P.request("abc", [["GetJointPosition", 0x010000, [3]], ["CallScriptFunction", 0, ["RG2", 1, "f", [1], [0.5], ["s"], b"\x00\x01"]]])
    client, cmds = P.parse_request(payload)
    assert client == "abc"
    assert cmds[0] == ["GetJointPosition", 0x010000, [3]]
    assert cmds[1][2][-1] == b"\x00\x01"  # bytes travel as msgpack bin


def test_request_encoder_appends_the_commands_to_a_packed_head():
    commands = [["SetJointTargetPosition", 0, [4, 0.5]], ["GetObjectHandle", 0x010000, ["ü" * 40]]]
    encoder = P.RequestEncoder("client-1")
    assert msgpack.unpackb(encoder.encode(commands)) == [P.PROTOCOL_VERSION, "client-1", commands]
    assert P.parse_request(encoder.encode([])) == ("client-1", [])


def test_a_failed_encoding_leaves_the_next_one_intact():
    with pytest.raises(TypeError):
        P.pack({"v": 1, "r": [object()]})
    assert msgpack.unpackb(P.pack({"v": 1, "r": [1]})) == {"v": 1, "r": [1]}


def test_response_and_stream_round_trip():
    image = bytes(range(256)) * 10
    message = P.unpack_response(P.response(1250, P.STATE_SIM_NOT_STOPPED, [[True, [[640, 480], image]], [False, "no"]], 7, 9))
    assert message[:5] == [P.PROTOCOL_VERSION, 1250, P.STATE_SIM_NOT_STOPPED, 7, 9]
    assert message[5][0][1][1] == image and message[5][1] == [False, "no"]
    t, entries = P.unpack_stream_update(P.stream_update(50, [["GetJointPosition", [3], True, 0.5]]))
    assert t == 50 and entries == [["GetJointPosition", [3], True, 0.5]]


@pytest.mark.parametrize("payload,match", [
    (P.error_response("bad things"), "refused the message: bad things"),
    (msgpack.packb({"v": 1, "err": "old server says no"}), "mismatch: peer speaks 1"),
    (msgpack.packb({"v": 1, "t": 0, "s": 0, "w": 0, "sc": 0, "r": []}), "mismatch: peer speaks 1"),
    (msgpack.packb([P.PROTOCOL_VERSION, 1, 2]), "not a simx response"),
    (b"\x93", "undecodable"),
])
def test_bad_responses_raise_protocol_error(payload, match):
    with pytest.raises(P.ProtocolError, match=match):
        P.unpack_response(payload)


@pytest.mark.parametrize("payload,match", [
    (b"\xc1", "undecodable"),
    (msgpack.packb([1, 2]), "version"),
    (msgpack.packb({"v": 1, "c": "x", "cmds": []}), "mismatch: peer speaks 1"),
    (msgpack.packb([99, "x", []]), "mismatch: peer speaks 99"),
    (msgpack.packb({"x": 1}), "not a simx request"),
    (P.pack([P.PROTOCOL_VERSION, 5, []]), "client id"),
    (P.pack([P.PROTOCOL_VERSION, "x", [["GetJointPosition", 0]]]), "malformed command"),
    (P.pack([P.PROTOCOL_VERSION, "x", [[1, 0, []]]]), "malformed command"),
])
def test_bad_requests_raise_protocol_error(payload, match):
    with pytest.raises(P.ProtocolError, match=match):
        P.parse_request(payload)


def test_identity_uses_identifying_arguments_only():
    assert P.identity("SetJointTargetPosition", [4, 0.1]) == P.identity("SetJointTargetPosition", [4, 0.2])
    assert P.identity("SetJointTargetPosition", [4, 0.1]) != P.identity("SetJointTargetPosition", [5, 0.1])
    assert P.identity("GetVisionSensorImage", [4, 0]) != P.identity("GetVisionSensorImage", [4, 1])
    assert hash(P.identity("CallScriptFunction", ["RG2", 1, "rg2Open", [], [], [], b""]))


def test_exception_hierarchy():
    assert issubclass(P.UnknownObjectError, P.RemoteError)
    assert issubclass(P.RemoteError, P.SimxError) and issubclass(P.LocalError, P.SimxError)
    assert not issubclass(P.LocalError, P.RemoteError)


def test_every_command_has_exactly_one_executor():
    """The server looks a command up in HANDLERS first and in its own client commands only
    when it is not there: the two tables must not overlap, and together cover COMMANDS."""
    from simx_server.commands import HANDLERS
    from simx_server.legacy.server import LegacyDoor as Server

    own = set(Server._CLIENT_COMMANDS)
    assert not own & set(HANDLERS)
    assert set(P.COMMANDS) <= own | set(HANDLERS)
