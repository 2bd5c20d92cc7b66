"""CoppeliaSim's ZMQ remote API with the official client (coppeliasim-zmqremoteapi-client) against a
real simx-server: what zmqRemoteApi.info lists, errors that name the function, stepping mode
with one and several clients, sim.acquireLock, clients leaving, calls into child scripts."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest

from conftest import ServerProcess, free_port, wait_until

RemoteAPIClient = pytest.importorskip("coppeliasim_zmqremoteapi_client").RemoteAPIClient

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
    """The ``sim`` of a fresh client; the simulation stopped and no client stepped afterwards."""
    sim = official(zmq_server.zmq_port).require("sim")
    yield sim
    sim.stopSimulation()  # also ends every ZMQ client's stepping mode, as CoppeliaSim's server does
    sim.setStepping(False)


def test_info_lists_facade_calls_constants_and_coppeliasim_names(sim):
    assert callable(sim.getObject) and callable(sim.step) and callable(sim.getVisionSensorImg)
    assert sim.handle_world == -1 and sim.simulation_stopped == 0 and sim.scripttype_childscript == 1
    assert sim.verbosity_scriptinfos == 450 and sim.stringparam_scenedefaultdir == 132  # CoppeliaSim 4.x's
    assert sim.jointintparam_motor_enabled == 2000  # the facade's (legacy) constants, simx's values
    with pytest.raises(Exception, match=r"sim\.generateTextShape: not implemented by simx"):
        sim.generateTextShape("simx")  # CoppeliaSim has it: listed, answered with an error


def test_errors_name_the_function_and_the_problem(sim):
    with pytest.raises(Exception, match=r"sim\.getObject: object '/Nowhere' does not exist"):
        sim.getObject("/Nowhere")
    assert sim.getObject("/Nowhere", {"noError": True}) == -1
    with pytest.raises(Exception, match=r"sim\.getJointPosition: .*argument"):
        sim.getJointPosition()
    with pytest.raises(Exception, match=r"sim\.getJointPosition: object '/Nowhere' does not exist"):
        sim.getJointPosition("/Nowhere")  # an object argument may be a path (CoppeliaSim 4.3+)
    with pytest.raises(Exception, match=r"sim\.getJointPosition: object handle must be an integer"):
        sim.getJointPosition(1.5)
    assert sim.getJointPosition(sim.getObject("/ArmJoint")) == sim.getJointPosition("ArmJoint") == 0.0


def test_object_paths_of_coppeliasim_4(sim):
    arm, joint = sim.getObject("/Arm"), sim.getObject("/ArmJoint")
    assert sim.getObject("/ArmJoint/Arm") == arm  # the joint carries the body: it is the body's parent
    assert sim.getObject("/Arm*") == joint  # wildcards: the first match in tree order
    assert sim.getObject("/Arm*", {"index": 1}) == arm
    assert sim.getObject("/Arm*", {"index": 2, "noError": True}) == -1
    assert sim.getObject("ArmJoint") == joint  # a V-REP name
    # a remote client has no object of its own: ./X, ./X[i] and :/X start from the scene root
    assert sim.getObject("./Arm") == sim.getObject(":/Arm") == sim.getObject("./ArmJoint[0]/Arm") == arm


def test_a_4x_program_first_calls(sim):
    assert sim.getInt32Param(sim.intparam_program_version) == 40800  # CoppeliaSim 4.8.0
    assert sim.getInt32Param(sim.intparam_dynamic_engine) == sim.physics_mujoco
    # deprecated 4.x names are listed (no AttributeError from the client) and answer or name themselves
    for name in ("getScriptHandle", "getVisionSensorResolution", "getObjectName", "rmlMoveToPosition"):
        assert callable(getattr(sim, name))
    with pytest.raises(Exception, match=r"sim\.rmlMoveToPosition: not implemented by simx"):
        sim.rmlMoveToPosition(-1, -1, -1, [0] * 4, [0] * 4, [0] * 4, [0] * 4, [0] * 3, [0] * 4, [0] * 4, [0] * 4)
    assert sim.isDeprecated("sim.getScriptHandle") == 1 and sim.isDeprecated("getObject") == 0
    with pytest.raises(Exception, match=r"sim\.quitSimulator: .*refused"):
        sim.quitSimulator()


def test_wait_for_signal_set_by_another_client(sim, zmq_server, official):
    sim.startSimulation()
    setter = threading.Timer(0.3, lambda: official(zmq_server.zmq_port).require("sim").setInt32Signal("go", 7))
    setter.start()
    try:
        assert sim.waitForSignal("go") == 7  # the call lasts steps until the other client sets it
    finally:
        setter.join()
        sim.clearInt32Signal("go")


def test_string_signals_come_back_as_text(sim):
    """CoppeliaSim's example programs compare sim.getStringSignal's value with a str (the
    movement examples wait for 'ready'): a UTF-8 value comes back as text, any other as bytes;
    sim.getBufferSignal (4.6's name for the same store) always as bytes."""
    try:
        sim.setStringSignal("/arm_executedMovId", "ready")
        assert sim.getStringSignal("/arm_executedMovId") == "ready"
        sim.setStringSignal("/arm_executedMovId", "überall")
        assert sim.getStringSignal("/arm_executedMovId") == "überall"
        assert sim.getBufferSignal("/arm_executedMovId") == "überall".encode()
        sim.setStringSignal("raw", b"\xff\x00\x80")
        assert sim.getStringSignal("raw") == b"\xff\x00\x80"
        assert sim.getStringSignal("never set") is None
    finally:
        sim.clearStringSignal()


def test_the_ready_line_says_how_a_running_pass_serves_zmq(zmq_server):
    """The pace a client that does not step gets: CoppeliaSim's 2 ms per client and pass."""
    assert "(a running pass serves its requests 2 ms per client, as CoppeliaSim's)" in zmq_server.ready_line


def test_stepping_one_client(sim):
    dt = sim.getSimulationTimeStep()
    assert sim.setStepping(True) == 0  # the previous level
    sim.startSimulation()
    t0 = sim.getSimulationTime()
    for _ in range(5):
        sim.step()
    assert sim.getSimulationTime() == pytest.approx(t0 + 5 * dt)
    assert sim.getBoolParam(sim.boolparam_waiting_for_trigger) is True


def test_stepping_waits_for_every_stepped_client(sim, zmq_server, official):
    other = official(zmq_server.zmq_port).require("sim")
    watcher = official(zmq_server.zmq_port).require("sim")  # not stepped: it only looks
    sim.setStepping(True)
    other.setStepping(True)
    sim.startSimulation()
    t0 = watcher.getSimulationTime()
    done = threading.Event()
    stepper = threading.Thread(target=lambda: (sim.step(), done.set()))
    stepper.start()
    # This client's sim.step() waits: the other stepped client has not asked for the step yet.
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        assert watcher.getSimulationTime() == t0 and not done.is_set()
    other.step()  # completes the barrier: one step, and both calls return
    stepper.join(10)
    assert done.is_set()
    assert watcher.getSimulationTime() == pytest.approx(t0 + sim.getSimulationTimeStep())
    other.setStepping(False)


def test_a_lock_holds_the_simulation(sim, zmq_server, official):
    sim.startSimulation()  # asynchronous: it runs on its own
    watcher = official(zmq_server.zmq_port).require("sim")
    t = watcher.getSimulationTime()
    wait_until(lambda: watcher.getSimulationTime() > t, what="the simulation running")
    sim.acquireLock()
    held = watcher.getSimulationTime()
    deadline = time.monotonic() + 0.3
    while time.monotonic() < deadline:
        assert watcher.getSimulationTime() == held
    sim.releaseLock()
    wait_until(lambda: watcher.getSimulationTime() > held, what="the simulation running again")


def test_a_stepped_client_that_goes_releases_the_simulation(sim, zmq_server):
    client = RemoteAPIClient("127.0.0.1", zmq_server.zmq_port)
    gone = client.require("sim")
    gone.setStepping(True)
    sim.startSimulation()
    t = sim.getSimulationTime()
    gone.step()
    assert sim.getSimulationTime() > t  # its step ran (it alone was stepped)
    t = sim.getSimulationTime()
    del gone
    client.__del__()  # the program ends: its socket closes
    wait_until(lambda: sim.getSimulationTime() > t + 0.2, what="the simulation running on its own again")


def test_stop_ends_stepping_as_coppeliasim_does(sim):
    sim.setStepping(True)
    sim.setStepping(True)
    assert sim.setStepping(True) == 2
    sim.startSimulation()
    sim.stopSimulation()
    assert sim.getSimulationState() == sim.simulation_stopped
    assert sim.setStepping(True) == 0  # the stop reset it


def test_a_joints_control_mode_through_both_doors(sim, zmq_server):
    """sim.jointintparam_dynctrlmode (2039, CoppeliaSim 4.x; simx_server/sim/dyn_ctrl.py) read and
    written by a ZMQ client and by a legacy one (simxSetObjectIntParameter), the same joint."""
    import vrep

    joint = sim.getObject("/ArmJoint")
    assert sim.getObjectInt32Param(joint, sim.jointintparam_dynctrlmode) == sim.jointdynctrl_position
    force, velocity = sim.getJointTargetForce(joint), sim.getJointTargetVelocity(joint)
    cid = vrep.simxStart("127.0.0.1", zmq_server.port, True, True, 5000, 5)
    assert cid >= 0
    B = vrep.simx_opmode_blocking
    try:
        sim.setObjectInt32Param(joint, sim.jointintparam_dynctrlmode, sim.jointdynctrl_force)
        sim.setJointTargetForce(joint, -0.5)
        assert vrep.simxGetObjectIntParameter(cid, joint, 2039, B) == (0, 1)
        assert vrep.simxGetObjectIntParameter(cid, joint, vrep.sim_jointintparam_ctrl_enabled, B) == (0, 0)
        assert sim.getJointTargetForce(joint) == -0.5
        assert vrep.simxSetObjectIntParameter(cid, joint, 2039, 4, B) == 0  # velocity
        assert sim.getObjectInt32Param(joint, sim.jointintparam_dynctrlmode) == sim.jointdynctrl_velocity
        assert vrep.simxSetObjectIntParameter(cid, joint, 2039, 7, B) == vrep.simx_return_remote_error_flag
    finally:  # the stopped scene's mode and targets back (a stop while stopped resets nothing)
        vrep.simxSetObjectIntParameter(cid, joint, 2039, 8, B)
        vrep.simxFinish(cid)
        sim.setJointTargetVelocity(joint, velocity)
        sim.setJointTargetForce(joint, force)
    assert sim.getObjectInt32Param(joint, sim.jointintparam_dynctrlmode) == sim.jointdynctrl_position


def test_step_while_stopped_returns_at_once(sim):
    sim.setStepping(True)
    sim.step()
    assert sim.getSimulationTime() == 0.0


@pytest.mark.parametrize("box", ["LuaBox", "PyBox"])
def test_call_script_function_with_any_values(sim, box):
    sim.startSimulation()  # child scripts run while the simulation runs
    values = (1, 2.5, "text", [1, 2, 3], {"a": 1}, b"\x00\xff")
    assert sim.callScriptFunction(f"echo@/{box}", sim.scripttype_childscript, *values) == values
    script = sim.getScript(sim.scripttype_childscript, sim.getObject(f"/{box}"))
    count, keys, alias = sim.callScriptFunction("describe", script, {"x": 1, "y": 2})
    assert (count, keys, alias) == (2, ["x", "y"], box)
    funcs = sim.getScriptFunctions(script)  # the client's wrapper of callScriptFunction(func, script, ...)
    assert funcs.echo(7) == 7
    with pytest.raises(Exception, match="failing on purpose"):
        funcs.fail()
    with pytest.raises(Exception, match="no function 'nope'"):
        funcs.nope()
    assert sim.getScript(sim.scripttype_childscript, sim.getObject("/Arm")) == -1


def test_scene_by_coppeliasim_name_and_confinement(sim, zmq_server):
    with pytest.raises(Exception, match=r"no MJCF file stands in for '.*nowhere\.ttt': looked for nowhere\.xml"):
        sim.loadScene(sim.getStringParam(sim.stringparam_scenedefaultdir) + "/nowhere.ttt")
    with pytest.raises(Exception, match="refused"):
        sim.loadScene("/etc/passwd")
    sim.loadScene(sim.getStringParam(sim.stringparam_scenedefaultdir) + "/scripted.ttt")
    assert sim.getStringParam(sim.stringparam_scene_name) == "scripted.xml"
    sim.startSimulation()
    with pytest.raises(Exception, match="stop the simulation first"):
        sim.loadScene("scripted.xml")


def test_wait_and_motions_last_several_steps(sim):
    dt = sim.getSimulationTimeStep()
    # Stepped by this client: the simulation advances only by the steps these calls take, not
    # by however long the machine takes between two calls (a free-running simulation took a
    # step or two more under load).
    assert sim.setStepping(True) == 0
    sim.startSimulation()
    t0 = sim.getSimulationTime()
    assert sim.wait(0.25) == pytest.approx(0.0, abs=1e-6)  # 5 steps
    assert sim.getSimulationTime() == pytest.approx(t0 + 0.25, abs=1e-9)  # exactly the 5 steps
    joint = sim.getObject("/ArmJoint")
    out = sim.moveToConfig({"joints": [joint], "targetPos": [0.5], "maxVel": [1], "maxAccel": [2], "maxJerk": [20]})
    assert out["pos"] == pytest.approx([0.5]) and out["targetPos"] == [0.5]
    assert sim.getJointTargetPosition(joint) == pytest.approx(0.5)
    took = sim.getSimulationTime() - t0 - 0.25
    assert 0.9 < took < 2.0 and round(took / dt) == pytest.approx(took / dt)  # whole steps, about 1.3 s of motion
    with pytest.raises(Exception, match="'callback' is not supported"):
        sim.moveToConfig({"joints": [joint], "targetPos": [0], "callback": "f@func"})
    with pytest.raises(Exception, match="targetPos"):
        sim.moveToConfig({"joints": [joint], "targetPos": [0, 1]})
    assert sim.setStepping(False) == 1  # the motion's own stepping level is over: only ours was left


def test_simik_maps_onto_the_scenes_ik_groups(official):
    port = free_port()
    ik_scene = Path(__file__).resolve().parents[2] / "scenes" / "ur5_ik.xml"
    srv = ServerProcess(str(ik_scene), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    try:
        client = official(port)
        sim, simIK = client.require("sim"), client.require("simIK")  # noqa: N806 (CoppeliaSim's name)
        env = simIK.createEnvironment()
        group = simIK.getGroupHandle(env, "UR5")
        assert group == sim.getIkGroupHandle("UR5") and simIK.doesGroupExist(env, "UR5")
        assert not simIK.doesGroupExist(env, "nothing")
        assert simIK.handleGroup(env, group)[0] == simIK.result_success
        with pytest.raises(Exception, match=r"simIK\.addElementFromScene: .*declared in the MJCF"):
            simIK.addElementFromScene(env, group, -1, -1, -1, simIK.constraint_pose)
        with pytest.raises(Exception, match="no IK environment 5"):
            simIK.handleGroup(5, group)
    finally:
        srv.stop()
