"""Script simulation parameters and user parameters are bounded like signals (issue 84): a client
scene's script (``--allow-remote-code``) set 40 user parameters of 100 MiB and took the server
from 259 to 4,455 MB, for good. Now one value is at most ``limits.MAX_PARAMETER_BYTES``, all of
the scene's parameters together at most ``limits.MAX_PARAMETERS`` entries and
``limits.MAX_PARAMETER_STORE_BYTES``, and they count toward the scripts' memory
(``limits.MAX_SCRIPTS_MEMORY``, which their Lua states share). In process, the bounds shrunk."""

from __future__ import annotations

import pytest

from test_scripts import small_scene
from simx_server.base import limits as L
from simx_server.scene.simulation import Simulation
from simx_wire.protocol import ArgumentError

SOURCE = """function put(a, b, c, d)
  local n, size, kind = a[1], a[2], c[1]
  for i = 1, n do
    local name = "p" .. i
    if kind == "user" then sim.setUserParameter(sim.handle_self, name, string.rep("x", size))
    else sim.setScriptSimulationParameter(sim.handle_self, name, string.rep("x", size)) end
  end
  return {}, {}, {}, ""
end
function get(a, b, c, d)
  return {#(sim.getUserParameter(sim.handle_self, "p" .. a[1]) or "")}, {}, {}, ""
end
"""


@pytest.fixture
def sim(tmp_path, monkeypatch):
    monkeypatch.setattr(L, "MAX_PARAMETER_BYTES", 1000)
    monkeypatch.setattr(L, "MAX_PARAMETERS", 20)
    monkeypatch.setattr(L, "MAX_PARAMETER_STORE_BYTES", 10_000)
    simulation = Simulation(small_scene(tmp_path, {"Box": ("p.lua", SOURCE)}), realtime=False)
    simulation.start()
    yield simulation
    simulation.stop()
    simulation.close()


def _put(sim, n: int, size: int, kind: str = "user") -> str:
    """The error of setting ``n`` parameters of ``size`` bytes, or ""."""
    box = sim.world.resolve("Box").handle
    try:
        sim.scripts.scripts[box].call("put", [n, size], [], [kind], b"")
    except Exception as exc:
        return str(exc)
    return ""


@pytest.mark.parametrize("kind", ["user", "script"])
def test_a_value_past_the_bound_is_refused(sim, kind):
    assert "MAX_PARAMETER_BYTES" in _put(sim, 1, 1001, kind)
    assert _put(sim, 1, 1000, kind) == ""


def test_the_store_is_bounded_in_count_and_bytes(sim):
    assert "MAX_PARAMETER_STORE_BYTES" in _put(sim, 15, 1000)  # the eleventh would pass 10,000 bytes
    box = sim.world.resolve("Box").handle
    assert sim.scripts.scripts[box].call("get", [9], [], [], b"")[0] == [1000]  # kept up to the bound
    assert "MAX_PARAMETERS" in _put(sim, 25, 1)  # 20 entries at most
    assert _put(sim, 5, 1) == ""  # rewriting an entry takes no more room


def test_parameters_count_toward_the_scripts_memory(sim, monkeypatch):
    """Their bytes are part of what the scene's scripts hold (limits.MAX_SCRIPTS_MEMORY), beside
    the Lua states: the Lua states' cap shrinks with them, and a value past what is left is
    refused (set here from Python, through the script's own sim)."""
    monkeypatch.setattr(L, "MAX_PARAMETER_BYTES", 1 << 20)
    monkeypatch.setattr(L, "MAX_PARAMETER_STORE_BYTES", 8 << 20)
    box = sim.world.resolve("Box").handle
    own = sim.scripts.scripts[box].sim_namespace()
    budget = sim.scripts.budget
    before = budget.memory_cap(object(), budget.memory)
    own.setUserParameter(box, "a", b"x" * (512 << 10))
    assert sim.scripts.memory_used() == (512 << 10) + 1
    assert budget.memory_cap(object(), budget.memory) == before - ((512 << 10) + 1)
    budget.memory -= budget.memory_cap(object(), budget.memory) - (256 << 10)  # 256 KiB left
    with pytest.raises(ArgumentError, match="MAX_SCRIPTS_MEMORY"):
        own.setUserParameter(box, "b", b"x" * (512 << 10))
    own.setUserParameter(box, "a", b"x" * (700 << 10))  # grows by 188 KiB: fits
