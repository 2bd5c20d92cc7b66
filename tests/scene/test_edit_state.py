"""A run-time edit that rebuilds the MuJoCo model keeps every object's state (issue 41): poses
placed by scripts, joint positions, free bodies' poses and velocities, and what scripts set
(masses, colours, special properties). V-REP's ``complexCommandTest``: a dummy placed at
(0.1, 0.2, 0.3) stayed there when an octree was created afterwards."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ROOT
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read

SENSORS = ROOT / "tests" / "scenes" / "sensors.xml"
TETRA = ROOT / "tests" / "scenes" / "tetra.obj"


@pytest.fixture
def placed():
    """A running simulation in which scripts placed, moved and changed things."""
    sim = Simulation(SENSORS, realtime=False)
    sim.start()
    api = script_sim(sim.world, sim.world.resolve("blockA").handle, sim.signals, simulation=sim)
    h = sim.world.resolve
    dummy = api.createDummy(0.05)
    api.setObjectPosition(dummy, -1, [0.1, 0.2, 0.3])
    api.setObjectPosition(h("blockB").handle, -1, [0.5, 2.0, 0.5])                # a static body
    api.setObjectPosition(h("cam").handle, -1, [0.0, 2.5, 3.0])                   # a camera
    api.setJointPosition(h("target_x").handle, 0.3)
    api.setJointPosition(h("hinge").handle, 0.4)
    api.setShapeMass(h("target").handle, 3.0)
    api.setShapeColor(h("blockC").handle, None, 0, [0.1, 0.2, 0.3])
    api.setObjectSpecialProperty(h("blockA").handle, 496)
    for _ in range(3):
        sim.step()                                                               # the faller falls
    yield sim, api, dummy
    sim.stop()
    sim.close()


def _state(sim, api, dummy):
    h = lambda n: sim.world.resolve(n).handle  # noqa: E731
    w, m = sim.world, sim.world.model
    faller = m.body("faller")
    q = w.data.qpos[m.jnt_qposadr[faller.jntadr[0]]:][:7].copy()
    v = w.data.qvel[m.jnt_dofadr[faller.jntadr[0]]:][:6].copy()
    return {
        "dummy": api.getObjectPosition(dummy, -1),
        "blockB": api.getObjectPosition(h("blockB"), -1),
        "cam": api.getObjectPosition(h("cam"), -1),
        "target_x": api.getJointPosition(h("target_x")),
        "hinge": api.getJointPosition(h("hinge")),
        "faller": np.concatenate([q, v]).tolist(),
        "mass": api.getShapeMass(h("target")),
        "colour": m.geom_rgba[m.body("blockC").geomadr[0]][:3].tolist(),
        "special": api.getObjectSpecialProperty(h("blockA")),
    }


EDITS = {
    "create dummy": lambda api, sim: api.createDummy(0.01),
    "create shape": lambda api, sim: api.createPrimitiveShape(api.primitiveshape_cuboid, [0.1, 0.1, 0.1]),
    "create octree": lambda api, sim: api.insertVoxelsIntoOctree(api.createOctree(0.5, 0, 1), 0, [0.1, 0.1, 0.1]),
    "create point cloud": lambda api, sim: api.insertPointsIntoPointCloud(api.createPointCloud(0.1, 10, 0, 1), 0,
                                                                          [0.1, 0.1, 0.1]),
    "remove": lambda api, sim: api.removeObject(sim.world.resolve("ball_above").handle),
    "reparent": lambda api, sim: api.setObjectParent(sim.world.resolve("prox_base").handle,
                                                     sim.world.resolve("mount").handle, True),
    "import mesh": lambda api, sim: api.importShape(0, str(TETRA), 0, 0.0, 1.0),
}


@pytest.mark.parametrize("edit", list(EDITS))
def test_an_edit_keeps_poses_joints_and_script_set_properties(placed, edit):
    sim, api, dummy = placed
    before = _state(sim, api, dummy)
    assert before["dummy"] == pytest.approx([0.1, 0.2, 0.3])
    EDITS[edit](api, sim)
    after = _state(sim, api, dummy)
    for key, value in before.items():
        assert after[key] == pytest.approx(value, abs=1e-9), key
    sim.step()                                                                   # and it goes on from there
    assert api.getObjectPosition(dummy, -1) == pytest.approx([0.1, 0.2, 0.3])


COMPLEX_COMMAND_TEST = """
function run(ints, floats, strings, buf)
    local dummy = simCreateDummy(0.05)
    simSetObjectPosition(dummy, -1, {0.1, 0.2, 0.3})
    local octree = simCreateOctree(0.5, 0, 1)
    simInsertVoxelsIntoOctree(octree, 0, {0.1, 0.1, 0.1}, {255, 0, 255})
    return {}, simGetObjectPosition(dummy, -1)
end
"""


def test_complex_command_test_keeps_the_dummy_where_it_was_put(tmp_path):
    """V-REP's ``complexCommandTest`` example, through a 3.x child script."""
    (tmp_path / "complex.lua").write_text(COMPLEX_COMMAND_TEST)
    scene = tmp_path / "complex.xml"
    scene.write_text("""<mujoco><worldbody><site name="Runner" size="0.01"/></worldbody>
<custom><text name="simx:Runner" data="child_script=complex.lua"/></custom></mujoco>""")
    sim = Simulation(scene, realtime=False)
    sim.start()
    try:
        _, floats, _, _ = sim.scripts.call("Runner", 1, "run", [], [], [], b"")
        assert floats == pytest.approx([0.1, 0.2, 0.3])
    finally:
        sim.stop()
        sim.close()


def test_a_reparented_shape_keeps_what_scripts_set_on_it(placed):
    """The shape an edit moves keeps its own run-time state: a non-respondable shape put under a
    respondable one stays out of the contacts (RLBench's stand-in hangs the table's visual twin
    under the table), with its colour and mass."""
    sim, api, _ = placed
    h = lambda n: sim.world.resolve(n).handle  # noqa: E731
    api.setObjectInt32Param(h("blockC"), api.shapeintparam_respondable, 0)
    api.setShapeMass(h("blockC"), 2.5)
    api.setObjectParent(h("blockC"), h("blockB"), True)
    assert api.getObjectParent(h("blockC")) == h("blockB")
    m = sim.world.model
    geoms = m.body("blockC").geomadr[0] + np.arange(m.body("blockC").geomnum[0])
    assert not m.geom_contype[geoms].any() and not m.geom_conaffinity[geoms].any()
    assert api.getObjectInt32Param(h("blockC"), api.shapeintparam_respondable) == 0
    assert m.geom_rgba[geoms[0]][:3] == pytest.approx([0.1, 0.2, 0.3])
    assert api.getShapeMass(h("blockC")) == pytest.approx(2.5)
    api.setObjectInt32Param(h("blockC"), api.shapeintparam_respondable, 1)       # and back on
    assert m.geom_contype[geoms].all()
