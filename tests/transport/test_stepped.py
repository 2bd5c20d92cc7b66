"""Synchronous (stepped) mode as RL and control programs use it, through real servers."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import vrep
from conftest import ROOT, ServerProcess
from simx_client import api

B = vrep.simx_opmode_blocking


@pytest.fixture
def stepped():
    """Start a server on a scene, connect, enable synchronous mode and start the simulation."""
    started = []

    def start(scene: str):
        srv = ServerProcess(str(ROOT / "scenes" / scene), "--stopped", renderers="on-demand")
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        started.append((srv, cid))
        assert vrep.simxSynchronous(cid, True) == 0
        assert vrep.simxStartSimulation(cid, B) == 0
        return cid

    yield start
    for srv, cid in started:
        vrep.simxFinish(cid)
        srv.stop()


def step(cid: int) -> None:
    assert vrep.simxSynchronousTrigger(cid) == 0
    assert vrep.simxGetPingTime(cid)[0] == 0  # returns once the triggered step is done


def test_p_controller_reaches_each_target(stepped):
    """CoppeliaSim's pController example: the client closes a P loop on a velocity-mode joint."""
    cid = stepped("pcontroller.xml")
    joint = vrep.simxGetObjectHandle(cid, "joint", B)[1]
    assert vrep.simxGetJointPosition(cid, joint, vrep.simx_opmode_streaming)[0] == 1
    step(cid)
    max_velocity, max_force, gain = math.radians(180), 100.0, 5.0  # rad/s, N·m, 1/s
    for target_deg in (45, 90, -89, 0):
        target = math.radians(target_deg)
        for _ in range(400):
            rc, angle = vrep.simxGetJointPosition(cid, joint, vrep.simx_opmode_buffer)
            assert rc == 0
            if abs(angle - target) < math.radians(0.1):
                break
            velocity = float(np.clip(gain * (target - angle), -max_velocity, max_velocity))
            vrep.simxPauseCommunication(cid, True)
            vrep.simxSetJointTargetVelocity(cid, joint, velocity, vrep.simx_opmode_oneshot)
            vrep.simxSetJointMaxForce(cid, joint, max_force, vrep.simx_opmode_oneshot)
            vrep.simxPauseCommunication(cid, False)
            step(cid)
        else:
            pytest.fail(f"joint did not reach {target_deg} deg (at {math.degrees(angle):.2f})")
        assert angle == pytest.approx(target, abs=math.radians(0.1))


def test_streams_deliver_one_value_per_step_and_time_advances_by_dt(stepped):
    cid = stepped("pcontroller.xml")
    joint = vrep.simxGetObjectHandle(cid, "joint", B)[1]
    vrep.simxGetJointPosition(cid, joint, vrep.simx_opmode_streaming)
    step(cid)
    times = []
    for _ in range(10):
        step(cid)
        vrep.simxGetJointPosition(cid, joint, vrep.simx_opmode_buffer)
        times.append(vrep.simxGetLastCmdTime(cid))
    assert np.all(np.diff(times) == 50)


def test_cart_pole_balanced_by_force_control(stepped):
    """Torque (force) control through a velocity-mode joint: max force = |u|, target velocity = sign(u)*big."""
    cid = stepped("cartpole.xml")
    cart = vrep.simxGetObjectHandle(cid, "joint_1", B)[1]
    pole = vrep.simxGetObjectHandle(cid, "joint_2", B)[1]
    assert vrep.simxSetJointPosition(cid, pole, 0.1, B) == 0  # start tilted by 0.1 rad
    for h in (cart, pole):
        vrep.simxGetJointPosition(cid, h, vrep.simx_opmode_streaming)
    step(cid)
    gains = np.array([2.0, 3.0, 40.0, 8.0])  # x, x', theta, theta'
    previous, worst = None, 0.0
    for k in range(200):  # 10 s of simulation
        x = vrep.simxGetJointPosition(cid, cart, vrep.simx_opmode_buffer)[1]
        theta = vrep.simxGetJointPosition(cid, pole, vrep.simx_opmode_buffer)[1]
        previous = previous or (x, theta)
        state = np.array([x, (x - previous[0]) / 0.05, theta, (theta - previous[1]) / 0.05])
        previous = (x, theta)
        u = float(gains @ state)
        vrep.simxPauseCommunication(cid, True)
        vrep.simxSetJointForce(cid, cart, abs(u), vrep.simx_opmode_oneshot)
        vrep.simxSetJointTargetVelocity(cid, cart, math.copysign(1000.0, u), vrep.simx_opmode_oneshot)
        vrep.simxPauseCommunication(cid, False)
        step(cid)
        if k > 60:
            worst = max(worst, abs(theta))
    assert worst < 0.05, f"pole not balanced: |theta| reached {worst:.3f} rad"
    assert abs(x) < 0.5


def test_two_clients_share_one_stepped_simulation(stepped):
    """A second client on the same server sees the time advance only with the first one's triggers."""
    cid = stepped("pcontroller.xml")
    port = api._connections[cid].port
    probe = textwrap.dedent(f"""
        import vrep
        cid = vrep.simxStart('127.0.0.1', {port}, True, True, 5000, 5)
        vrep.simxGetPingTime(cid)
        print(vrep.simxGetLastCmdTime(cid))
        vrep.simxFinish(cid)
    """)
    run = lambda: int(subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                                     timeout=60).stdout.strip())
    t0 = run()
    step(cid)
    step(cid)
    assert run() == t0 + 100
