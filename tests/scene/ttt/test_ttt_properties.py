"""Objects' special properties (issue 41): V-REP's collidable, measurable, detectable and
renderable flags read from a ``.ttt`` (``Omp``) and used by collision, distance, proximity and
vision independently of physical contact (respondable)."""

from __future__ import annotations

import re

import pytest

import tttwriter as W
from simx_server.commands import collisions as cmd
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader
from simx_server.api import script_sim
from simx_server.sim import properties
from simx_server.sim.proximity import proximity_reading

pytestmark = pytest.mark.renderers_on_demand  # no image is read

ALL = 1 | 2 | 496 | 512


def _shape(h, name, pos, bits=None, respondable=False):
    extra = W.rec("Omp", W.i32(bits)) if bits is not None else b""
    return W.cuboid_shape(h, -1, name, (0.1, 0.1, 0.1), pos, dynamic=False, respondable=respondable, extra=extra)


def _down_sensor(h, name, pos, sensable):
    """A ray proximity sensor looking down (-z), 1 m long, of V-REP detection type ``sensable``."""
    typed = W.lst(W.rec("Snt", W.i32(34)), W.rec("Vod", W.lst(W.rec("Ss3", W.f32(0, 1.0, *([0.0] * 7))))),
                  W.rec("Sst", W.i32(sensable)))
    return W.rec("SNR", W.common(h, -1, name, pos, quat=(0, 1, 0, 0)) + typed)


@pytest.fixture
def scene(tmp_path):
    body = (_shape(1, "Robot", (0, 0, 0.5), respondable=True)
            + _shape(2, "FinishLine", (0.08, 0, 0.5), ALL)        # not respondable, collidable
            + _shape(3, "Ghost", (-0.08, 0, 0.5), 0)               # neither
            + _shape(4, "Hidden", (0, 3, 0.5), 1 | 2 | 496)        # not renderable
            + _shape(5, "Glass", (3, 0, 0.6), 1 | 2 | 512)         # not detectable
            + _shape(6, "Plate", (3, 0, 0.2), 1 | 2 | 32 | 512)    # infrared-detectable only
            + _down_sensor(7, "Eye", (3, 0, 1.0), 32)              # an infrared sensor
            + _down_sensor(8, "Ear", (3, 0, 1.0), 16)             # an ultrasonic one
            # a model whose base says: not collidable, not renderable, for all of it
            + W.cuboid_shape(9, -1, "Cart", (0.1, 0.1, 0.1), (-1, 0, 0.5), dynamic=False,
                             extra=W.model_base() + W.rec("Mpo", W.i32(1 | 4)))
            + W.cuboid_shape(10, 9, "CartPart", (0.1, 0.1, 0.1), (-0.08, 0, 0), dynamic=False))
    f = tmp_path / "flags.ttt"
    f.write_bytes(W.ttt_file(body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "flags")
    sim = Simulation(xml, realtime=False)
    yield xml, sim
    sim.close()


def _texts(xml):
    return dict(re.findall(r'<text name="(simx:[^"]+)" data="([^"]*)"', xml.read_text()))


def test_the_files_flags_become_settings(scene):
    xml, sim = scene
    texts = _texts(xml)
    assert "special=" not in texts.get("simx:FinishLine", "")  # V-REP's default for a shape
    assert texts["simx:Ghost"] == "special=0"
    assert texts["simx:Hidden"] == "special=499"
    assert texts["simx:Eye"] == "sensable=32"
    assert "model_property=5" in texts["simx:Cart"]
    h = sim.world.resolve
    assert [properties.special(sim.world, h(n).handle) for n in ("Robot", "FinishLine", "Ghost", "Hidden")] == \
        [ALL, ALL, 0, 499]


def test_collision_follows_collidable_not_respondable(scene):
    _, sim = scene
    h = lambda n: sim.world.resolve(n).handle  # noqa: E731
    robot, line, ghost = h("Robot"), h("FinishLine"), h("Ghost")
    # the finish line does not collide physically (contype 0) and is tested all the same
    assert sim.world.model.geom_contype[sim.world.model.body("FinishLine").geomadr[0]] == 0
    assert cmd.check_collision(sim, [robot, line]) is True
    assert cmd.check_collision(sim, [robot, ghost]) is True   # named explicitly: V-REP tests it anyway
    assert cmd.check_distance(sim, [robot, line]) == 0.0
    api = script_sim(sim.world, robot, sim.signals, simulation=sim)
    api.setObjectSpecialProperty(line, 0)                      # nothing else is collidable near the robot now
    assert api.getObjectSpecialProperty(line) == 0
    assert cmd.check_collision(sim, [robot, -2]) is False
    assert cmd.check_collision(sim, [robot, line]) is True
    api.setObjectSpecialProperty(line, 1)                      # collidable, not measurable
    assert cmd.check_collision(sim, [robot, -2]) is True
    assert cmd.check_distance(sim, [robot, -2]) > 0.5          # the others measured: Hidden, Glass, Plate


def test_a_model_base_overrides_its_parts_flags(scene):
    _, sim = scene
    h = lambda n: sim.world.resolve(n).handle  # noqa: E731
    m = sim.world.model
    assert properties.special(sim.world, h("CartPart")) == ALL                     # its own flags
    assert properties.cumulative(sim.world, h("CartPart")) == 2 | 496               # what acts
    assert m.geom_group[m.body("CartPart").geomadr[0]] == properties.HIDDEN_GROUP
    part = m.body("CartPart").geomadr[0]
    assert cmd.check_collision(sim, [h("Cart"), h("CartPart")]) is True            # explicit: tested
    assert not properties.geom_mask(sim.world, properties.COLLIDABLE)[part]        # not among "all others"
    assert properties.geom_mask(sim.world, properties.MEASURABLE)[part]
    api = script_sim(sim.world, h("Cart"), sim.signals, simulation=sim)
    assert api.getModelProperty(h("Cart")) == 5
    api.setModelProperty(h("Cart"), 0)                                             # overrides off
    assert properties.geom_mask(sim.world, properties.COLLIDABLE)[part]
    assert sim.world.model.geom_group[part] <= 2


def test_proximity_sensors_see_only_detectable_shapes(scene):
    _, sim = scene
    h = lambda n: sim.world.resolve(n).handle  # noqa: E731
    detected, point, obj, _ = proximity_reading(sim, h("Eye"))
    assert detected and obj == h("Plate")                      # through the glass, onto the plate
    assert point[2] == pytest.approx(0.75, abs=1e-6)
    assert proximity_reading(sim, h("Ear"))[0] is False        # the plate is not ultrasonic-detectable
    api = script_sim(sim.world, h("Glass"), sim.signals, simulation=sim)
    api.setObjectSpecialProperty(h("Glass"), ALL)
    assert proximity_reading(sim, h("Ear"))[2] == h("Glass")


def test_renderable_moves_geoms_out_of_the_vision_groups_and_edits_keep_it(scene):
    _, sim = scene
    m = sim.world.model
    assert m.geom_group[m.body("Hidden").geomadr[0]] == properties.HIDDEN_GROUP
    assert m.geom_group[m.body("Robot").geomadr[0]] <= 2
    robot = sim.world.resolve("Robot").handle
    api = script_sim(sim.world, robot, sim.signals, simulation=sim)
    api.setObjectSpecialProperty(robot, 1 | 2 | 496)
    assert sim.world.model.geom_group[m.body("Robot").geomadr[0]] == properties.HIDDEN_GROUP
    api.createDummy(0.01)                                      # an edit: a new model, the flags stay
    m = sim.world.model
    assert api.getObjectSpecialProperty(robot) == 1 | 2 | 496
    assert m.geom_group[m.body("Robot").geomadr[0]] == properties.HIDDEN_GROUP
    assert m.geom_group[m.body("Hidden").geomadr[0]] == properties.HIDDEN_GROUP


def test_coppeliasim_48_property_names(scene):
    _, sim = scene
    ghost = sim.world.resolve("Ghost").handle
    api = script_sim(sim.world, ghost, sim.signals, simulation=sim)
    assert api.getBoolProperty(ghost, "collidable") is False
    api.setBoolProperty(ghost, "collidable", True)
    api.setBoolProperty(ghost, "detectable", True)
    assert api.getObjectSpecialProperty(ghost) == 1 | 496
    assert api.getBoolProperty(ghost, "collidable") and not api.getBoolProperty(ghost, "measurable")
    assert "collidable" in [api.getPropertyName(ghost, i)[0] for i in range(12) if api.getPropertyName(ghost, i)]


def test_check_proximity_sensor_on_one_shape_overrides_its_flag(scene):
    _, sim = scene
    h = lambda n: sim.world.resolve(n).handle  # noqa: E731
    api = script_sim(sim.world, h("Eye"), sim.signals, simulation=sim)
    # the glass is not detectable: looked for alone it is found all the same, at 0.35 m
    result, dist, point = api.checkProximitySensor(h("Eye"), h("Glass"))
    assert result == 1 and dist == pytest.approx(0.35, abs=1e-6)
    # the plate alone: the ultrasonic sensor finds it too, through the glass in front of it
    assert api.checkProximitySensor(h("Ear"), h("Plate"))[:2] == (1, pytest.approx(0.75, abs=1e-6))
    assert api.checkProximitySensor(h("Ear"), -2)[0] == 0  # the plate is not ultrasonic-detectable


MEASURED = """<mujoco><worldbody>
  <body name="A" pos="0 0 1"><geom type="box" size="0.1 0.1 0.1"/></body>
  <body name="B" pos="0.15 0 1"><geom type="box" size="0.1 0.1 0.1" contype="0" conaffinity="0"/></body>
</worldbody><custom>
  <text name="simx:B" data="special=0"/>
  <text name="simx.collision:AB" data="entity1=A entity2=B"/>
  <text name="simx.distance:AB" data="entity1=A entity2=B"/>
</custom></mujoco>"""


def test_declared_collision_objects_test_only_flagged_shapes(tmp_path):
    (tmp_path / "measured.xml").write_text(MEASURED)
    sim = Simulation(tmp_path / "measured.xml", realtime=False)
    try:
        a, b = sim.world.resolve("A").handle, sim.world.resolve("B").handle
        assert cmd.check_collision(sim, [a, b]) is True                  # simxCheckCollision: flag overridden
        h = cmd.get_collision_handle(sim, ["AB"])
        assert cmd.read_collision(sim, [h]) is False                     # a collision object: B is not collidable
        api = script_sim(sim.world, a, sim.signals, simulation=sim)
        assert api.handleCollision(h) == 0                               # the same from a script
        with pytest.raises(Exception, match="measurable"):
            cmd.read_distance(sim, [cmd.get_distance_handle(sim, ["AB"])])
        api.setObjectSpecialProperty(b, 1 | 2)
        assert cmd.read_collision(sim, [h]) is True and api.handleCollision(h)[0] == 1
    finally:
        sim.close()
