"""``PyRep.export_scene`` (``sim.saveScene``) writes a scene that loads back as it was (issue 58):
the meshes it names are written next to it, an attached model's default class is no empty
nested ``<default>`` (MuJoCo refuses it) and its elements keep their values, the compiler's
``balanceinertia`` is kept, the objects are where they are now (a shape placed after it was
made, a dummy moved, a joint turned), what commands set at run time (a colour, a contact flag, a
mass: also kept when a rename recompiles the model), and the scripts, custom data and ``simx:`` settings that a
loaded model brought come along. Scene built by the test: an empty PyRep scene, a ``.ttm``
written by the test (a mesh, a child script, custom data, a dynamic cuboid whose moments break
A + B >= C) and an MJCF model with default classes of its own."""

from __future__ import annotations

import sys

import mujoco
import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "tests" / "scene" / "ttt"))
import tttwriter as W  # noqa: E402

TETRA = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], "<f4")
SCRIPT = "function sysCall_init() sim.setInt32Signal('block_script', 7) end"

ARM = b"""<mujoco model="arm">
  <default><geom rgba="1 0 0 1"/><joint damping="3"/>
    <default class="soft"><geom rgba="0 0 1 1"/></default></default>
  <worldbody>
    <body name="arm_base" pos="0.4 0 0"><geom type="box" size="0.05 0.05 0.05"/>
      <body name="arm_link" pos="0 0 0.1"><joint name="arm_joint" axis="0 1 0" range="-90 90"/>
        <geom class="soft" type="capsule" size="0.02" fromto="0 0 0 0 0 0.2"/></body></body>
  </worldbody>
</mujoco>
"""


def _task() -> bytes:
    return W.ttt_file(
        W.mesh_pool(TETRA, [0, 1, 2, 0, 1, 3, 0, 2, 3, 1, 2, 3]) +
        W.dummy(1, -1, "task", (0, 0, 0.2), extra=W.model_base() + W.custom_data_4x({"tag": b"hello"})) +
        W.cuboid_shape(2, 1, "block", (0.04, 0.04, 0.04), (0.1, 0, 0.1), moments=(1e-4, 1e-4, 3e-4)) +
        W.pool_shape(3, 1, "stand", pos=(0, 0, -0.2)) +
        W.script(10, 2, SCRIPT), serialization=24, program=40100)


def _state():
    from pyrep.backend import sim
    from pyrep.objects import Object

    w = sim.context().world
    poses = {n: np.round(Object.get_object(n).get_position(), 6) for n in ("task", "block", "stand", "mine",
                                                                            "arm_base", "arm_link", "mask_cam")}
    return set(w.by_name), poses, (w.model.nmesh, w.model.nmeshvert, w.model.nmeshface)


def test_a_saved_scene_reopens_with_its_objects_poses_meshes_scripts_and_data(tmp_path, monkeypatch):
    from pyrep import PyRep
    from pyrep.backend import sim
    from pyrep.const import PrimitiveShape, RenderMode
    from pyrep.objects import Dummy, Joint, Object, Shape, VisionSensor

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (tmp_path / "task.ttm").write_bytes(_task())
    (tmp_path / "arm.xml").write_bytes(ARM)
    out = tmp_path / "saved" / "scene.xml"
    out.parent.mkdir()
    pr = PyRep()
    pr.launch("", headless=True)
    try:
        pr.import_model(str(tmp_path / "task.ttm"))
        pr.import_model(str(tmp_path / "arm.xml"))
        mine = Shape.create(PrimitiveShape.CUBOID, [0.1, 0.2, 0.3], position=[0.5, 0.5, 0.5], respondable=False,
                            color=[0.2, 0.6, 0.3])
        mine.set_name("mine")  # a new pure shape: neither collidable, measurable nor detectable
        # a rename recompiles the model: what was set at run time stays (it is the same object)
        assert not mine.is_respondable() and mine.get_color() == pytest.approx([0.2, 0.6, 0.3])
        Shape("block").set_mass(0.3)
        Shape("block").set_collidable(False)
        Dummy("task").set_position([0.3, 0.1, 0.25])
        Joint("arm_joint").set_joint_position(0.5)
        mask = VisionSensor.create([64, 48], explicit_handling=True, render_mode=RenderMode.OPENGL_COLOR_CODED,
                                   near_clipping_plane=0.02, far_clipping_plane=3.0, position=[1, 0, 1])
        mask.set_name("mask_cam")  # an edit: the sensors are made again, what was set on them stays
        assert mask.get_render_mode() == RenderMode.OPENGL_COLOR_CODED
        before = _state()
        rgba = sim.context().world.model.geom_rgba.copy()
        pr.export_scene(str(out))
    finally:
        pr.shutdown()
    text = out.read_text()
    assert "<default/>" not in text and 'balanceinertia="true"' in text
    for name in ("scene_task_custom.json", "scene_block_child.lua"):
        assert (out.parent / name).is_file()
    assert any(p.suffix == ".stl" for p in out.parent.iterdir())  # the tetrahedron's mesh, named by the file
    pr = PyRep()
    pr.launch(str(out), headless=True)  # refused before: no mesh file, an empty class, bad inertias
    try:
        after = _state()
        assert after[0] == before[0]
        for name, pos in before[1].items():
            assert after[1][name] == pytest.approx(pos, abs=1e-5), name
        assert after[2] == before[2]
        assert Joint("arm_joint").get_joint_position() == pytest.approx(0.5, abs=1e-6)
        mask = VisionSensor("mask_cam")  # set after it was made: kept
        assert mask.get_render_mode() == RenderMode.OPENGL_COLOR_CODED and mask.get_resolution() == [64, 48]
        assert mask.get_near_clipping_plane() == pytest.approx(0.02) and mask.get_position()[0] == pytest.approx(1)
        assert not Shape("mine").is_collidable() and not Shape("mine").is_measurable()
        assert not Shape("block").is_collidable() and Shape("block").is_measurable()  # flags as saved
        # what commands set at run time is saved with the scene, as CoppeliaSim saves it as it is
        assert not Shape("mine").is_respondable() and Shape("mine").get_color() == pytest.approx([0.2, 0.6, 0.3])
        assert Shape("block").get_mass() == pytest.approx(0.3)
        w = sim.context().world
        assert np.allclose(w.model.geom_rgba, rgba)  # the arm's classes: red box, blue capsule
        assert sim.call("readCustomDataBlockEx", Object.get_object("task").get_handle(), "tag") == b"hello"
        pr.start()
        pr.step()
        assert sim.call("getInt32Signal", "block_script") == 7  # the model's child script came along
        pr.stop()
        assert mujoco.mj_name2id(w.model, mujoco.mjtObj.mjOBJ_JOINT, "arm_joint") >= 0
    finally:
        pr.shutdown()
