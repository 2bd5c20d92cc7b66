"""CoppeliaSim 4.3-4.5's positional ``sim.moveToConfig`` / ``sim.moveToPose`` with a callback, over
the ZMQ remote API with the official client: the client's Python function is passed as
``"name@func"``, the server answers the pending call with ``{func: name, args}`` once per step,
the client runs it (its own ``sim.*`` calls served meanwhile) and answers ``_*executed*_``."""

from __future__ import annotations

import math
from pathlib import Path

import cbor2
import pytest

from conftest import ServerProcess, free_port, wait_until

RemoteAPIClient = pytest.importorskip("coppeliasim_zmqremoteapi_client").RemoteAPIClient
zmq = pytest.importorskip("zmq")

SCENES = Path(__file__).resolve().parents[1] / "scenes" / "zmq"


@pytest.fixture(scope="module")
def zmq_server():
    port = free_port()
    srv = ServerProcess(str(SCENES / "scripted.xml"), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    srv.zmq_port = port
    yield srv
    srv.stop()


@pytest.fixture
def sim(zmq_server, official):
    sim = official(zmq_server.zmq_port).require("sim")
    yield sim
    sim.stopSimulation()
    sim.setStepping(False)


def test_move_to_config_positional_with_callback_moves_the_joint(sim):
    joint = sim.getObject("/ArmJoint")
    dt = sim.getSimulationTimeStep()
    calls = []

    def follow(config, vel, accel, handles):  # a nested sim call per step, as the examples do
        calls.append((sim.getSimulationTime(), list(config), list(vel)))
        sim.setJointTargetPosition(handles[0], config[0])

    # Stepped by this client: the simulation advances only by the motion's own steps, not by
    # however long the machine takes between this client's calls (a free-running simulation
    # took a step or two more under load, so the count of callbacks against the time was loose).
    assert sim.setStepping(True) == 0
    sim.startSimulation()
    t0 = sim.getSimulationTime()
    pos, vel, accel, time_left = sim.moveToConfig(
        -1, [0.0], None, None, [1.0], [2.0], [20.0], [0.8], None, follow, [joint]
    )
    steps = round((sim.getSimulationTime() - t0) / dt)
    assert pos == pytest.approx([0.8]) and vel == pytest.approx([0.0], abs=1e-9) and time_left >= 0
    assert len(accel) == 1
    assert calls[-1][1] == pytest.approx([0.8])
    assert len(calls) == steps  # one callback per step the motion took
    times = [c[0] for c in calls]
    assert all(b - a == pytest.approx(dt) for a, b in zip(times, times[1:]))  # one step between callbacks
    assert max(abs(c[2][0]) for c in calls) == pytest.approx(1.0, abs=0.01)  # maxVel reached, not passed
    assert sim.setStepping(False) == 1  # the motion's own stepping is over: only ours was left
    wait_until(lambda: abs(sim.getJointPosition(joint) - 0.8) < 0.02, 5, what="the joint follows its target")


def test_move_to_pose_positional_with_callback_and_metric(sim):
    dummy = sim.createDummy(0.02)
    poses = []

    def place(pose, vel, accel, handle):
        poses.append(list(pose))
        sim.setObjectPose(handle, -1, pose)  # 4.3-4.5's argument order

    sim.startSimulation()
    start = [0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0]
    goal = [0.3, 0.0, 0.2, 0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]
    end_pose, time_left = sim.moveToPose(-1, start, [0.5], [2.0], [40.0], goal, place, dummy, [1, 1, 1, 0.1])
    assert end_pose == pytest.approx(goal, abs=1e-6) and time_left >= 0
    assert sim.getObjectPose(dummy, -1) == pytest.approx(goal, abs=1e-6)
    assert len(poses) > 10 and poses[0][0] < 0.05  # started at the start, stepwise
    xs = [p[0] for p in poses]
    assert all(b >= a - 1e-12 for a, b in zip(xs, xs[1:]))  # along the straight line, monotonic


def test_callback_error_ends_the_call_and_leaves_the_server_clean(sim, zmq_server, official):
    joint = sim.getObject("/ArmJoint")

    def broken(config, vel, accel, aux):
        raise RuntimeError("callback failed on purpose")

    sim.startSimulation()
    with pytest.raises(RuntimeError, match="on purpose"):
        sim.moveToConfig(-1, [0.0], None, None, [1.0], [2.0], [20.0], [0.5], None, broken, [joint])
    # the client's next motion abandons the suspended one, and runs to its end
    moved = []
    out = sim.moveToConfig(
        -1, [0.0], None, None, [1.0], [2.0], [20.0], [0.3], None, lambda c, v, a, h: moved.append(c[0]), [joint]
    )
    assert out[0] == pytest.approx([0.3]) and moved[-1] == pytest.approx(0.3)
    assert sim.setStepping(False) == 0  # neither motion left its stepping behind
    other = official(zmq_server.zmq_port).require("sim")
    t = other.getSimulationTime()
    wait_until(lambda: other.getSimulationTime() > t, 5, what="the simulation runs on its own again")


def test_client_gone_mid_callback_leaves_nothing_behind(sim, zmq_server):
    joint = sim.getObject("/ArmJoint")
    sim.startSimulation()
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REQ)
    sock.connect(f"tcp://127.0.0.1:{zmq_server.zmq_port}")
    args = [-1, [0.0], None, None, [1.0], [2.0], [20.0], [0.5], None, "cb_1@func", [joint]]
    sock.send(
        cbor2.dumps(
            {
                "func": "sim.moveToConfig",
                "args": args,
                "uuid": "gone-client",
                "ver": 2,
                "lang": "python",
                "timeout": 600,
            }
        )
    )
    assert sock.poll(10_000)
    reply = cbor2.loads(sock.recv())
    assert reply["func"] == "cb_1" and len(reply["args"]) == 4 and reply["args"][3] == [joint]
    sock.close(linger=0)
    ctx.term()
    # its stepping ended with its connection: the simulation steps without it
    t = sim.getSimulationTime()
    wait_until(lambda: sim.getSimulationTime() > t + 0.05, 10, what="the simulation steps once the client is gone")


def test_callback_forms_are_checked(sim):
    joint = sim.getObject("/ArmJoint")

    def ignore(*args):
        pass

    with pytest.raises(Exception, match=r"sim\.moveToConfig: .*callback"):
        sim.moveToConfig(-1, [0.0], None, None, [1.0], [2.0], [20.0], [0.5], None, "not a function", [joint])
    with pytest.raises(Exception, match=r"sim\.moveToConfig: .*targetPos"):
        sim.moveToConfig(-1, [0.0, 0.0], None, None, [1.0] * 2, [2.0] * 2, [20.0] * 2, [0.5], None, ignore, 0)
    with pytest.raises(Exception, match=r"sim\.moveToPose: .*targetPose"):
        sim.moveToPose(-1, [0, 0, 0, 0, 0, 0, 1], [1], [1], [1], [0, 0], ignore, 0)

    def nested_step(config, vel, accel, aux):
        sim.step()

    sim.startSimulation()
    with pytest.raises(Exception, match=r"sim\.moveToConfig: the motion ended while its callback ran"):
        sim.moveToConfig(-1, [0.0], None, None, [1.0], [2.0], [20.0], [0.5], None, nested_step, 0)
    assert sim.setStepping(False) == 0
