"""V-REP's local respondable masks (issue 58, RLBench's Panda gripper): two respondable shapes of
one tree collide only when their local masks (low byte of ``Dc2``) share a bit. "One tree" is
CoppeliaSim's: the same topmost ancestor (``CShape::getLastParentForLocalGlobalRespondable``),
through model bases. The Panda's finger pads hang from touch sensors that are model bases of their
own; taken as other models (global masks), the two pads collided, and the closed fingers jammed
against each other (MuJoCo's contacts held them shut with more than the motors' 20 N, so
RLBench's ``Discrete()`` gripper never opened again)."""

from __future__ import annotations

import struct

import mujoco
import pytest

import tttwriter as W
from simx_server.scene.ttt import convert, reader


def _shape(handle: int, parent: int, name: str, mask: int, pos, extra: bytes = b"") -> bytes:
    plain = W.cuboid_shape(handle, parent, name, (0.02, 0.02, 0.02), pos, dynamic=False, extra=extra)
    return plain.replace(W.rec("Dc2", struct.pack("<H", 0xFFFF)), W.rec("Dc2", struct.pack("<H", mask)))


def gripper() -> bytes:
    """A hand (model base) with two fingers (local masks 0x0f, 0xf0) and, under each, a touch
    sensor (a model base) carrying a pad whose local mask is the other finger's."""
    return W.ttt_file(
        _shape(1, -1, "hand", 0xFF0F, (0, 0, 0.5), W.model_base()) +
        _shape(2, 1, "left_finger", 0xFF0F, (0, 0.05, 0)) +
        W.force_sensor(3, 2, "left_touch", extra=W.model_base()) +
        _shape(4, 3, "left_pad", 0xFFF0, (0, -0.01, 0)) +
        _shape(5, 1, "right_finger", 0xFFF0, (0, -0.05, 0)) +
        W.force_sensor(6, 5, "right_touch", extra=W.model_base()) +
        _shape(7, 6, "right_pad", 0xFF0F, (0, 0.01, 0)) +
        _shape(8, -1, "table", 0xFFFF, (0, 0, 0)), serialization=24, program=40100)


def test_local_masks_hold_across_model_bases_within_one_tree(tmp_path):
    (tmp_path / "gripper.ttm").write_bytes(gripper())
    xml, _ = convert.convert(reader.read(str(tmp_path / "gripper.ttm")), tmp_path / "out")
    spec = mujoco.MjSpec.from_file(str(xml))
    excluded = {frozenset((e.bodyname1, e.bodyname2)) for e in spec.excludes}
    assert frozenset(("left_pad", "right_pad")) in excluded  # 0xf0 & 0x0f: below one root
    assert frozenset(("left_finger", "right_finger")) in excluded
    assert frozenset(("left_finger", "left_pad")) in excluded
    assert frozenset(("left_pad", "right_finger")) not in excluded  # 0xf0 & 0xf0: they collide
    assert frozenset(("right_pad", "left_finger")) not in excluded
    assert not any("table" in pair for pair in excluded)  # another tree: the global masks decide


@pytest.mark.renderers_on_demand  # no image is read
def test_a_shape_with_both_masks_empty_meets_nothing_and_stays_respondable(tmp_path):
    """V-REP pairs two respondable shapes only when their masks share a bit: a dynamic cube whose
    masks are both 0 (the TurtleBot's wheel-drop bodies) falls through the table another cube,
    of the default masks, rests on; sim.getObjectInt32Param still reads it respondable."""
    from simx_server.api import script_sim
    from simx_server.scene.simulation import Simulation

    def cube(handle: int, name: str, mask: int, x: float) -> bytes:
        plain = W.cuboid_shape(handle, -1, name, (0.05, 0.05, 0.05), (x, 0, 0.2), mass=0.1)
        return plain.replace(W.rec("Dc2", struct.pack("<H", 0xFFFF)), W.rec("Dc2", struct.pack("<H", mask)))

    f = tmp_path / "masks.ttt"
    f.write_bytes(W.ttt_file(W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05))))
                             + W.cuboid_shape(1, -1, "table", (1.0, 1.0, 0.1), (0, 0, 0), dynamic=False)
                             + cube(2, "kept", 0xFFFF, -0.2) + cube(3, "unmasked", 0x0000, 0.2)))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "masks")
    sim = Simulation(xml, realtime=False)
    try:
        sim.start()
        api = script_sim(sim.world, sim.world.resolve("table").handle, sim.signals, simulation=sim)
        for _ in range(20):  # 1 s
            sim.step()
        kept, unmasked = api.getObject("/kept"), api.getObject("/unmasked")
        assert abs(api.getObjectPosition(kept, -1)[2] - 0.075) < 0.005  # on the table's top (0.05)
        assert api.getObjectPosition(unmasked, -1)[2] < -1.0  # through it, falling
        assert api.getObjectInt32Param(unmasked, 3004) == 1  # sim.shapeintparam_respondable
    finally:
        sim.close()
