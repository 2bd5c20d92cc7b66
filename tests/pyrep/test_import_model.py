"""PyRep's ``import_model`` and ``Object.remove`` as RLBench uses them (issue 51): each task's
model (``.ttm``) is imported, simulated and removed with ``task.get_base().remove()``, then the
next is imported. ``import_model`` returns the model's root, a model base (``is_model``), so that
``remove`` removes the whole model (``sim.removeModel``); every cycle leaves the scene's bodies,
meshes, textures and materials as they were. Models written by the test: a ``.ttm`` whose root
is a dummy with a free shape and a meshed static shape below it, and an MJCF model."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from conftest import ROOT
from pyrep.objects import Dummy, Object, Shape

sys.path.insert(0, str(ROOT / "tests" / "scene" / "ttt"))
import tttwriter as W  # noqa: E402

TETRA = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], "<f4")

MJCF = b"""<mujoco model="bin">
  <asset><texture name="bin_tex" type="2d" builtin="checker" width="8" height="8"/>
    <material name="bin_mat" texture="bin_tex"/></asset>
  <worldbody>
    <body name="bin" pos="0 0.5 0.1"><geom type="box" size="0.1 0.1 0.05" material="bin_mat"/>
      <body name="bin_lid" pos="0 0 0.06"><joint name="bin_hinge" axis="1 0 0"/>
        <geom type="box" size="0.1 0.1 0.005" material="bin_mat"/></body></body>
  </worldbody>
</mujoco>
"""


def _task() -> bytes:
    return W.ttt_file(
        W.mesh_pool(TETRA, [0, 1, 2, 0, 1, 3, 0, 2, 3, 1, 2, 3]) +
        W.dummy(1, -1, "reach_task", (0, 0, 0.2), extra=W.model_base()) +
        W.cuboid_shape(2, 1, "target_block", (0.04, 0.04, 0.04), (0.1, 0, 0.1)) +
        W.pool_shape(3, 1, "task_stand", pos=(0, 0, -0.2)) +
        W.dummy(4, 2, "waypoint0", (0, 0, 0.05)), serialization=24, program=40100)


def _counts(pr) -> tuple:
    from pyrep.backend import sim

    m = sim.context().world.model
    return (m.nbody, m.njnt, m.ngeom, m.nsite, m.nmesh, m.nmeshface, m.ntex, m.nmat, m.ntext,
            len(pr.simulation.editor._live_spec().assets or {}))


@pytest.fixture
def models(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (tmp_path / "reach_task.ttm").write_bytes(_task())
    (tmp_path / "bin.xml").write_bytes(MJCF)
    return tmp_path


def test_import_model_returns_the_model_base_and_remove_takes_the_whole_model(pr, models):
    pr.stop()
    empty = _counts(pr)
    for _ in range(3):  # RLBench's cycle: import, simulate, remove, import the next
        for file, name, kind in (("reach_task.ttm", "reach_task", Dummy), ("bin.xml", "bin", Shape)):
            base = pr.import_model(str(models / file))
            assert isinstance(base, kind) and base.get_name() == name  # no #n: nothing was left
            assert base.is_model()
            loaded = _counts(pr)
            assert loaded[4] > empty[4] if kind is Dummy else loaded[6] > empty[6]  # a mesh / a texture
            tree = {o.get_name() for o in base.get_objects_in_tree()}
            assert tree >= ({"target_block", "task_stand", "waypoint0"} if kind is Dummy else {"bin_lid", "bin_hinge"})
            pr.start()
            for _ in range(5):
                pr.step()
            pr.stop()
            base.remove()
            assert _counts(pr) == empty
            assert not Object.exists(name) and not Object.exists("target_block")


def _chair_task() -> bytes:
    """A table (static box) and a 1.3 kg block on four 2 mm legs (static shapes: part of its body) of RLBench's chairs' material
    (Bullet friction 100, capped at 10 with any other)."""
    legs = b"".join(W.cuboid_shape(3 + i, 2, f"leg{i}", (0.004, 0.004, 0.06), (x, y, -0.05), dynamic=False,
                                   material=W.bullet_material(100.0, 100.0))
                    for i, (x, y) in enumerate([(-0.04, -0.04), (-0.04, 0.04), (0.04, -0.04), (0.04, 0.04)]))
    return W.ttt_file(
        W.dummy(1, -1, "chair_task", (0, 0, 0), extra=W.model_base()) +
        W.cuboid_shape(7, 1, "table", (0.6, 0.6, 0.04), (0, 0, 0.73), dynamic=False) +
        W.cuboid_shape(2, 1, "chair", (0.1, 0.1, 0.02), (0, 0, 0.83), mass=1.26,
                       material=W.bullet_material(100.0, 100.0)) + legs, serialization=24, program=40100)


def test_a_high_friction_model_rests_on_a_table_in_pyreps_empty_scene(tmp_path, monkeypatch):
    """PyRep's empty scene has the engine settings of a converted .ttt (elliptic friction cone,
    implicit integrator): under MuJoCo's pyramidal cone a contact's normal softens with mu^2, and RLBench's
    chairs (friction 10) on their thin legs fell through the table of a scene built from models."""
    from pyrep import PyRep

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (tmp_path / "chair_task.ttm").write_bytes(_chair_task())
    pr = PyRep()
    pr.launch("", headless=True)
    try:
        pr.import_model(str(tmp_path / "chair_task.ttm"))
        chair = Shape("chair")
        start = chair.get_position()[2]
        pr.start()
        for _ in range(40):  # 2 s
            pr.step()
        assert chair.get_position()[2] == pytest.approx(start, abs=0.003)
    finally:
        pr.shutdown()


def test_a_block_on_a_slope_in_pyreps_empty_scene_does_not_creep():
    """The empty scene keeps a converted .ttt's ``impratio`` (10): a 0.1 kg block made with
    ``Shape.create`` on a static 20 degree slope stays put, as on Bullet's static friction
    (at MuJoCo's default 1 it crept 4.4 mm in 5 s; RLBench's door handles slid out of the grip)."""
    from pyrep import PyRep
    from pyrep.const import PrimitiveShape

    tilt = np.radians(20)
    normal = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    pr = PyRep()
    pr.launch("", headless=True)
    try:
        Shape.create(PrimitiveShape.CUBOID, [0.6, 0.3, 0.02], static=True, respondable=True,
                     position=[0, 0, 0.3], orientation=[0, tilt, 0])
        block = Shape.create(PrimitiveShape.CUBOID, [0.05, 0.05, 0.05], mass=0.1, respondable=True,
                             position=list(np.array([0, 0, 0.3]) + normal * 0.0355), orientation=[0, tilt, 0])
        pr.start()
        for _ in range(20):  # 1 s: settled
            pr.step()
        start = np.array(block.get_position())
        for _ in range(100):  # 5 s
            pr.step()
        assert np.linalg.norm(np.array(block.get_position()) - start) < 1.5e-3
    finally:
        pr.shutdown()


def test_a_static_shape_made_at_run_time_is_as_rigid_as_a_files():
    """``Shape.create(static=True)`` (``sim.createPureShape``) gives the new table a converted
    ``.ttt``'s rigid static contact: a 1 cm cube dropped 0.5 m on it sinks less than 8 mm (with
    MuJoCo's default contact 14 mm; RLBench's dropped objects passed a thin container bottom and
    the stand-in's table top), and made dynamic it keeps the rigid contact, which then no longer
    rules the contacts of geoms that have another, as the dynamic cube's."""
    from pyrep import PyRep
    from pyrep.backend import sim
    from pyrep.const import PrimitiveShape

    pr = PyRep()
    pr.launch("", headless=True)
    try:
        table = Shape.create(PrimitiveShape.CUBOID, [0.6, 0.6, 0.04], static=True, respondable=True,
                             position=[0, 0, 0.73])
        cube = Shape.create(PrimitiveShape.CUBOID, [0.01] * 3, mass=0.1, respondable=True,
                            position=[0, 0, 0.755 + 0.5])
        pr.start()
        low = min(cube.get_position()[2] for _ in range(40) if pr.step() is None)
        assert 0.755 - low < 0.008
        pr.stop()
        table.set_dynamic(True)
        m = sim.context().view.world.model
        g = m.body(table.get_name()).geomadr[0]
        assert m.geom_solref[g] == pytest.approx([2 * m.opt.timestep, 2.0]) and m.geom_solmix[g] == 1.0
        floor = m.geom("Floor").id  # empty.xml writes the static form out: it must stay what simx gives
        assert m.geom_solref[floor] == pytest.approx([2 * m.opt.timestep, 2.0]) and m.geom_solmix[floor] == 1000.0
        c = m.body(cube.get_name()).geomadr[0]  # a dynamic shape made at run time: the same contact
        assert m.geom_solref[c] == pytest.approx([2 * m.opt.timestep, 2.0]) and m.geom_solmix[c] == 1.0
    finally:
        pr.shutdown()
