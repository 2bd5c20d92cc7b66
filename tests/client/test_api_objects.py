"""Object tree, poses, selection, parameters, messages and connection details, end to end."""

from __future__ import annotations

import math
import threading

import numpy as np
import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until

B = vrep.simx_opmode_blocking


def h(cid: int, name: str) -> int:
    rc, handle = vrep.simxGetObjectHandle(cid, name, B)
    assert rc == 0, name
    return handle


def test_parent_and_children(vrep_client):
    ur5, j1, link1 = h(vrep_client, "UR5"), h(vrep_client, "UR5_joint1"), h(vrep_client, "UR5_link1")
    assert vrep.simxGetObjectParent(vrep_client, j1, B) == (0, ur5)
    assert vrep.simxGetObjectParent(vrep_client, link1, B) == (0, j1)
    assert vrep.simxGetObjectChild(vrep_client, j1, 0, B) == (0, link1)
    assert vrep.simxGetObjectChild(vrep_client, j1, 99, B) == (0, -1)
    assert vrep.simxGetObjectParent(vrep_client, 9999, B) == (8, 0)
    rc, top = vrep.simxGetObjectChild(vrep_client, -1, 0, B)
    assert rc == 0 and vrep.simxGetObjectParent(vrep_client, top, B) == (0, -1)


def test_set_pose_of_a_free_body_in_every_frame(vrep_client):
    sphere, table, ur5 = h(vrep_client, "Sphere"), h(vrep_client, "Table"), h(vrep_client, "UR5")
    vrep.simxPauseSimulation(vrep_client, B)
    try:
        for rel in (-1, table, ur5):
            target = [0.05, 0.1, 0.3]
            assert vrep.simxSetObjectPosition(vrep_client, sphere, rel, target, B) == 0
            rc, p = vrep.simxGetObjectPosition(vrep_client, sphere, rel, B)
            assert p == pytest.approx(target, abs=1e-5), rel
            euler = [0.3, -0.2, 0.5]
            assert vrep.simxSetObjectOrientation(vrep_client, sphere, rel, euler, B) == 0
            assert vrep.simxGetObjectOrientation(vrep_client, sphere, rel, B)[1] == pytest.approx(euler, abs=1e-5)
            quat = [0.0, 0.0, math.sin(0.4), math.cos(0.4)]
            assert vrep.simxSetObjectQuaternion(vrep_client, sphere, rel, quat, B) == 0
            got = vrep.simxGetObjectQuaternion(vrep_client, sphere, rel, B)[1]
            assert abs(np.dot(got, quat)) == pytest.approx(1.0, abs=1e-5)
    finally:
        vrep.simxStopSimulation(vrep_client, B)
        vrep.simxStartSimulation(vrep_client, B)


def test_set_pose_of_a_static_body_moves_its_subtree_and_stop_restores(vrep_client):
    ur5, flange = h(vrep_client, "UR5"), h(vrep_client, "RG2")
    p0 = vrep.simxGetObjectPosition(vrep_client, ur5, -1, B)[1]
    start = vrep.simxGetObjectPosition(vrep_client, h(vrep_client, "UR5_joint2"), -1, B)[1]
    f0 = vrep.simxGetObjectPosition(vrep_client, flange, -1, B)[1]
    moved = [p0[0] + 0.1, p0[1], p0[2]]
    assert vrep.simxSetObjectPosition(vrep_client, ur5, -1, moved, B) == 0
    assert vrep.simxGetObjectPosition(vrep_client, ur5, -1, B)[1] == pytest.approx(moved, abs=1e-5)
    assert vrep.simxGetObjectPosition(vrep_client, flange, -1, B)[1][0] == pytest.approx(f0[0] + 0.1, abs=0.01)
    # As in V-REP, a joint is placed with what hangs from it, and a body on a joint relative
    # to the joint, which stays (tests/sim/test_joint_placement.py)
    joint2, link2 = h(vrep_client, "UR5_joint2"), h(vrep_client, "UR5_link2")
    j0 = vrep.simxGetObjectPosition(vrep_client, joint2, -1, B)[1]
    l0 = vrep.simxGetObjectPosition(vrep_client, link2, joint2, B)[1]
    up = [j0[0], j0[1], j0[2] + 0.05]
    assert vrep.simxSetObjectPosition(vrep_client, joint2, -1, up, B) == 0
    assert vrep.simxGetObjectPosition(vrep_client, joint2, -1, B)[1] == pytest.approx(up, abs=1e-4)
    assert vrep.simxGetObjectPosition(vrep_client, link2, joint2, B)[1] == pytest.approx(l0, abs=1e-4)
    assert vrep.simxSetObjectPosition(vrep_client, ur5, -1, [1, 2], B) == vrep.simx_return_local_error_flag
    vrep.simxStopSimulation(vrep_client, B)
    assert vrep.simxGetObjectPosition(vrep_client, ur5, -1, B)[1] == pytest.approx(p0, abs=1e-5)
    assert vrep.simxGetObjectPosition(vrep_client, joint2, -1, B)[1] == pytest.approx(start, abs=1e-5)
    vrep.simxStartSimulation(vrep_client, B)


def test_selection_and_model_property(vrep_client):
    ur5, j1 = h(vrep_client, "UR5"), h(vrep_client, "UR5_joint1")
    assert vrep.simxSetObjectSelection(vrep_client, [ur5, j1], B) == 0
    assert vrep.simxGetObjectSelection(vrep_client, B) == (0, [ur5, j1])
    assert vrep.simxSetObjectSelection(vrep_client, [123456], B) == 8
    assert vrep.simxSetObjectSelection(vrep_client, [], B) == 0
    assert vrep.simxGetObjectSelection(vrep_client, B) == (0, [])
    assert vrep.simxGetModelProperty(vrep_client, ur5, B) == (0, 0)
    assert vrep.simxGetModelProperty(vrep_client, j1, B) == (0, 0xF000)
    # a model's not-collidable override (V-REP's, over its objects' special properties)
    assert vrep.simxSetModelProperty(vrep_client, ur5, vrep.sim_modelproperty_not_collidable, B) == 0
    assert vrep.simxGetModelProperty(vrep_client, ur5, B) == (0, vrep.sim_modelproperty_not_collidable)
    assert vrep.simxSetModelProperty(vrep_client, ur5, 0, B) == 0
    assert vrep.simxGetModelProperty(vrep_client, ur5, B) == (0, 0)


def test_parameters(vrep_client):
    assert vrep.simxGetFloatingParameter(vrep_client, vrep.sim_floatparam_simulation_time_step, B) == \
        (0, pytest.approx(0.05))
    assert vrep.simxGetFloatParam(vrep_client, vrep.sim_floatparam_simulation_time_step, B)[1] == pytest.approx(0.05)
    # The time step only changes while stopped.
    assert vrep.simxSetFloatingParameter(vrep_client, vrep.sim_floatparam_simulation_time_step, 0.01, B) == 8
    assert vrep.simxGetArrayParameter(vrep_client, vrep.sim_arrayparam_gravity, B) == \
        (0, pytest.approx([0.0, 0.0, -9.81], abs=1e-5))
    assert vrep.simxGetBooleanParameter(vrep_client, vrep.sim_boolparam_realtime_simulation, B) == (0, True)
    assert vrep.simxGetBooleanParameter(vrep_client, vrep.sim_boolparam_waiting_for_trigger, B) == (0, False)
    assert vrep.simxGetIntegerParameter(vrep_client, 7, B)[1] >= 1  # dynamics step divider = substeps
    assert vrep.simxGetIntegerParameter(vrep_client, vrep.sim_intparam_program_version, B) == (8, 0)
    rc, path = vrep.simxGetStringParameter(vrep_client, 13, B)
    assert rc == 0 and path.endswith(SCENE.name)
    assert vrep.simxGetStringParameter(vrep_client, 99, B) == (8, "")


def test_gui_calls_are_refused_and_errors_reported(vrep_client):
    vrep.simxGetLastErrors(vrep_client, B)  # start from a clean list
    assert vrep.simxGetUIHandle(vrep_client, "UI", B) == (8, 0)
    assert vrep.simxDisplayDialog(vrep_client, "t", "m", 0, "", None, None, B) == (8, 0, 0)
    assert vrep.simxGetCollectionHandle(vrep_client, "c", B) == (8, 0)
    rc, errors = vrep.simxGetLastErrors(vrep_client, B)
    assert rc == 0 and len(errors) == 3
    assert "graphical user interface" in errors[0] and "collection" in errors[2]
    assert vrep.simxGetLastErrors(vrep_client, B) == (0, [])


def test_messages_and_consoles_go_to_the_server_log(vrep_client):
    assert vrep.simxAddStatusbarMessage(vrep_client, "hello from a test", B) == 0
    rc, console = vrep.simxAuxiliaryConsoleOpen(vrep_client, "aux", 10, 0, None, None, None, None, B)
    assert rc == 0 and console > 0
    assert vrep.simxAuxiliaryConsolePrint(vrep_client, console, "line one\n", B) == 0
    assert vrep.simxAuxiliaryConsoleShow(vrep_client, console, False, B) == 0
    assert vrep.simxAuxiliaryConsoleClose(vrep_client, console, B) == 0
    assert vrep.simxAuxiliaryConsolePrint(vrep_client, console, "gone", B) == 8


def test_message_info(vrep_client):
    vrep.simxGetPingTime(vrep_client)
    rc, state = vrep.simxGetInMessageInfo(vrep_client, vrep.simx_headeroffset_server_state)
    assert rc == 1 and state & 1  # simulation running
    rc, sent = vrep.simxGetOutMessageInfo(vrep_client, vrep.simx_headeroffset_message_id)
    assert rc == 1 and vrep.simxGetInMessageInfo(vrep_client, vrep.simx_headeroffset_message_id) == (1, sent)
    assert vrep.simxGetInMessageInfo(vrep_client, 99) == (-1, 0)


def test_split_modes_are_delivered_whole(vrep_client):
    j = h(vrep_client, "UR5_joint1")
    split = vrep.simx_opmode_oneshot_split + 100
    rc = vrep.simxGetJointPosition(vrep_client, j, split)[0]
    assert rc in (0, 1)  # the reply may already be in when the call returns
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, j, vrep.simx_opmode_buffer)[0] == 0, 5, 0.01,
               "the split reply in the inbox")


def test_connection_id_follows_the_server_and_reconnects():
    port = free_port()
    srv = ServerProcess(str(SCENE), ports=[port], renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", port, True, False, 5000, 5)  # may reconnect
    try:
        assert cid >= 0
        first = vrep.simxGetConnectionId(cid)
        assert first > 0
        j = h(cid, "UR5_joint1")
        vrep.simxGetJointPosition(cid, j, vrep.simx_opmode_streaming)
        srv.stop()
        wait_until(lambda: vrep.simxGetConnectionId(cid) == -1, 10, 0.05,
                   "connection id -1 once the server left")
        assert vrep.simxGetObjectHandle(cid, "UR5", B)[0] & vrep.simx_return_timeout_flag
        srv = ServerProcess(str(SCENE), ports=[port], renderers="on-demand")
        wait_until(lambda: vrep.simxGetConnectionId(cid) not in (-1, first), 20, 0.05, "reconnection")
        vrep.simxGetJointPosition(cid, j, vrep.simx_opmode_remove)
        wait_until(lambda: vrep.simxGetJointPosition(cid, j, vrep.simx_opmode_buffer)[0] == 0, 20, 0.05,
                   "the stream resumed")
    finally:
        vrep.simxFinish(cid)
        srv.stop()


def test_signals_shared_by_clients(server, vrep_client):
    assert vrep.simxSetIntegerSignal(vrep_client, "count", 41, B) == 0
    assert vrep.simxGetIntegerSignal(vrep_client, "count", B) == (0, 41)
    assert vrep.simxSetInt32Signal(vrep_client, "count", 42, B) == 0
    assert vrep.simxSetFloatSignal(vrep_client, "gain", 0.25, B) == 0
    assert vrep.simxSetStringSignal(vrep_client, "blob", vrep.simxPackFloats([1.5, 2.5]), B) == 0
    assert vrep.simxAppendStringSignal(vrep_client, "blob", b"\x00\x01", B) == 0
    other = vrep.simxStart("127.0.0.1", server.ports[1], True, True, 5000, 5)
    try:
        assert vrep.simxGetIntegerSignal(other, "count", B) == (0, 42)
        assert vrep.simxGetFloatSignal(other, "gain", B) == (0, 0.25)
        rc, blob = vrep.simxGetStringSignal(other, "blob", B)
        assert rc == 0 and isinstance(blob, bytearray) and vrep.simxUnpackFloats(blob[:8]) == [1.5, 2.5]
        assert blob[8:] == b"\x00\x01"
    finally:
        vrep.simxFinish(other)
    assert vrep.simxGetAndClearStringSignal(vrep_client, "blob", B)[0] == 0
    assert vrep.simxGetStringSignal(vrep_client, "blob", B) == (8, bytearray())
    assert vrep.simxClearIntegerSignal(vrep_client, "count", B) == 0
    assert vrep.simxGetIntegerSignal(vrep_client, "count", B) == (8, 0)
    assert vrep.simxClearFloatSignal(vrep_client, "", B) == 0  # "" clears them all
    assert vrep.simxGetFloatSignal(vrep_client, "gain", B) == (8, 0.0)


def test_string_stream_accumulates_until_read(vrep_client):
    assert vrep.simxReadStringStream(vrep_client, "log", vrep.simx_opmode_streaming)[0] == 1
    for chunk in (b"ab", b"cd", b"ef"):
        assert vrep.simxWriteStringStream(vrep_client, "log", chunk, B) == 0
    data = bytearray()

    def six_bytes() -> bool:
        rc, part = vrep.simxReadStringStream(vrep_client, "log", vrep.simx_opmode_buffer)
        data.extend(part if rc == 0 else b"")
        return len(data) >= 6

    wait_until(six_bytes, 5, 0.02, lambda: f"six bytes from the stream (got {bytes(data)!r})")
    assert data == b"abcdef"
    vrep.simxReadStringStream(vrep_client, "log", vrep.simx_opmode_discontinue)


def test_query_waits_for_the_answer_signal(vrep_client):
    assert vrep.simxSetStringSignal(vrep_client, "answer", "pong", B) == 0
    assert vrep.simxQuery(vrep_client, "request", "ping", "answer", 2000) == (0, bytearray(b"pong"))
    assert vrep.simxGetStringSignal(vrep_client, "request", B) == (0, bytearray(b"ping"))
    rc, value = vrep.simxQuery(vrep_client, "request", "ping", "never_answered", 200)
    assert rc & vrep.simx_return_timeout_flag and value == bytearray()


def test_scene_editing_while_running_keeps_other_handles(vrep_client, tmp_path):
    j1, sphere = h(vrep_client, "UR5_joint1"), h(vrep_client, "Sphere")
    model = tmp_path / "crate.xml"
    model.write_text('<mujoco><worldbody><body name="Crate" pos="0.3 0.3 1.2"><freejoint/>'
                     '<geom type="box" size="0.05 0.05 0.05" mass="0.2" rgba="0 .6 0 1"/></body>'
                     '</worldbody></mujoco>')
    rc, crate = vrep.simxLoadModel(vrep_client, str(model), 1, B)  # bit 0: a file of this client
    assert rc == 0 and crate > 0
    assert vrep.simxGetObjectHandle(vrep_client, "Crate", B) == (0, crate)
    assert vrep.simxGetObjectHandle(vrep_client, "UR5_joint1", B) == (0, j1)
    assert vrep.simxGetObjectHandle(vrep_client, "Sphere", B) == (0, sphere)
    z0 = 1.2  # where the model puts it; a loaded machine may have let it land already (the paced loop catches up)
    wait_until(lambda: vrep.simxGetObjectPosition(vrep_client, crate, -1, B)[1][2] < z0 - 0.01, what="the crate falling")
    rc, (copy,) = vrep.simxCopyPasteObjects(vrep_client, [crate], B)
    assert rc == 0 and copy not in (crate, j1, sphere)
    assert vrep.simxRemoveModel(vrep_client, copy, B) == 0
    assert vrep.simxGetObjectPosition(vrep_client, copy, -1, B)[0] == 8
    rc, dummy = vrep.simxCreateDummy(vrep_client, 0.05, None, B)
    assert rc == 0 and vrep.simxGetObjectHandle(vrep_client, "Dummy", B) == (0, dummy)
    assert vrep.simxRemoveObject(vrep_client, dummy, B) == 0
    assert vrep.simxRemoveObject(vrep_client, crate, B) == 0
    assert vrep.simxGetJointPosition(vrep_client, j1, B)[0] == 0
    assert vrep.simxTransferFile(vrep_client, str(model), "../escape.xml", 1000, B) == 8
    assert vrep.simxEraseFile(vrep_client, "crate.xml", B) == 0
    assert vrep.simxLoadScene(vrep_client, "whatever.xml", 0, B) == 8  # refused while running


def test_negative_start_timeout_is_the_blocking_timeout():
    """simxStart(..., timeOutInMs < 0, ...): |t| bounds every blocking call (extApi.c's rule).
    A peer that answers the handshake at once and every other request SLOW_ANSWER s late (slow
    on purpose) shows it by the outcome, not by seconds: with -300 ms the call times out before
    the answer comes; with the default 5 s blocking timeout the same late answer is taken."""
    import zenoh

    from simx_client import protocol as P
    from simx_server.legacy.zenoh_config import zenoh_config

    slow_answer = 2.0  # s: far beyond 0.3 s, well within the default 5 s
    port = free_port()
    timers = []

    def answer(query):
        try:
            query.reply(query.key_expr, P.response(0, 0, [[True, 42]]))
        except zenoh.ZError:
            pass  # the query ended: its client stopped waiting

    def on_query(query):
        _, commands = P.parse_request(query.payload.to_bytes())
        if commands[0][0] == "Hello":
            query.reply(query.key_expr, P.response(0, 0, [[True, {"protocol": P.PROTOCOL_VERSION}]]))
        else:
            timer = threading.Timer(slow_answer, answer, (query,))
            timer.start()
            timers.append(timer)  # started before the test's cleanup can see it

    session = zenoh.open(zenoh_config([f"tcp/127.0.0.1:{port}"]))
    queryable = session.declare_queryable(P.call_keys(), on_query)
    try:
        for start_timeout, outcome in ((-300, (vrep.simx_return_timeout_flag | 1, 0)),
                                       (5000, (vrep.simx_return_ok, 42))):  # the late answer taken
            cid = vrep.simxStart("127.0.0.1", port, True, True, start_timeout, 5)
            assert cid >= 0
            try:
                assert vrep.simxGetObjectHandle(cid, "UR5", B) == outcome, start_timeout
            finally:
                vrep.simxFinish(cid)  # one connection per address and port in a process, as in V-REP
    finally:
        queryable.undeclare()  # no new answer timers from here on
        for timer in list(timers):
            timer.cancel()
            timer.join()
        session.close()


def test_non_finite_poses_are_refused(vrep_client):
    sphere = h(vrep_client, "Sphere")
    p0 = vrep.simxGetObjectPosition(vrep_client, sphere, -1, B)[1]
    assert vrep.simxSetObjectPosition(vrep_client, sphere, -1, [float("nan"), 0.0, 1.0], B) == 8
    assert vrep.simxSetObjectOrientation(vrep_client, sphere, -1, [0.0, float("inf"), 0.0], B) == 8
    assert vrep.simxGetObjectPosition(vrep_client, sphere, -1, B)[1] == pytest.approx(p0, abs=0.01)
