"""V-REP's rigid contacts between two dynamic shapes (simx_server/sim/mechanisms.py,
``rigid_contact``). Bullet corrects an overlap between two dynamic bodies as it does against a
static one; with MuJoCo's default contact (a 20 ms time constant) a body pressed on a dynamic
shape sank into it: a Panda finger sank 7 mm into RLBench's fridge door, and that overlap's
friction held the closing finger before it reached the handle."""

from __future__ import annotations

import mujoco
import pytest

import tttwriter as W
from simx_server.scene.ttt import convert, reader
from simx_server.sim import mechanisms

pytestmark = pytest.mark.renderers_on_demand  # no image is read here

FLOOR_TOP, PLATE, CUBE = 0.05, 0.02, 0.05  # the floor's top (m), the plate's and the cube's height (m)


def _stack(cube_mass: float = 2.0) -> bytes:
    """A static floor, a 0.5 kg dynamic plate on it and a dynamic cube (2 kg) on the plate."""
    return W.ttt_file(
        W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, -9.81)))) +
        W.cuboid_shape(1, -1, "Floor", (2.0, 2.0, 0.1), (0, 0, FLOOR_TOP - 0.05), dynamic=False) +
        W.cuboid_shape(2, -1, "Plate", (0.3, 0.3, PLATE), (0, 0, FLOOR_TOP + PLATE / 2), mass=0.5,
                       moments=(0.0075, 0.0075, 0.015)) +
        W.cuboid_shape(3, -1, "Cube", (CUBE, CUBE, CUBE), (0, 0, FLOOR_TOP + PLATE + CUBE / 2), mass=cube_mass,
                       moments=(4.2e-4, 4.2e-4, 4.2e-4)))


def test_a_cube_on_a_dynamic_plate_sinks_as_little_as_the_plate_on_the_floor(tmp_path):
    (tmp_path / "stack.ttt").write_bytes(_stack())
    xml, _ = convert.convert(reader.read(str(tmp_path / "stack.ttt")), tmp_path / "out")
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    for _ in range(round(1.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
    plate, cube = d.body("Plate").xpos[2], d.body("Cube").xpos[2]
    plate_sink = FLOOR_TOP - (plate - PLATE / 2)  # the plate's bottom below the floor's top
    cube_sink = (plate + PLATE / 2) - (cube - CUBE / 2)  # the cube's bottom below the plate's top
    # 2.5 kg on the floor, 2 kg on the plate: as deep, 0.08 mm (MuJoCo's default contact between
    # the cube and the plate: 0.43 mm, five times the plate's on the floor)
    assert 0.0 < cube_sink < 2e-4, cube_sink
    assert cube_sink < 1.5 * plate_sink, (cube_sink, plate_sink)
    # every geom of the file has the rigid contact; the static floor's rules its pairs
    floor, plate_geom = m.body("Floor").geomadr[0], m.body("Plate").geomadr[0]
    assert list(m.geom_solref[plate_geom]) == pytest.approx(list(m.geom_solref[floor]))
    assert m.geom_solmix[floor] > m.geom_solmix[plate_geom]


def _pressed_sink(tmp_path) -> float:
    """How deep (m) a 50 g cube on the plate sinks into it pressed with 300 N (0.5 s at rest,
    then 0.5 s pressed: a hand pressing a held part onto a surface)."""
    (tmp_path / "stack.ttt").write_bytes(_stack(cube_mass=0.05))
    xml, _ = convert.convert(reader.read(str(tmp_path / "stack.ttt")), tmp_path / "out")
    m = mujoco.MjModel.from_xml_path(str(xml))
    d = mujoco.MjData(m)
    cube = m.body("Cube").id
    for i in range(round(1.0 / m.opt.timestep)):
        d.xfrc_applied[cube, 2] = -300.0 if i * m.opt.timestep >= 0.5 else 0.0
        mujoco.mj_step(m, d)
    plate, cube_z = d.body("Plate").xpos[2], d.body("Cube").xpos[2]
    return (plate + PLATE / 2) - (cube_z - CUBE / 2)


def test_a_hard_press_on_a_light_part_gives_as_porting_md_says(tmp_path, monkeypatch):
    """The limit of the rigid contact that docs/PORTING.md states: MuJoCo scales a contact's give
    by the inverse mass of the bodies it joins (its impedance's regularisation), so the pressed
    50 g cube sinks about 5 mm, where Bullet's contact stays rigid; with an impedance of 0.999 on
    every geom, about 0.1 mm."""
    assert 3e-3 < _pressed_sink(tmp_path) < 8e-3
    from simx_server.scene.ttt import geoms

    def stiffer(geom, timestep, static=True):
        mechanisms.rigid_contact(geom, timestep, static)
        geom.solimp = [0.999, 0.999, 0.001, 0.5, 2.0]

    monkeypatch.setattr(geoms, "rigid_contact", stiffer)
    (tmp_path / "stiffer").mkdir()
    assert 0.0 < _pressed_sink(tmp_path / "stiffer") < 2e-4


def test_a_changed_contact_rule_converts_cached_files_again(monkeypatch):
    """The converter takes its contact from ``simx_server/sim/mechanisms.py``: a change there
    is part of the conversion cache's key, as a change of the converter's own modules is (a
    cached conversion of the old rule would otherwise be loaded)."""
    from pathlib import Path

    from simx_server.scene.ttt import cache

    before, read = cache._converter_version(), Path.read_bytes

    def changed(self: Path) -> bytes:
        data = read(self)
        return data + b"# changed" if self.name == "mechanisms.py" and self.parent.name == "sim" else data

    monkeypatch.setattr(Path, "read_bytes", changed)
    assert cache._converter_version() != before
