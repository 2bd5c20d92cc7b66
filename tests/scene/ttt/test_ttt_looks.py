"""V-REP's look in converted scenes (simx_server/scene/ttt/looks.py, simx_server/sim/vision_look.py):
a vision sensor sees a flat surface in the colour OpenGL's fixed-function lighting gives it with
V-REP's material, lights and ambient light, as V-REP drew it."""

from __future__ import annotations

import math
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from simx_server.api import script_sim  # noqa: E402
from simx_server.scene.simulation import Simulation  # noqa: E402
from simx_server.scene.ttt.convert import convert  # noqa: E402
from simx_server.scene.ttt import looks  # noqa: E402
from simx_server.scene.ttt.looks import read_ambient, read_colour  # noqa: E402
from simx_server.scene.ttt.reader import read  # noqa: E402
from simx_server.scene.ttt.records import Records  # noqa: E402

import tttwriter as W  # noqa: E402

# Three materials (ambient-diffuse, specular, shininess); each drawn without and with an emission
# colour proportional to its diffuse one (the line follower's line: grey 0.72, emission 0.5).
MATERIALS = [((0.8, 0.2, 0.1), (0.5, 0.5, 0.5), 20, 0.375),
             ((0.72, 0.72, 0.72), (0.25, 0.25, 0.25), 48, 0.5 / 0.72),
             ((0.1, 0.3, 0.9), (0.1, 0.1, 0.1), 5, 0.5)]
# A directional light 40 degrees off the vertical, travelling toward +x (V-REP: along its +z).
SUN_QUAT = (math.cos(math.radians(70)), 0.0, math.sin(math.radians(70)), 0.0)
TO_LIGHT = np.array([-math.sin(math.radians(40)), 0.0, math.cos(math.radians(40))])
DEFAULT_AMBIENT = 0.2  # V-REP's (CEnvironment::setUpDefaultValues): the file has no ENV record
SIZE, RES = 1.0, 64  # the orthographic sensor's view (m) and resolution


def fixed_function(diffuse, specular, shininess, emission, light_diffuse, light_specular,
                   to_light=TO_LIGHT) -> np.ndarray:
    """OpenGL's lighting of a surface facing up, seen from straight above by a distant viewer
    (V-REP leaves GL_LIGHT_MODEL_LOCAL_VIEWER off), under one directional light and V-REP's
    global ambient light: emission + ambient x diffuse + (N.L) diffuse x light diffuse +
    (N.H)^shininess specular x light specular, 0-255."""
    n = v = np.array([0.0, 0, 1])
    half = (to_light + v) / np.linalg.norm(to_light + v)
    d, s = np.asarray(diffuse), np.asarray(specular)
    rgb = (np.asarray(emission) + DEFAULT_AMBIENT * d + max(n @ to_light, 0) * d * np.asarray(light_diffuse)
           + max(n @ half, 0) ** shininess * s * np.asarray(light_specular))
    return np.round(np.clip(rgb, 0, 1) * 255)


def shapes() -> tuple[bytes, list[tuple[float, float, np.ndarray, tuple]]]:
    """Six flat-topped boxes (top at z = 0) in a 3 x 2 grid: (records, [(x, y, emission, material)])."""
    records, placed = b"", []
    for i, (diffuse, specular, shininess, glow) in enumerate(MATERIALS):
        for j, lit in enumerate((False, True)):
            emission = tuple(glow * c for c in diffuse) if lit else (0.0, 0.0, 0.0)
            x, y = (i - 1) * 0.3, (j - 0.5) * 0.4
            look = W.colour_object(diffuse, specular, emission, shininess)
            records += W.cuboid_shape(10 + 2 * i + j, -1, f"Box{i}{j}", (0.2, 0.2, 0.1), (x, y, -0.05),
                                      dynamic=False, colour=look)
            placed.append((x, y, np.array(emission), (diffuse, specular, shininess)))
    return records, placed


@pytest.mark.parametrize("light_diffuse, light_specular", [((1.0, 1.0, 1.0), (0.6, 0.6, 0.6)),
                                                           ((0.9, 0.6, 0.3), (0.5, 0.4, 0.2))])
def test_a_sensor_sees_the_fixed_function_colour_of_each_material(tmp_path, light_diffuse, light_specular):
    boxes, placed = shapes()
    body = (W.light(1, -1, "Sun", 3, light_diffuse, light_specular, pos=(0, 0, 2), quat=SUN_QUAT) +
            W.camera_sensor(2, -1, "Top", (RES, RES), SIZE, pos=(0, 0, 1), quat=(0, 1, 0, 0)) + boxes)
    (tmp_path / "looks.ttt").write_bytes(W.ttt_file(body))
    xml, report = convert(read(tmp_path / "looks.ttt"), tmp_path / "out")
    assert report.lines() == []  # proportional emissions and grey speculars: nothing approximated
    sim = Simulation(xml, realtime=False)
    try:
        (w, h), data = sim.vision.image_bytes(sim.world.resolve("Top").handle, 0)
    finally:
        sim.close()
    image = np.frombuffer(data, np.uint8).reshape(h, w, 3).astype(int)  # V-REP's rows: bottom-up
    for x, y, emission, (diffuse, specular, shininess) in placed:
        # looking down from +z (the sensor turned about x): image right is world -x, up is -y
        col, row = int(w / 2 - x / SIZE * w), int(h / 2 - y / SIZE * h)
        want = fixed_function(diffuse, specular, shininess, emission, light_diffuse, light_specular)
        got = image[row - 2:row + 3, col - 2:col + 3].reshape(-1, 3)
        assert np.abs(got - want).max() <= 6, (diffuse, emission.tolist(), got.min(0), got.max(0), want)


def test_a_perspective_sensor_sees_a_highlight_as_vrep_does_across_its_view(tmp_path):
    # V-REP's distant viewer: a flat glossy surface under a light straight above has its whole
    # highlight wherever it lies in a perspective sensor's view (a maze's walls seen from above
    # keep one colour). MuJoCo's local viewer lost most of it 22 and 30 degrees off the axis.
    diffuse, specular = (0.5, 0.5, 0.6), (0.5, 0.5, 0.5)
    look = W.colour_object(diffuse, specular, shininess=48)
    tiles = [(0.0, 0.0), (0.8, 0.0), (-0.8, 0.0), (0.0, 0.8), (0.8, 0.8)]
    body = (W.light(1, -1, "Down", 3, (0.6, 0.6, 0.6), (0.6, 0.6, 0.6), pos=(0, 0, 3), quat=(0, 1, 0, 0)) +
            W.camera_sensor(2, -1, "Eye", (RES, RES), pos=(0, 0, 2), quat=(0, 1, 0, 0), perspective=True,
                            angle=math.radians(60)) +
            b"".join(W.cuboid_shape(10 + i, -1, f"Tile{i}", (0.3, 0.3, 0.1), (x, y, -0.05), dynamic=False,
                                    colour=look) for i, (x, y) in enumerate(tiles)))
    (tmp_path / "eye.ttt").write_bytes(W.ttt_file(body))
    xml, _ = convert(read(tmp_path / "eye.ttt"), tmp_path / "out")
    sim = Simulation(xml, realtime=False)
    try:
        (w, h), data = sim.vision.image_bytes(sim.world.resolve("Eye").handle, 0)
    finally:
        sim.close()
    image = np.frombuffer(data, np.uint8).reshape(h, w, 3).astype(int)  # V-REP's rows: bottom-up
    want = fixed_function(diffuse, specular, 48, (0, 0, 0), (0.6,) * 3, (0.6,) * 3, np.array([0.0, 0, 1]))
    half_view = 2 * math.tan(math.radians(30))  # m, at the tiles' tops, 2 m below the sensor
    for x, y in tiles:
        col, row = int(w / 2 - x / half_view * w / 2), int(h / 2 - y / half_view * h / 2)
        got = image[row - 1:row + 2, col - 1:col + 2].reshape(-1, 3)
        assert np.abs(got - want).max() <= 3, ((x, y), got.min(0), got.max(0), want)


def test_light_and_headlight_carry_vrep_settings(tmp_path):
    body = (W.light(1, -1, "Lamp", 1, (0.4, 0.5, 0.6), (0.1, 0.2, 0.3), attenuation=(0.5, 0.1, 0.2)) +
            W.light(2, -1, "Spot", 2, cutoff=math.radians(30)) +
            W.light(3, -1, "Off", 3, active=False) + W.light(4, -1, "Local", 3, local=True) +
            W.environment(ambient=(0.3, 0.35, 0.4), fog=True))
    (tmp_path / "lights.ttt").write_bytes(W.ttt_file(body))
    xml, report = convert(read(tmp_path / "lights.ttt"), tmp_path / "out")
    m = mujoco.MjModel.from_xml_path(str(xml))
    lamp, spot, off, local = (m.light(n) for n in ("Lamp", "Spot", "Off", "Local"))
    # omnidirectional: a spot light of 180 degrees (MuJoCo's classic renderer draws no point light)
    assert lamp.type == mujoco.mjtLightType.mjLIGHT_SPOT and lamp.cutoff == 180
    np.testing.assert_allclose(lamp.diffuse, [0.4, 0.5, 0.6], atol=1e-6)
    np.testing.assert_allclose(lamp.specular, [0.1, 0.2, 0.3], atol=1e-6)
    np.testing.assert_allclose(lamp.ambient, 0)  # V-REP's lights have no ambient
    np.testing.assert_allclose(lamp.attenuation, [0.5, 0.1, 0.2], atol=1e-6)
    assert spot.cutoff == pytest.approx(30) and spot.exponent == 5
    assert off.active == 0 and local.active == 0
    assert report.counts["local lights (off: simx's sensors use the scene's lights)"] == 1
    assert report.counts["fog (vision sensors draw none)"] == 1
    np.testing.assert_allclose(m.vis.headlight.ambient, [0.3, 0.35, 0.4], atol=1e-6)
    np.testing.assert_allclose(m.vis.headlight.diffuse, 0)
    np.testing.assert_allclose(m.vis.headlight.specular, 0)


def test_what_mujoco_cannot_give_is_reported(tmp_path):
    look = W.colour_object((0.5, 0.5, 0.1), (0.9, 0.1, 0.1), (0.0, 0.3, 0.0))
    body = W.cuboid_shape(1, -1, "Odd", (0.1, 0.1, 0.1), dynamic=False, colour=look)
    (tmp_path / "odd.ttt").write_bytes(W.ttt_file(body))
    xml, report = convert(read(tmp_path / "odd.ttt"), tmp_path / "out")
    assert set(report.counts) == {"specular colours that are not grey (their mean: MuJoCo's specular is a level)",
                                  "emission colours that are not a multiple of the shape's colour (the closest)"}
    m = mujoco.MjModel.from_xml_path(str(xml))
    mat = m.geom_matid[m.body("Odd").geomadr[0]]
    assert m.mat_specular[mat] == pytest.approx(1.1 / 3, abs=1e-6)
    # the least-squares multiple of (0.5, 0.5, 0.1) closest to (0, 0.3, 0): 0.15 / 0.51
    assert m.mat_emission[mat] == pytest.approx(0.15 / 0.51, abs=1e-6)


def test_older_colour_and_ambient_records_as_vrep_reads_them():
    # before 3.1.3 a shape kept Cl2 only: (colour x 0.85) - 0.125 with a light diffuse of 0.25
    old = W.lst(W.rec("Cl2", W.f32(*(np.array([0.8, 0.4, 0.2]) * 0.85 - 0.125), 0.25, 0.25, 0.25, *[0.0] * 9)))
    look = read_colour(Records(old, "t"))
    np.testing.assert_allclose(look.diffuse, [0.8, 0.4, 0.2], atol=1e-6)
    assert look.shininess == 48 and look.opacity == 1
    # Alc is half the ambient light (capped at 0.4 once doubled); Al2 the light itself
    assert read_ambient(Records(W.lst(W.rec("Alc", W.f32(0.1, 0.1, 0.15))), "t")).tolist() == pytest.approx(
        [0.2, 0.2, 0.3])
    assert read_ambient(Records(W.lst(W.rec("Alc", W.f32(0.3, 0.3, 0.3))), "t")).tolist() == pytest.approx([0.4] * 3)
    assert read_ambient(Records(W.lst(W.rec("Al2", W.f32(0.5, 0.5, 0.5)), W.rec("Alc", W.f32(0.1, 0.1, 0.1))),
                                "t")).tolist() == pytest.approx([0.5] * 3)


def test_materials_stay_within_what_mujocos_renderer_draws(tmp_path, monkeypatch):
    # MuJoCo draws at most 999 materials beside a sky box: one per mesh made the kitchen scene
    # (1,207 meshes) undrawable. Here the bound is 2: the third look keeps its colour only.
    monkeypatch.setattr(looks, "MAX_MATERIALS", 2)
    body = b"".join(W.cuboid_shape(1 + i, -1, f"Box{i}", (0.1, 0.1, 0.1), (i * 0.2, 0, 0), dynamic=False,
                                   colour=W.colour_object((0.2 * (i + 1), 0.1, 0.1))) for i in range(3))
    (tmp_path / "many.ttt").write_bytes(W.ttt_file(body))
    xml, report = convert(read(tmp_path / "many.ttt"), tmp_path / "out")
    m = mujoco.MjModel.from_xml_path(str(xml))
    assert m.nmat == 2
    assert [int(m.geom_matid[m.body(f"Box{i}").geomadr[0]]) >= 0 for i in range(3)] == [True, True, False]
    np.testing.assert_allclose(m.geom_rgba[m.body("Box2").geomadr[0]], [0.6, 0.1, 0.1, 1], atol=1e-6)
    assert report.counts["shape looks beyond the 2th material (V-REP's default specular)"] == 1


def test_the_epuck_camera_sees_its_track_as_vrep_did(tmp_path):
    """The e-puck line follower (a public project's own scene, ../shared/ttt-corpus/): V-REP
    showed the track as a black line on a light floor. With MuJoCo's headlight and the darker
    backward-compatibility colours, the floor was dark grey (about 50) and the line hard to
    tell from it."""
    try:
        from conftest import SHARED, require_shared
    except ImportError:  # pragma: no cover - run from the repository root
        from tests.conftest import SHARED, require_shared
    path = require_shared(SHARED / "ttt-corpus" / "RL-LDV-TUM+epuck-vrep__epuck_test.ttt")
    xml, _ = convert(read(path), tmp_path / "out")
    sim = Simulation(xml, realtime=False)
    try:
        (w, h), data = sim.vision.image_bytes(sim.world.resolve("ePuck_camera").handle, 0)
    finally:
        sim.close()
    floor = np.frombuffer(data, np.uint8).reshape(h, w, 3)[: h // 3].astype(int).mean(axis=2)  # rows bottom-up
    assert np.percentile(floor, 50) > 180  # the light floor
    assert (floor < 40).mean() > 0.05  # the black line


@pytest.mark.parametrize("apply", [0, 1])
def test_a_texture_meets_the_shapes_colour_as_vrep_applies_it(tmp_path, apply):
    # V-REP's texture modes (rendering.cpp _startTextureDisplay): modulate (0) multiplies the
    # texture with the shape's lit colour, decal (1) shows it as it is, unlit
    diffuse = (0.6, 0.3, 0.2)
    white = np.full((8, 8, 3), 255, np.uint8)
    body = (W.texture(7, "white", white) +
            W.light(1, -1, "Sun", 3, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), pos=(0, 0, 2), quat=SUN_QUAT) +
            W.camera_sensor(2, -1, "Top", (RES, RES), SIZE, pos=(0, 0, 1), quat=(0, 1, 0, 0)) +
            W.cuboid_shape(3, -1, "Tile", (0.6, 0.6, 0.1), (0, 0, -0.05), dynamic=False,
                           colour=W.colour_object(diffuse, (0.0, 0.0, 0.0)),
                           texture=W.texture_link(7, 0, (0.6, 0.6), apply=apply)))
    (tmp_path / "tile.ttt").write_bytes(W.ttt_file(body))
    xml, report = convert(read(tmp_path / "tile.ttt"), tmp_path / "out")
    sim = Simulation(xml, realtime=False)
    try:
        (w, h), data = sim.vision.image_bytes(sim.world.resolve("Top").handle, 0)
    finally:
        sim.close()
    got = np.frombuffer(data, np.uint8).reshape(h, w, 3)[h // 2 - 2:h // 2 + 3, w // 2 - 2:w // 2 + 3].reshape(-1, 3)
    want = fixed_function(diffuse, (0, 0, 0), 48, (0, 0, 0), (1, 1, 1), (0, 0, 0)) if apply == 0 else np.full(3, 255)
    assert np.abs(got.astype(int) - want).max() <= 6, (got.min(0), got.max(0), want)


def test_set_shape_color_sets_one_component_and_keeps_the_others(tmp_path):
    # CColorObject::setColor: a part recoloured yellow at run time keeps its glossy specular and
    # its glow; its specular and emission colours are set on their own (programs threshold on
    # the colours V-REP drew: a yellow part seen as (255, 255, 36), its blue the highlight)
    specular, emission = (0.6, 0.6, 0.6), (0.1, 0.0, 0.05)
    body = (W.light(1, -1, "Sun", 3, (0.5, 0.5, 0.5), (0.5, 0.5, 0.5), pos=(0, 0, 2), quat=SUN_QUAT) +
            W.camera_sensor(2, -1, "Top", (32, 32), SIZE, pos=(0, 0, 1), quat=(0, 1, 0, 0)) +
            W.cuboid_shape(3, -1, "Part", (0.6, 0.6, 0.1), (0, 0, -0.05), dynamic=False,
                           colour=W.colour_object((0.3, 0.3, 0.8), specular, (0.1, 0.1, 0.267), shininess=20)) +
            W.cuboid_shape(4, -1, "Other", (0.1, 0.1, 0.1), (0.4, 0.4, -0.05), dynamic=False))
    (tmp_path / "part.ttt").write_bytes(W.ttt_file(body))
    xml, _ = convert(read(tmp_path / "part.ttt"), tmp_path / "out")
    sim = Simulation(xml, realtime=False)
    part = sim.world.resolve("Part").handle
    api = script_sim(sim.world, part, sim.signals, simulation=sim)

    def centre() -> np.ndarray:
        (w, h), data = sim.vision.image_bytes(sim.world.resolve("Top").handle, 0)
        return np.frombuffer(data, np.uint8).reshape(h, w, 3)[h // 2 - 1:h // 2 + 2, w // 2 - 1:w // 2 + 2].reshape(-1, 3)

    try:
        yellow = (1.0, 1.0, 0.0)
        api.setShapeColor(part, None, 0, list(yellow))  # sim.colorcomponent_ambient_diffuse
        want = fixed_function(yellow, specular, 20, (0.1, 0.1, 0.0), (0.5,) * 3, (0.5,) * 3)
        # the emission kept as the multiple of the new colour closest to (0.1, 0.1, 0.267): 0.1
        assert np.abs(centre().astype(int) - want).max() <= 4, (centre().min(0), want)
        assert api.getShapeColor(part, None, 2)[1] == pytest.approx(list(specular), abs=1e-6)
        api.setShapeColor(part, None, 2, [0.2, 0.2, 0.2])  # sim.colorcomponent_specular
        api.setShapeColor(part, None, 3, list(emission))  # sim.colorcomponent_emission
        glow = tuple(np.array(yellow) * (np.array(yellow) @ emission) / 2)  # MuJoCo: a multiple of the colour
        want = fixed_function(yellow, (0.2,) * 3, 20, glow, (0.5,) * 3, (0.5,) * 3)
        assert np.abs(centre().astype(int) - want).max() <= 4, (centre().min(0), want)
        assert api.getShapeColor(part, None, 3)[1] == pytest.approx(list(emission), abs=1e-6)
        assert api.getShapeColor(part, None, 0)[1] == pytest.approx(list(yellow))
        # a scene edit (a copy of another shape: the scene recompiles) keeps them
        api.copyPasteObjects([sim.world.resolve("Other").handle], 0)
        assert np.abs(centre().astype(int) - want).max() <= 4
        assert api.getShapeColor(part, None, 2)[1] == pytest.approx([0.2] * 3, abs=1e-6)
        # the sensor's disabled light components (1006): 4 the lights' specular, 6 their diffuse too
        top = sim.world.resolve("Top").handle
        api.setObjectInt32Param(top, 1006, 4)
        want = fixed_function(yellow, (0.2,) * 3, 20, glow, (0.5,) * 3, (0.0,) * 3)
        assert np.abs(centre().astype(int) - want).max() <= 4, (centre().min(0), want)
        api.setObjectInt32Param(top, 1006, 6)
        sim.start()
        sim.stop()  # not a scene value: a stop keeps it (CViewableBase)
        assert api.getObjectInt32Param(top, 1006) == 6
        want = fixed_function(yellow, (0.2,) * 3, 20, glow, (0.0,) * 3, (0.0,) * 3)
        assert np.abs(centre().astype(int) - want).max() <= 4, (centre().min(0), want)
    finally:
        sim.close()


def test_a_file_older_than_vrep_3_0_5_has_its_ambient_light_scaled_down():
    # CEnvironment::serialize: files before serialization 17 had brighter default lights; V-REP
    # scales an ambient light above 0.21 down by 0.675 (the default lights themselves changed
    # only their unused ambient-diffuse part)
    records = Records(W.lst(W.rec("Alc", W.f32(0.2, 0.2, 0.2))), "t")
    assert read_ambient(records, serialization=16).tolist() == pytest.approx([0.4 * 0.675] * 3)
    assert read_ambient(records, serialization=17).tolist() == pytest.approx([0.4] * 3)
    dim = Records(W.lst(W.rec("Al2", W.f32(0.2, 0.2, 0.2))), "t")
    assert read_ambient(dim, serialization=16).tolist() == pytest.approx([0.2] * 3)
