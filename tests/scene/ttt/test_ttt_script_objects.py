"""CoppeliaSim 4.6+ script objects (issue 41): scripts stored as ``SCT`` objects of the tree are
loaded and run as the child scripts they are, reachable by path (``/UR3/IK``), with their own
handle answering ``sim.getObject`` and the script calls."""

from __future__ import annotations

import pytest

import tttwriter as W
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.sim import paths
from simx_server.api import client_context

pytestmark = pytest.mark.renderers_on_demand  # no image is read

IK = """
function sysCall_init()
    self = sim.getObject('.')
    robot = sim.getObject('..')
    sim.setInt32Signal('ik_self', self)
    sim.setInt32Signal('ik_robot', robot)
end
function sysCall_actuation()
    sim.setJointTargetPosition(sim.getObject('/UR3/joint'), 0.5)
end
function hello(x)
    return x + 1, sim.getObjectAlias(self)
end
function ping(ints, floats, strings, buf)
    return {self + 1000}, {}, {'pong'}, ''
end
"""

PROXY = """
function sysCall_init()
    sim.setInt32Signal('proxy_self', sim.getObject('.'))
end
"""


@pytest.fixture
def scene(tmp_path):
    body = (W.cuboid_shape(1, -1, "UR3", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False)
            + W.joint(2, 1, "joint", (0, 0, 0.15))
            + W.cuboid_shape(3, 2, "link", (0.05, 0.05, 0.3), (0, 0, 0.15), mass=0.3)
            + W.script_object(4, 1, "IK", IK)
            + W.cuboid_shape(5, -1, "Gripper", (0.1, 0.1, 0.1), (1, 0, 0.05), dynamic=False)
            + W.script_object(6, 5, "Script", PROXY, proxy=True)
            + W.script_object(7, 2, "JointScript", "function sysCall_init() end\n"))
    f = tmp_path / "ur3.ttt"
    f.write_bytes(W.ttt_file(body, serialization=25, program=40600))
    return f


def test_script_objects_are_read_and_converted(scene, tmp_path):
    read = reader.read(scene)
    assert [s.handle for s in read.scripts] == [4, 6, 7] and read.objects[4].kind == "script"
    assert read.scripts[0].text.startswith("--lua\n") and read.scripts[1].proxy
    xml, report = convert.convert(read, tmp_path / "out", "ur3")
    assert not any("script" in line for line in report.lines())
    text = xml.read_text()
    assert 'name="simx:IK"' in text and "child_script=IK_child.lua" in text
    assert "child_script=Gripper_child.lua" in text  # parent is proxy: the gripper's script


def test_script_objects_run_and_answer_by_path(scene, tmp_path):
    xml, _ = convert.convert(reader.read(scene), tmp_path / "out", "ur3")
    sim = Simulation(xml, realtime=False)
    try:
        w = sim.world
        ik = paths.find_one(w, "/UR3/IK")
        assert ik == w.resolve("IK").handle and w.get(ik).parent == w.resolve("UR3").handle
        assert paths.find_one(w, "/UR3/joint/link") == w.resolve("link").handle
        assert w.get(w.resolve("JointScript").handle).parent == w.resolve("joint").handle
        assert paths.find_one(w, "../joint", proxy=ik) == w.resolve("joint").handle   # a sibling
        assert paths.find(w, "../..", proxy=ik) == [] and paths.find(w, "..") == []      # the world: none
        assert ik in sim.scripts.scripts                      # sim.getScript's handle is the object's
        sim.start()
        sim.step()
        assert sim.signals.get_int("ik_self") == ik            # '.' is the script object itself
        assert sim.signals.get_int("ik_robot") == w.resolve("UR3").handle
        assert sim.signals.get_int("proxy_self") == w.resolve("Gripper").handle
        ints, _, strings, _ = sim.scripts.call("IK", 1, "ping", [], [], [], b"")
        assert ints == [ik + 1000] and strings == ["pong"]
        remote = client_context(sim).sim                               # what a ZMQ program calls
        assert remote.getScript(1, "/UR3/IK") == ik           # sim.scripttype_simulation
        assert remote.callScriptFunction("hello", ik, 41) == (42, "IK")
        motor = w.motor_index[w.resolve("joint").handle]
        assert w.target_position[motor] == pytest.approx(0.5)  # its actuation ran
    finally:
        sim.stop()
        sim.close()
