"""A shape's friction is its material's Bullet coefficient for the scene's Bullet version, as
CoppeliaSim hands it to the engine: Bullet 2.78 (V-REP's and CoppeliaSim 4.1's default) gets the
material's "old" friction, Bullet 2.83 the newer one (coppeliaSimLib ``_simGetFriction_internal``,
simDyn's Bullet 2.78 ``CRigidBodyDyn``). PyRep's TurtleBot wheels keep 0.71 and 0.25: simx read
0.25, which Bullet 2.78 never used."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.ttt import convert, reader


def _friction(tmp_path, version, material):
    body = (W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.dynamics(version=version)
            + W.cuboid_shape(1, -1, "Wheel", (0.07, 0.07, 0.02), (0, 0, 0.5), mass=0.05, material=material))
    f = tmp_path / f"friction_{version}.ttt"
    f.write_bytes(W.ttt_file(body))
    scene = reader.read(f)
    xml, _ = convert.convert(scene, tmp_path / f"out{version}", "friction")
    m = mujoco.MjModel.from_xml_path(str(xml))
    body_id = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "Wheel")
    return [float(m.geom_friction[g, 0]) for g in range(m.ngeom) if m.geom_bodyid[g] == body_id]


@pytest.mark.parametrize("version, expected", [(None, 0.71), (0, 0.71), (283, 0.25)])
def test_the_scenes_bullet_version_picks_the_coefficient(tmp_path, version, expected):
    # MuJoCo's friction is mu^2: Bullet's product for two shapes of the same material
    assert _friction(tmp_path, version, W.bullet_material(0.71, 0.25)) == [pytest.approx(expected ** 2, rel=1e-5)]


def test_a_material_from_before_2016_has_one_coefficient_for_both(tmp_path):
    assert _friction(tmp_path, 283, W.bullet_material(0.4)) == [pytest.approx(0.16, rel=1e-5)]
    assert _friction(tmp_path, None, W.bullet_material(0.4)) == [pytest.approx(0.16, rel=1e-5)]


def test_a_combined_friction_is_capped_as_bullets(tmp_path):
    # btManifoldResult::calculateCombinedFriction caps the product at 10: RLBench's chairs (100)
    assert _friction(tmp_path, None, W.bullet_material(100.0, 100.0)) == [pytest.approx(10.0)]


def test_a_block_on_a_slope_does_not_creep(tmp_path):
    """Bullet's friction is static: a 0.1 kg block on a 20 degree slope (tan 20 = 0.36 < its
    friction 0.5) stays where it is. MuJoCo's soft friction creeps at a speed proportional to
    the load over ``impratio``: 0.9 mm in 5 s at 1; a converted scene's 10 gives a tenth."""
    tilt = math.radians(20)
    normal = np.array([math.sin(tilt), 0.0, math.cos(tilt)])  # the slope's +z, turned about y
    quat = (math.cos(tilt / 2), 0.0, math.sin(tilt / 2), 0.0)
    block_at = np.array([0.0, 0.0, 0.3]) + normal * 0.0355
    body = (W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.dynamics()
            + W.cuboid_shape(1, -1, "slope", (0.6, 0.3, 0.02), (0, 0, 0.3), dynamic=False, quat=quat)
            + W.cuboid_shape(2, -1, "block", (0.05, 0.05, 0.05), tuple(block_at), mass=0.1, quat=quat,
                             moments=(0.05 ** 2 / 6,) * 3))
    f = tmp_path / "slope.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "slope")
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    block = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "block")
    second = round(1 / m.opt.timestep)
    for _ in range(second):  # settled
        mujoco.mj_step(m, d)
    start = d.xpos[block].copy()
    for _ in range(5 * second):
        mujoco.mj_step(m, d)
    assert np.linalg.norm(d.xpos[block] - start) < 3e-4  # 0.9 mm at impratio 1
    assert m.opt.impratio == 10.0
