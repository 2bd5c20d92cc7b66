"""CoppeliaSim 4.x's model-library conveyors in a scene of the project's own (a synthetic .ttt as
CoppeliaSim 4.3 saves such a model: a path dummy with a customization script that requires
``conveyor_customization-2``, its configuration in ``__config__`` packed in CoppeliaSim's own
binary format, its closed path in ``PATHCTRLPTS``, its pads tagged ``PATHPAD``; and an efficient
conveyor whose customization script requires ``efficientConveyor_customization-2``, with its
``forwarder``; and a roller conveyor): the belt runs at its configured velocity from the start, carries what lies on it,
takes a new velocity or position written to ``__ctrl__`` and reports itself in ``__state__``.
"""

from __future__ import annotations

import logging
import math
import struct

import numpy as np
import pytest

import tttwriter as W
from simx_server.api import client_context
from simx_server.api.stack_tables import unpack_stack_table
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read

LENGTH, RADIUS, THICK, PADS = 0.6, 0.05, 0.005, 29
Z = 0.3  # the belt's top (its model's origin, as CoppeliaSim builds the path)


def stack_table(value) -> bytes:
    """CoppeliaSim's binary packed table (``sim.packTable(t)``, version 5): written here from the
    format's description, independently of the reader."""
    strings: list[int] = []

    def obj(v) -> bytes:
        if isinstance(v, bool):
            return bytes([2, int(v)])
        if isinstance(v, int):
            return bytes([9]) + struct.pack("<q", v)
        if isinstance(v, float):
            return bytes([1]) + struct.pack("<d", v)
        if isinstance(v, str):
            strings.append(2)
            return bytes([3]) + struct.pack("<I", len(v.encode())) + v.encode()
        if isinstance(v, list):
            return bytes([4, 1]) + struct.pack("<I", len(v)) + b"".join(obj(x) for x in v)
        items = sorted(v.items())  # CoppeliaSim sorts a map's string keys
        return bytes([4, 0]) + struct.pack("<I", 2 * len(items)) + b"".join(obj(k) + obj(x) for k, x in items)

    body = obj(value)[1:]  # the table without its type byte
    return bytes([5]) + body + bytes(strings) + b"\xff"


def test_a_binary_packed_table_reads_as_coppeliasim_wrote_it():
    config = {"type": 1, "accel": 0.5, "respondable": True, "color": [0.2, 0.25, 0.5], "name": "belt"}
    assert unpack_stack_table(stack_table(config)) == config
    assert unpack_stack_table(stack_table([1, 2.5, [], "x"])) == [1, 2.5, [], "x"]


def _path() -> list[float]:
    """CoppeliaSim's control points of a conveyor (conveyor_customization's rebuild): 9 round the
    +x end from the top down, 9 round the -x end from the bottom up, each with its z axis
    outward; the path's top lies a pad's thickness below the model's origin, so that the pads'
    top faces are at the origin."""
    out: list[float] = []
    vo = RADIUS + THICK
    for end in (1, -1):
        for i in range(9):
            a = math.pi / 2 - i * math.pi / 8
            x, z = end * (RADIUS * math.cos(a) + LENGTH / 2), end * RADIUS * math.sin(a) - vo
            beta = (math.pi / 2 - a) if end == 1 else (-math.pi / 2 - a)
            out += [x, 0.0, z, 0.0, math.sin(beta / 2), 0.0, math.cos(beta / 2)]  # x y z, qx qy qz qw
    return out


CONVEYOR_LUA = "require('conveyor_customization-2')\n"
EFFICIENT_LUA = "require('efficientConveyor_customization-2')\n"


@pytest.fixture
def cell(tmp_path):
    config = {"type": 1, "length": LENGTH, "width": 0.2, "radius": RADIUS, "beltElementWidth": 0.05,
              "beltElementThickness": THICK, "beltElementSpacing": 0.002, "targetVel": 0.1, "accel": 1.0,
              "respondable": True, "rollerCnt": 16, "color": [0.2, 0.2, 0.2]}
    blocks = {"__config__": stack_table(config), "PATHCTRLPTS": struct.pack(f"<{len(_path())}d", *_path())}
    body = (W.cuboid_shape(1, -1, "Floor", (3, 3, 0.1), (0, 0, -0.05), dynamic=False)
            + W.dummy(2, -1, "conveyor", (0, 0, Z), extra=W.model_base() + W.custom_data_4x(blocks)))
    for i in range(PADS):  # anywhere: the module places them along the path
        body += W.cuboid_shape(10 + i, 2, f"pad{i}", (0.05, 0.2, THICK), (0, 0, -0.2), dynamic=False,
                               extra=W.custom_data_4x({"PATHPAD": b"a"}))
    body += W.cuboid_shape(3, -1, "Part", (0.05, 0.05, 0.05), (-0.15, 0, Z + 0.026), mass=0.2)
    eff = {"__config__": stack_table({"length": 0.6, "width": 0.2, "height": 0.1, "targetVel": -0.2, "accel": 1.0})}
    body += (W.cuboid_shape(4, -1, "efficientConveyor", (0.6, 0.2, 0.1), (0, 1, 0.05), dynamic=False,
                            respondable=False, extra=W.model_base() + W.custom_data_4x(eff))
             + W.cuboid_shape(5, 4, "efficientConveyor_forwarder", (0.6, 0.2, 0.1), (0, 0, 0), dynamic=False,
                              extra=W.alias("forwarder"))
             + W.cuboid_shape(6, -1, "Crate", (0.05, 0.05, 0.05), (0.1, 1, 0.126), mass=0.2))
    rollers = {"__config__": stack_table({"type": 2, "radius": 0.03, "targetVel": 0.1, "accel": 1.0})}
    body += W.dummy(7, -1, "rollers", (0, -1, Z), extra=W.model_base() + W.custom_data_4x(rollers))
    turned = (math.cos(-math.pi / 4), math.sin(-math.pi / 4), 0, 0)  # rx(-90 deg): the axis along y
    for i, x in enumerate((-0.18, -0.12, -0.06, 0.0, 0.06, 0.12, 0.18)):
        body += (W.joint(50 + 2 * i, 7, f"jrol{i}", (x, 0, -0.03), turned, mode=0, motor=False, loop=False, cyclic=True,
                         common_extra=W.custom_data_4x({"PATHROL": b"a"}))
                 + W.cuboid_shape(51 + 2 * i, 50 + 2 * i, f"rol{i}", (0.06, 0.06, 0.19), mass=0.01, primitive=5))
    body += W.cuboid_shape(8, -1, "Box", (0.15, 0.05, 0.05), (-0.12, -1, Z + 0.026), mass=0.2)  # on 2-3 rollers
    body += (W.script(100, 2, CONVEYOR_LUA, kind=6) + W.script(101, 4, EFFICIENT_LUA, kind=6)
             + W.script(102, 7, CONVEYOR_LUA, kind=6))
    f = tmp_path / "cell.ttt"
    f.write_bytes(W.ttt_file(body, program=40300))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "cell")
    sim = Simulation(xml, realtime=False)
    yield sim, client_context(sim, "test").sim
    sim.close()


def _steps(sim, n):
    for _ in range(n):
        sim.step()


def test_model_library_conveyors_run_and_take_their_velocity_from_ctrl(cell, caplog):
    sim, api = cell
    world = sim.world
    conveyor, part, crate, box = (api.getObject(p) for p in ("/conveyor", "/Part", "/Crate", "/Box"))
    pad0 = api.getObject("/conveyor/pad0")
    # at load (the customization script's init): pads along the path, the first at its start
    assert api.getObjectPosition(pad0, -1) == pytest.approx([LENGTH / 2, 0, Z - THICK / 2], abs=1e-9)
    tops = [api.getObjectPosition(api.getObject(f"/conveyor/pad{i}"), -1)[2] for i in range(PADS)]
    assert sum(abs(t - (Z - THICK / 2)) < 1e-9 for t in tops) >= 10  # a dozen pads form the top
    assert api.readCustomTableData(conveyor, "__state__") == {"pos": 0, "vel": 0}
    with caplog.at_level(logging.WARNING, "simx"):
        sim.start()
        _steps(sim, 20)  # 1 s: at 0.1 m/s after 0.1 s of acceleration
        x0, c0, b0 = (api.getObjectPosition(h, -1) for h in (part, crate, box))
        _steps(sim, 20)
        x1, c1, b1 = (api.getObjectPosition(h, -1) for h in (part, crate, box))
        state = api.readCustomTableData(conveyor, "__state__")
        assert state["vel"] == pytest.approx(0.1) and state["pos"] == pytest.approx(0.2 - 0.005, abs=1e-6)
        assert (x1[0] - x0[0]) / 1.0 == pytest.approx(0.1, abs=0.01)  # carried along +x, on the belt
        assert abs(x1[1]) < 0.01 and x1[2] == pytest.approx(Z + 0.025, abs=0.003)
        assert (c1[0] - c0[0]) / 1.0 == pytest.approx(-0.2, abs=0.02)  # the efficient one: -0.2 m/s along x
        assert (b1[0] - b0[0]) / 1.0 == pytest.approx(0.1, abs=0.01)  # rollers: their surface at 0.1 m/s
        # a roller's joint is cyclic: CoppeliaSim reads its angle normalised to [-pi, pi]
        turned = math.remainder(state["pos"] / 0.03, 2 * math.pi)
        assert api.getJointPosition(api.getObject("/rollers/jrol0")) == pytest.approx(turned, abs=1e-9)
        # pad 0 moved along the path by the belt's position
        assert api.getObjectPosition(pad0, -1)[2] < Z - THICK  # round the +x end, going down
        api.setProperty(conveyor, "customData.__ctrl__", {"vel": -0.05})  # 4.8's property, the same block
        _steps(sim, 10)
        x2 = api.getObjectPosition(part, -1)
        _steps(sim, 20)
        x3 = api.getObjectPosition(part, -1)
        assert (x3[0] - x2[0]) / 1.0 == pytest.approx(-0.05, abs=0.006)
        assert api.readCustomTableData(conveyor, "__ctrl__") == {}  # taken
        api.writeCustomTableData(conveyor, "__ctrl__", {"pos": 0.0})  # back to the start, and stop
        _steps(sim, 40)
        state = api.readCustomTableData(conveyor, "__state__")
        assert state == {"pos": pytest.approx(0.0, abs=1e-9), "vel": 0}
        x4 = api.getObjectPosition(part, -1)
        _steps(sim, 10)
        assert api.getObjectPosition(part, -1) == pytest.approx(x4, abs=1e-3)  # the belt stands still
        sim.stop()
        assert api.readCustomTableData(conveyor, "__state__") == {"pos": 0, "vel": 0}
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING], [r.getMessage() for r in caplog.records]
    assert np.isfinite(world.data.qpos).all()


# V-REP 3.x's conveyor belt script (its model library's pattern): the belt's texture slides at the
# belt's velocity, texture_x = t * v.
SLIDE_LUA = """function sysCall_init()
    belt=sim.getObjectHandle('Belt')
end
function sysCall_actuation()
    sim.setObjectFloatParameter(belt,sim.shapefloatparam_texture_x,sim.getSimulationTime()*0.1)
end
"""


def test_a_belts_texture_slides_with_texture_x(tmp_path):
    stripes = np.full((16, 16, 3), 255, np.uint8)
    stripes[:, :4] = 0  # a black band a quarter of the texture wide, across its u
    res = 64
    body = (W.texture(7, "stripes", stripes)
            + W.camera_sensor(1, -1, "Top", (res, res), 0.4, pos=(0, 0, 1), quat=(0, 1, 0, 0))
            + W.cuboid_shape(2, -1, "Belt", (0.4, 0.4, 0.02), (0, 0, -0.01), dynamic=False,
                             texture=W.texture_link(7, 0, (0.4, 0.4), apply=1)))  # once across, unlit
    body += W.script(100, 2, SLIDE_LUA)
    f = tmp_path / "belt.ttt"
    f.write_bytes(W.ttt_file(W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + body))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "belt")
    sim = Simulation(xml, realtime=False)
    api = client_context(sim, "test").sim
    top, belt = api.getObject("/Top"), api.getObject("/Belt")

    def band() -> float:
        (w, h), data = sim.vision.image_bytes(top, 0)
        row = np.frombuffer(data, np.uint8).reshape(h, w, 3)[h // 2, :, 0].astype(float)
        dark = np.flatnonzero(row < 128)
        assert 0 < len(dark) < w // 2, row
        return float(np.angle(np.exp(2j * np.pi * dark / w).mean()) / (2 * np.pi) * w % w)  # the band's centre, px

    try:
        before = band()
        sim.start()
        for _ in range(21):  # t = 1 s at the last actuation: texture_x 0.1 m
            sim.step()
        assert api.getObjectFloatParam(belt, api.shapefloatparam_texture_x) == pytest.approx(0.1, abs=1e-5)
        moved = (before - band()) % res  # the image's columns run along the world's -x
        sim.stop()
    finally:
        sim.close()
    # the texture's frame moved 0.1 m along +x: its band, a quarter of the view
    assert moved == pytest.approx(0.1 / 0.4 * res, abs=1.5)
