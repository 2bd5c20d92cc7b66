"""A PyRep program's files are its own (issue 81): a relative name is its working folder's, as
in CoppeliaSim, which runs in PyRep's process (RLBench's domain randomization example loads
``../tests/unit/assets/textures/0.png`` from ``examples/``). The scene's own folder is
elsewhere, so a name taken relative to it would miss. Files written by the test."""

from __future__ import annotations

import struct

import numpy as np


def _stl() -> bytes:
    v = [(0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1)]
    out = bytearray(80) + struct.pack("<I", 4)
    for face in ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)):
        out += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v[i]) for i in face) + b"\0\0"
    return bytes(out)


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
    (tmp_path / "program" / "assets" / "tetra.stl").write_bytes(_stl())
    monkeypatch.chdir(work)
    plane, texture = pr.create_texture("../assets/0.png")  # refused before: "files are read only from..."
    top = np.frombuffer(sim.call("readTexture", texture.get_texture_id()), np.uint8).reshape(2, 4, 3)[1]
    assert top.tolist() == [[255, 0, 0]] * 4
    tetra = Shape.import_shape("../assets/tetra.stl")
    assert len(tetra.get_mesh_data()[1]) == 4  # its 4 triangles
