"""Vision sensors' ``sysCall_vision`` callbacks (simx_server/scripts/vision_callbacks.py), called
where CoppeliaSim calls them (coppeliaSimLib's ``CVisionSensor::_computeDefaultReturnValuesAndApplyFilters``):
each simulation pass, by ``sim.handleVisionSensor``, when a passive sensor gets an image. The
callback's ``simVision`` processing is what every client then reads (the image, the trigger, the
packets after V-REP's default one), in process, over the legacy API and over ZMQ.

The scene: a red box on a grey floor, seen from 1.2 m above by a 64x48 sensor ``cam`` whose Lua
child script keeps the red pixels, makes the image binary and detects the blob."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

import vrep
from conftest import ServerProcess, free_port, wait_until
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation
from simx_server.sim import vision_chain

SCENE = """<mujoco model="vision_callback">
  <option timestep="0.01"/>
  <worldbody>
    <light name="lamp" pos="0 0 3" dir="0 0 -1" diffuse="0.8 0.8 0.8"/>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.3 0.3 0.3 1"/>
    <body name="box" pos="0.1 0.05 0.05">
      <joint name="slide" type="slide" axis="1 0 0" damping="100"/>
      <geom type="box" size="0.2 0.12 0.05" rgba="1 0 0 1" mass="1"/>
    </body>
    <camera name="cam" pos="0 0 1.2" xyaxes="1 0 0 0 1 0" fovy="60" resolution="64 48"/>
    <camera name="ext" pos="-1 0 1.2" resolution="16 12"/>
  </worldbody>
  <custom>
    <text name="simx:cam" data="{script} near=0.1 far=2"/>
    <text name="simx:ext" data="image=external {ext}"/>
  </custom>
</mujoco>
"""
LUA = """simVision = require('simVision')
function sysCall_init()
    calls = 0
    local ok, err = pcall(function() return simVision.distort(sim.handle_self) end)
    sim.setStringSignal('distort', tostring(err))
end
function sysCall_vision(inData)
    calls = calls + 1
    sim.setInt32Signal('calls', calls)
    sim.setStringSignal('inData', sim.packTable(inData))
    local h = inData.handle
    simVision.sensorImgToWorkImg(h)
    simVision.selectiveColorOnWorkImg(h, {1, 0, 0}, {0.4, 0.4, 0.4}, true, true, false)
    local trig, binary = simVision.binaryWorkImg(h, 0.1, 0.1, 0.1, 0.5, 0.5, 0.5, 0.5, 0, 3.2, 1, true)
    local _, blobs = simVision.blobDetectionOnWorkImg(h, 0.5, 0, false)
    simVision.workImgToSensorImg(h)
    return {trigger = trig, packedPackets = {binary, blobs}}
end
function sysCall_trigger(inData)
    sim.setInt32Signal('triggered', #inData.packedPackets)
end
"""


def scene(tmp_path, lua: str = LUA, ext: str = "", script: str = "child_script=vis.lua"):
    (tmp_path / "vis.lua").write_text(lua)
    (tmp_path / "scene.xml").write_text(SCENE.format(script=script, ext=ext))
    return tmp_path / "scene.xml"


def processed(raw: np.ndarray) -> np.ndarray:
    """The callback's image made here from the sensor's rendering: pixels within 0.4 of red in
    each channel, made white (binary at intensity 0.1), the rest black."""
    red = np.all(np.abs(raw / np.float32(255.0) - np.float32([1, 0, 0])) <= np.float32(0.4), axis=2)
    work = np.where(red[..., None], raw / np.float32(255.0), np.float32(0))
    white = work.sum(axis=2, dtype=np.float32) / np.float32(3.0) >= np.float32(0.1)
    return np.repeat(np.where(white, 255, 0).astype(np.uint8)[..., None], 3, axis=2)


def check_packets(img: np.ndarray, packets) -> None:
    """Packets 2 and 3 (the callback's) describe the white blob of ``img`` (rows bottom-up)."""
    ys, xs = np.nonzero(img[..., 0])
    binary, blobs = packets[1], packets[2]
    assert binary[:3] == pytest.approx([len(xs) / img[..., 0].size, xs.mean() / 64, ys.mean() / 48], abs=1e-6)
    assert blobs[:2] == [1, 6] and blobs[2] == pytest.approx(len(xs) / img[..., 0].size)
    assert blobs[4:6] == pytest.approx([(xs.min() + xs.max() + 1) / 2 / 64, (ys.min() + ys.max() + 1) / 2 / 48])


def same(a, b) -> bool:
    """The same packets (float32 values, as two clients receive them)."""
    return len(a) == len(b) and all(np.allclose(x, y, rtol=0, atol=1e-6) for x, y in zip(a, b))


def test_a_lua_callback_processes_the_image_each_pass(tmp_path):
    s = Simulation(scene(tmp_path), realtime=False)
    try:
        h = s.world.resolve("cam").handle
        sim = script_sim(s.world, h, s.signals, simulation=s)
        s.start()
        assert s.signals.get_string("distort") == b"vis.lua:4: simVision.distort is not available in simx " \
                                                  b"(docs/SCRIPTS.md lists what is)"
        s.step()
        assert s.signals.get_int("calls") == 1
        in_data = sim.unpackTable(s.signals.get_string("inData"))
        angle = 2 * math.atan(math.tan(math.radians(30)) * 64 / 48)  # V-REP's angle: along the larger side
        assert in_data == {"visionSensor": h, "handle": h, "resolution": [64, 48], "clippingPlanes": [0.1, 2.0],
                           "viewAngle": pytest.approx(angle), "orthoSize": 0.1, "perspectiveOperation": True}
        raw = s.vision.after(s.vision.raw_image_job(h)).result()
        depth = s.vision.after(s.vision.depth_job(h)).result()
        img = s.vision.image(h, False)
        assert np.array_equal(img, processed(raw)) and 100 < (img[..., 0] > 0).sum() < 1500
        result, *packets = sim.readVisionSensor(h)
        assert result == 1 and len(packets) == 3 and s.signals.get_int("triggered") == 3
        assert packets[0] == pytest.approx(vision_chain.default_packet(raw, depth))  # before the callback
        check_packets(img, packets)
        # the box moves 0.2 m along +x (the image's right): the next pass's blob follows it; a read
        # before that pass returns the last handling's result, as CoppeliaSim's sensor buffers
        x0 = packets[2][4]
        sim.setJointPosition(sim.getObject("/slide"), 0.2)
        assert sim.readVisionSensor(h)[3][4] == x0 and np.array_equal(s.vision.image(h, False), img)
        s.step()
        assert s.signals.get_int("calls") == 2
        x1 = sim.readVisionSensor(h)[3][4]
        assert x1 - x0 == pytest.approx(0.2 / (2 * 1.15 * math.tan(math.atan(math.tan(math.radians(30)) * 64 / 48))),
                                        abs=0.03)
        s.stop()
        assert not np.array_equal(s.vision.image(h, False), processed(s.vision.image(h, False)))  # rendered again
    finally:
        s.close()


def test_explicit_handling_and_handle_vision_sensor(tmp_path):
    s = Simulation(scene(tmp_path), realtime=False)
    try:
        h = s.world.resolve("cam").handle
        sim = script_sim(s.world, h, s.signals, simulation=s)
        s.start()
        sim.setExplicitHandling(h, 1)
        for _ in range(3):
            s.step()
        assert s.signals.get_int("calls") is None  # not handled each pass
        count, *packets = sim.handleVisionSensor(h)
        assert s.signals.get_int("calls") == 1 and count == 1 and len(packets) == 3
        check_packets(s.vision.image(h, False), packets)
        sim.handleVisionSensor(sim.handle_all_except_explicit)
        assert s.signals.get_int("calls") == 1
        sim.setExplicitHandling(h, 0)
        s.step()
        assert s.signals.get_int("calls") == 2
    finally:
        s.close()


def test_the_callback_counts_toward_the_scripts_budget(tmp_path, caplog):
    """A sysCall_vision that never returns is interrupted at the pass's end like any callback,
    the script named; its callbacks are skipped from then on and the simulation goes on."""
    burn = "function sysCall_vision(inData) sim.setInt32Signal('n', (sim.getInt32Signal('n') or 0) + 1) " \
           "while true do end end\nfunction sysCall_sensing() sim.setInt32Signal('sensed', 1) end\n"
    s = Simulation(scene(tmp_path, burn, script="child_script=vis.lua script_timeout=5"), realtime=False)
    s.scripts.budget.seconds = 0.3
    try:
        with caplog.at_level(logging.ERROR, "simx.scripts"):
            s.start()
            for _ in range(3):
                s.step()
        assert s.signals.get_int("n") == 1 and s.steps == 3 and s.signals.get_int("sensed") is None
    finally:
        s.close()
    lines = [r.getMessage() for r in caplog.records if "sysCall_vision" in r.getMessage()]
    assert len(lines) == 1 and "of 'cam'" in lines[0] and "used up their 0.3 s of this pass" in lines[0]


PYTHON = """def sysCall_vision(inData):
    h = inData['handle']
    simVision.sensorImgToWorkImg(h)
    simVision.scaleAndOffsetWorkImg(h, [0, 0, 0], [-1, -1, -1], [1, 1, 1], True)
    simVision.workImgToSensorImg(h)
    return {'trigger': True, 'packedPackets': [sim.packFloatTable([inData['resolution'][0], 7.5])]}
"""


def test_a_python_callback_on_a_passive_sensor_runs_when_it_gets_an_image(tmp_path):
    (tmp_path / "inv.py").write_text(PYTHON)
    s = Simulation(scene(tmp_path, ext="child_script=inv.py"), realtime=False, allow_python_scripts=True)
    try:
        h = s.world.resolve("ext").handle
        sim = script_sim(s.world, h, s.signals, simulation=s)
        s.start()
        s.step()  # a passive sensor is not handled each pass
        assert sim.getVisionSensorImg(h)[0] == bytes(16 * 12 * 3)
        rgb = np.random.default_rng(3).integers(0, 256, (12, 16, 3), dtype=np.uint8)
        sim.setVisionSensorImg(h, rgb.tobytes())
        inverted = ((1 - rgb / np.float32(255)) * np.float32(255.1)).astype(np.uint8)
        assert sim.getVisionSensorImg(h)[0] == inverted.tobytes()
        result, *packets = sim.readVisionSensor(h)
        assert result == 1 and packets[1] == [16.0, 7.5]
    finally:
        s.close()


def test_a_scene_without_vision_callbacks_renders_nothing_per_pass(tmp_path):
    s = Simulation(scene(tmp_path, "function sysCall_sensing() end\n"), realtime=False)
    try:
        s.start()
        for _ in range(5):
            s.step()
        assert s.vision.renders == 0 and s.scripts.vision.sensors == []
    finally:
        s.close()


def test_legacy_and_zmq_clients_read_the_processed_image_and_packets(tmp_path, official):
    """A real server: the legacy client's simxGetVisionSensorImage and simxReadVisionSensor,
    and the ZMQ client's sim.getVisionSensorImg / readVisionSensor / handleVisionSensor return
    the callback's image and packets; the ZMQ client's own simVision calls work on it too."""
    port = free_port()
    srv = ServerProcess(str(scene(tmp_path)), "--zmq-port", str(port))
    cid = -1
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        rc, h = vrep.simxGetObjectHandle(cid, "cam", vrep.simx_opmode_blocking)
        assert rc == 0
        assert vrep.simxStartSimulation(cid, vrep.simx_opmode_blocking) == 0
        wait_until(lambda: (vrep.simxGetIntegerSignal(cid, "calls", vrep.simx_opmode_blocking)[1] or 0) > 2,
                   what="vision callbacks")
        rc, res, data = vrep.simxGetVisionSensorImage(cid, h, 0, vrep.simx_opmode_blocking)
        assert rc == 0 and res == [64, 48]
        img = (np.array(data, dtype=np.int16) % 256).astype(np.uint8).reshape(48, 64, 3)
        assert set(np.unique(img)) == {0, 255}
        rc, detected, packets = vrep.simxReadVisionSensor(cid, h, vrep.simx_opmode_blocking)
        assert rc == 0 and detected is True and [len(p) for p in packets] == [15, 5, 8]
        check_packets(img, packets)
        client = official(port)
        sim, simVision = client.require("sim"), client.require("simVision")  # noqa: N806 (CoppeliaSim's name)
        buffer, size = sim.getVisionSensorImg(h)
        assert size == [64, 48] and buffer == img.tobytes()
        result, *zmq_packets = sim.readVisionSensor(h)
        assert result == 1 and same(zmq_packets, packets)
        calls = sim.getInt32Signal("calls")
        count, *handled = sim.handleVisionSensor(h)
        assert count == 1 and sim.getInt32Signal("calls") > calls and same(handled, packets)
        # the scene's callback ends with workImgToSensorImg, which drops the work image at each
        # pass: in stepping mode no pass comes between the client's two calls
        sim.setStepping(True)
        assert simVision.sensorImgToWorkImg(h) is False
        trig, blob = simVision.blobDetectionOnWorkImg(h, 0.5, 0.0, False)
        assert trig is False and np.frombuffer(blob, "<f4").tolist() == pytest.approx(packets[2])
        sim.setStepping(False)
        with pytest.raises(Exception, match="not implemented by simx .CoppeliaSim 4.x has simVision.distort"):
            simVision.distort(h)
        vrep.simxStopSimulation(cid, vrep.simx_opmode_blocking)
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        srv.stop()
