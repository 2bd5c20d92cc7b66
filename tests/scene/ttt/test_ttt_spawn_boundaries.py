"""What RLBench's task placement asks of a converted ``.ttm`` (issue 58), on a tiny task model
built here: a spawn boundary drawn as lines (a V-REP wireframe plane) keeps its geometry, pose
and a bounding box of no height; dummies, sensors and joints have CoppeliaSim 4.1's bounding
boxes; a model's box covers its tree in the base's frame; ``checkCollision`` with an object that
is not a shape answers 0; a dynamic shape saved on a static one is a free body; and a shape
hung from a force sensor is re-parented to the sensor again and to the joint above it."""

from __future__ import annotations

import struct

import mujoco
import numpy as np
import pytest

import tttwriter as W
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation
from simx_server.scene.ttt import convert, reader

pytestmark = pytest.mark.renderers_on_demand  # no image is read

BASE = (0.25, 0.0, 0.75)


def _task() -> bytes:
    no_special = W.rec("Omp", W.i32(0))  # not collidable, measurable, detectable nor renderable
    return W.ttt_file(
        W.rec("SIM", W.lst(W.rec("Sts", W.f32(0.05)))) + W.rec("DYN", W.lst(W.rec("En2", W.i32(0) + W.f32(0, 0, -9.81))))
        + W.dummy(1, -1, "task", BASE, extra=W.model_base())
        + W.plane_shape(2, 1, "boundary", (0.4, 0.6), (0.0, 0.0, 0.001), extra=no_special)
        + W.cuboid_shape(3, 1, "box", (0.2, 0.2, 0.1), (0.3, 0.0, 0.05), dynamic=False)
        + W.cuboid_shape(4, 3, "cup", (0.04, 0.04, 0.06), (0.0, 0.0, 0.08), mass=0.05)
        + W.dummy(5, 1, "waypoint", (0.0, 0.0, 0.3))
        + W.proximity_sensor(6, 1, "detector", reach=0.2, pos=(-0.1, 0.0, 0.0))
        + W.joint(7, 1, "hinge", (0.0, 0.2, 0.1), extra=W.rec("Arg", W.f32(0.1, 0.02)))
        + W.cuboid_shape(8, 7, "link", (0.05, 0.05, 0.05), (0.0, 0.0, 0.0), mass=0.1)
        + W.force_sensor(9, 8, "wrist", (0.0, 0.0, 0.05))
        + W.cuboid_shape(10, 9, "cap", (0.03, 0.03, 0.03), (0.0, 0.0, 0.02), mass=0.01)
        + W.dummy(11, 1, "marker", (0.0, -0.2, 0.0), extra=W.object_property(256)))  # left out of model boxes


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    out = tmp_path_factory.mktemp("task")
    f = out / "task.ttm"
    f.write_bytes(_task())
    xml, report = convert.convert(reader.read(f), out / "mjcf", "task")
    assert "wireframe meshes (not drawn: MuJoCo draws no lines)" in report.approximations()[0] or any(
        "wireframe" in line for line in report.approximations())
    sim = Simulation(xml, realtime=False)
    sim.start()
    yield script_sim(sim.world, sim.world.resolve("task").handle, sim.signals, simulation=sim)
    sim.stop()
    sim.close()


def _box(api, name: str, first: int = 15) -> list[float]:
    h = api.getObject("/" + name)
    return [api.getObjectFloatParam(h, first + i) for i in range(6)]  # min x y z, max x y z


def test_a_wireframe_boundary_keeps_its_geometry_and_has_no_height(api):
    lo_hi = _box(api, "task/boundary")
    assert lo_hi == pytest.approx([-0.2, -0.3, 0.0, 0.2, 0.3, 0.0], abs=1e-6)
    w = api.context.world
    m = w.model
    geoms = np.flatnonzero(m.geom_bodyid == w.resolve("boundary").mj_id)
    assert len(geoms) == 1
    assert m.geom_group[geoms[0]] == 3 and m.geom_contype[geoms[0]] == 0 and m.geom_conaffinity[geoms[0]] == 0
    assert api.getObjectPosition(api.getObject("/task/boundary"), -1) == pytest.approx(
        [BASE[0], BASE[1], BASE[2] + 0.001], abs=1e-9)


def test_non_shapes_have_coppeliasim_bounding_boxes(api):
    assert _box(api, "task/waypoint") == pytest.approx([-0.01, -0.01, -0.01, 0.01, 0.01, 0.01], abs=1e-9)
    lo = _box(api, "task/detector")  # the ray from 0 to its range along +z, and the sensor's size
    assert lo == pytest.approx([-0.005, -0.005, -0.005, 0.005, 0.005, 0.2], abs=1e-6)
    assert _box(api, "task/hinge") == pytest.approx([-0.01, -0.01, -0.05, 0.01, 0.01, 0.05], abs=1e-6)


def test_the_model_box_covers_the_tree_in_the_base_frame(api):
    lo_hi = _box(api, "task", first=21)
    # x: the boundary's -0.2 to the box's side at 0.4; y: the boundary's -0.3 to its 0.3 (the
    # marker at -0.2 is left out, the hinge reaches 0.21); z: the base dummy's -0.01 to the
    # waypoint's 0.31
    assert lo_hi == pytest.approx([-0.2, -0.3, -0.01, 0.4, 0.3, 0.31], abs=1e-6)


def test_a_model_box_when_the_base_is_a_shape(api):
    lo_hi = _box(api, "task/box", first=21)  # the box, and the cup on it (V-REP's child: a free body)
    assert lo_hi == pytest.approx([-0.1, -0.1, -0.05, 0.1, 0.1, 0.11], abs=1e-6)


def test_check_collision_with_an_object_that_is_not_a_shape_is_zero(api):
    dummy, sensor, box = (api.getObject(p) for p in ("/task/waypoint", "/task/detector", "/task/box"))
    api.setObjectPosition(dummy, -1, api.getObjectPosition(box, -1))  # inside the box
    assert api.checkCollision(dummy, box) == (0, [-1, -1])
    assert api.checkCollision(box, dummy)[0] == 0
    assert api.checkCollision(dummy, api.handle_all)[0] == 0
    assert api.checkCollision(sensor, dummy)[0] == 0
    assert api.checkCollisionEx(dummy, box) == (0, [])


def test_a_dynamic_shape_on_a_static_one_is_a_free_body(api):
    w = api.context.world
    m = w.model
    cup = w.resolve("cup")
    assert m.body_parentid[cup.mj_id] == 0
    assert m.jnt_type[m.body_jntadr[cup.mj_id]] == mujoco.mjtJoint.mjJNT_FREE
    assert api.getObjectParent(cup.handle) == w.resolve("box").handle  # V-REP's tree kept


def test_a_flat_primitive_shape_has_no_height(api):
    plane = api.createPureShape(0, 16, [0.4, 0.3, 0.0], 1.0)
    assert [api.getObjectFloatParam(plane, p) for p in (17, 20)] == [0.0, 0.0]
    assert api.getObjectFloatParam(plane, 18) == pytest.approx(0.2)
    disc = api.createPrimitiveShape(2, [0.2, 0.0, 0.0], 2)
    assert [api.getObjectFloatParam(disc, p) for p in (17, 20)] == [0.0, 0.0]
    with pytest.raises(Exception, match="sizes"):
        api.createPrimitiveShape(3, [0.2, 0.0, 0.1], 2)


def test_a_shape_under_a_force_sensor_is_reparented_as_coppeliasim_does(api):
    cap, wrist, hinge = (api.getObject(p) for p in ("/task/hinge/link/wrist/cap", "/task/hinge/link/wrist",
                                                    "/task/hinge"))
    before = api.getObjectPosition(cap, -1)
    api.setObjectParent(cap, wrist, True)  # its parent already: nothing changes
    assert api.getObjectParent(cap) == wrist
    api.setObjectParent(cap, hinge, True)  # RLBench's open_wine_bottle, once the cap is turned
    assert api.getObjectParent(cap) == hinge
    assert api.getObjectPosition(cap, -1) == pytest.approx(before, abs=1e-9)
    api.setObjectParent(cap, wrist, True)  # and back, at the next episode
    assert api.getObjectParent(cap) == wrist
    assert api.getObjectPosition(cap, -1) == pytest.approx(before, abs=1e-9)


def test_joint_sizes_are_read(tmp_path):
    f = tmp_path / "j.ttt"
    f.write_bytes(W.ttt_file(W.joint(1, -1, "j", extra=W.rec("Arg", struct.pack("<2f", 0.3, 0.05)))))
    assert reader.read(f).objects[1].data.size == pytest.approx((0.3, 0.05))


def test_moving_a_dummy_moves_its_whole_subtree(tmp_path):
    """CoppeliaSim moves a subtree with its top: RLBench places a task by its base dummy, whose
    children (sites, static and dynamic shapes, a joint) MuJoCo keeps beside the base's site."""
    f = tmp_path / "t.ttm"
    f.write_bytes(W.ttt_file(
        W.dummy(1, -1, "base", BASE, extra=W.model_base())
        + W.proximity_sensor(2, 1, "sensor", pos=(0.1, 0.0, 0.0))
        + W.cuboid_shape(3, 2, "cup", (0.04, 0.04, 0.06), (0.0, 0.0, 0.03), mass=0.05)
        + W.plane_shape(4, 1, "area", (0.4, 0.6), (0.0, 0.0, 0.0))
        + W.joint(5, 1, "hinge", (0.0, 0.2, 0.1))
        + W.cuboid_shape(6, 5, "door", (0.05, 0.05, 0.05), (0.0, 0.0, 0.0), mass=0.1)
        + W.dummy(7, 1, "tip", (0.0, -0.1, 0.05))))
    xml, _ = convert.convert(reader.read(f), tmp_path / "out", "t")
    sim = Simulation(xml, realtime=False)
    try:
        api = script_sim(sim.world, sim.world.resolve("base").handle, sim.signals, simulation=sim)
        names = ("sensor", "cup", "area", "hinge", "door", "tip")
        h = {n: api.getObject("/base/" + n if n not in ("cup", "door") else
                              {"cup": "/base/sensor/cup", "door": "/base/hinge/door"}[n]) for n in names}
        base = api.getObject("/base")
        before = {n: api.getObjectPosition(h[n], base) for n in names}
        api.setObjectPosition(base, -1, [0.5, -0.2, 0.8])
        api.setObjectOrientation(base, -1, [0.0, 0.0, 0.7])
        for n in names:
            assert api.getObjectPosition(h[n], base) == pytest.approx(before[n], abs=1e-9), n
        assert api.getObjectPosition(h["tip"], -1) == pytest.approx(
            [0.5 + 0.1 * np.sin(0.7), -0.2 - 0.1 * np.cos(0.7), 0.85], abs=1e-9)
    finally:
        sim.close()
