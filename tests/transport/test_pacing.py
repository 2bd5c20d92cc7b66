"""Issue 12, parts 3 and 6, through real servers: legacy pacing of blocking calls (a client's
blocking calls never see the same simulation step twice, as on V-REP) and synchronous mode
with several clients (the simulation steps once every synchronous client has triggered)."""

from __future__ import annotations

import select
import subprocess
import sys
import textwrap

import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until

B = vrep.simx_opmode_blocking
FINGERS = "RG2_openCloseJoint"  # prismatic, 0 (closed) .. 0.055 m (open, where it starts)


@pytest.fixture
def start():
    """Start servers with the given options; finish their clients and stop them afterwards."""
    started = []

    def run(*options: str, ports: int = 1) -> tuple[ServerProcess, list[int]]:
        srv = ServerProcess(str(SCENE), *options, ports=[free_port() for _ in range(ports)], renderers="on-demand")
        cids = [vrep.simxStart("127.0.0.1", p, True, True, 5000, 5) for p in srv.ports]
        started.append((srv, cids))
        assert all(cid >= 0 for cid in cids)
        return srv, cids

    yield run
    for srv, cids in started:
        for cid in cids:
            vrep.simxFinish(cid)
        srv.stop()


def close_gripper(cid: int) -> tuple[float, int]:
    """A program in the style of visual-pushing-grasping's ``close_gripper()``: drive the
    fingers closed, then poll their position with blocking calls and stop as soon as a reading
    is not smaller than the previous one (the fingers stopped). Returns the last reading and
    the number of readings taken."""
    rc, joint = vrep.simxGetObjectHandle(cid, FINGERS, B)
    assert rc == 0
    rc, position = vrep.simxGetJointPosition(cid, joint, B)
    assert rc == 0
    assert vrep.simxSetJointForce(cid, joint, 20.0, B) == 0
    assert vrep.simxSetJointTargetVelocity(cid, joint, -0.05, B) == 0  # closes 0.055 m in 1.1 s
    for readings in range(1, 200):
        rc, new_position = vrep.simxGetJointPosition(cid, joint, B)
        assert rc == 0
        if new_position >= position:
            return new_position, readings
        position = new_position
    pytest.fail("the fingers never stopped")


def blocking_times(cid: int, calls: int) -> list[int]:
    """Simulation times (ms) of ``calls`` consecutive blocking calls' replies."""
    joint = vrep.simxGetObjectHandle(cid, FINGERS, B)[1]
    times = []
    for _ in range(calls):
        assert vrep.simxGetJointPosition(cid, joint, B)[0] == 0
        times.append(vrep.simxGetLastCmdTime(cid))
    return times


def ping_time(cid: int) -> int:
    """The simulation time (ms) of a blocking call's reply."""
    assert vrep.simxGetPingTime(cid)[0] == 0
    return vrep.simxGetLastCmdTime(cid)


# ----------------------------------------------------------------- part 3: legacy pacing
def test_legacy_pacing_lets_a_polling_loop_see_the_fingers_close(start):
    """By default (legacy pacing) the poll sees the fingers move until they stop at their limit,
    and every blocking call's reply is of a later step than the previous one's."""
    srv, (cid,) = start()
    times = blocking_times(cid, 8)
    assert all(b > a for a, b in zip(times, times[1:])), f"two blocking calls saw the same step: {times}"
    position, readings = close_gripper(cid)
    assert position < 0.002, f"the poll stopped at {position:.4f} m after {readings} readings: fingers still open"
    assert readings >= 10  # 1.1 s of closing at 50 ms a step: one reading per step


def test_immediate_pacing_serves_at_once_and_may_see_one_step_twice(start):
    """``--pacing immediate``: blocking calls are served as they arrive, so consecutive ones
    see the same step and the same polling loop stops at once with the fingers still open
    (the defect legacy pacing fixes; what programs that want raw speed choose)."""
    srv, (cid,) = start("--pacing", "immediate")
    times = blocking_times(cid, 30)  # a few ms of calls in 50 ms steps
    assert any(a == b for a, b in zip(times, times[1:])), f"no two calls in the same step: {times}"
    position, readings = close_gripper(cid)
    assert position > 0.04 and readings <= 3, (position, readings)


def test_paused_stopped_and_stepped_simulations_serve_blocking_calls_at_once(start):
    """No step comes while the simulation is paused, stopped or waiting for a trigger: blocking
    calls are served at once there (V-REP's instance passes), never held for a step."""
    srv, (cid,) = start()
    assert vrep.simxPauseSimulation(cid, B) == 0
    paused = blocking_times(cid, 10)
    assert len(set(paused)) == 1 and paused[0] > 0  # all answered, all in the paused step
    assert vrep.simxStopSimulation(cid, B) == 0
    assert blocking_times(cid, 10) == [0] * 10
    assert vrep.simxSynchronous(cid, True) == 0
    assert vrep.simxStartSimulation(cid, B) == 0
    waiting = blocking_times(cid, 10)
    assert len(set(waiting)) == 1
    assert vrep.simxSynchronousTrigger(cid) == 0
    assert ping_time(cid) == waiting[0] + 50  # the triggered step, then served at once
    assert vrep.simxSynchronous(cid, False) == 0  # asynchronous again: paced again
    times = blocking_times(cid, 4)
    assert all(b > a for a, b in zip(times, times[1:])), times


def test_non_blocking_requests_are_not_held(start):
    """Only blocking calls are paced: 300 oneshot setters sent in a burst are all executed at
    once (held one per step, they would overflow the client's queue of 256 and the blocking
    call behind them would wait 256 steps, past its 5 s timeout)."""
    srv, (cid,) = start()
    joint = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
    t0 = ping_time(cid)
    codes = {vrep.simxSetJointTargetPosition(cid, joint, 0.001 * i, vrep.simx_opmode_oneshot) for i in range(300)}
    assert codes <= {0, 1}, codes  # never 8: no "server busy"
    t1 = ping_time(cid)
    assert t1 - t0 <= 50 * 20, (t0, t1)  # a few steps, not one per request
    assert vrep.simxGetLastErrors(cid, B) == (0, [])


def test_pacing_is_per_client(start):
    """Two clients polling in turn: each one's blocking calls see strictly increasing steps."""
    srv, (a, b) = start(ports=2)
    ja = vrep.simxGetObjectHandle(a, FINGERS, B)[1]
    jb = vrep.simxGetObjectHandle(b, FINGERS, B)[1]
    seen = {a: [], b: []}
    for _ in range(6):
        for cid, joint in ((a, ja), (b, jb)):
            assert vrep.simxGetJointPosition(cid, joint, B)[0] == 0
            seen[cid].append(vrep.simxGetLastCmdTime(cid))
    for times in seen.values():
        assert all(y > x for x, y in zip(times, times[1:])), times


# ------------------------------------------------------- part 6: synchronous barrier
def test_sync_step_waits_for_every_synchronous_client_and_a_leaver_releases_it(start):
    """Two synchronous clients: one trigger alone does not step, both -> exactly one step (a
    second trigger of the same client before it counts once); the other client leaving releases
    the step already triggered, and then the remaining client's trigger alone steps."""
    srv, (a, b) = start("--stopped", ports=2)
    assert vrep.simxSynchronous(a, True) == 0
    assert vrep.simxSynchronous(b, True) == 0
    assert vrep.simxStartSimulation(a, B) == 0
    t0 = ping_time(a)
    assert vrep.simxGetBooleanParameter(a, vrep.sim_boolparam_waiting_for_trigger, B) == (0, True)

    assert vrep.simxSynchronousTrigger(a) == 0
    assert ping_time(a) == t0 and ping_time(b) == t0  # b has not triggered
    assert vrep.simxSynchronousTrigger(a) == 0  # again: still one trigger of a
    assert ping_time(a) == t0
    assert vrep.simxSynchronousTrigger(b) == 0
    assert ping_time(b) == t0 + 50 and ping_time(a) == t0 + 50  # one step, not two

    assert vrep.simxSynchronousTrigger(b) == 0
    assert ping_time(b) == t0 + 50  # a's trigger was used by the step: re-armed
    vrep.simxFinish(a)  # a leaves: b's pending trigger releases its step
    wait_until(lambda: ping_time(b) == t0 + 100, timeout=10, what="the step released by a's leaving")
    assert vrep.simxSynchronousTrigger(b) == 0  # b alone now
    assert ping_time(b) == t0 + 150
    log = srv.stop()
    assert "out of synchronous mode (the step its other clients triggered runs now)" in log


def test_trigger_of_a_client_without_synchronous_mode_is_refused_and_steps_nothing(start):
    """Only a client that enabled synchronous mode may trigger (V-REP: the trigger answers an
    error on a connection without it); the last synchronous client's leaving resumes
    asynchronous stepping and sim_boolparam_waiting_for_trigger says so."""
    srv, (a, b) = start("--stopped", ports=2)
    assert vrep.simxSynchronous(a, True) == 0
    assert vrep.simxStartSimulation(b, B) == 0
    t0 = ping_time(b)
    assert vrep.simxSynchronousTrigger(b) == vrep.simx_return_remote_error_flag
    errors = vrep.simxGetLastErrors(b, B)
    assert errors[0] == 0 and "has not enabled synchronous mode" in errors[1][-1]
    assert ping_time(b) == t0 and ping_time(a) == t0
    assert vrep.simxGetBooleanParameter(b, vrep.sim_boolparam_waiting_for_trigger, B) == (0, True)
    assert vrep.simxSynchronous(a, False) == 0  # no synchronous client left: the simulation runs
    wait_until(lambda: ping_time(b) > t0 + 100, timeout=10, what="asynchronous steps")
    assert vrep.simxGetBooleanParameter(b, vrep.sim_boolparam_waiting_for_trigger, B) == (0, False)


def test_a_killed_synchronous_client_leaves_the_barrier_and_releases_the_step(start):
    """A synchronous client whose process dies (SIGKILL: its liveliness token goes, no Bye) is
    taken out of the barrier: the step the other client triggered runs, then its triggers
    alone step the simulation."""
    srv, (a,) = start("--stopped")
    other = textwrap.dedent(f"""
        import sys, vrep
        cid = vrep.simxStart('127.0.0.1', {srv.port}, True, True, 5000, 5)
        assert cid >= 0 and vrep.simxSynchronous(cid, True) == 0
        print('synchronous', flush=True)
        sys.stdin.readline()
    """)
    proc = subprocess.Popen([sys.executable, "-c", other], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    try:
        assert select.select([proc.stdout], [], [], 60)[0] and proc.stdout.readline().strip() == "synchronous"
        assert vrep.simxSynchronous(a, True) == 0
        assert vrep.simxStartSimulation(a, B) == 0
        t0 = ping_time(a)
        assert vrep.simxSynchronousTrigger(a) == 0
        assert ping_time(a) == t0  # the other client has not triggered
        proc.kill()  # by its own PID
        proc.wait(timeout=10)
        wait_until(lambda: ping_time(a) == t0 + 50, timeout=15, what="the step released by the killed client")
        assert vrep.simxSynchronousTrigger(a) == 0
        assert ping_time(a) == t0 + 100
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert "left: out of synchronous mode (the step its other clients triggered runs now)" in srv.stop()
