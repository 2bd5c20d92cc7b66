"""Vision sensors' filter chains and options read from ``.ttt`` files: what the converter
writes (``simx:NAME`` settings, the load report) and what the sensors then output, in an
in-process Simulation (V-REP's semantics: coppeliaSimLib's ``CSimpleFilter`` and simVision)."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import mujoco
import numpy as np
import pytest

import ttt_vision as V
import tttwriter as W
from simx_server.commands import sensors as cmd_sensors
from simx_server.scene.ttt import convert, reader

try:
    from conftest import SHARED, require_shared
except ImportError:
    from tests.conftest import SHARED, require_shared

TUTORIAL = SHARED / "ttt-corpus" / "Ianlande+Vrep_yolov3_ddpg_pytorch__scenes_scene.ttt"
PNGS = Path(os.environ.get("SIMX_TEST_PNGS", "/nonexistent"))


@pytest.fixture()
def load(tmp_path, monkeypatch):
    """Write a scene, convert it (settings + report) and load it in a Simulation."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    from simx_server.scene.simulation import Simulation

    sims = []

    def make(data: bytes):
        f = tmp_path / "scene.ttt"
        f.write_bytes(data)
        xml, report = convert.convert(reader.read(f), tmp_path / "out", "scene")
        texts = {t.name: t.data for t in mujoco.MjSpec.from_file(str(xml)).texts}
        sims.append(Simulation(f, realtime=False))
        return sims[-1], texts, report

    yield make
    for sim in sims:
        sim.close()


def _h(sim, name):
    return sim.world.resolve(name).handle


def _save(name: str, img: np.ndarray) -> None:
    """Keep a PNG of ``img`` (rows bottom-up) where SIMX_TEST_PNGS points, to look at."""
    if PNGS.is_dir():
        cv2.imwrite(str(PNGS / name), np.ascontiguousarray(img[::-1, :, ::-1] if img.ndim == 3 else img[::-1]))


def test_depth_to_work_to_output_is_grey_depth_rising_with_distance(load):
    """Components 2 and 4 ("original depth image to work image", "work image to output
    image") of a sensor that ignores RGB, as the tutorial's kinect_depth: a grey image of the
    depth, near dark, far bright, bytes = depth x 255.1 truncated."""
    sim, texts, report = load(V.scene(V.vision_sensor(10, "depth", [V.component(2), V.component(4)], va2=2 | 16)))
    settings = texts["simx:depth"].split()
    assert "filters=sensorDepthMapToWorkImg;workImgToSensorImg" in settings and "ignore_rgb=true" in settings
    assert not any("filter" in line for line in report.lines())
    h = _h(sim, "depth")
    img, depth = sim.vision.image(h, False), sim.vision.depth(h)
    _save("synthetic_depth_chain.png", img)
    assert np.array_equal(img[..., 0], img[..., 1]) and np.array_equal(img[..., 0], img[..., 2])
    assert np.array_equal(img[..., 0], (depth * np.float32(255.1)).astype(np.uint8))
    tower, floor = img[..., 0].min(), img[2, 2, 0]  # the tower's top (nearest), the floor in a corner
    assert 0 < tower < floor < 255
    # the floor is 1.5 m away, the tower's top 0.9 m: (d - near) / (far - near) x 255.1
    assert floor == int((1.5 - 0.1) / 1.9 * 255.1) and abs(int(tower) - int(0.8 / 1.9 * 255.1)) <= 1
    assert np.array_equal(sim.vision.image(h, True), img[..., 0])  # grey: the same bytes
    # V-REP's default packet is off (Va2 bit 4): an empty first packet
    detected, packets = cmd_sensors.read_vision_sensor(sim, [h]).future.result()
    assert detected is False and packets == [[]]


def test_blob_detection_finds_the_tower_with_v_reps_packet(load):
    """Depth, inverted (intensity scale to greys from 1 to 0), blobs of intensity >= 0.5: the
    tower's top, 0.25 m square in an orthographic 1 m x 1 m view of 64 x 64 pixels."""
    chain = [V.component(2), V.component(25, ints=(0,), floats=(1.0, 0.0)),
             V.component(34, bytes_=(0,), floats=(0.5, 0.0)), V.component(4)]
    sim, texts, _ = load(V.scene(V.vision_sensor(10, "blobs", chain, res=(64, 64), ortho=1.0)))
    assert "filters=sensorDepthMapToWorkImg;intensityScaleOnWorkImg(1,0,1);blobDetectionOnWorkImg(0.5,0,0);" \
           "workImgToSensorImg" in texts["simx:blobs"].split()
    h = _h(sim, "blobs")
    detected, packets = cmd_sensors.read_vision_sensor(sim, [h]).future.result()
    assert detected is False and len(packets) == 2 and len(packets[0]) == 15
    count, size, angle, x, y, w, hh = packets[1][0], *packets[1][2:]
    assert (count, packets[1][1], len(packets[1])) == (1, 6, 8)
    img = sim.vision.image(h, True)
    _save("synthetic_blob_chain.png", img)
    rows, cols = np.nonzero(img >= 128)
    assert size == pytest.approx(len(rows) / 64 ** 2) and size == pytest.approx(16 * 16 / 64 ** 2, abs=0.01)
    # V-REP's box: the outline pixels' span (one pixel less than the blob), its centre + 0.5
    assert angle == pytest.approx(0.0, abs=1e-6)
    assert w == pytest.approx((cols.max() - cols.min()) / 64) and hh == pytest.approx((rows.max() - rows.min()) / 64)
    assert x == pytest.approx((cols.max() + cols.min() + 1) / 2 / 64)
    assert y == pytest.approx((rows.max() + rows.min() + 1) / 2 / 64)
    # where the tower is: the sensor looks along its +z with +y up, so +x is on the image's left;
    # it looks down with its y along the world's -y: the tower at world (0.1, 0.05) is at
    # x = 0.5 - 0.1, y (from the image's bottom) = 0.5 - 0.05
    assert x == pytest.approx(0.4, abs=1.5 / 64) and y == pytest.approx(0.45, abs=1.5 / 64)


def test_a_component_simx_cannot_apply_is_reported_and_the_image_stays_rendered(load):
    sim, texts, report = load(V.scene(
        V.vision_sensor(10, "rot", [V.component(1), V.component(35, bytes_=(0,), ints=(32, 32)), V.component(4)]),
        V.vision_sensor(11, "plain", [V.component(1), V.component(4)])))
    assert "vision sensor filters: image to coordinates (the sensor shows its unfiltered image)" in report.counts
    assert "filters=" not in texts["simx:rot"] and "filters=" not in texts["simx:plain"]
    assert np.array_equal(sim.vision.image(_h(sim, "rot"), False), sim.vision.image(_h(sim, "plain"), False))


def test_sensor_options_from_the_file(load):
    """Ignore RGB (the image is the sensor's background colour, Db2), ignore depth (all 1),
    colour-coded handles (Rmd 2)."""
    sim, texts, report = load(V.scene(
        V.vision_sensor(10, "norgb", va2=2, background=(1.0, 0.5, 0.0)),
        V.vision_sensor(11, "nodepth", va2=4),
        V.vision_sensor(12, "coded", render_mode=2)))
    assert "background=1,0.5,0" in texts["simx:norgb"].split()
    assert "render_mode=handles" in texts["simx:coded"].split()
    img = sim.vision.image(_h(sim, "norgb"), False)
    assert np.all(img == np.array([255, 127, 0], np.uint8))  # V-REP's bytes: value x 255.1, truncated
    assert np.all(sim.vision.depth(_h(sim, "nodepth")) == 1.0)
    coded = sim.vision.image(_h(sim, "coded"), False).astype(np.int64)
    ids = set(np.unique(coded[..., 0] + 256 * coded[..., 1] + 65536 * coded[..., 2]).tolist())
    assert _h(sim, "Tower") in ids and _h(sim, "Floor") in ids
    # V-REP 3.x's first packet of a colour-coded sensor: the handles it sees, each + 0.5
    _, packets = cmd_sensors.read_vision_sensor(sim, [_h(sim, "coded")]).future.result()
    assert packets == [sorted(h + 0.5 for h in ids if h != 0xFFFFFF)]


def test_the_background_is_the_sensors_colour_not_the_sky(load):
    """V-REP clears a sensor's image to its default background colour (Db2), or with Va3 bit 7
    to the environment's fog background (Fbg, black when the file has none): no sky box."""
    up = (1.0, 0.0, 0.0, 0.0)  # the sensor's +z (its view) up: nothing in view
    sim, texts, _ = load(V.scene(
        V.vision_sensor(10, "blue", background=(0.2, 0.4, 0.6), quat=up),
        V.vision_sensor(11, "black", quat=up),
        V.vision_sensor(12, "env", background=(1, 1, 1), quat=up, va3=128),
        V.vision_sensor(13, "floor", background=(0.2, 0.4, 0.6))))
    assert "background=0.2,0.4,0.6" in texts["simx:blue"].split() and "background=0,0,0" in texts["simx:env"].split()
    assert np.all(sim.vision.image(_h(sim, "blue"), False) == [51, 102, 153])  # x 255.1, truncated
    assert not sim.vision.image(_h(sim, "black"), False).any()
    assert not sim.vision.image(_h(sim, "env"), False).any()
    floor = sim.vision.image(_h(sim, "floor"), False)
    assert not np.all(floor == [51, 102, 153], axis=2).any()  # the floor fills its view


def test_a_sensor_sees_nothing_beyond_its_far_plane(load):
    """V-REP clips a sensor's image at its clipping planes: with far = 1.2 m, looking down from
    1.5 m, the floor is gone (the background colour), the tower's top (0.9 m away) stays."""
    sim, _, _ = load(V.scene(V.vision_sensor(10, "short", far=1.2, background=(0.2, 0.4, 0.6)),
                             V.vision_sensor(11, "long", far=2.0, background=(0.2, 0.4, 0.6))))
    short, long_ = sim.vision.image(_h(sim, "short"), False), sim.vision.image(_h(sim, "long"), False)
    _save("synthetic_far_plane.png", short)
    bg = np.all(short == [51, 102, 153], axis=2)
    tower = sim.vision.depth(_h(sim, "long")) < (1.2 - 0.1) / 1.9  # nearer than 1.2 m
    assert tower.sum() > 50 and np.array_equal(bg, ~tower)
    inside = cv2.erode(tower.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0  # not its anti-aliased edge
    assert not np.all(long_ == [51, 102, 153], axis=2).any() and np.array_equal(short[inside], long_[inside])


def test_the_tutorials_kinect_depth_outputs_grey_depth(load):
    """The tutorial's scene.ttt: kinect_depth's chain (2, 4) makes V-REP's grey depth image;
    kinect_rgb's (1, 4) is the identity."""
    sim, texts, report = load(require_shared(TUTORIAL, "the tutorial's scene").read_bytes())
    assert "filters=sensorDepthMapToWorkImg;workImgToSensorImg" in texts["simx:kinect_depth"].split()
    assert "filters=" not in texts["simx:kinect_rgb"]
    depth_h, rgb_h = _h(sim, "kinect_depth"), _h(sim, "kinect_rgb")
    assert np.all(sim.vision.image(depth_h, False) == 255)  # at load it sees nothing within 3.5 m: white
    for h in (depth_h, rgb_h):  # look down at the robot from 1.5 m
        sim.world.set_pose(h, -1, position=[0.0, 0.0, 1.5], rotation=np.diag([1.0, -1.0, -1.0]))
    img, rgb = sim.vision.image(depth_h, False), sim.vision.image(rgb_h, False)
    _save("tutorial_kinect_depth.png", img)
    _save("tutorial_kinect_rgb.png", rgb)
    assert np.array_equal(img[..., 0], img[..., 2]) and np.array_equal(img[..., 1], img[..., 2])
    depth = sim.vision.depth(depth_h)
    assert np.array_equal(img[..., 0], (depth * np.float32(255.1)).astype(np.uint8))
    assert img.std() > 5 and abs(float(img.mean()) - float(rgb.mean())) > 1  # not the colour photo


VISION_SCRIPT = """function sysCall_init() calls = 0 end
function sysCall_vision(inData)
    calls = calls + 1
    sim.setInt32Signal('calls_' .. sim.getObjectAlias(inData.handle), calls)
    simVision.sensorDepthMapToWorkImg(inData.handle)
    local trig, packet = simVision.binaryWorkImg(inData.handle, 0.6, 0, 0, 0, 0, 0, 0, 0, 0, 0, false)
    simVision.workImgToSensorImg(inData.handle)
    return {packedPackets = {packet}}
end
"""


def test_a_sensors_own_script_processes_its_image_and_explicit_ones_wait(tmp_path, monkeypatch):
    """A .ttt sensor's child script with a vision callback (CoppeliaSim 4.2+): each pass, the
    image clients read is the callback's (here the depth made binary: the tower near, black;
    the floor white); a sensor saved with explicit handling (``Va3`` bit 1) is handled only by
    ``sim.handleVisionSensor``."""
    from simx_server.api import script_sim
    from simx_server.scene.simulation import Simulation

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    f = tmp_path / "scene.ttt"
    f.write_bytes(V.scene(V.vision_sensor(10, "seen"), V.vision_sensor(11, "later", va3=2),
                          W.script(100, 10, VISION_SCRIPT), W.script(101, 11, VISION_SCRIPT)))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "scene")
    texts = {t.name: t.data for t in mujoco.MjSpec.from_file(str(xml)).texts}
    assert "explicit=true" in texts["simx:later"].split() and "explicit=true" not in texts["simx:seen"].split()
    sim = Simulation(f, realtime=False)
    try:
        api = script_sim(sim.world, _h(sim, "seen"), sim.signals, simulation=sim)
        sim.start()
        sim.step()
        sim.step()
        h = _h(sim, "seen")
        depth, img = sim.vision.depth(h), sim.vision.image(h, False)
        _save("synthetic_vision_callback.png", img)
        assert np.array_equal(img[..., 0], np.where(depth >= np.float32(0.6), 255, 0).astype(np.uint8))
        assert 0 < (img[..., 0] == 0).sum() < img[..., 0].size / 2  # the tower
        result, default, binary = api.readVisionSensor(h)
        assert binary[0] == pytest.approx((img[..., 0] > 0).mean())
        assert sim.signals.get_int("calls_seen") == 2 and sim.signals.get_int("calls_later") is None
        api.handleVisionSensor(_h(sim, "later"))
        assert sim.signals.get_int("calls_later") == 1
        # one truth: what the file saved is what sim.getExplicitHandling reads, and a change shows
        assert (api.getExplicitHandling(_h(sim, "later")), api.getExplicitHandling(h)) == (1, 0)
        api.setExplicitHandling(_h(sim, "later"), 0)
        api.setExplicitHandling(h, 1)
        assert (api.getExplicitHandling(_h(sim, "later")), api.getExplicitHandling(h)) == (0, 1)
        assert sim.vision.explicit == {h}
    finally:
        sim.close()
