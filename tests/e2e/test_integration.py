"""Every issue-2 command against a real simx-server subprocess over Zenoh on loopback."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
import time
import types

import msgpack
import numpy as np
import pytest
import zenoh

import vrep
from conftest import wait_until
from simx_client import api as simx_api
from simx_client import protocol as P
from simx_client.connection import client_config

B = vrep.simx_opmode_blocking
ONESHOT = vrep.simx_opmode_oneshot
JOINTS = [f"UR5_joint{i}" for i in range(1, 7)]


def handle(cid: int, name: str) -> int:
    rc, h = vrep.simxGetObjectHandle(cid, name, B)
    assert rc == 0, f"{name}: rc {rc}"
    return h


def test_ready_line_names_scene_objects_and_endpoints(server):
    line = server.ready_line
    assert "ur5_rg2_kinect.xml" in line
    assert "objects" in line
    for p in server.ports:
        assert f"tcp/127.0.0.1:{p}" in line


def test_object_handles_and_unknown_name(vrep_client):
    handles = [handle(vrep_client, n) for n in JOINTS + ["UR5", "RG2", "kinect_rgb", "kinect_depth"]]
    assert len(set(handles)) == len(handles)
    assert all(isinstance(h, int) and h > 0 for h in handles)
    assert vrep.simxGetObjectHandle(vrep_client, "no_such_object", B) == (8, 0)
    # V-REP's 'name#' means 'name'; CoppeliaSim 4.2 paths resolve through the tree.
    assert vrep.simxGetObjectHandle(vrep_client, "UR5#", B) == (0, handle(vrep_client, "UR5"))
    assert vrep.simxGetObjectHandle(vrep_client, "/UR5/UR5_joint3", B) == (0, handle(vrep_client, "UR5_joint3"))


def test_get_objects_by_type(vrep_client):
    rc, joints = vrep.simxGetObjects(vrep_client, vrep.sim_object_joint_type, B)
    assert rc == 0
    for name in JOINTS + ["RG2_openCloseJoint"]:
        assert handle(vrep_client, name) in joints
    rc, sensors = vrep.simxGetObjects(vrep_client, vrep.sim_object_visionsensor_type, B)
    assert sorted(sensors) == sorted([handle(vrep_client, "kinect_rgb"), handle(vrep_client, "kinect_depth")])
    rc, everything = vrep.simxGetObjects(vrep_client, vrep.sim_handle_all, B)
    assert set(joints) < set(everything)


def test_joint_target_position_moves_joint_within_velocity_limit(vrep_client):
    h = handle(vrep_client, "UR5_joint1")
    rc, q0 = vrep.simxGetJointPosition(vrep_client, h, B)
    assert rc == 0
    target = q0 + math.radians(90)
    # 180 deg/s at most, in simulation time: stepped by this client (synchronous mode), each
    # reading is checked against the simulation time passed since the target was set, whatever
    # the machine's speed (a free-running simulation was compared with the wall clock).
    assert vrep.simxSynchronous(vrep_client, True) == 0
    try:
        assert vrep.simxSetJointTargetPosition(vrep_client, h, target, B) == 0
        t_set = vrep.simxGetLastCmdTime(vrep_client)
        moved = []
        for _ in range(4):
            assert vrep.simxSynchronousTrigger(vrep_client) == 0
            rc, q = vrep.simxGetJointPosition(vrep_client, h, B)
            assert rc == 0
            moved.append((q - q0, (vrep.simxGetLastCmdTime(vrep_client) - t_set) / 1000))
    finally:
        assert vrep.simxSynchronous(vrep_client, False) == 0
    assert [round(t, 3) for _, t in moved] == [0.05, 0.1, 0.15, 0.2], moved  # one step per trigger
    assert 0 < moved[0][0] and all(q <= math.pi * t + 1e-3 for q, t in moved), moved  # moving, within 180 deg/s
    wait_until(lambda: abs(vrep.simxGetJointPosition(vrep_client, h, B)[1] - target) < math.radians(0.5))
    vrep.simxSetJointTargetPosition(vrep_client, h, q0, B)
    wait_until(lambda: abs(vrep.simxGetJointPosition(vrep_client, h, B)[1] - q0) < math.radians(0.5))


def test_numpy_arguments_are_accepted(vrep_client):
    h = np.zeros((1, 1), dtype=int)
    h[0] = handle(vrep_client, "UR5_joint2")
    rc, q = vrep.simxGetJointPosition(vrep_client, h[0], B)
    assert rc == 0 and isinstance(q, float)
    assert vrep.simxSetJointTargetPosition(vrep_client, h[0], np.array([q]), B) == 0
    assert vrep.simxGetJointPosition(vrep_client, np.int64(h[0, 0]), B)[0] == 0


def test_bad_arguments_are_local_errors(vrep_client):
    assert vrep.simxGetJointPosition(vrep_client, "UR5_joint1", B) == (vrep.simx_return_local_error_flag, 0.0)
    assert vrep.simxSetJointTargetPosition(vrep_client, np.array([1, 2]), 0.1, B) == vrep.simx_return_local_error_flag
    assert vrep.simxGetJointPosition(99, 1, B) == (vrep.simx_return_initialize_error_flag, 0.0)


def test_wrong_handle_type_is_remote_error(vrep_client):
    ur5 = handle(vrep_client, "UR5")
    assert vrep.simxGetJointPosition(vrep_client, ur5, B) == (8, 0.0)
    assert vrep.simxGetJointPosition(vrep_client, 10_000, B) == (8, 0.0)
    cam = handle(vrep_client, "kinect_rgb")
    assert vrep.simxGetVisionSensorImage(vrep_client, ur5, 0, B) == (8, [], [])
    gripper = handle(vrep_client, "RG2_openCloseJoint")
    # Targets of the other mode are stored, as V-REP stores them (they act once the mode changes);
    # a target on an object that is not a joint is the error.
    assert vrep.simxSetJointTargetPosition(vrep_client, gripper, 0.0, B) == 0
    assert vrep.simxSetJointTargetVelocity(vrep_client, handle(vrep_client, "UR5_joint1"), 0.0, B) == 0
    assert vrep.simxSetJointTargetPosition(vrep_client, ur5, 0.01, B) == 8
    assert vrep.simxSetJointTargetVelocity(vrep_client, ur5, 0.1, B) == 8
    assert vrep.simxGetVisionSensorImage(vrep_client, cam, 0, B)[0] == 0


def test_set_joint_position_teleports(vrep_client):
    h = handle(vrep_client, "UR5_joint6")
    assert vrep.simxSetJointPosition(vrep_client, h, 1.0, B) == 0
    assert vrep.simxGetJointPosition(vrep_client, h, B)[1] == pytest.approx(1.0, abs=0.02)
    assert vrep.simxSetJointPosition(vrep_client, h, 0.0, B) == 0


def test_joint_force_and_max_force(vrep_client):
    h = handle(vrep_client, "UR5_joint2")
    assert vrep.simxGetJointMaxForce(vrep_client, h, B) == (0, pytest.approx(150.0))
    rc, f = vrep.simxGetJointForce(vrep_client, h, B)
    assert rc == 0 and abs(f) > 0.0  # holding the arm against gravity takes torque
    g = handle(vrep_client, "RG2_openCloseJoint")
    assert vrep.simxSetJointForce(vrep_client, g, 15.0, B) == 0
    assert vrep.simxGetJointMaxForce(vrep_client, g, B) == (0, pytest.approx(15.0))
    assert vrep.simxSetJointForce(vrep_client, g, 20.0, B) == 0


def test_object_position_and_orientation(vrep_client):
    ur5, j1 = handle(vrep_client, "UR5"), handle(vrep_client, "UR5_joint1")
    rc, p = vrep.simxGetObjectPosition(vrep_client, j1, -1, B)
    assert rc == 0 and len(p) == 3
    rc, rel = vrep.simxGetObjectPosition(vrep_client, j1, ur5, B)
    assert rc == 0
    rc, base = vrep.simxGetObjectPosition(vrep_client, ur5, -1, B)
    assert np.linalg.norm(np.subtract(p, base)) == pytest.approx(np.linalg.norm(rel), abs=1e-4)
    rc, e = vrep.simxGetObjectOrientation(vrep_client, ur5, -1, B)
    assert rc == 0 and len(e) == 3
    rc, q = vrep.simxGetObjectQuaternion(vrep_client, ur5, -1, B)
    assert rc == 0 and np.linalg.norm(q) == pytest.approx(1.0, abs=1e-5)
    assert vrep.simxGetObjectPosition(vrep_client, ur5, 12345, B) == (8, [0.0, 0.0, 0.0])


def test_vision_sensor_rgb_grey_and_depth(vrep_client):
    rgb, depth = handle(vrep_client, "kinect_rgb"), handle(vrep_client, "kinect_depth")
    rc, res, img = vrep.simxGetVisionSensorImage(vrep_client, rgb, 0, B)
    assert rc == 0 and res == [640, 480] and len(img) == 640 * 480 * 3
    assert all(isinstance(v, int) for v in img[:100]) and min(img) >= -128 and max(img) <= 127
    pixels = np.array(img, dtype=np.int16).astype(np.uint8).reshape(480, 640, 3)
    assert pixels.std() > 5, "the RGB image is blank"
    rc, res, grey = vrep.simxGetVisionSensorImage(vrep_client, rgb, 1, B)
    assert rc == 0 and len(grey) == 640 * 480
    rc, res, dimg = vrep.simxGetVisionSensorImage(vrep_client, depth, 0, B)
    d = np.array(dimg, dtype=np.int16).astype(np.uint8).reshape(480, 640, 3)
    assert (d[..., 0] == d[..., 1]).all() and (d[..., 1] == d[..., 2]).all()
    rc, res, buf = vrep.simxGetVisionSensorDepthBuffer(vrep_client, depth, B)
    assert rc == 0 and res == [640, 480] and len(buf) == 640 * 480
    buf = np.array(buf).reshape(480, 640)
    assert 0.0 <= buf.min() and buf.max() <= 1.0 and buf.std() > 0.001
    # The depth image is the depth buffer as grey: near dark, far bright.
    assert np.abs(d[..., 0].astype(float) - np.rint(buf * 255)).max() <= 1


def test_call_script_function_rg2_close_and_open(vrep_client):
    g = handle(vrep_client, "RG2_openCloseJoint")
    ct = vrep.sim_scripttype_childscript
    rc, ints, floats, strings, buf = vrep.simxCallScriptFunction(vrep_client, "RG2", ct, "rg2Close", [], [], [], b"", B)
    assert (rc, ints, strings, buf) == (0, [], [], bytearray())
    assert floats == [pytest.approx(-0.05)]
    q_open = vrep.simxGetJointPosition(vrep_client, g, B)[1]
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, g, B)[1] < q_open - 0.01)
    rc, _, floats, _, _ = vrep.simxCallScriptFunction(vrep_client, "RG2", ct, "rg2Open", [], [], [], b"", B)
    assert rc == 0 and floats == [pytest.approx(0.05)]
    q_closed = vrep.simxGetJointPosition(vrep_client, g, B)[1]
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, g, B)[1] > q_closed + 0.01)
    assert vrep.simxCallScriptFunction(vrep_client, "RG2", ct, "noSuchFunction", [], [], [], b"", B)[0] == 8
    assert vrep.simxCallScriptFunction(vrep_client, "UR5", ct, "rg2Open", [], [], [], b"", B)[0] == 8
    assert vrep.simxCallScriptFunction(vrep_client, "RG2", vrep.sim_scripttype_mainscript, "rg2Open",
                                       [], [], [], b"", B) == (8, [], [], [], bytearray())


def test_oneshot_returns_previous_reply(vrep_client):
    h = handle(vrep_client, "UR5_joint4")
    rc, q = vrep.simxGetJointPosition(vrep_client, h, B)
    # Nothing in the inbox for this command yet: flag 1; the reply lands later.
    assert vrep.simxSetJointTargetPosition(vrep_client, h, q, ONESHOT) == vrep.simx_return_novalue_flag
    wait_until(lambda: vrep.simxSetJointTargetPosition(vrep_client, h, q, vrep.simx_opmode_buffer) == 0)
    assert vrep.simxSetJointTargetPosition(vrep_client, h, q, ONESHOT) == 0


def test_streaming_buffer_discontinue_remove_life_cycle(vrep_client):
    h = handle(vrep_client, "UR5_joint1")
    assert vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer) == (1, 0.0)
    assert vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_streaming)[0] == 1
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] == 0)
    # Fresh values every step: the reply's simulation time advances by dt.
    times = set()
    for _ in range(40):
        vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)
        times.add(vrep.simxGetLastCmdTime(vrep_client))
        time.sleep(0.01)
    assert len(times) >= 3
    assert all(t % 50 == 0 for t in times)
    # The streamed value follows the joint.
    rc, q = vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)
    vrep.simxSetJointTargetPosition(vrep_client, h, q + 0.3, ONESHOT)
    wait_until(lambda: abs(vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[1] - (q + 0.3)) < 0.01)
    vrep.simxSetJointTargetPosition(vrep_client, h, q, ONESHOT)
    # discontinue: the stream stops and its value leaves the inbox.
    vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_discontinue)
    time.sleep(0.2)
    assert vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] == 1
    # remove: clears the inbox entry of a running stream without stopping it.
    vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_streaming)
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] == 0)
    vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_remove)
    assert vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] in (0, 1)
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] == 0)
    vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_discontinue)


def test_stream_delivers_one_update_per_step(server, vrep_client):
    h = handle(vrep_client, "UR5_joint3")
    updates = []
    session = zenoh.open(client_config("127.0.0.1", server.port))
    try:
        conn = simx_api._connections[vrep_client]
        sub = session.declare_subscriber(P.stream_key(P.DEFAULT_PREFIX, conn.client),
                                         lambda s: updates.append(P.unpack_stream_update(s.payload.to_bytes())[0]))
        vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_streaming)
        wait_until(lambda: len(updates) >= 20)
        sub.undeclare()
    finally:
        session.close()
        vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_discontinue)
    steps = np.diff(updates)
    assert (steps == 50).all(), f"stream updates not one per 50 ms step: {updates}"


def test_pause_communication_lands_in_one_step(vrep_client):
    hs = [handle(vrep_client, n) for n in JOINTS]
    qs = [vrep.simxGetJointPosition(vrep_client, h, B)[1] for h in hs]
    assert vrep.simxPauseCommunication(vrep_client, True) == 0
    for h, q in zip(hs, qs):
        vrep.simxSetJointTargetPosition(vrep_client, h, q, ONESHOT)
        time.sleep(0.03)  # spread over more than one step: still sent as one batch
    assert vrep.simxPauseCommunication(vrep_client, False) == 0
    times = []
    for h, q in zip(hs, qs):
        wait_until(lambda: vrep.simxSetJointTargetPosition(vrep_client, h, q, vrep.simx_opmode_buffer) == 0)
        times.append(vrep.simxGetLastCmdTime(vrep_client))
    assert len(set(times)) == 1, f"batched commands ran at different simulation times: {times}"


def test_two_clients_at_once(server, vrep_client, tmp_path):
    """A second client process (own connection, second port) sees what the first one does."""
    h = handle(vrep_client, "UR5_joint5")
    rc, q0 = vrep.simxGetJointPosition(vrep_client, h, B)
    script = tmp_path / "second.py"
    script.write_text(textwrap.dedent(f"""
        import time, vrep
        cid = vrep.simxStart('127.0.0.1', {server.ports[1]}, True, True, 5000, 5)
        assert cid >= 0
        rc, h = vrep.simxGetObjectHandle(cid, 'UR5_joint5', vrep.simx_opmode_blocking)
        vrep.simxSetJointTargetPosition(cid, h, {q0 + 0.4}, vrep.simx_opmode_blocking)
        for _ in range(200):
            rc, q = vrep.simxGetJointPosition(cid, h, vrep.simx_opmode_blocking)
            if abs(q - {q0 + 0.4}) < 0.01:
                break
            time.sleep(0.02)
        print(rc, q)
        vrep.simxFinish(cid)
    """))
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    rc, q = vrep.simxGetJointPosition(vrep_client, h, B)
    assert q == pytest.approx(q0 + 0.4, abs=0.01)
    vrep.simxSetJointTargetPosition(vrep_client, h, q0, B)


def test_malformed_requests_do_not_hurt_other_clients(server, vrep_client):
    session = zenoh.open(client_config("127.0.0.1", server.port))
    try:
        answers = []
        for payload in (b"\xc1garbage", P.pack([999, "x", []]), P.pack({"v": 1, "c": "x", "cmds": []}),
                        P.pack([1, 2, 3]), P.pack([P.PROTOCOL_VERSION, "x", [["GetJointPosition", 0]]])):
            replies = list(session.get(P.call_key("simx", "x"), payload=payload, timeout=5))
            answers.append(msgpack.unpackb(replies[0].ok.payload.to_bytes()))
        assert all("err" in a for a in answers)
        assert "version" in answers[1]["err"] and "version" in answers[2]["err"]  # a version-1 client too
        assert "malformed command" in answers[4]["err"]
        # A request naming another client than its key's is refused (no acting under another id).
        spoof = list(session.get(P.call_key("simx", "x"), payload=P.request("y", [["GetPingTime", B, []]]), timeout=5))
        assert "client id" in msgpack.unpackb(spoof[0].ok.payload.to_bytes())["err"]
        # A client of protocol 1 or 2 queried <prefix>/call: refused with the reason, not left waiting.
        old = list(session.get(P.legacy_call_key(), payload=P.pack([2, "x", []]), timeout=5))
        assert "version" in msgpack.unpackb(old[0].ok.payload.to_bytes())["err"]
        # Wrong argument types inside a valid request: an error result, not a crash.
        bad = P.request("x", [["GetJointPosition", B, ["UR5_joint1"]], ["NoSuchCommand", B, []],
                              ["GetObjectHandle", B, ["UR5"]]])
        r = P.unpack_response(list(session.get(P.call_key("simx", "x"), payload=bad, timeout=5))[0].ok.payload.to_bytes())[5]
        assert r[0][0] is False and "int" in r[0][1]
        assert r[1][0] is False and "NoSuchCommand" in r[1][1]
        assert r[2][0] is True
    finally:
        session.close()
    assert vrep.simxGetObjectHandle(vrep_client, "UR5", B)[0] == 0


def test_ping_and_connection_calls(vrep_client):
    rc, ping = vrep.simxGetPingTime(vrep_client)
    assert rc == 0 and isinstance(ping, int) and ping >= 0
    assert vrep.simxGetConnectionId(vrep_client) >= 0
    assert vrep.simxGetConnectionId(200) == -1
    assert vrep.simxStart("127.0.0.1", simx_api._connections[vrep_client].port, True, True, 1000, 5) == -1


def test_stop_resets_scene_and_start_runs_again(vrep_client):
    h = handle(vrep_client, "UR5_joint2")
    sphere = handle(vrep_client, "Sphere")
    p0 = vrep.simxGetObjectPosition(vrep_client, sphere, -1, B)[1]
    vrep.simxSetJointTargetPosition(vrep_client, h, 0.5, B)
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, h, B)[1] > 0.2)
    assert vrep.simxStopSimulation(vrep_client, B) == 0
    assert vrep.simxGetJointPosition(vrep_client, h, B) == (0, pytest.approx(0.0, abs=1e-4))
    t_stopped = vrep.simxGetLastCmdTime(vrep_client)
    assert t_stopped == 0
    assert vrep.simxGetObjectPosition(vrep_client, sphere, -1, B)[1] == pytest.approx(p0, abs=1e-3)
    assert vrep.simxStartSimulation(vrep_client, B) == 0
    wait_until(lambda: vrep.simxGetPingTime(vrep_client) and vrep.simxGetLastCmdTime(vrep_client) > 100)
    # The scripts ran their init again: the gripper opens (velocity > 0) after a restart.
    g = handle(vrep_client, "RG2_openCloseJoint")
    q = vrep.simxGetJointPosition(vrep_client, g, B)[1]
    assert q >= 0.0


def test_pause_holds_the_simulation(vrep_client):
    assert vrep.simxPauseSimulation(vrep_client, B) == 0
    vrep.simxGetPingTime(vrep_client)
    t0 = vrep.simxGetLastCmdTime(vrep_client)
    time.sleep(0.3)
    vrep.simxGetPingTime(vrep_client)
    assert vrep.simxGetLastCmdTime(vrep_client) == t0 > 0
    assert vrep.simxStartSimulation(vrep_client, B) == 0
    wait_until(lambda: vrep.simxGetPingTime(vrep_client) and vrep.simxGetLastCmdTime(vrep_client) > t0)


def test_synchronous_stepping(vrep_client):
    assert vrep.simxSynchronous(vrep_client, True) == 0
    try:
        vrep.simxGetPingTime(vrep_client)
        t0 = vrep.simxGetLastCmdTime(vrep_client)
        time.sleep(0.2)
        vrep.simxGetPingTime(vrep_client)
        assert vrep.simxGetLastCmdTime(vrep_client) == t0, "time advanced without a trigger"
        for i in range(1, 4):
            assert vrep.simxSynchronousTrigger(vrep_client) == 0
            vrep.simxGetPingTime(vrep_client)
            assert vrep.simxGetLastCmdTime(vrep_client) == t0 + 50 * i
    finally:
        assert vrep.simxSynchronous(vrep_client, False) == 0
    assert vrep.simxSynchronousTrigger(vrep_client) == 8


def test_finish_all_and_start_timeout(monkeypatch, caplog):
    """simxStart's positive timeOutInMs bounds its connection wait: the retries stop at the
    client's own deadline (simx_client.connect.wait_connect's timer). Counted, not timed: on a
    clock that moves only by the client's 50 ms sleeps between tries, 500 ms is 11 tries to
    open a session (12 where the float sum falls short); the default 5 s would be 101."""
    from simx_client import connect, connection

    clock, opened = [0.0], []

    def sleep(seconds: float) -> None:
        clock[0] += seconds

    def counting_open(*args, **kwargs):
        opened.append(clock[0])
        return open_session(*args, **kwargs)

    open_session = connection.open_session
    fake_time = types.SimpleNamespace(monotonic=lambda: clock[0], sleep=sleep)
    monkeypatch.setattr(connection, "time", fake_time)
    monkeypatch.setattr(connect, "time", fake_time)  # wait_connect's retries
    monkeypatch.setattr(connection, "open_session", counting_open)
    port = __import__("conftest").free_port()
    with caplog.at_level("INFO", logger=connection.log.name):
        assert vrep.simxStart("127.0.0.1", port, True, True, 500, 5) == -1
    assert len(opened) in (11, 12) and opened[-1] >= 0.5 - 1e-9, opened
    assert [r.getMessage() for r in caplog.records if f"no simx server at 127.0.0.1:{port}" in r.getMessage()]
    assert vrep.simxFinish(-1) is None


def test_buffer_reads_of_one_image_are_equal_copies(vrep_client):
    cam = handle(vrep_client, "kinect_rgb")
    vrep.simxPauseSimulation(vrep_client, B)  # one state, one image
    try:
        vrep.simxGetVisionSensorImage(vrep_client, cam, 0, vrep.simx_opmode_streaming)
        wait_until(lambda: vrep.simxGetVisionSensorImage(vrep_client, cam, 0, vrep.simx_opmode_buffer)[0] == 0)
        rc1, res1, img1 = vrep.simxGetVisionSensorImage(vrep_client, cam, 0, vrep.simx_opmode_buffer)
        img1[0] = 999  # a caller may change its list ...
        rc2, res2, img2 = vrep.simxGetVisionSensorImage(vrep_client, cam, 0, vrep.simx_opmode_buffer)
        assert img2[0] != 999 and img2[1:] == img1[1:]  # ... without changing the next one
        assert res1 == res2 == [640, 480] and res1 is not res2
    finally:
        vrep.simxGetVisionSensorImage(vrep_client, cam, 0, vrep.simx_opmode_discontinue)
        vrep.simxStartSimulation(vrep_client, B)


def test_streams_survive_stop_and_start(vrep_client):
    h = handle(vrep_client, "UR5_joint2")
    vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_streaming)
    wait_until(lambda: vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] == 0)
    try:
        assert vrep.simxStopSimulation(vrep_client, B) == 0
        assert vrep.simxStartSimulation(vrep_client, B) == 0
        vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_remove)
        wait_until(lambda: vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] == 0)
        t = vrep.simxGetLastCmdTime(vrep_client)
        wait_until(lambda: vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_buffer)[0] == 0
                   and vrep.simxGetLastCmdTime(vrep_client) > t)
    finally:
        vrep.simxGetJointPosition(vrep_client, h, vrep.simx_opmode_discontinue)
