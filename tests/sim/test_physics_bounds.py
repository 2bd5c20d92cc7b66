"""Issue 11, physics side: bounded work per step, physical ranges, blow-ups without a flood.

Reproductions of the issue (real servers on loopback) and unit checks of the bounds
(in-process ``Simulation``/``World``). Bounds live in ``simx_server.base.limits``.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client.protocol import ArgumentError, RemoteError
from simx_server.commands import joints, objects, parameters, signals
from simx_server.base import limits
from simx_server.commands import parameters as cmd_parameters
from simx_server.sim.physics import PhysicsError
from simx_server.api.signals import Signals
from simx_server.scene.simulation import Simulation
from simx_server.sim.state import RunState
from simx_server.sim.world import World

import vrep

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
B = vrep.simx_opmode_blocking
DT = vrep.sim_floatparam_simulation_time_step
MASS = 3005  # sim_shapefloatparam_mass
CTRL_LOOP = 2001  # sim_jointintparam_ctrl_enabled


# ------------------------------------------------------------------- helpers
def _sim_time(cid: int) -> int:
    """Simulation time (ms) stamped on a fresh reply."""
    assert vrep.simxGetPingTime(cid)[0] == 0
    return vrep.simxGetLastCmdTime(cid)


def _running(cid: int) -> bool:
    """The server-state bit 0 (simulation not stopped) of a fresh reply."""
    assert vrep.simxGetPingTime(cid)[0] == 0
    ok, state = vrep.simxGetInMessageInfo(cid, vrep.simx_headeroffset_server_state)
    assert ok == 1
    return bool(state & 1)


def _last_error(cid: int) -> str:
    rc, errors = vrep.simxGetLastErrors(cid, B)
    assert rc == 0 and errors, "the server kept no error for this client"
    return errors[-1]


def _connect(srv: ServerProcess) -> int:
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    assert cid >= 0
    return cid


def _scene(tmp_path: Path, option: str = "", camera: str = "") -> Path:
    path = tmp_path / "scene.xml"
    path.write_text(f"""<mujoco>
  <option {option}/>
  <worldbody>
    <body name="Box" pos="0 0 1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="1"/>
      {camera}
    </body>
  </worldbody>
</mujoco>""")
    return path


@pytest.fixture(scope="module")
def sim():
    s = Simulation(SCENE, renderers_at_load=False)  # module-scoped: the marker does not reach it
    yield s
    s.close()


# ------------------------------------------------- defect 1: work per step
def test_huge_time_step_is_refused_and_the_server_keeps_running():
    """Issue: stop; dt = 1e7; start -> the process exited (an exception in mj_step)."""
    srv = ServerProcess(str(SCENE), "--speed", "0", renderers="on-demand")
    try:
        cid = _connect(srv)
        assert vrep.simxStopSimulation(cid, B) == 0
        for bad in (1e7, math.inf, math.nan, 0.0, -0.05):
            assert vrep.simxSetFloatingParameter(cid, DT, bad, B) == vrep.simx_return_remote_error_flag, bad
            assert "MAX_DT" in _last_error(cid)
        assert vrep.simxGetFloatingParameter(cid, DT, B) == (0, pytest.approx(0.05))
        assert vrep.simxSetFloatingParameter(cid, DT, limits.MAX_DT, B) == 0  # the bound itself is fine
        assert vrep.simxStartSimulation(cid, B) == 0
        wait_until(lambda: _sim_time(cid) >= 3000, timeout=10, what="three 1 s steps")
        assert srv.proc.poll() is None
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    assert srv.proc.returncode == 0, log
    assert "internal error" not in log and "Traceback" not in log, log


def test_cli_refuses_a_time_step_out_of_bounds():
    """``--dt`` obeys the same bound, with a one-line error and exit status 2."""
    out = subprocess.run([sys.executable, "-m", "simx_server.cli", "--dt", "1e7", "--port", str(free_port())],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 2
    assert "MAX_DT" in out.stderr and "--dt" in out.stderr and "Traceback" not in out.stderr, out.stderr


@pytest.mark.parametrize("dt", [1e300, math.inf, math.nan, 0.0, -1.0, 1.5])
def test_world_refuses_a_time_step_out_of_bounds(dt):
    with pytest.raises(ValueError, match="MAX_DT"):
        World(SCENE, dt)


def test_time_step_making_too_many_substeps_is_refused(tmp_path):
    scene = _scene(tmp_path, option='timestep="1e-5"')  # 0.5 s = 50,000 substeps
    with pytest.raises(ValueError, match="MAX_SUBSTEPS"):
        World(scene, 0.5)
    world = World(scene, 0.05)  # 5,000 substeps: fine
    with pytest.raises(ArgumentError, match="MAX_SUBSTEPS"):
        world.set_dt(0.5)
    assert (world.substeps, world.dt) == (5000, pytest.approx(0.05))  # unchanged


def test_time_step_in_bounds_is_set_while_stopped(sim):
    parameters.set_floating_parameter(sim, [1, 0.01])
    assert parameters.get_floating_parameter(sim, [1]) == pytest.approx(0.01)
    with pytest.raises(ArgumentError, match="MAX_DT"):
        parameters.set_floating_parameter(sim, [1, 1e300])  # what a raw client can send
    parameters.set_floating_parameter(sim, [1, 0.05])


def test_scene_with_a_huge_camera_resolution_is_refused(tmp_path):
    cam = '<camera name="eye" resolution="{} 480"/>'
    World(_scene(tmp_path, camera=cam.format(limits.MAX_RESOLUTION)))
    with pytest.raises(ValueError, match="MAX_RESOLUTION"):
        World(_scene(tmp_path, camera=cam.format(limits.MAX_RESOLUTION + 1)))


def test_models_and_scenes_loaded_by_clients_obey_the_scene_bounds(tmp_path):
    """simxLoadModel / simxLoadScene: a camera too large, or a timestep too small for dt, is
    refused before anything changes (server-side files of a --scene-path folder)."""
    sim = Simulation(SCENE, scene_paths=[tmp_path])
    try:
        _check_scene_bounds(sim, tmp_path)
    finally:
        sim.close()


def _check_scene_bounds(sim, tmp_path):
    from simx_server.commands import editing as editing_commands

    model = tmp_path / "eye.xml"
    model.write_text(f'<mujoco><worldbody><body name="Eye"><geom size="0.1"/>'
                     f'<camera name="eye" resolution="{limits.MAX_RESOLUTION * 4} 16"/></body></worldbody></mujoco>')
    before = dict(sim.world.objects)
    with pytest.raises(ArgumentError, match="MAX_RESOLUTION"):
        editing_commands.load_model(sim, [str(model), 0])
    assert sim.world.objects == before and "Eye" not in sim.world.by_name
    scene = _scene(tmp_path, option='timestep="1e-7"')  # 0.05 s = 500,000 substeps
    with pytest.raises(RemoteError, match="MAX_SUBSTEPS"):
        editing_commands.load_scene(sim, [str(scene), 0])
    assert sim.world.objects == before


# ------------------------------------------------ defect 2: physical ranges
def test_gravity_flood_reproduction_is_refused_and_time_advances():
    """Issue: gravity [0, 0, -3e38] -> 188 KB/s of MuJoCo warnings, simulation time stuck."""
    srv = ServerProcess(str(SCENE), "--speed", "0", renderers="on-demand")
    try:
        cid = _connect(srv)
        grav = vrep.sim_arrayparam_gravity
        for bad in ([0, 0, -3e38], [0, 0, math.inf], [0, math.nan, 0], [0, 0, -1001]):
            assert vrep.simxSetArrayParameter(cid, grav, bad, B) == vrep.simx_return_remote_error_flag, bad
            assert "MAX_GRAVITY" in _last_error(cid)
        rc, ball = vrep.simxGetObjectHandle(cid, "Sphere", B)
        assert rc == 0
        assert vrep.simxSetObjectFloatParameter(cid, ball, MASS, 3e38, B) == vrep.simx_return_remote_error_flag
        assert "MAX_MASS" in _last_error(cid)
        assert vrep.simxSetArrayParameter(cid, grav, [0, 0, -20], B) == 0  # in range: accepted
        t0 = _sim_time(cid)
        wait_until(lambda: _sim_time(cid) > t0 + 2000, timeout=10, what="simulation time advancing")
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    assert "unstable" not in log and "MuJoCo" not in log, log
    assert len(log.splitlines()) < 20, log  # a few lines: ready, client, the refused calls


def test_joint_values_out_of_range_are_argument_errors(sim):
    """Issue 11 (server side): every float a client writes into a joint is finite and in range."""
    sim.start()
    w = sim.world
    h = w.resolve("UR5_joint2").handle
    q0 = w.joint_position(h)
    for bad in (1e39, -1e5, math.inf, math.nan):
        with pytest.raises(ArgumentError, match="MAX_JOINT_POSITION"):
            joints.set_joint_position(sim, [h, bad])
        with pytest.raises(ArgumentError, match="MAX_JOINT_POSITION"):
            joints.set_joint_target_position(sim, [h, bad])
    assert w.joint_position(h) == q0  # nothing was written
    for bad in (1e9, math.inf, -math.inf, math.nan):
        with pytest.raises(ArgumentError, match="MAX_JOINT_FORCE"):
            joints.set_joint_force(sim, [h, bad])
    joints.set_joint_force(sim, [h, -200.0])
    assert w.joint_max_force(h) == 200.0
    joints.set_joint_position(sim, [h, 0.5])
    assert w.joint_position(h) == 0.5
    cmd_parameters.set_object_int_parameter(sim, [h, CTRL_LOOP, 0])  # velocity control
    for bad in (1e7, math.nan):
        with pytest.raises(ArgumentError, match="MAX_JOINT_VELOCITY"):
            joints.set_joint_target_velocity(sim, [h, bad])
    joints.set_joint_target_velocity(sim, [h, -1e4])  # the torque-control idiom still works
    for bad in (1e7, math.inf):
        with pytest.raises(ArgumentError, match="MAX_JOINT_VELOCITY"):
            cmd_parameters.set_object_float_parameter(sim, [h, 2017, bad])
    sim.stop()


def test_masses_positions_and_rotations_out_of_range_are_argument_errors(sim):
    sim.start()
    w = sim.world
    ball = w.resolve("Sphere").handle
    for bad in (1e308, 1e7, 1e-7, 0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ArgumentError, match="MASS"):
            cmd_parameters.set_object_float_parameter(sim, [ball, MASS, bad])
    assert cmd_parameters.get_object_float_parameter(sim, [ball, MASS]) > 0
    cmd_parameters.set_object_float_parameter(sim, [ball, MASS, 1e6])  # the bound itself
    for bad in ([1e5, 0, 0], [0, 0, -1e39], [math.nan, 0, 0]):
        with pytest.raises(ArgumentError):
            objects.set_object_position(sim, [ball, -1, bad])
    objects.set_object_position(sim, [ball, -1, [1e4, 0, 1]])
    objects.set_object_quaternion(sim, [ball, -1, [1e308, 1e308, 0, 0]])  # huge but finite: normalised
    q = objects.get_object_quaternion(sim, [ball, -1])
    assert q == pytest.approx([math.sqrt(0.5), math.sqrt(0.5), 0, 0], abs=1e-9)
    sim.stop()
    assert cmd_parameters.get_object_float_parameter(sim, [ball, MASS]) < 1e6  # stop restores the mass


def test_script_setters_obey_the_same_bounds(sim):
    from simx_server.api import script_sim

    w = sim.world
    facade = script_sim(w, w.resolve("UR5").handle, sim.signals)
    h = w.resolve("UR5_joint1").handle
    with pytest.raises(ArgumentError, match="MAX_JOINT_POSITION"):
        facade.setJointPosition(h, 1e39)
    with pytest.raises(ArgumentError, match="MAX_POSITION"):
        facade.setObjectPosition(w.resolve("Sphere").handle, -1, [0, 0, 1e30])


# --------------------------------------------- defect 2: blow-ups, one line
def test_blow_up_stops_the_simulation_with_one_log_line():
    """Values inside every bound can still blow the physics up (here: 1e8 N·m and 1e6 rad/s on
    the light wrist joint). MuJoCo then resets the state at every step and warned each time
    (stdout flood, time stuck at 0): the simulation now stops, one line says why, and it runs
    again after simxStartSimulation."""
    srv = ServerProcess(str(SCENE), "--speed", "0", renderers="on-demand")
    try:
        cid = _connect(srv)
        rc, wrist = vrep.simxGetObjectHandle(cid, "UR5_joint6", B)
        assert rc == 0
        assert vrep.simxSetObjectIntParameter(cid, wrist, CTRL_LOOP, 0, B) == 0
        assert vrep.simxSetJointForce(cid, wrist, 1e8, B) == 0
        assert vrep.simxSetJointTargetVelocity(cid, wrist, 1e6, B) == 0
        # The first call after the blow-up answers remote error with the reason (not executed).
        wait_until(lambda: vrep.simxGetPingTime(cid)[0] == vrep.simx_return_remote_error_flag, timeout=10,
                   what="the simulation stopping by itself and the client being told")
        assert "unstable" in _last_error(cid)
        assert not _running(cid)
        assert vrep.simxGetJointMaxForce(cid, wrist, B) == (0, pytest.approx(28.0))  # initial state back
        assert vrep.simxStartSimulation(cid, B) == 0
        t0 = _sim_time(cid)
        wait_until(lambda: _sim_time(cid) > t0 + 1000, timeout=10, what="time advancing after the restart")
        assert _running(cid)
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    incidents = [line for line in log.splitlines() if "unstable" in line]
    assert len(incidents) == 1, log
    assert "joint 'UR5_joint" in incidents[0] and "stopped" in incidents[0]  # where it blew up
    assert "WARNING: Nan" not in log and len(log.splitlines()) < 20, log


def test_mujoco_warnings_never_reach_stdout_nor_mujoco_log(sim, tmp_path, monkeypatch, capfd, caplog):
    monkeypatch.chdir(tmp_path)  # where MuJoCo would write MUJOCO_LOG.TXT
    w = sim.world
    wrist = w.resolve("UR5_joint6").handle
    sim.start()
    cmd_parameters.set_object_int_parameter(sim, [wrist, CTRL_LOOP, 0])
    w.set_joint_force(wrist, 1e8)
    w.set_joint_target_velocity(wrist, 1e6)
    with pytest.raises(PhysicsError):  # the server logs it once and tells the clients
        for _ in range(5):
            sim.step()
    assert sim.state is RunState.STOPPED and "joint 'UR5_joint" in sim.stop_reason
    out, err = capfd.readouterr()
    assert "Nan, Inf" not in out + err
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert not [r for r in caplog.records if "unstable" in r.getMessage()]  # no line of its own
    sim.start()
    assert sim.stop_reason is None
    t0 = sim.world.time
    for _ in range(3):
        sim.step()
    assert sim.world.time == pytest.approx(t0 + 3 * sim.world.dt)  # time is not stuck
    sim.stop()


# ------------------------------------------------------------- signal store
def test_signal_store_is_bounded():
    s = Signals(max_signals=3, max_bytes=10, max_store_bytes=40, max_name=8)
    s.set(Signals.INT, "a", 1)
    s.set(Signals.FLOAT, "b", 2.0)
    s.set(Signals.STRING, "c", b"0123456789")  # 10 bytes: the most
    with pytest.raises(ArgumentError, match="MAX_SIGNALS"):
        s.set(Signals.INT, "d", 4)
    s.set(Signals.INT, "a", 5)  # replacing one is fine
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_BYTES"):
        s.set(Signals.STRING, "c", b"0123456789x")
    assert s.get(Signals.STRING, "c") == b"0123456789"  # unchanged
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_NAME"):
        s.set(Signals.INT, "x" * 9, 1)
    with pytest.raises(ArgumentError, match="64 bits"):
        s.set(Signals.INT, "a", 10 ** 30)  # a Python script's int that no reply could carry
    s.clear(Signals.INT, "a")
    s.set(Signals.STRING, "long", b"0123456789")
    assert (s.count, s.size) == (3, 9 + 11 + 14)  # a name's characters + 8 bytes a number
    s.clear(Signals.FLOAT, "b")
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_STORE_BYTES"):
        s.set(Signals.STRING, "bigger", b"0123456789")  # 16 more bytes: 41 > 40
    assert (s.count, s.size) == (2, 11 + 14)
    s.clear()
    assert (s.count, s.size) == (0, 0)
    s.set(Signals.STRING, "e", "é" * 5, by_script=True)  # 10 bytes in UTF-8
    s.clear_script_signals()
    assert (s.count, s.size) == (0, 0)


def test_appending_to_a_string_signal_stops_at_the_bound(sim):
    """simxAppendStringSignal grew one signal without end (each append copying it whole)."""
    chunk = b"x" * (1 << 20)
    for _ in range(limits.MAX_SIGNAL_BYTES >> 20):
        signals.append_string_signal(sim, ["stream", chunk])
    with pytest.raises(ArgumentError, match="MAX_SIGNAL_BYTES"):
        signals.append_string_signal(sim, ["stream", b"y"])
    assert len(sim.signals.get(Signals.STRING, "stream")) == limits.MAX_SIGNAL_BYTES
    sim.signals.clear(Signals.STRING, "stream")
    assert sim.signals.size == 0


def test_other_mujoco_warnings_are_logged_once_per_kind(caplog):
    """A warning MuJoCo repeats (a full contact buffer after each reset...) is one log line."""
    from simx_server.sim.physics import _WarningSink

    sink = _WarningSink()  # what physics.SINK does, on a fresh one
    for t in range(100):
        sink(f"Pre-allocated contact buffer is full. Increase nconmax above 7. Time = {t / 10:.4f}.")
        sink(f"Pre-allocated constraint buffer is full. Increase njmax above 9. Time = {t / 10:.4f}.")
        sink.report()
    lines = [r.getMessage() for r in caplog.records if r.name == "simx.physics"]
    assert len(lines) == 1 and "contact buffer" in lines[0] and "1 more" in lines[0], lines
    assert sink.take() == ([], 0)
