"""Any object as a parent (issue 41): ``sim.setObjectParent(cube, forceSensor)``, as a gripper
holds what it grasps, and under dummies, joints and cameras; the child goes into the body that
carries the parent, ``sim.getObjectParent`` answers the V-REP parent, and the child's world
pose is kept (``keepInPlace``) or its pose relative to its parent."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tttwriter as W
from conftest import ROOT
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.api import script_sim

pytestmark = pytest.mark.renderers_on_demand  # no image is read

SENSORS = ROOT / "tests" / "scenes" / "sensors.xml"


@pytest.fixture
def api():
    sim = Simulation(SENSORS, realtime=False)
    sim.start()
    yield script_sim(sim.world, sim.world.resolve("blockA").handle, sim.signals, simulation=sim)
    sim.stop()
    sim.close()


def _h(api, name):
    return api.getObject("/" + name) if "/" not in name else api.getObject(name)


def test_a_shape_hangs_from_a_force_sensor_in_place(api):
    cube, ft = _h(api, "blockB"), api.context.world.resolve("ft").handle
    before = api.getObjectPosition(cube, -1)
    api.setObjectParent(cube, ft, True)
    assert api.getObjectParent(cube) == ft
    assert api.getObjectPosition(cube, -1) == pytest.approx(before, abs=1e-9)
    m = api.context.world.model
    assert m.body_parentid[m.body("blockB").id] == m.body("payload").id  # the body carrying the sensor
    api.createDummy(0.01)                                                  # an edit keeps the parent
    assert api.getObjectParent(cube) == ft
    assert api.getObjectPosition(cube, -1) == pytest.approx(before, abs=1e-9)
    api.setObjectParent(cube, -1, True)                                    # and back to the world
    assert api.getObjectParent(cube) == -1
    assert api.getObjectPosition(cube, -1) == pytest.approx(before, abs=1e-9)


def test_without_keep_in_place_the_pose_is_relative_to_the_new_parent(api):
    cube, marker = _h(api, "blockB"), api.context.world.resolve("marker").handle  # a dummy on ball_above
    api.setObjectPosition(marker, -1, [-0.4, 2.0, 0.9])                    # 0.1 m above its body's origin
    rel = api.getObjectPosition(cube, -1)                                  # relative to the world, its parent
    api.setObjectParent(cube, marker, False)
    assert api.getObjectParent(cube) == marker
    assert api.getObjectPosition(cube, marker) == pytest.approx(rel, abs=1e-9)
    assert api.getObjectPosition(cube, -1) == pytest.approx([-0.4 + 0.25, 4.0, 1.4], abs=1e-9)


def test_a_shape_under_a_joint_turns_with_it(api):
    cube, hinge = _h(api, "blockB"), api.context.world.resolve("hinge").handle    # hinge at (2, 0, 1), axis y
    sim = api.context.view
    api.setObjectPosition(cube, -1, [2.5, 0.0, 1.0])
    api.setObjectParent(cube, hinge, True)
    assert api.getObjectParent(cube) == hinge
    assert api.getObjectPosition(cube, -1) == pytest.approx([2.5, 0, 1], abs=1e-9)
    api.setJointPosition(hinge, math.pi / 2)
    p = np.array(api.getObjectPosition(cube, -1))
    assert np.linalg.norm(p - [2, 0, 1]) == pytest.approx(0.5, abs=1e-6)   # on a circle about the anchor
    assert p[2] == pytest.approx(0.5, abs=1e-6) or p[2] == pytest.approx(1.5, abs=1e-6)
    assert sim.world.get(cube).parent == hinge


def test_a_camera_and_a_dummy_as_parents_of_sites(api):
    cam, prox = api.context.world.resolve("cam").handle, api.context.world.resolve("prox").handle
    d = api.createDummy(0.01)
    api.setObjectPosition(d, -1, [0.3, 2.0, 2.5])
    api.setObjectParent(d, cam, True)
    assert api.getObjectParent(d) == cam
    assert api.getObjectPosition(d, -1) == pytest.approx([0.3, 2.0, 2.5], abs=1e-9)
    api.setObjectParent(prox, d, True)                                     # a sensor under that dummy
    assert api.getObjectParent(prox) == d
    with pytest.raises(Exception, match="descendants"):
        api.setObjectParent(_h(api, "ball_above"), api.context.world.resolve("marker").handle, True)


def test_a_ttt_shape_hung_from_a_dummy_keeps_that_parent(tmp_path):
    body = (W.dummy(1, -1, "Attach", (0, 0, 1.0))
            + W.cuboid_shape(2, 1, "Held", (0.1, 0.1, 0.1), (0, 0, -0.1), dynamic=False)
            + W.force_sensor(3, -1, "Wrist", (1, 0, 1))
            + W.dummy(4, 3, "Tip", (0, 0, 0.05)))
    f = tmp_path / "held.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "held")
    sim = Simulation(xml, realtime=False)
    try:
        w = sim.world
        assert w.get(w.resolve("Held").handle).parent == w.resolve("Attach").handle
        assert w.get(w.resolve("Tip").handle).parent == w.resolve("Wrist").handle
        assert w.position(w.resolve("Held").handle, -1) == pytest.approx([0, 0, 0.9], abs=1e-6)
    finally:
        sim.close()
