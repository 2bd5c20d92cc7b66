"""A shape whose stored inertia breaks the triangle inequality (V-REP simulated it; MuJoCo says
"inertia must satisfy A + B >= C") loads with the nearest valid moments, named in the load
report (issue 41)."""

from __future__ import annotations

import logging

import numpy as np
import pytest

import tttwriter as W

from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader


pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


def _scene() -> bytes:
    return W.ttt_file(
        W.cuboid_shape(1, -1, "Base", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False) +
        W.joint(2, 1, "Joint", (0, 0, 0.2)) +
        W.cuboid_shape(3, 2, "Rod", (0.02, 0.02, 0.4), (0, 0, 0.2), mass=2.0, moments=(0.001, 0.001, 0.05)) +
        W.cuboid_shape(4, -1, "Fine", (0.1, 0.1, 0.1), (1, 0, 0.5), moments=(0.01, 0.02, 0.025)))


def test_the_nearest_valid_moments_and_the_shape_named(tmp_path):
    f = tmp_path / "rod.ttt"
    f.write_bytes(_scene())
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "scene")
    assert report.repaired == ["1 x shape inertias that break A + B >= C, set to the nearest valid ones: Rod"]
    assert report.lines() == []  # repaired, not lost
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(xml))
    rod = np.sort(m.body_inertia[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "Rod")])
    # (0.001, 0.001, 0.05) x 2 kg: the excess moved in thirds, the trace kept
    assert rod == pytest.approx([0.034, 0.034, 0.068], rel=1e-4)
    assert rod[0] + rod[1] >= rod[2]
    fine = m.body_inertia[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "Fine")]
    assert fine == pytest.approx([0.01, 0.02, 0.025], rel=1e-6)  # a valid one is left alone


def test_the_server_loads_it_and_says_so(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    f = tmp_path / "rod.ttt"
    f.write_bytes(_scene())
    with caplog.at_level(logging.INFO, logger="simx.ttt"):
        sim = Simulation(f, realtime=False)
    try:
        sim.start()
        for _ in range(5):
            sim.step()
        assert np.all(np.isfinite(sim.world.data.qpos))
    finally:
        sim.close()
    assert "rod.ttt: repaired: 1 x shape inertias that break A + B >= C, set to the nearest valid " \
           "ones: Rod" in caplog.text


def _crumb_scene() -> bytes:
    """A static floor and a 1 cm cube of 0.5 mg (a crumb of dirt) with its own moments, a^2/6
    of its mass each, as V-REP stores them (divided by the mass)."""
    return W.ttt_file(
        W.cuboid_shape(1, -1, "Floor", (1.0, 1.0, 0.02), (0, 0, -0.01), dynamic=False) +
        W.cuboid_shape(2, -1, "Crumb", (0.01, 0.01, 0.01), (0, 0, 0.005), mass=4.88e-7,
                       moments=(1e-4 / 6,) * 3))


def test_a_light_shape_keeps_its_small_moments_and_stops_as_pushed(tmp_path):
    """Bullet 2.78 gets the file's moments times the mass (simExtDynamics ``CRigidBodyDyn``):
    8.1e-12 kg m2 here, not a floor 120 times that; a crumb flicked along the floor with a spin
    stops within a millimetre, where with 1e-9 it tumbled on like a flywheel for 5 cm."""
    f = tmp_path / "crumb.ttt"
    f.write_bytes(_crumb_scene())
    xml, report = convert.convert(reader.read(f), tmp_path / "out", "scene")
    assert report.repaired == []
    import mujoco

    m = mujoco.MjModel.from_xml_path(str(xml))
    b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "Crumb")
    assert m.body_inertia[b] == pytest.approx([4.88e-7 * 1e-4 / 6] * 3, rel=1e-4)
    d = mujoco.MjData(m)
    m.opt.timestep = 0.005
    for _ in range(40):  # settle on the floor
        mujoco.mj_step(m, d)
    dof = m.jnt_dofadr[m.body_jntadr[b]]
    d.qvel[dof + 1], d.qvel[dof + 3] = 0.15, -19.0  # 0.15 m/s along y, rolling about -x
    y0 = float(d.xpos[b][1])
    for _ in range(100):  # 0.5 s
        mujoco.mj_step(m, d)
    assert abs(float(d.xpos[b][1]) - y0) < 0.002
    assert np.linalg.norm(d.qvel[dof:dof + 3]) < 0.01
