"""The synchronous trigger as V-REP answered it: before its step runs, the step overlapping the
reply's way back and the program's next call, with V-REP's guarantee kept that the next call
sees the step's result (docs/ARCHITECTURE.md, "The synchronous barrier").

Everything is asserted through values and order, never timings: a reply's simulation time (the
legacy header's, ``simxGetLastCmdTime``) says on which side of a step it was made. The slow
scene (heavy_step.xml: 4 ms or more a substep, 10 substeps a step at dt 1 ms, so a step of a
tenth of a second or more) makes sure that the calls after a trigger arrive while its step still runs.
"""

from __future__ import annotations

from pathlib import Path

import vrep

from conftest import ROOT, ServerProcess, free_port

B, S, BUF = vrep.simx_opmode_blocking, vrep.simx_opmode_streaming, vrep.simx_opmode_buffer
HEAVY = Path(__file__).resolve().parents[1] / "scenes" / "heavy_step.xml"
DT_MS = 1


def _connect(port: int) -> int:
    cid = vrep.simxStart("127.0.0.1", port, True, True, -30000, 5)  # blocking calls wait up to 30 s
    assert cid >= 0
    return cid


def test_the_trigger_is_answered_before_its_step_and_the_next_calls_after_it():
    """Per trigger: its reply carries the time before the step (answered before the step ran,
    as V-REP's); the ping that follows, and another client's blocking call sent while the
    slow step runs, carry the time after it (they waited for the step: the simulation thread
    owns the data). Steps are neither lost nor run twice."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(HEAVY), "--stopped", "--dt", str(DT_MS / 1000), ports=ports, renderers="on-demand")
    cid = other = -1
    try:
        cid, other = _connect(ports[0]), _connect(ports[1])
        assert vrep.simxSynchronous(cid, True) == 0 and vrep.simxStartSimulation(cid, B) == 0
        assert vrep.simxGetPingTime(cid)[0] == 0
        t0 = vrep.simxGetLastCmdTime(cid)
        for k in range(1, 3):
            assert vrep.simxSynchronousTrigger(cid) == 0
            assert vrep.simxGetLastCmdTime(cid) == t0 + (k - 1) * DT_MS  # answered before its step
            # Another client's blocking call, sent while that step runs, is served after it.
            assert vrep.simxGetPingTime(other)[0] == 0
            assert vrep.simxGetLastCmdTime(other) == t0 + k * DT_MS
            assert vrep.simxGetPingTime(cid)[0] == 0  # returns once the step is done
            assert vrep.simxGetLastCmdTime(cid) == t0 + k * DT_MS
        assert vrep.simxGetPingTime(cid)[0] == 0  # no trigger: no step
        assert vrep.simxGetLastCmdTime(cid) == t0 + 2 * DT_MS
    finally:
        for c in (cid, other):
            if c >= 0:
                vrep.simxFinish(c)
        srv.stop()


def test_a_blocking_read_right_after_the_trigger_sees_the_steps_result():
    """No ping: the blocking read sent right after the trigger is the step's (its value is
    the one a second client reads after the step, and its time is the step's)."""
    ports = [free_port(), free_port()]
    srv = ServerProcess(str(ROOT / "scenes" / "pcontroller.xml"), "--stopped", ports=ports, renderers="on-demand")
    cid = watcher = -1
    try:
        cid, watcher = _connect(ports[0]), _connect(ports[1])
        joint = vrep.simxGetObjectHandle(cid, "joint", B)[1]
        assert vrep.simxSynchronous(cid, True) == 0 and vrep.simxStartSimulation(cid, B) == 0
        assert vrep.simxSetJointTargetVelocity(cid, joint, 1.0, B) == 0
        assert vrep.simxGetPingTime(cid)[0] == 0
        t0, last = vrep.simxGetLastCmdTime(cid), None
        for k in range(1, 11):
            assert vrep.simxSynchronousTrigger(cid) == 0
            rc, q = vrep.simxGetJointPosition(cid, joint, B)
            assert rc == 0 and vrep.simxGetLastCmdTime(cid) == t0 + 50 * k
            rc, q_true = vrep.simxGetJointPosition(watcher, joint, B)
            assert rc == 0 and q == q_true and vrep.simxGetLastCmdTime(watcher) == t0 + 50 * k
            assert last is None or q > last  # it moves every step
            last = q
    finally:
        for c in (cid, watcher):
            if c >= 0:
                vrep.simxFinish(c)
        srv.stop()


def test_streaming_in_synchronous_mode_delivers_each_steps_update_in_order():
    """A stream's value in the inbox after trigger + ping is that step's, step after step."""
    srv = ServerProcess(str(ROOT / "scenes" / "pcontroller.xml"), "--stopped", renderers="on-demand")
    cid = -1
    try:
        cid = _connect(srv.port)
        joint = vrep.simxGetObjectHandle(cid, "joint", B)[1]
        assert vrep.simxSynchronous(cid, True) == 0 and vrep.simxStartSimulation(cid, B) == 0
        assert vrep.simxSetJointTargetVelocity(cid, joint, 1.0, B) == 0
        assert vrep.simxGetJointPosition(cid, joint, S)[0] == vrep.simx_return_novalue_flag
        assert vrep.simxGetPingTime(cid)[0] == 0
        t0 = vrep.simxGetLastCmdTime(cid)
        times, values = [], []
        for _ in range(20):
            assert vrep.simxSynchronousTrigger(cid) == 0
            assert vrep.simxGetPingTime(cid)[0] == 0
            rc, q = vrep.simxGetJointPosition(cid, joint, BUF)
            assert rc == 0
            times.append(vrep.simxGetLastCmdTime(cid))
            values.append(q)
        assert times == [t0 + 50 * k for k in range(1, 21)]
        assert values == sorted(values) and len(set(values)) == 20
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        srv.stop()
