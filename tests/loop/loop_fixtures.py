"""What the loop's tests share (imported by the modules of tests/loop): a small scene, a real
:class:`~simx_server.scene.simulation.Simulation` of it, and a :class:`Loop` with the thread
that serves it."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from simx_server.loop.core import Loop
from simx_server.scene.simulation import Simulation

SCENE = """<mujoco>
  <option timestep="0.01"/>
  <worldbody>
    <body name="arm"><joint name="hinge" type="hinge" axis="0 0 1"/><geom type="capsule" size="0.02 0.1"/></body>
  </worldbody>
</mujoco>
"""
WAIT = 10.0  # s: a bound on a loaded machine, never a timing under test


class LoopThread:
    """A loop and the thread that serves it (``thread.start()`` is the test's)."""

    def __init__(self, sim: Simulation, **kwargs: Any) -> None:
        self.loop = Loop(sim, **kwargs)
        self.thread = threading.Thread(target=self.loop.serve, name="test-loop", daemon=True)

    def stop(self) -> None:
        self.loop.request_stop()
        self.thread.join(WAIT)
        assert not self.thread.is_alive(), "serve() did not return after request_stop()"
        self.loop.close()


@pytest.fixture
def sim(tmp_path: Path) -> Iterator[Simulation]:
    """A Simulation of :data:`SCENE`, not real time."""
    scene = tmp_path / "arm.xml"
    scene.write_text(SCENE)
    simulation = Simulation(scene, dt=0.01, realtime=False)
    yield simulation
    simulation.close()
