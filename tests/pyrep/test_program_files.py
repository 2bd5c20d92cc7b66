"""A PyRep program's files are its own (issue 81): a relative name is its working folder's, as
in CoppeliaSim, which runs in PyRep's process (RLBench's domain randomization example loads
``../tests/unit/assets/textures/0.png`` from ``examples/``). The scene's own folder is
elsewhere, so a name taken relative to it would miss. Files written by the test."""

from __future__ import annotations

import numpy as np


#: A tetrahedron as an OBJ file.
TETRA_OBJ = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def test_relative_names_are_the_programs_working_folders(pr, tmp_path, monkeypatch):
    import cv2

    from pyrep.backend import sim
    from pyrep.objects import Shape

    work = tmp_path / "program" / "examples"
    (tmp_path / "program" / "assets").mkdir(parents=True)
    work.mkdir()
    picture = np.zeros((2, 4, 3), np.uint8)
    picture[0] = [0, 0, 255]  # BGR: the top row red
    cv2.imwrite(str(tmp_path / "program" / "assets" / "0.png"), picture)
    (tmp_path / "program" / "assets" / "tetra.obj").write_text(TETRA_OBJ)
    monkeypatch.chdir(work)
    plane, texture = pr.create_texture("../assets/0.png")  # refused before: "files are read only from..."
    top = np.frombuffer(sim.call("readTexture", texture.get_texture_id()), np.uint8).reshape(2, 4, 3)[1]
    assert top.tolist() == [[255, 0, 0]] * 4
    tetra = Shape.import_shape("../assets/tetra.obj")
    assert len(tetra.get_mesh_data()[1]) == 4  # its 4 triangles
