"""A joint or force sensor with more than one child links nothing (simExtDynamics
``CRigidBodyContainerDyn``: a constraint only while it has exactly one child): a dynamic shape
re-parented under one that has a child already is a free body, as RLBench's open_wine_bottle
re-parents its turned cap to the bottle's joint and lifts it off."""

from __future__ import annotations

import numpy as np
import pytest

import tttwriter as W
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.sim import grasps

pytestmark = pytest.mark.renderers_on_demand  # no image is read


@pytest.fixture
def api(tmp_path):
    body = (W.cuboid_shape(1, -1, "Bottle", (0.1, 0.1, 0.2), (0, 0, 0.1), dynamic=False)
            + W.joint(2, 1, "Turn", (0, 0, 0.12), motor=False, loop=False, cyclic=True)
            + W.cuboid_shape(3, 2, "Neck", (0.01, 0.01, 0.01), (0, 0, 0), mass=0.01)
            + W.force_sensor(4, 3, "Sensor", (0, 0, 0.01))
            + W.cuboid_shape(5, 4, "Cap", (0.04, 0.02, 0.01), (0, 0, 0.001), mass=0.02)
            + W.force_sensor(6, -1, "Grip", (0.5, 0, 0.5))
            + W.cuboid_shape(7, -1, "PartA", (0.02, 0.02, 0.02), (0.5, 0, 0.45), mass=0.05)
            + W.cuboid_shape(8, -1, "PartB", (0.02, 0.02, 0.02), (0.5, 0, 0.55), mass=0.05))
    f = tmp_path / "bottle.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "bottle")
    sim = Simulation(xml, realtime=False)
    sim.start()
    yield script_sim(sim.world, sim.world.resolve("Bottle").handle, sim.signals, simulation=sim)
    sim.stop()
    sim.close()


def _h(api, name):
    return api.context.world.resolve(name).handle


def _yaw(api, handle):
    m = np.array(api.getObjectMatrix(handle, -1)).reshape(3, 4)
    return float(np.arctan2(m[1, 0], m[0, 0]))


def test_a_shape_put_under_a_joint_with_a_child_is_free(api):
    cap, turn, sensor = _h(api, "Cap"), _h(api, "Turn"), _h(api, "Sensor")
    w = api.context.world
    assert w.get(sensor).body == w.get(cap).mj_id               # its child's body carries its site
    api.setJointPosition(turn, 0.5)
    assert _yaw(api, cap) == pytest.approx(0.5, abs=1e-6)       # linked through the sensor: it turns
    before = api.getObjectPosition(cap, -1)
    api.setObjectParent(cap, turn, True)                        # the joint's second child
    assert api.getObjectParent(cap) == turn
    assert api.getObjectPosition(cap, -1) == pytest.approx(before, abs=1e-9)
    assert grasps.is_free(w.model, w.get(cap).mj_id)
    assert w.get(sensor).body == w.get(_h(api, "Neck")).mj_id   # the sensor stays on its own parent
    api.setJointPosition(turn, 1.2)
    assert _yaw(api, cap) == pytest.approx(0.5, abs=1e-6)       # the joint turns the neck, not the cap
    assert _yaw(api, _h(api, "Neck")) == pytest.approx(1.2, abs=1e-6)
    api.setObjectPosition(cap, -1, [0.3, 0.0, 0.6])             # and it can be lifted off alone
    assert api.getObjectPosition(_h(api, "Neck"), -1)[2] == pytest.approx(0.22, abs=1e-6)
    api.setObjectParent(cap, sensor, True)                      # back: the sensor's only child, held
    assert api.getObjectParent(cap) == sensor
    assert w.grasps["Cap"].held


def test_a_second_part_under_a_force_sensor_lets_both_go(api):
    grip, a, b = _h(api, "Grip"), _h(api, "PartA"), _h(api, "PartB")
    w = api.context.world
    api.setObjectParent(a, grip, True)
    assert w.grasps["PartA"].held                               # one child: held
    api.setObjectParent(b, grip, True)
    assert api.getObjectParent(a) == grip and api.getObjectParent(b) == grip
    assert not w.grasps["PartA"].held and not w.grasps["PartB"].held
