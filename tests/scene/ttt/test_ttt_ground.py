"""Static shapes fixed to the world are as hard as V-REP's engines make them: what falls or is
pressed onto V-REP's 4 cm floor box stays on it (with MuJoCo's default 20 ms contact it sank by
its speed x 20 ms, passed the box's middle and fell for ever)."""

from __future__ import annotations

import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


def test_cubes_dropped_on_a_v_rep_floor_box_stay_on_it(tmp_path):
    body = (W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, -9.81))))
            + W.cuboid_shape(1, -1, "Floor", (5, 5, 0.04), (0, 0, -0.02), dynamic=False)
            + W.cuboid_shape(2, -1, "Light", (0.04, 0.04, 0.04), (0, 0, 0.5), mass=0.05, moments=(2e-4,) * 3)
            + W.cuboid_shape(3, -1, "Heavy", (0.04, 0.04, 0.04), (0.5, 0, 2.0), mass=1.0, moments=(2e-4,) * 3))
    f = tmp_path / "drop.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "drop")
    sim = Simulation(xml, realtime=False)
    try:
        w = sim.world
        sim.start()
        lowest = {}
        for _ in range(30):  # 1.5 s: both have landed and rest
            sim.step()
            for name in ("Light", "Heavy"):
                z = w.position(w.resolve(name).handle, -1)[2]
                lowest[name] = min(lowest.get(name, z), z)
        for name in ("Light", "Heavy"):
            assert w.position(w.resolve(name).handle, -1)[2] == pytest.approx(0.02, abs=1e-3)
            assert lowest[name] > 0.015  # it never sank more than 5 mm into the floor
    finally:
        sim.stop()
        sim.close()
