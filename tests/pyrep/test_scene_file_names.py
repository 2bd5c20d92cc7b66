"""PyRep's files are what their content says, whatever their names (issue 81): RLBench users
save their scene with ``export_scene("task_design.ttt")`` (MJCF under that name on simx, with
its mesh files beside it) and ``launch`` it again; ``import_model`` and ``sim.loadScene`` read
MJCF named ``.ttm``/``.ttt`` and a V-REP model under a name of its own; content that is none of
them is a clear error. Scene and models written by the test."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "tests" / "scene" / "ttt"))
import tttwriter as W  # noqa: E402

TETRA = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], "<f4")
LID = b"""<mujoco model="lid"><worldbody><body name="lid" pos="0 0.3 0.2"><geom type="box" size="0.05 0.05 0.01"/>
</body></worldbody></mujoco>"""


def _model() -> bytes:
    """A V-REP model: a dummy base with a meshed shape below it."""
    return W.ttt_file(
        W.mesh_pool(TETRA, [0, 1, 2, 0, 1, 3, 0, 2, 3, 1, 2, 3]) +
        W.dummy(1, -1, "task", (0, 0, 0.2), extra=W.model_base()) +
        W.pool_shape(2, 1, "stand", pos=(0.2, 0, 0)), serialization=24, program=40100)


def test_a_scene_exported_as_ttt_launches_again(pyrep_scene, tmp_path, monkeypatch):
    from pyrep import PyRep
    from pyrep.backend import sim
    from pyrep.objects import Joint, Object

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (tmp_path / "task.model").write_bytes(_model())  # V-REP content, not a .ttm name
    (tmp_path / "lid.ttm").write_bytes(LID)  # MJCF under a .ttm name
    saved = tmp_path / "saved" / "task_design.ttt"
    saved.parent.mkdir()
    pr = PyRep()
    pr.launch(str(pyrep_scene), headless=True)
    try:
        assert pr.import_model(str(tmp_path / "task.model")).get_name() == "task"
        assert pr.import_model(str(tmp_path / "lid.ttm")).get_name() == "lid"
        Joint("hinge").set_joint_position(0.4)
        before = {n: np.round(Object.get_object(n).get_position(), 6) for n in ("stand", "lid", "cube")}
        meshes = sim.context().world.model.nmesh
        pr.export_scene(str(saved))
    finally:
        pr.shutdown()
    assert saved.read_bytes().lstrip().startswith(b"<mujoco")
    assert any(p.suffix == ".stl" for p in saved.parent.iterdir())  # the stand's mesh, beside it
    assert not list(saved.parent.glob("*.xml"))  # no staging file left
    pr = PyRep()
    pr.launch(str(saved), headless=True)  # refused before: "not a V-REP/CoppeliaSim file"
    try:
        assert sim.context().world.model.nmesh == meshes
        for name, pos in before.items():
            assert Object.get_object(name).get_position() == pytest.approx(pos, abs=1e-5), name
        assert Joint("hinge").get_joint_position() == pytest.approx(0.4, abs=1e-6)
        # sim.loadScene of the same file, as a program outside the scene calls it
        sim.trust_folder(saved.parent)
        sim.call("loadScene", str(saved))
        assert Joint("hinge").get_joint_position() == pytest.approx(0.4, abs=1e-6)
    finally:
        pr.shutdown()


def test_content_that_is_no_scene_is_refused_clearly(pr, tmp_path):
    from pyrep import PyRep
    from pyrep.errors import CoppeliaSimError, PyRepError

    bad = tmp_path / "bad.ttm"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n not a model")
    with pytest.raises(CoppeliaSimError, match="bad.ttm: not a scene or model file: not XML"):
        pr.import_model(str(bad))
    other = PyRep()
    with pytest.raises(PyRepError, match="bad.ttm: not a scene or model file"):
        other.launch(str(bad), headless=True)
    other.shutdown()
