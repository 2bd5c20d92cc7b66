"""The fixtures the ``sim`` facade's in-process tests share: a running Simulation of
``tests/scenes/sensors.xml`` stepped once, and the facade of its ``blockA`` (imported by the test
modules that use them)."""

from __future__ import annotations

import pytest

from conftest import ROOT
from simx_server.scene.simulation import Simulation
from simx_server.api import script_sim

SENSORS = ROOT / "tests" / "scenes" / "sensors.xml"


def running(scene) -> Simulation:
    s = Simulation(scene, realtime=False)
    s.start()
    s.step()
    return s


@pytest.fixture
def sim():
    s = running(SENSORS)
    yield s
    s.stop()
    s.close()


@pytest.fixture
def api(sim):
    return script_sim(sim.world, sim.world.resolve("blockA").handle, sim.signals, simulation=sim)
