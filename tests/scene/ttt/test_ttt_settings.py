"""A ``.ttt``'s saved simulation settings (issue 41): the time step (a custom 10 ms step, a
preset, CoppeliaSim 4.5's double), gravity, real-time mode and the physics step, read as
CoppeliaSim's ``CSimulation::serialize`` / ``CDynamicsContainer::serialize`` load them, applied
by default, ``--dt`` / ``--speed`` winning, and said in the report and the ready line."""

from __future__ import annotations

import mujoco
import pytest

import tttwriter as W

try:
    from conftest import ServerProcess
except ImportError:
    from tests.conftest import ServerProcess

import vrep
from simx_server.scene.ttt import convert, reader
from simx_server.sim.world import World

B = vrep.simx_opmode_blocking


def _scene(*settings: bytes) -> bytes:
    return W.ttt_file(b"".join(settings) + W.cuboid_shape(1, -1, "Box", (0.1, 0.1, 0.1), (0, 0, 0.5)))


@pytest.mark.parametrize("record, expected", [
    (W.simulation(0.01), 0.01),                        # custom, as V-REP 3.x saves it
    (W.simulation(0.01, preset=2), 0.05),              # a preset: V-REP's value, not the stored one
    (W.simulation(0.015, preset=4), 0.01),
    (W.simulation(0.0125, preset=2, double=True), 0.0125),  # 4.5: _t3 is the step itself
], ids=["custom", "preset", "another_preset", "double"])
def test_the_saved_step_as_coppeliasim_reads_it(tmp_path, record, expected):
    path = tmp_path / "s.ttt"
    path.write_bytes(_scene(record))
    scene = reader.read(path)
    assert scene.saved_settings.time_step == pytest.approx(expected)
    xml, report = convert.convert(scene, tmp_path / "out", "scene")
    world = World(xml, None)  # no --dt: the scene's
    assert world.dt == pytest.approx(expected)
    assert world.substeps * world.model.opt.timestep == pytest.approx(expected)  # whole substeps
    assert world.model.opt.timestep <= 0.002 + 1e-12
    assert any(line.startswith(f"simulation time step {expected * 1000:g} ms") for line in report.taken)
    assert World(xml, 0.05).dt == pytest.approx(0.05)  # --dt wins


def test_gravity_real_time_and_physics_step_are_reported(tmp_path):
    path = tmp_path / "s.ttt"
    path.write_bytes(_scene(W.simulation(0.01, real_time=True, factor=2.0), W.dynamics((0, 0, -1.62), step=0.001)))
    xml, report = convert.convert(reader.read(path), tmp_path / "out", "scene")
    world = World(xml, None)
    assert list(world.model.opt.gravity) == pytest.approx([0, 0, -1.62])
    assert world.model.opt.timestep == pytest.approx(0.001)  # the engine's finer step
    assert (world.scene_settings.real_time, world.scene_settings.speed) == (True, 2.0)
    text = "; ".join(report.taken)
    for part in ("simulation time step 10 ms (custom)", "real-time mode x2", "gravity (0, 0, -1.62)",
                 "physics step 1 ms"):
        assert part in text, text


def _pendulum(respondable: bool = False, motor: bool = False, stiffness: float | None = None) -> bytes:
    """A link on a free (cyclic) hinge from a static base, at the engine's saved 5 ms; the link
    respondable (contacts), the hinge motorised, or the hinge in V-REP's spring mode faster
    than its target velocity (the joint's own MuJoCo spring) of ``stiffness``."""
    extra = b"" if stiffness is None else W.rec("Dcm", W.i32(12)) + W.rec("Spp", W.f32(stiffness, 0.5))
    return W.ttt_file(W.dynamics(step=0.005) + W.cuboid_shape(1, -1, "Base", (0.1, 0.1, 0.1), (0, 0, 1), dynamic=False,
                                                              respondable=False)
                      + W.joint(2, 1, "Hinge", (0, 0, 0.1), cyclic=True, motor=motor or stiffness is not None,
                                target_velocity=5.0, extra=extra)
                      + W.cuboid_shape(3, 2, "Link", (0.3, 0.05, 0.05), (0.15, 0, 0), mass=0.2, respondable=respondable))


@pytest.mark.parametrize("kind, expected, why", [
    ("free", 0.005, None),
    ("respondable", 0.002, "shape 'Link' is dynamic and respondable"),
    ("motor", 0.002, "joint 'Hinge' has a motor"),
    ("stiff spring", 0.002, "joint 'Hinge''s spring (50000 N·m/rad"),
])
def test_the_engines_step_where_mujoco_holds_the_scene_at_it(tmp_path, kind, expected, why):
    """MuJoCo steps a converted scene at its engine's saved step (10 substeps of 5 ms), as
    CoppeliaSim steps its engine, unless it cannot hold the scene there as V-REP does: contacts,
    limits, closed mechanisms and motors (two timesteps stiff) and a joint's own spring too stiff
    for it keep 2 ms, and the report says why."""
    body = _pendulum(respondable=kind == "respondable", motor=kind == "motor",
                     stiffness=5e4 if kind == "stiff spring" else None)
    path = tmp_path / "p.ttt"
    path.write_bytes(body)
    xml, report = convert.convert(reader.read(path), tmp_path / "out", "scene")
    world = World(xml, None)
    assert world.model.opt.timestep == pytest.approx(expected)
    assert world.substeps == round(0.05 / expected)
    assert "physics step 5 ms (MuJoCo substeps of " in "; ".join(report.taken)
    assert len(report.physics) == 1, report.physics
    if why is None:
        assert report.physics[0] == "MuJoCo substeps of 5 ms, the engine step's"
    else:
        assert report.physics[0].startswith(f"MuJoCo substeps of 2 ms, not the engine step's 5 ms: {why}"), \
            report.physics
    if kind == "stiff spring":  # built again for 2 ms: the limits' and contacts' stiffness is 2 ms's
        assert world.model.opt.timestep * 2 == pytest.approx(0.004)


def test_a_file_without_settings_keeps_simx_defaults(tmp_path):
    path = tmp_path / "s.ttt"
    path.write_bytes(_scene())
    xml, report = convert.convert(reader.read(path), tmp_path / "out", "scene")
    world = World(xml, None)
    assert world.dt == pytest.approx(0.05) and world.scene_settings.speed is None
    assert report.taken == []
    assert mujoco.mj_name2id(world.model, mujoco.mjtObj.mjOBJ_TEXT, "simx:scene:simulation") < 0


def test_a_server_steps_at_the_saved_10_ms_unless_told(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    path = tmp_path / "custom.ttt"
    path.write_bytes(_scene(W.simulation(0.01, real_time=False)))
    dt = vrep.sim_floatparam_simulation_time_step
    srv = ServerProcess(str(path), "--stopped", renderers="on-demand")
    try:
        assert ("dt 0.01 s (the scene's), a pass per 60 Hz display frame (the scene's not real time"
                in srv.ready_line), srv.ready_line
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        assert vrep.simxGetFloatingParameter(cid, dt, B) == (0, pytest.approx(0.01))
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    assert "custom.ttt: taken from the file: simulation time step 10 ms (custom); real-time mode off" in log, log
    srv = ServerProcess(str(path), "--stopped", "--dt", "0.05", "--speed", "1", renderers="on-demand")
    try:
        assert "dt 0.05 s," in srv.ready_line and "the scene's" not in srv.ready_line, srv.ready_line
    finally:
        srv.stop()


def test_a_scene_saved_not_real_time_runs_at_the_window_pace(tmp_path, monkeypatch):
    """Real time off in the file and no ``--speed``: at most one pass per 60 Hz display frame of
    wall time, as CoppeliaSim's window runs it (a slow machine takes fewer, never more); a
    program that sleeps 1 s with the simulation running sees about 60 passes, not thousands."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    path = tmp_path / "window.ttt"
    path.write_bytes(_scene(W.simulation(0.05, preset=2, real_time=False)))
    srv = ServerProcess(str(path), "--stopped", renderers="on-demand")
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        import time

        began = time.monotonic()
        assert vrep.simxStartSimulation(cid, B) == 0
        time.sleep(1.0)
        rc, _ = vrep.simxGetPingTime(cid)
        elapsed = time.monotonic() - began
        passes = round(vrep.simxGetLastCmdTime(cid) / 50)
        assert rc == 0 and passes >= 1
        assert passes <= elapsed * 60 + 2, (passes, elapsed)  # an upper bound: the pace caps the rate
        vrep.simxStopSimulation(cid, B)
        vrep.simxFinish(cid)
    finally:
        srv.stop()
