"""What the scripts of a ``.ttt`` read besides the objects (issues 31 and 34): custom data blocks
(V-REP 3.x ``Cod`` and CoppeliaSim 4.3+ ``Cda``), script simulation parameters kept with the
object (4.3's ``Lsp``), 4.3 aliases, model bases and V-REP's tree for ``sim.getObject`` paths;
read, converted, and used by a scene's own script in a loaded simulation."""

from __future__ import annotations

import json
import struct

import mujoco
import pytest

import tttwriter as W
from simx_server.scene.ttt import convert, reader
from simx_server.scene.ttt.errors import SceneFileError

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

TABLE = struct.pack("<4f", 1.5, 0.25, 0.75, 0.5)

SCRIPT = """
function sysCall_init()
  local s = sim.getObject('./Sensor')
  sim.setInt32Signal('sensor', s)
  sim.setStringSignal('alias', sim.getObjectAlias(s))
  sim.setInt32Signal('model', sim.getObject(':'))
  sim.setInt32Signal('robot', sim.getObject('::'))
  sim.setInt32Signal('body', sim.getObject('/MTB/suctionPad/BodyRespondable'))
  sim.setInt32Signal('element', sim.getObject('/Floor/element'))
  local t = sim.unpackFloatTable(sim.readCustomDataBlock(sim.getObject('/MTB'), 'tableParams'))
  sim.setFloatSignal('table2', t[2])
  sim.setStringSignal('info', sim.readCustomDataBlock(sim.getObject('/Floor'), 'XYZ_INFO'))
  sim.setFloatSignal('speed', sim.getScriptSimulationParameter(sim.handle_self, 'speed'))
end
"""


def _scene() -> bytes:
    """A robot (model base, alias MTB, 3.x custom data) carrying a force sensor (a model base)
    whose child shape holds a dummy aliased ``Sensor``; a floor dummy with 4.3 custom data and a
    child shape; the sensor's child script, its parameters on the object."""
    return W.ttt_file(
        W.cuboid_shape(1, -1, "MTB_Robot", (0.2, 0.2, 0.2), (0, 0, 0.1), dynamic=False,
                       extra=W.alias("MTB") + W.model_base() + W.custom_data_3x({"tableParams": TABLE}, 2)) +
        W.force_sensor(2, 1, "suctionPad", (0, 0, 0.15),
                       extra=W.model_base() + W.object_parameters((("speed", "m/s", "2.5"),))) +
        W.cuboid_shape(3, 2, "suctionPadBodyRespondable", (0.05, 0.05, 0.05), (0, 0, 0.03), mass=0.1,
                       extra=W.alias("BodyRespondable")) +
        W.dummy(4, 3, "suctionPadSensor", (0, 0, 0.03), extra=W.alias("Sensor")) +
        W.dummy(5, -1, "Floor", (1, 0, 0), extra=W.custom_data_4x({"XYZ_INFO": b"sizes=5,5"})) +
        W.cuboid_shape(6, 5, "element", (0.5, 0.5, 0.01), (0, 0, 0), dynamic=False) +
        W.script(100, 2, SCRIPT), serialization=23, program=40300)


def test_reader_reads_custom_data_parameters_and_aliases(tmp_path):
    f = tmp_path / "pad.ttt"
    f.write_bytes(_scene())
    scene = reader.read(f)
    robot, pad, floor = scene.objects[1], scene.objects[2], scene.objects[5]
    assert robot.custom_data == {"tableParams": TABLE} and robot.developer_data == 2
    assert floor.custom_data == {"XYZ_INFO": b"sizes=5,5"}
    assert pad.script_parameters == [{"name": "speed", "value": b"2.5", "unit": "m/s"}]
    assert robot.alias == "MTB" and scene.objects[4].alias == "Sensor"
    assert robot.model_base and pad.model_base
    assert scene.skipped == {"object custom data of other headers (V-REP's simAddObjectCustomData)": 2}


def test_a_custom_data_entry_beyond_its_block_is_a_clear_error(tmp_path):
    bad = W.rec("Cod", W.lst(W.rec("Dat", W.i32(356248756, 12) + W.i32(400, 4) + b"abc\0")))
    f = tmp_path / "bad.ttt"
    f.write_bytes(W.ttt_file(W.dummy(1, -1, "D", extra=bad)))
    with pytest.raises(SceneFileError, match=r"bad.ttt.*Cod/Dat.*custom data entry of declared size 400"):
        reader.read(f)


def test_converter_writes_custom_data_aliases_and_vrep_tree(tmp_path):
    f = tmp_path / "pad.ttt"
    f.write_bytes(_scene())
    out = tmp_path / "out"
    xml, report = convert.convert(reader.read(f), out, "pad")
    texts = {t.name: dict(i.split("=", 1) for i in t.data.split()) for t in mujoco.MjSpec.from_file(str(xml)).texts}
    robot = texts["simx:MTB_Robot"]
    assert robot["alias"] == "MTB" and robot["model_base"] == "1"
    assert json.loads((out / robot["custom_data"]).read_text()) == {"tableParams": "AADAPwAAgD4AAEA/AAAAPw=="}
    # the MJCF hangs the force sensor's site in its child shape's body; V-REP's tree is kept
    assert texts["simx:suctionPadBodyRespondable"]["vrep_parent"] == "suctionPad"
    assert texts["simx:suctionPad"]["vrep_parent"] == "MTB_Robot"
    assert texts["simx:element"]["vrep_parent"] == "Floor"  # a dummy's child: in the dummy's body
    params = json.loads((out / texts["simx:suctionPad"]["script_parameters"]).read_text())
    assert params == [{"name": "speed", "value": "2.5", "unit": "m/s"}]
    assert report.counts["object custom data of other headers (V-REP's simAddObjectCustomData)"] == 2


def test_the_scenes_script_reads_its_custom_data_parameters_and_paths(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation

    f = tmp_path / "pad.ttt"
    f.write_bytes(_scene())
    sim = Simulation(f, realtime=False)
    try:
        sim.start()
        sim.step()
        w, get = sim.world, sim.signals.get
        handle = {name: w.resolve(name).handle for name in ("MTB_Robot", "suctionPad", "suctionPadSensor",
                                                             "suctionPadBodyRespondable", "element")}
        assert get("int", "sensor") == handle["suctionPadSensor"]
        assert get("string", "alias") in ("Sensor", b"Sensor")
        assert get("int", "model") == handle["suctionPad"]  # ':' the script's model base
        assert get("int", "robot") == handle["MTB_Robot"]   # '::' the model above it
        assert get("int", "body") == handle["suctionPadBodyRespondable"]
        assert get("int", "element") == handle["element"]
        assert get("float", "table2") == pytest.approx(0.25)
        assert get("string", "info") in ("sizes=5,5", b"sizes=5,5")
        assert get("float", "speed") == pytest.approx(2.5)
        # one store: the 4.x block calls see the file's data, and what a script writes
        assert sim.custom_data[handle["MTB_Robot"]]["tableParams"] == TABLE
        sim.stop()
    finally:
        sim.close()


def test_renaming_keeps_aliases_and_the_vrep_tree_true(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation
    from simx_server.api import script_sim

    f = tmp_path / "pad.ttt"
    f.write_bytes(_scene())
    sim = Simulation(f, realtime=False)
    try:
        api = script_sim(sim.world, sim.world.resolve("MTB_Robot").handle, sim.signals, simulation=sim)
        sensor = api.getObject("/MTB/suctionPad/Sensor")
        assert api.getObjectAlias(sensor) == "Sensor"
        api.setObjectAlias(sensor, "Probe")  # the file's alias gives way to the new one
        assert api.getObjectAlias(sensor) == "Probe"
        assert api.getObject("/MTB/suctionPad/Probe") == sensor
        assert api.getObject("/MTB/suctionPad/Sensor", {"noError": True}) == -1
        pad = api.getObject("/MTB/suctionPad")
        api.setObjectAlias(pad, "gripper")  # the shape below still hangs from it in V-REP's tree
        assert api.getObject("/MTB/gripper/BodyRespondable") == sim.world.resolve("suctionPadBodyRespondable").handle
    finally:
        sim.close()


COROUTINE = """
function sysCall_init()
  corout = coroutine.create(coroutineMain)
end

function sysCall_actuation()
  if coroutine.status(corout) ~= 'dead' then
    local ok, errorMsg = coroutine.resume(corout)
    if errorMsg then error(debug.traceback(corout, errorMsg), 2) end
  end
end

function coroutineMain()
  local n = 0
  while true do
    n = n + 1
    sim.setInt32Signal('passes', n)
    sim.switchThread()  -- 4.2+'s non-threaded template: yields this coroutine, one pass a step
  end
end
"""


def test_a_4x_coroutine_script_switches_once_a_step(tmp_path, monkeypatch, caplog):
    """CoppeliaSim 4.2+ writes 'threaded' child scripts as non-threaded ones that resume their
    own coroutine each step, which yields with sim.switchThread() (the scara corpus scene)."""
    import logging

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation

    f = tmp_path / "co.ttt"
    f.write_bytes(W.ttt_file(W.dummy(1, -1, "Robot") + W.script(100, 1, COROUTINE), serialization=24,
                             program=40501))
    with caplog.at_level(logging.ERROR, logger="simx.scripts"):
        sim = Simulation(f, realtime=False)
        try:
            sim.start()
            for _ in range(5):
                sim.step()
            passes = sim.signals.get("int", "passes")
            sim.stop()
        finally:
            sim.close()
    assert not [r for r in caplog.records if r.name == "simx.scripts"], caplog.text
    assert passes == 5


def test_a_scene_loaded_later_brings_its_custom_data(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation

    (tmp_path / "empty.ttt").write_bytes(W.ttt_file(W.dummy(1, -1, "Nothing")))
    (tmp_path / "pad.ttt").write_bytes(_scene())
    sim = Simulation(tmp_path / "empty.ttt", realtime=False)
    try:
        assert sim.custom_data == {}
        sim.editor.load_scene("pad.ttt", 0)  # simxLoadScene
        robot = sim.world.resolve("MTB_Robot").handle
        assert sim.custom_data[robot] == {"tableParams": TABLE}
        assert sim.scripts.shared["custom_data"] is sim.custom_data  # the 3.x calls' store is the same
    finally:
        sim.close()


def test_full_paths_walk_vreps_tree(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation
    from simx_server.api import script_sim

    f = tmp_path / "pad.ttt"
    f.write_bytes(_scene())
    sim = Simulation(f, realtime=False)
    try:
        api = script_sim(sim.world, sim.world.resolve("MTB_Robot").handle, sim.signals, simulation=sim)
        body = sim.world.resolve("suctionPadBodyRespondable").handle
        path = api.getObjectAlias(body, 1)
        assert path == "/MTB/suctionPad/BodyRespondable"  # aliases; both model bases kept
        assert api.getObject(path) == body
    finally:
        sim.close()
