"""Graph streams and curves kept as data (issue 32): values recorded at the simulation time,
transformations, x/y curves, static copies, through the facade and a Lua child script."""

from __future__ import annotations

import numpy as np
import pytest

from simx_client.protocol import ArgumentError, RemoteError
from simx_server.scene.simulation import Simulation
from simx_server.api import script_sim

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

LUA = """
function sysCall_init()
    graph = sim.getObject('/Graph')
    height = sim.addGraphStream(graph, 'height', 'm')
    speed = sim.addGraphStream(graph, 'speed', 'm/s')
    sim.setGraphStreamTransformation(graph, speed, sim.stream_transf_derivative)
    sim.addGraphCurve(graph, 'phase', 2, {height, speed}, {0, 0}, 'm', 0)
end
function sysCall_actuation()
    local t = sim.getSimulationTime()
    sim.setGraphStreamValue(graph, height, 2 * t)
    sim.setGraphStreamValue(graph, speed, 2 * t)
end
function curve(ints, floats, strings, buf)
    local label, attr, color, x, y = sim.getGraphCurve(graph, ints[1], ints[2])
    return {#x}, y, {label}
end
"""


@pytest.fixture
def sim(tmp_path):
    (tmp_path / "graph.lua").write_text(LUA)
    scene = tmp_path / "graph.xml"
    scene.write_text("""<mujoco><option timestep="0.01"/><worldbody><site name="Graph" size="0.01"/>
<site name="Recorder" size="0.01"/></worldbody>
<custom><text name="simx:Recorder" data="child_script=graph.lua"/></custom></mujoco>""")
    s = Simulation(scene, realtime=False)
    s.start()
    yield s
    s.stop()
    s.close()


def test_a_script_records_streams_and_reads_curves(sim):
    for _ in range(10):
        sim.step()
    n, values, label, _ = sim.scripts.call("Recorder", 1, "curve", [0, 0], [], [], b"")
    assert label == ["height"] and n[0] >= 9
    assert np.diff(values) == pytest.approx([2 * sim.world.dt] * (len(values) - 1))  # 2 t, one value per step
    _, speed, _, _ = sim.scripts.call("Recorder", 1, "curve", [0, 1], [], [], b"")
    assert speed[1:] == pytest.approx([2.0] * (len(speed) - 1))  # the derivative of 2 t
    _, xy, label, _ = sim.scripts.call("Recorder", 1, "curve", [1, 0], [], [], b"")
    assert label == ["phase"] and xy[1:] == pytest.approx([2.0] * (len(xy) - 1))


def test_transformations_static_copies_and_errors(sim):
    api = script_sim(sim.world, sim.world.resolve("Graph").handle, sim.signals, simulation=sim)
    g = api.getObject("/Graph")
    s = api.addGraphStream(g, "ones", "")
    for _ in range(4):
        api.setGraphStreamValue(g, s, 1.0)
        api.setGraphStreamValue(g, s, 1.0)  # the same time: replaces
        sim.step()
    api.setGraphStreamTransformation(g, s, api.stream_transf_cumulative, 2.0, 1.0)
    label, _, _, x, y, minmax, cid, _ = api.getGraphCurve(g, 0, 2)  # the script's two streams come first
    assert y == pytest.approx([3, 5, 7, 9]) and minmax[2:4] == pytest.approx([3, 9]) and cid == s
    frozen = api.duplicateGraphCurveToStatic(g, s, "frozen")
    api.setGraphStreamValue(g, s, 1.0)
    assert api.getGraphCurve(g, 1, 1)[4] == pytest.approx([3, 5, 7, 9])  # the copy stays
    api.destroyGraphCurve(g, frozen)
    with pytest.raises(ArgumentError, match="curveIndex"):
        api.getGraphCurve(g, 1, 1)
    with pytest.raises(RemoteError, match="no graph stream"):
        api.setGraphStreamValue(g, 99, 1.0)
