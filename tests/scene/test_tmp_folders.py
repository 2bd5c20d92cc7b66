"""Issue 19 part 5: only the server's own transfer folders are untrusted. A folder named
``simx-*`` in the temporary folder that a person made (a checkout cloned to /tmp/simx-demo, a
``--scene-path`` folder) is an ordinary folder: its scenes' child scripts run, its meshes import."""

from __future__ import annotations

import shutil
import tempfile
import uuid
from pathlib import Path

import pytest

from conftest import ROOT
from simx_server.base import scene_guard as guard
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

SCRIPTS = ROOT / "tests" / "scenes" / "scripts"
CHILD = 1


@pytest.fixture
def demo():
    folder = Path(tempfile.gettempdir()).resolve() / f"simx-demo-{uuid.uuid4().hex[:8]}"
    shutil.copytree(SCRIPTS, folder)
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


def test_a_simx_named_folder_of_a_person_is_not_a_transfer_folder(demo):
    assert not guard.is_transferred(demo / "facade.lua")
    assert demo not in guard.transfer_folders()
    sim = Simulation(demo / "scripts_scene.xml", dt=0.05, realtime=False, allow_python_scripts=True)
    try:
        assert sim.editor.files_dir not in (demo, *demo.parents)
        assert guard.is_transferred(sim.editor.files_dir / "x.lua")  # the server's own still is
        sim.start()
        ints, *_ = sim.scripts.call("LuaBox", CHILD, "echo", [7], [], [], b"")
        assert ints == [7]  # the scene's own child script runs
    finally:
        sim.close()
