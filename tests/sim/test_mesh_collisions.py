"""Collision and distance on the triangles of mesh geoms (coal), not on MuJoCo's convex hulls, as
CoppeliaSim's ``sim.checkCollision`` / ``sim.checkDistance`` test the meshes
(simx_server/sim/mesh_geometry.py, simx_server/sim/collisions.py).

The scene: two U-shaped meshes linked like the links of a chain (each one's hull holds a bar of
the other; the triangles are 0.12 m apart at the nearest), a ball in the first U's opening
(0.03 m from its post), and the second U on a slide joint along x (MuJoCo's contacts between the two excluded: its
hulls would push them apart), so a scratch copy of the state can move it onto the first U's post.
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np
import pytest

from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation
from simx_server.sim import collisions

pytestmark = pytest.mark.renderers_on_demand  # no image is read here


def _boxes(*boxes: tuple[tuple[float, float, float], tuple[float, float, float]]) -> tuple[str, str]:
    """MJCF ``vertex`` and ``face`` texts of axis-aligned boxes (lower, upper corners) as one mesh."""
    verts, faces = [], []
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    for lo, hi in boxes:
        base = len(verts)
        verts += [(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        for a, b, c, d in quads:
            faces += [(base + a, base + b, base + c), (base + a, base + c, base + d)]
    return " ".join(f"{v:g}" for p in verts for v in p), " ".join(str(i) for f in faces for i in f)


# U1 in the xz plane, open upwards: posts x in +-[0.2, 0.3], bottom bar z in [0, 0.1], y in +-0.05
U1 = _boxes(((-0.3, -0.05, 0.1), (-0.2, 0.05, 0.5)), ((0.2, -0.05, 0.1), (0.3, 0.05, 0.5)),
            ((-0.3, -0.05, 0.0), (0.3, 0.05, 0.1)))
# U2 in the yz plane, open downwards: its top bar (x in [-0.02, 0.08], z in [0.3, 0.4]) through
# U1's opening, U1's bottom bar through its opening between posts y in +-[0.2, 0.3]
U2 = _boxes(((-0.02, -0.3, -0.1), (0.08, -0.2, 0.3)), ((-0.02, 0.2, -0.1), (0.08, 0.3, 0.3)),
            ((-0.02, -0.3, 0.3), (0.08, 0.3, 0.4)))

SCENE = f"""<mujoco model="chain">
  <option gravity="0 0 0"/>
  <asset>
    <mesh name="u1" vertex="{U1[0]}" face="{U1[1]}"/>
    <mesh name="u2" vertex="{U2[0]}" face="{U2[1]}"/>
  </asset>
  <worldbody>
    <body name="LinkA"><geom type="mesh" mesh="u1"/></body>
    <body name="LinkB"><joint name="Slide" type="slide" axis="1 0 0"/><geom type="mesh" mesh="u2"/></body>
    <body name="Ball" pos="-0.12 0 0.25"><geom type="sphere" size="0.05"/></body>
  </worldbody>
  <contact><exclude body1="LinkA" body2="LinkB"/></contact>
</mujoco>
"""


@pytest.fixture
def api(tmp_path, caplog):
    path = tmp_path / "chain.xml"
    path.write_text(SCENE)
    with caplog.at_level(logging.ERROR, logger="simx.scene"):
        sim = Simulation(path, realtime=False)
    sim.start()
    sim.step()
    yield script_sim(sim.world, sim.world.resolve("LinkA").handle, sim.signals, simulation=sim), sim
    sim.close()


def test_linked_meshes_whose_hulls_overlap_do_not_collide_and_measure_exactly(api):
    api, sim = api
    a, b = api.getObject("/LinkA"), api.getObject("/LinkB")
    m = sim.world.model
    # MuJoCo's hulls overlap: the question is the triangles'
    assert mujoco.mj_geomDistance(m, sim.world.data, 0, 1, 1.0, None) < 0
    assert api.checkCollision(a, b) == (0, [-1, -1])
    result, data, pair = api.checkDistance(a, b)
    assert result == 1 and pair == [a, b]
    assert data[6] == pytest.approx(0.12, abs=1e-6)
    # the nearest points: U2's top bar face x = 0.08 and U1's right post x = 0.2, 0.12 apart
    assert data[0] == pytest.approx(0.2, abs=1e-6) and data[3] == pytest.approx(0.08, abs=1e-6)
    assert np.linalg.norm(np.subtract(data[:3], data[3:6])) == pytest.approx(0.12, abs=1e-6)


def test_a_primitive_in_a_mesh_opening_and_a_scratch_pose(api):
    api, sim = api
    world = sim.world
    a, b, ball = api.getObject("/LinkA"), api.getObject("/LinkB"), api.getObject("/Ball")
    assert api.checkCollision(ball, a) == (0, [-1, -1])
    assert api.checkDistance(ball, a)[1][6] == pytest.approx(0.03, abs=1e-6)  # to the left post, x = -0.2
    # a scratch copy of the state (a planner's): U2 slid 0.12 m reaches U1's post, 0.119 m does not
    pairs = collisions.collision_pairs(world, a, b)
    scratch = mujoco.MjData(world.model)
    for slide, touching in ((0.119, False), (0.1200001, True), (0.2, True), (-0.1, False)):
        scratch.qpos[0] = slide
        mujoco.mj_kinematics(world.model, scratch)
        assert collisions.pairs_collide(world, *pairs, scratch) is touching, slide
    assert api.checkCollision(a, b) == (0, [-1, -1])  # the simulation did not move
    assert collisions.distance(sim, b, a) == pytest.approx(0.12, abs=1e-6)
