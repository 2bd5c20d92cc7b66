"""Streamed setters run their newest value (issue 19 part 2): a second ``simx_opmode_streaming``
call of the same command (same identity) replaces the stream's arguments, from the step after it,
for every family of setter: joint velocity, position, force and target position, object poses,
signals, and script calls. Stepped synchronously, so that each check reads known steps."""

from __future__ import annotations

import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port

STREAMING, BLOCKING = vrep.simx_opmode_streaming, vrep.simx_opmode_blocking


@pytest.fixture(scope="module")
def stepped():
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port()], renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    assert cid >= 0
    assert vrep.simxSynchronous(cid, True) == 0
    yield cid
    vrep.simxFinish(cid)
    srv.stop()


def steps(cid: int, n: int) -> None:
    for _ in range(n):
        assert vrep.simxSynchronousTrigger(cid) == 0
    vrep.simxGetPingTime(cid)  # after the last step's streams ran


def handle(cid: int, name: str) -> int:
    rc, h = vrep.simxGetObjectHandle(cid, name, BLOCKING)
    assert rc == 0, name
    return h


def joint(cid: int, h: int) -> float:
    rc, q = vrep.simxGetJointPosition(cid, h, BLOCKING)
    assert rc == 0
    return q


def test_joint_target_velocity_follows_the_newest_streamed_value(stepped):
    cid = stepped
    h = handle(cid, "UR5_joint1")
    assert vrep.simxSetObjectIntParameter(cid, h, vrep.sim_jointintparam_ctrl_enabled, 0, BLOCKING) == 0
    vrep.simxSetJointTargetVelocity(cid, h, 0.5, STREAMING)
    steps(cid, 5)
    q0 = joint(cid, h)
    steps(cid, 10)
    assert joint(cid, h) - q0 > 0.2  # +0.5 rad/s for 0.5 s
    vrep.simxSetJointTargetVelocity(cid, h, -0.5, STREAMING)  # the newer value replaces the stream
    steps(cid, 5)
    q1 = joint(cid, h)
    steps(cid, 10)
    assert joint(cid, h) - q1 < -0.2, "the stream still runs its first value"
    vrep.simxSetJointTargetVelocity(cid, h, 0.0, vrep.simx_opmode_discontinue)


def test_joint_position_and_target_position_follow_the_newest_value(stepped):
    cid = stepped
    h = handle(cid, "UR5_joint2")
    vrep.simxSetJointPosition(cid, h, 0.3, STREAMING)
    steps(cid, 2)
    assert joint(cid, h) == pytest.approx(0.3, abs=1e-6)
    vrep.simxSetJointPosition(cid, h, -0.2, STREAMING)
    steps(cid, 2)
    assert joint(cid, h) == pytest.approx(-0.2, abs=1e-6)
    vrep.simxSetJointPosition(cid, h, 0.0, vrep.simx_opmode_discontinue)


def test_object_position_follows_the_newest_value(stepped):
    cid = stepped
    ball = handle(cid, "Sphere")
    for target in ([0.3, 0.1, 1.5], [0.1, -0.2, 1.6]):
        vrep.simxSetObjectPosition(cid, ball, -1, target, STREAMING)
        steps(cid, 1)
        rc, where = vrep.simxGetObjectPosition(cid, ball, -1, BLOCKING)
        assert rc == 0 and where == pytest.approx(target, abs=0.02), (target, where)
    vrep.simxSetObjectPosition(cid, ball, -1, [0, 0, 0], vrep.simx_opmode_discontinue)


def test_signals_follow_the_newest_value(stepped):
    cid = stepped
    for value in (7, 11):
        vrep.simxSetIntegerSignal(cid, "streamed", value, STREAMING)
        vrep.simxClearIntegerSignal(cid, "streamed", BLOCKING)  # the stream sets it again at each step
        steps(cid, 1)
        assert vrep.simxGetIntegerSignal(cid, "streamed", BLOCKING) == (0, value)
    vrep.simxSetIntegerSignal(cid, "streamed", 0, vrep.simx_opmode_discontinue)


def test_the_newest_stream_period_is_kept(stepped):
    """``simx_opmode_streaming + alpha``: the newer request's period replaces the older one's."""
    cid = stepped
    vrep.simxSetFloatSignal(cid, "period", 1.0, STREAMING + 60_000)  # once a minute
    vrep.simxSetFloatSignal(cid, "period", 2.0, STREAMING)  # every step
    vrep.simxClearFloatSignal(cid, "period", BLOCKING)
    steps(cid, 1)
    assert vrep.simxGetFloatSignal(cid, "period", BLOCKING) == (0, 2.0)
    vrep.simxSetFloatSignal(cid, "period", 0, vrep.simx_opmode_discontinue)



def test_a_streamed_script_call_runs_with_its_newest_arguments():
    scene = SCENE.parents[1] / "tests" / "scenes" / "scripts" / "scripts_scene.xml"
    srv = ServerProcess(str(scene), "--pacing", "immediate", ports=[free_port()], renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    try:
        assert cid >= 0 and vrep.simxSynchronous(cid, True) == 0
        for value in (1, 2):
            vrep.simxCallScriptFunction(cid, "PyBox", vrep.sim_scripttype_childscript, "echo", [value], [], [],
                                        bytearray(), STREAMING)
            steps(cid, 2)
            rc, ints, *_ = vrep.simxCallScriptFunction(cid, "PyBox", vrep.sim_scripttype_childscript, "echo", [],
                                                       [], [], bytearray(), vrep.simx_opmode_buffer)
            assert rc == 0 and list(ints) == [value]
    finally:
        vrep.simxFinish(cid)
        srv.stop()


def test_joint_target_position_follows_the_newest_streamed_value(stepped):
    """Position control (motor and control loop on) steers to the newest streamed target."""
    cid = stepped
    h = handle(cid, "UR5_joint3")
    assert vrep.simxSetObjectIntParameter(cid, h, vrep.sim_jointintparam_ctrl_enabled, 1, BLOCKING) == 0
    for target in (0.3, -0.2):
        vrep.simxSetJointTargetPosition(cid, h, target, STREAMING)
        for _ in range(100):  # 5 s of simulation at most
            steps(cid, 1)
            if abs(joint(cid, h) - target) < 1e-3:
                break
        assert joint(cid, h) == pytest.approx(target, abs=1e-3), "the stream still runs an older target"
    vrep.simxSetJointTargetPosition(cid, h, 0.0, vrep.simx_opmode_discontinue)


def test_joint_force_follows_the_newest_streamed_value(stepped):
    cid = stepped
    h = handle(cid, "UR5_joint4")
    for force in (5.0, 7.5):
        vrep.simxSetJointForce(cid, h, force, STREAMING)
        steps(cid, 2)  # an older stream would run its first value again at each step
        assert vrep.simxGetJointMaxForce(cid, h, BLOCKING) == (0, pytest.approx(force))
    vrep.simxSetJointForce(cid, h, 0.0, vrep.simx_opmode_discontinue)


def test_object_orientation_follows_the_newest_value(stepped):
    cid = stepped
    ball = handle(cid, "Sphere")
    for euler in ([0.3, -0.2, 0.5], [-0.4, 0.1, -0.6]):
        vrep.simxSetObjectOrientation(cid, ball, -1, euler, STREAMING)
        steps(cid, 1)
        rc, got = vrep.simxGetObjectOrientation(cid, ball, -1, BLOCKING)
        assert rc == 0 and got == pytest.approx(euler, abs=0.02), (euler, got)
    vrep.simxSetObjectOrientation(cid, ball, -1, [0, 0, 0], vrep.simx_opmode_discontinue)
