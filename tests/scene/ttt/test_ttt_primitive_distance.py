"""A converted scene answers distances between two primitives exactly (MuJoCo's native convex
collision): with libccd (``nativeccd`` disabled) ``mj_geomDistance`` between a tilted disc and a
box was off by 1.6 cm in the median and up to 9 cm, so ``sim.checkDistance`` and
``sim.checkCollision`` (RLBench's spawn boundaries: "could not place the task") were wrong, and
contacts' depths too. The reference is coal's exact distance of the same two shapes."""

from __future__ import annotations

import coal
import numpy as np
import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.sim import collisions

pytestmark = pytest.mark.renderers_on_demand  # no image is read


def _quat(rng) -> tuple[float, float, float, float]:
    q = rng.normal(size=4)
    return tuple(float(x) for x in q / np.linalg.norm(q))


def test_a_disc_and_a_box_are_measured_exactly(tmp_path):
    rng = np.random.default_rng(7)
    poses = [(tuple(rng.uniform(-0.15, 0.15, 3) + [0, 0, 0.5]), _quat(rng)) for _ in range(12)]
    body = b"".join(
        W.cuboid_shape(10 + 2 * i, -1, f"Disc{i}", (0.2, 0.2, 0.02), (0.6 * i, 0, 0.5), dynamic=False,
                       primitive=5)
        + W.cuboid_shape(11 + 2 * i, -1, f"Box{i}", (0.1, 0.04, 0.2), (0.6 * i + pos[0], pos[1], pos[2]),
                         dynamic=False, quat=quat)
        for i, (pos, quat) in enumerate(poses))
    f = tmp_path / "pairs.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "pairs")
    sim = Simulation(xml, realtime=False)
    try:
        w = sim.world
        m, d = w.model, w.data
        errors = []
        for i in range(len(poses)):
            disc, box = w.resolve(f"Disc{i}"), w.resolve(f"Box{i}")
            g1, g2 = int(m.body_geomadr[disc.mj_id]), int(m.body_geomadr[box.mj_id])
            assert m.geom_type[g1] == 5 and m.geom_type[g2] == 6  # a cylinder and a box
            shapes = [coal.Cylinder(m.geom_size[g1][0], 2 * m.geom_size[g1][1]), coal.Box(*(2 * m.geom_size[g2][:3]))]
            objects = [coal.CollisionObject(s, coal.Transform3s(d.geom_xmat[g].reshape(3, 3).copy(), d.geom_xpos[g].copy()))
                       for s, g in zip(shapes, (g1, g2))]
            exact = coal.distance(objects[0], objects[1], coal.DistanceRequest(), coal.DistanceResult())
            if exact > 0:  # V-REP's distance of touching or overlapping shapes is 0
                errors.append(abs(collisions.distance(sim, disc.handle, box.handle) - exact))
        assert len(errors) >= 6
        assert max(errors) < 1e-4, errors
    finally:
        sim.close()
