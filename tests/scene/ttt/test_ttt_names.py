"""Messages about a ``.ttt`` name the file the user gave, not its conversion's ``scene.xml`` in
the cache (issue 41): ``--list-objects``, unknown names and paths, and a scene loaded later."""

from __future__ import annotations

import pytest

import tttwriter as W

from simx_wire.protocol import UnknownObjectError
from simx_server.scene import listing
from simx_server.scene.simulation import Simulation


pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


@pytest.fixture()
def cell(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    (tmp_path / "cell.ttt").write_bytes(W.simple_scene())
    (tmp_path / "other.ttt").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.5))))
    return tmp_path


def test_list_objects_names_the_ttt(cell, capsys):
    assert listing.main(cell / "cell.ttt") == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first.startswith("scene cell.ttt: 6 objects"), first


def test_unknown_names_and_paths_name_the_ttt(cell):
    sim = Simulation(cell / "cell.ttt", realtime=False)
    try:
        assert sim.world.scene_name == "cell.ttt"
        with pytest.raises(UnknownObjectError, match=r"'Nothing' does not exist in scene cell.ttt$"):
            sim.world.resolve("Nothing")
        with pytest.raises(UnknownObjectError, match=r"does not exist in scene cell.ttt"):
            sim.world.resolve("/Base/Nothing")
        sim.editor.load_scene("other.ttt", 0)  # simxLoadScene of another .ttt beside it
        with pytest.raises(UnknownObjectError, match=r"does not exist in scene other.ttt"):
            sim.world.resolve("Base")
    finally:
        sim.close()
