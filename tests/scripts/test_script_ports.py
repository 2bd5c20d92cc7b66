"""Issue 40: ``simRemoteApi.start`` / ``simExtRemoteApiStart`` from scripts is bounded: at most
limits.MAX_SCRIPT_PORTS distinct ports, on the server's own hosts (loopback by default:
tests/scripts/test_legacy_remote.py serves one on tcp/127.0.0.1 and reads it back)."""

from __future__ import annotations

import pytest

from simx_server.base import limits as L
from simx_server.scene.simulation import Simulation

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

PORTS = r"""
function sysCall_init()
  local out = {}
  for port = 30001, 30000 + COUNT do
    local ok, r = pcall(simRemoteApi.start, port)
    out[#out + 1] = ok and tostring(r) or r
  end
  out[#out + 1] = tostring(simExtRemoteApiStart(30001))  -- asked already: no new port
  sim.setStringSignal("ports", table.concat(out, "\n"))
end
"""


def test_scripts_may_ask_for_a_bounded_number_of_ports(tmp_path):
    count = L.MAX_SCRIPT_PORTS + 3
    (tmp_path / "ports.lua").write_text(f"local COUNT = {count}\n" + PORTS)
    (tmp_path / "scene.xml").write_text("""<mujoco model="ports">
  <worldbody><body name="Box"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody>
  <custom><text name="simx:Box" data="child_script=ports.lua"/></custom>
</mujoco>
""")
    sim = Simulation(tmp_path / "scene.xml", realtime=False)
    try:
        sim.start()
        results = sim.signals.get_string("ports").decode().split("\n")
    finally:
        sim.close()
    assert results[:L.MAX_SCRIPT_PORTS] == ["1"] * L.MAX_SCRIPT_PORTS
    refused = results[L.MAX_SCRIPT_PORTS:count]
    assert len(refused) == 3 and all("at most 8 ports (limits.MAX_SCRIPT_PORTS)" in r for r in refused), refused
    assert results[-1] == "1"
    assert sim.remote_api.take() == list(range(30001, 30001 + L.MAX_SCRIPT_PORTS))  # what the server opens
