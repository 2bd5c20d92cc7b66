"""A scene loaded while the simulation runs is refused with the way out (issue 33 item 7):
CoppeliaSim starts stopped and its ZMQ examples load a scene first, simx-server starts running."""

from __future__ import annotations

import pytest

from simx_client.protocol import RemoteError
from simx_server.commands.editing import EDITING_HANDLERS as H
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


def test_load_scene_while_running_says_how_to_stop(tmp_path):
    scene = tmp_path / "box.xml"
    scene.write_text("<mujoco><worldbody><body name='box'><freejoint/><geom size='0.1'/></body></worldbody>"
                     "</mujoco>")
    sim = Simulation(scene, dt=0.05, realtime=False)
    try:
        sim.start()
        with pytest.raises(RemoteError) as refused:
            H["LoadScene"](sim, [scene.name, 0])
        text = str(refused.value)
        assert text.startswith("stop the simulation first")
        assert "sim.stopSimulation()" in text and "--stopped" in text
    finally:
        sim.close()
