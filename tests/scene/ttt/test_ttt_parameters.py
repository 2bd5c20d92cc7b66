"""Script simulation parameters typed as V-REP pushes them (issue 41): a boolean parameter is
a boolean (``"false"`` is false in Lua), a number a number, a binary value its bytes unchanged
(CoppeliaSim's ``pushCorrectTypeOntoLuaStack_old``), from a synthetic ``.ttt`` through its
conversion; ``simSetScriptSimulationParameter(sim_handle_tree, ...)`` sets the scripts below."""

from __future__ import annotations

import numpy as np
import pytest

import tttwriter as W

from simx_server.scene.simulation import Simulation
from simx_server.api import script_parameters as SP

#: A recorded trajectory: 5,000 float32 joint angles, bytes that are not UTF-8 (zeros included).
pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here
TRAJECTORY = np.linspace(-3.1, 3.1, 5000, dtype="<f4").tobytes()

PARENT = """
function sysCall_init()
    local active = simGetScriptSimulationParameter(sim_handle_self, 'active')
    simSetIntegerSignal('active_is_boolean', type(active) == 'boolean' and 1 or 0)
    simSetIntegerSignal('active_branch', active and 1 or 0)
    simSetIntegerSignal('count_plus_one', simGetScriptSimulationParameter(sim_handle_self, 'count') + 1)
    simSetStringSignal('trajectory', simGetScriptSimulationParameter(sim_handle_self, 'trajectory'))
    simSetStringSignal('label', simGetScriptSimulationParameter(sim_handle_self, 'label'))
    simSetStringSignal('count_text', simGetScriptSimulationParameter(sim_handle_self, 'count', true))
    simSetIntegerSignal('tree', simSetScriptSimulationParameter(sim_handle_tree, 'gain', '7'))
end
"""

CHILD = """
function sysCall_actuation()
    simSetIntegerSignal('child_gain', simGetScriptSimulationParameter(sim_handle_self, 'gain') or -1)
end
"""


def _scene() -> bytes:
    return W.ttt_file(
        W.cuboid_shape(1, -1, "Robot", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False) +
        W.cuboid_shape(2, 1, "Arm", (0.1, 0.1, 0.1), (0, 0, 0.2), dynamic=False) +
        W.script(100, 1, PARENT, parameters=(("active", "", "false"), ("count", "", "41"), ("label", "", "robot one"),
                                             ("trajectory", "rad", TRAJECTORY))) +
        W.script(101, 2, CHILD, parameters=(("gain", "", "1"),)))


@pytest.fixture()
def sim(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    path = tmp_path / "params.ttt"
    path.write_bytes(_scene())
    s = Simulation(path, realtime=False)
    yield s
    s.close()


def test_lua_scripts_get_booleans_numbers_and_the_binary_bytes(sim):
    sim.start()
    sim.step()
    get = sim.signals.get
    assert get("int", "active_is_boolean") == 1 and get("int", "active_branch") == 0  # "false" is false
    assert get("int", "count_plus_one") == 42
    assert get("string", "trajectory") == TRAJECTORY  # 20,000 bytes, not one U+FFFD
    assert get("string", "label") == b"robot one"
    assert get("string", "count_text") == b"41"
    # sim_handle_tree: the one script below the robot's, which then reads the value set
    assert get("int", "tree") == 1 and get("int", "child_gain") == 7
    sim.stop()


def test_python_scripts_get_the_typed_values(sim):
    robot = sim.world.resolve("Robot").handle
    facade = sim.scripts.scripts[robot].sim_namespace()  # what a Python child script's sim is
    get = facade.getScriptSimulationParameter
    assert get(-4, "active") is False
    assert get(-4, "count") == 41
    assert get(-4, "trajectory") == TRAJECTORY
    assert get(-4, "label") == "robot one"
    assert get(-4, "trajectory", True) == TRAJECTORY and get(-4, "count", True) == "41"
    assert get(-4, "missing") is None
    assert facade.setScriptSimulationParameter(-4, "raw", b"\x00\xff") == 1
    assert get(-4, "raw") == b"\x00\xff"


@pytest.mark.parametrize("stored, expected", [
    ("nil", None), ("true", True), ("false", False), ("3", 3), ("-2.5e-3", -2.5e-3), (" 3", " 3"), ("1_000", "1_000"),
    ("0x10", "0x10"), (b"a\x00b", "a\x00b"), (b"\xff\xfe", b"\xff\xfe"), ("True", "True"), ("", ""),
])
def test_the_type_rule_of_coppeliasim(stored, expected):
    assert SP.typed(stored) == expected
    assert type(SP.typed(stored)) is type(expected)
