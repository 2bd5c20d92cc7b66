"""A scene or model file is what its content says, whatever its name (issue 81): MJCF under a
``.ttt`` name, with ``<include>``\\ d files and meshes beside it, and a URDF under a name of its
own load as MJCF and URDF; a V-REP file is told by its ``VREP`` magic; anything else is one
clear error. Files written by the test."""

from __future__ import annotations

import struct

import pytest

from simx_server.base.file_kinds import FileKind, NotASceneFileError, is_vrep, kind_of
from simx_server.scene.simulation import Simulation
from simx_server.sim.urdf import load_spec

pytestmark = pytest.mark.renderers_on_demand  # no image is read here


def _tetra_stl() -> bytes:
    v = [(0, 0, 0), (0.1, 0, 0), (0, 0.1, 0), (0, 0, 0.1)]
    out = bytearray(80) + struct.pack("<I", 4)
    for face in ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)):
        out += struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *v[i]) for i in face) + b"\0\0"
    return bytes(out)


@pytest.fixture
def mjcf_as_ttt(tmp_path):
    """``scene.ttt`` holding MJCF: a mesh under its ``meshdir``, an include that includes another
    (named relative to the including file's folder)."""
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "tetra.stl").write_bytes(_tetra_stl())
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "arm.xml").write_text(
        '<mujoco><include file="hand.xml"/><worldbody><body name="arm"><geom type="mesh" mesh="tetra"/>'
        '</body></worldbody></mujoco>')
    (tmp_path / "parts" / "hand.xml").write_text(
        '<mujoco><worldbody><body name="hand" pos="0 0 1"><joint name="wrist"/><geom size=".05"/></body>'
        '</worldbody></mujoco>')
    scene = tmp_path / "scene.ttt"
    scene.write_text('<mujoco><compiler meshdir="meshes"/><asset><mesh name="tetra" file="tetra.stl"/></asset>'
                     '<include file="parts/arm.xml"/></mujoco>')
    return scene


def test_mjcf_under_a_ttt_name_loads_with_its_includes_and_meshes(mjcf_as_ttt):
    assert kind_of(mjcf_as_ttt) is FileKind.MJCF and not is_vrep(mjcf_as_ttt)
    model = load_spec(mjcf_as_ttt).compile()  # MuJoCo alone: "could not find decoder for resource"
    assert (model.nbody, model.nmesh, model.njnt) == (3, 1, 1)
    sim = Simulation(mjcf_as_ttt)  # what PyRep.launch and the server's command line make
    try:
        assert {"arm", "hand", "wrist"} <= set(sim.world.by_name)
    finally:
        sim.close()


def test_a_urdf_under_another_name_gets_simxs_urdf_conventions(tmp_path):
    robot = tmp_path / "robot.description"
    robot.write_text('<robot name="r"><link name="base"/><link name="tip"/>'
                     '<joint name="j" type="fixed"><parent link="base"/><child link="tip"/></joint></robot>')
    assert kind_of(robot) is FileKind.URDF
    model = load_spec(robot).compile()
    assert model.nbody == 3  # every link a body: fusestatic off, as for robot.urdf


@pytest.mark.parametrize(("content", "said"), [
    (b"PK\x03\x04 a zip", "not XML (it begins with b'PK\\x03\\x04"),
    (b"<html><body/></html>", "XML whose root element is <html>"),
    (b"", "empty"),
])
def test_content_that_is_no_scene_is_one_clear_error(tmp_path, content, said):
    bad = tmp_path / "bad.ttt"
    bad.write_bytes(content)
    with pytest.raises(NotASceneFileError, match="bad.ttt: not a scene or model file") as info:
        kind_of(bad)
    assert said in str(info.value)
    with pytest.raises(ValueError, match="not a scene or model file"):
        Simulation(bad)


def test_a_vrep_file_is_told_by_its_magic_not_its_name(tmp_path):
    vrep = tmp_path / "scene.bin"
    vrep.write_bytes(b"VREP" + bytes(1100))
    assert is_vrep(vrep) and kind_of(vrep) is FileKind.VREP
    assert not is_vrep(tmp_path / "missing.ttt")
