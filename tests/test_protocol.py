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


def test_request_encoder_gives_the_bytes_of_request():
    commands = [["SetJointTargetPosition", 0, [4, 0.5]], ["GetObjectHandle", 0x010000, ["ü" * 40]]]
    encoder = P.RequestEncoder("client-1")
    assert encoder.encode(commands) == P.request("client-1", commands)
    assert P.parse_request(encoder.encode([])) == ("client-1", [])


def test_a_failed_encoding_leaves_the_next_one_intact():
    with pytest.raises(TypeError):
        P.pack({"v": 1, "r": [object()]})
    assert msgpack.unpackb(P.pack({"v": 1, "r": [1]})) == {"v": 1, "r": [1]}


def test_response_and_stream_round_trip():
    image = bytes(range(256)) * 10
    message = P.unpack(P.response(1250, P.STATE_SIM_NOT_STOPPED, [[True, [[640, 480], image]], [False, "no"]]))
    assert message["t"] == 1250 and message["r"][0][1][1] == image and message["r"][1] == [False, "no"]
    update = P.unpack(P.stream_update(50, [["GetJointPosition", [3], True, 0.5]]))
    assert update["r"] == [["GetJointPosition", [3], True, 0.5]]


@pytest.mark.parametrize("payload,match", [
    (b"\xc1", "undecodable"),
    (msgpack.packb([1, 2]), "version"),
    (msgpack.packb({"v": 99, "c": "x", "cmds": []}), "mismatch"),
    (P.pack({"v": P.PROTOCOL_VERSION, "cmds": []}), "client id"),
    (P.pack({"v": P.PROTOCOL_VERSION, "c": "x", "cmds": [["GetJointPosition", 0]]}), "malformed command"),
    (P.pack({"v": P.PROTOCOL_VERSION, "c": "x", "cmds": [[1, 0, []]]}), "malformed command"),
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
