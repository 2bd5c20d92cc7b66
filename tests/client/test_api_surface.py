"""The legacy surface: every function of the reference with its exact parameter names, and the
legacy return shapes when nothing could be done (not connected: flag 64)."""

from __future__ import annotations

import csv
import inspect

import pytest

import sim
import vrep
from conftest import REFERENCE, ROOT, require_shared

TSV = REFERENCE / "simx_functions.tsv"


def reference_rows() -> list[dict]:
    with require_shared(TSV).open() as f:
        return list(csv.DictReader(f, delimiter="\t"))


def test_reference_lists_133_functions():
    assert len(reference_rows()) == 133


@pytest.mark.parametrize("module", [vrep, sim])
def test_every_function_has_the_legacy_signature(module):
    mismatches = []
    for row in reference_rows():
        sig = row["python_signature"]
        expected = [p.strip() for p in sig[sig.index("(") + 1 : sig.rindex(")")].split(",") if p.strip()]
        fn = getattr(module, row["name"], None)
        if fn is None:
            mismatches.append(f"{row['name']}: missing")
            continue
        got = list(inspect.signature(fn).parameters)
        if got != expected:
            mismatches.append(f"{row['name']}: {got} != {expected}")
    assert not mismatches, "\n".join(mismatches)


NOT_CONNECTED = 250  # a client id nobody opened
B = vrep.simx_opmode_blocking

# function -> arguments after clientID (the operation mode last), and the expected legacy return.
CASES = {
    "simxGetJointPosition": ((1, B), (64, 0.0)),
    "simxGetJointMatrix": ((1, B), (64, [0.0] * 12)),
    "simxReadForceSensor": ((1, B), (64, 0, [0.0] * 3, [0.0] * 3)),
    "simxReadVisionSensor": ((1, B), (64, False, [])),
    "simxGetObjectHandle": (("UR5", B), (64, 0)),
    "simxGetVisionSensorImage": ((1, 0, B), (64, [], [])),
    "simxGetVisionSensorDepthBuffer": ((1, B), (64, [], [])),
    "simxGetObjectChild": ((1, 0, B), (64, 0)),
    "simxReadProximitySensor": ((1, B), (64, False, [0.0] * 3, 0, [0.0] * 3)),
    "simxLoadModel": (("m.xml", 0, B), (64, 0)),
    "simxLoadUI": (("u", 0, B), (64, [])),
    "simxGetUIEventButton": ((1, B), (64, 0, [0, 0])),
    "simxGetObjectPosition": ((1, -1, B), (64, [0.0] * 3)),
    "simxGetObjectQuaternion": ((1, -1, B), (64, [0.0] * 4)),
    "simxGetLastErrors": ((B,), (64, [])),
    "simxGetArrayParameter": ((0, B), (64, [0.0] * 3)),
    "simxGetBooleanParameter": ((0, B), (64, False)),
    "simxGetStringParameter": ((0, B), (64, "")),
    "simxReadCollision": ((1, B), (64, False)),
    "simxGetObjects": ((0, B), (64, [])),
    "simxDisplayDialog": (("t", "m", 0, "", None, None, B), (64, 0, 0)),
    "simxGetDialogInput": ((1, B), (64, "")),
    "simxCopyPasteObjects": (([1], B), (64, [])),
    "simxGetStringSignal": (("s", B), (64, bytearray())),
    "simxReadStringStream": (("s", vrep.simx_opmode_buffer), (64, bytearray())),
    "simxGetObjectGroupData": ((0, 0, B), (64, [], [], [], [])),
    "simxCallScriptFunction": (("RG2", 1, "f", [], [], [], b"", B), (64, [], [], [], bytearray())),
    "simxGetObjectVelocity": ((1, B), (64, [0.0] * 3, [0.0] * 3)),
    "simxStartSimulation": ((B,), 64),
    "simxSetJointTargetPosition": ((1, 0.5, B), 64),
    "simxSetStringSignal": (("s", "v", B), 64),
    "simxCreateDummy": ((0.1, None, B), (64, 0)),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_return_shapes_when_not_connected(name):
    args, expected = CASES[name]
    assert getattr(vrep, name)(NOT_CONNECTED, *args) == expected


def test_connection_calls_when_not_connected():
    assert vrep.simxGetPingTime(NOT_CONNECTED) == (0, 0)
    assert vrep.simxGetLastCmdTime(NOT_CONNECTED) == 0
    assert vrep.simxGetConnectionId(NOT_CONNECTED) == -1
    assert vrep.simxGetInMessageInfo(NOT_CONNECTED, vrep.simx_headeroffset_server_state) == (-1, 0)
    assert vrep.simxGetOutMessageInfo(NOT_CONNECTED, vrep.simx_headeroffset_message_id) == (-1, 0)
    assert vrep.simxSynchronous(NOT_CONNECTED, True) == 64
    assert vrep.simxSynchronousTrigger(NOT_CONNECTED) == 64
    assert vrep.simxPauseCommunication(NOT_CONNECTED, False) == 64
    assert vrep.simxFinish(NOT_CONNECTED) is None
    assert vrep.simxTransferFile(NOT_CONNECTED, __file__, "x.py", 1000, B) == 64


def test_local_helpers():
    buf = vrep.simxCreateBuffer(16)
    assert [buf[i] for i in range(16)] == [0] * 16
    assert vrep.simxReleaseBuffer(buf) is None
    assert vrep.simxReadStringStream(0, "s", B)[0] == vrep.simx_return_illegal_opmode_flag


def test_docs_api_lists_every_function():
    text = (ROOT / "docs" / "API.md").read_text()
    missing = [row["name"] for row in reference_rows() if row["name"] not in text]
    assert not missing, f"docs/API.md does not mention {missing}"
