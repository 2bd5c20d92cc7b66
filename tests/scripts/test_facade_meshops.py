"""Shape frame and size edits of the one ``sim`` facade (issue 32): relocateShapeFrame keeps the
geometry in place, setShapeBB and scaleObjects resize through the MjSpec."""

from __future__ import annotations

import numpy as np
import pytest

from simx_client.protocol import ArgumentError, RemoteError, UnsupportedError
from simx_server.scene.simulation import Simulation
from simx_server.api import script_sim
import facade_fixtures

sim, api = facade_fixtures.sim, facade_fixtures.api  # the shared fixtures


def world_mesh(api, h):
    v = np.array(api.getShapeMesh(h)[0]).reshape(-1, 3)
    m = np.array(api.getObjectMatrix(h, -1)).reshape(3, 4)
    return v @ m[:, :3].T + m[:, 3]


@pytest.mark.renderers_on_demand  # no image read
def test_relocated_frame_leaves_the_geometry_in_place(api):
    a = api.getObject("/blockA")
    before = world_mesh(api, a)
    pose = [0.3, 2.1, 0.7, 0, 0, np.sin(0.4), np.cos(0.4)]
    assert api.relocateShapeFrame(a, pose) == 1
    assert api.getObjectPose(a) == pytest.approx(pose, abs=1e-9)
    assert world_mesh(api, a) == pytest.approx(before, abs=1e-9)
    api.relocateShapeFrame(a, [0] * 7)  # back to the box's centre, axes kept
    assert api.getObjectPosition(a) == pytest.approx([0, 2, 0.5], abs=1e-9)
    assert world_mesh(api, a) == pytest.approx(before, abs=1e-9)
    falling = api.getObject("/faller")  # a free body: its state follows the new frame
    p = api.getObjectPosition(falling)
    api.relocateShapeFrame(falling, [p[0] + 0.1, p[1], p[2], 0, 0, 0, 1])
    assert api.getObjectPosition(falling) == pytest.approx([p[0] + 0.1, p[1], p[2]], abs=1e-9)
    with pytest.raises(UnsupportedError, match="joints"):
        api.relocateShapeFrame(api.getObject("/hinge_link"), [0] * 7)


@pytest.mark.renderers_on_demand  # no image read
def test_bounding_box_size_and_scaling(api):
    a, b = api.getObject("/blockA"), api.getObject("/blockB")
    api.setShapeBB(a, [0.1, 0.4, 0.2])
    assert api.getShapeBB(a) == pytest.approx([0.1, 0.4, 0.2])
    pb = api.getObjectPosition(b)
    api.scaleObjects([b], 2.0, True)
    assert api.getShapeBB(b) == pytest.approx([0.4, 0.4, 0.4])
    assert api.getObjectPosition(b) == pytest.approx([2 * c for c in pb])
    with pytest.raises(ArgumentError, match="scalingFactor"):
        api.scaleObjects([b], 0, False)


LOOKS = """<mujoco><asset>
  <texture name="checks" type="2d" builtin="checker" rgb1="1 0 0" rgb2="0 0 1" width="8" height="8"/>
  <material name="tiles" texture="checks" specular="0.3" shininess="0.7"/>
</asset><worldbody>
  <body name="tiled"><geom name="face" type="box" size="0.1 0.1 0.1" material="tiles"/></body>
  <body name="plain"><geom name="paint" type="box" size="0.1 0.1 0.1" rgba="0 1 0 1"/></body>
  <camera name="eye" pos="0 0 1" resolution="40 20" fovy="90"/>
</worldbody><custom><text name="simx:eye" data="near=0.1 far=2"/></custom></mujoco>"""


def test_appearance_textures_and_parameters(tmp_path):
    scene = tmp_path / "looks.xml"
    scene.write_text(LOOKS)
    sim = Simulation(scene, realtime=False)
    sim.start()
    try:
        api = script_sim(sim.world, sim.world.resolve("tiled").handle, sim.signals, simulation=sim)
        tiled, plain = api.getObject("/tiled"), api.getObject("/plain")
        tex, res = api.getTextureId("checks")
        assert api.getShapeTextureId(tiled) == tex and api.getShapeTextureId(plain) == -1
        img = np.frombuffer(api.readTexture(tex), np.uint8).reshape(res[1], res[0], 3)
        assert {tuple(p) for p in img.reshape(-1, 3)} == {(255, 0, 0), (0, 0, 255)}
        assert len(api.readTexture(tex, 0, 1, 1, 2, 3)) == 2 * 3 * 3
        with pytest.raises(ArgumentError, match="outside"):
            api.readTexture(tex, 0, 0, 0, res[0] + 1, 1)
        saved = api.getShapeAppearance(plain)
        assert saved["geoms"][0]["color"] == [0, 1, 0, 1]
        api.setShapeColor(plain, None, 0, [1, 1, 0])
        api.setShapeAppearance(plain, saved)
        assert api.getShapeColor(plain, None, 0)[1] == pytest.approx([0, 1, 0])
        api.setShapeMaterial(plain, tiled)
        assert api.getShapeAppearance(plain)["geoms"][0]["color"] == api.getShapeAppearance(tiled)["geoms"][0]["color"]
        assert api.getObjectStringParam(plain, api.shapestringparam_colorname) == "paint"
        api.setShapeTexture(plain, tex, 0, 0, [2, 3])
        assert api.getShapeTextureId(plain) == tex
        m = sim.world.model
        mat = m.geom_matid[sim.world.model.geom_bodyid == sim.world.resolve("plain").mj_id][0]
        assert m.mat_texrepeat[mat] == pytest.approx([2, 3])
        api.setShapeTexture(plain, -1, 0, 0, [1, 1])
        assert api.getShapeTextureId(plain) == -1
        with pytest.raises(RemoteError, match="no texture"):
            api.setShapeTexture(plain, 99, 0, 0, [1, 1])
        picture = np.zeros((2, 4, 3), np.uint8)
        picture[0] = [0, 0, 255]  # OpenCV's BGR: the top row red
        import cv2  # noqa: PLC0415
        cv2.imwrite(str(tmp_path / "pic.png"), picture)
        shape, tid, size = api.createTexture("pic.png", 0, [0.4, 0.2])
        assert size == [4, 2] and api.getShapeTextureId(shape) == tid
        assert api.getShapeBB(shape)[:2] == pytest.approx([0.4, 0.2])
        top = np.frombuffer(api.readTexture(tid), np.uint8).reshape(2, 4, 3)[1]  # rows bottom-up
        assert top.tolist() == [[255, 0, 0]] * 4
        f = np.array(api.getObjectFloatArrayParam(api.getObject("/eye"), api.visionfarrayparam_viewfrustum))
        corners = f.reshape(8, 3)  # fovy 90 deg, aspect 2: the far plane 2 m away spans 8 x 4 m
        assert corners[6] == pytest.approx([4, 2, 2]) and corners[0] == pytest.approx([-0.2, -0.1, 0.1])
    finally:
        sim.stop()
        sim.close()


@pytest.mark.renderers_on_demand  # no image read
def test_heightfield_shape_has_the_given_heights(api, sim):
    xs = np.linspace(-0.5, 0.5, 5)
    ys = np.linspace(-0.25, 0.25, 3)
    heights = [0.1 + 0.2 * (x + 0.5) for y in ys for x in xs]  # a slope along x, from 0.1 to 0.3 m
    hf = api.createHeightfieldShape(0, 0.5, 5, 3, 1.0, heights)
    assert api.getObjectType(hf) == api.object_shape_type
    assert api.getShapeBB(hf)[:2] == pytest.approx([1.0, 0.5])
    # a ray straight down meets the surface at the given height
    m, d = sim.world.model, sim.world.data
    import mujoco  # noqa: PLC0415
    geomid = np.array([-1], np.int32)
    for x, expect in ((-0.25, 0.15), (0.25, 0.25)):
        dist = mujoco.mj_ray(m, d, np.array([x, 0.0, 2.0]), np.array([0.0, 0.0, -1.0]), None, 1, -1, geomid)
        assert 2.0 - dist == pytest.approx(expect, abs=1e-6)
    with pytest.raises(ArgumentError, match="15 numbers"):
        api.createHeightfieldShape(0, 0.5, 5, 3, 1.0, [0.0] * 14)


@pytest.mark.renderers_on_demand  # no image read
def test_group_then_ungroup_keeps_the_geometry(api, sim):
    a, b = api.getObject("/blockA"), api.getObject("/blockB")
    before = np.vstack([world_mesh(api, a), world_mesh(api, b)])
    mass = api.getShapeMass(a) + api.getShapeMass(b)
    c = api.groupShapes([a, b])
    assert c == a and b not in sim.world.objects
    assert api.getShapeGeomInfo(c)[0] & 1  # compound
    assert world_mesh(api, c) == pytest.approx(before, abs=1e-9)
    assert api.getShapeBB(c) == pytest.approx([0.45, 0.2, 0.2])
    assert api.getShapeMass(c) == pytest.approx(mass)  # MuJoCo's inertia from both geoms
    parts = api.ungroupShape(c)
    assert len(parts) == 2 and parts[0] == c
    assert np.vstack([world_mesh(api, p) for p in parts]) == pytest.approx(before, abs=1e-9)
    assert api.ungroupShape(parts[1]) == [parts[1]]
    with pytest.raises(UnsupportedError, match="joints"):
        api.groupShapes([a, api.getObject("/hinge_link")])
    with pytest.raises(ArgumentError, match="at least 2"):
        api.groupShapes([a])


WELDED = """<mujoco><worldbody>
  <body name="arm" pos="0 0 1"><freejoint/><geom size="0.05"/><site name="tipA"/></body>
  <site name="anchor" pos="0 0 1"/><site name="free1"/><site name="free2"/>
</worldbody><equality><weld site1="tipA" site2="anchor"/></equality></mujoco>"""


def test_dummy_links_and_vision_check_image(tmp_path):
    scene = tmp_path / "welded.xml"
    scene.write_text(WELDED)
    sim = Simulation(scene, realtime=False)
    sim.start()
    try:
        api = script_sim(sim.world, sim.world.resolve("arm").handle, sim.signals, simulation=sim)
        tip, anchor, f1, f2 = (api.getObject("/" + n) for n in ("arm/tipA", "anchor", "free1", "free2"))
        assert api.getLinkDummy(tip) == anchor and api.getLinkDummy(anchor) == tip  # the MJCF weld
        assert api.getLinkDummy(f1) == -1
        api.setLinkDummy(f1, f2)  # two dummies the scene never linked: a weld made at run time
        assert api.getLinkDummy(f1) == f2 and api.getLinkDummy(f2) == f1
        api.setLinkDummy(f2, -1)
        assert api.getLinkDummy(f1) == -1 and api.getLinkDummy(f2) == -1
        api.setLinkDummy(tip, -1)  # the weld switched off, then on again
        assert api.getLinkDummy(tip) == -1 and api.getLinkDummy(anchor) == -1
        api.setLinkDummy(anchor, tip)
        assert api.getLinkDummy(tip) == anchor
        with pytest.raises(Exception, match="dummy"):
            api.setLinkDummy(f1, api.getObject("/arm"))
        cam = api.createVisionSensor(1, [8, 6, 0, 0], [0.01, 5, 1.0, 0, 0, 0, 0, 0, 0, 0, 0])
        rgb = api.checkVisionSensorEx(cam, api.handle_all, True)
        depth = api.checkVisionSensorEx(cam, api.handle_all, False)
        img, _ = api.getVisionSensorImg(cam)
        assert rgb == pytest.approx((np.frombuffer(img, np.uint8) / 255.0).tolist())
        assert len(depth) == 48 and all(0 <= v <= 1 for v in depth)
        with pytest.raises(UnsupportedError, match="whole scene"):
            api.checkVisionSensorEx(cam, api.getObject("/arm"), True)
    finally:
        sim.stop()
        sim.close()


def test_proximity_check_against_given_triangles(api):
    prox = api.createProximitySensor(api.proximitysensor_ray, 0, 0, [0] * 8, [0, 2] + [0] * 13)
    api.setObjectPosition(prox, -1, [5, 5, 0])  # looking up (+z) from (5, 5, 0), 2 m range
    up = [4, 4, 1, 6, 4, 1, 5, 6, 1]  # counter-clockwise seen from above: its back faces the sensor
    down = [4, 4, 1, 5, 6, 1, 6, 4, 1]  # the same triangle turned: its front faces the sensor
    res, dist, point, normal = api.checkProximitySensorEx2(prox, down, 2, 1, 1, 5.0, 0)
    assert res == 1 and dist == pytest.approx(1) and point == pytest.approx([0, 0, 1])
    assert normal == pytest.approx([0, 0, -1])
    assert api.checkProximitySensorEx2(prox, up, 2, 1, 1, 5.0, 0)[0] == 0  # a back face, front asked
    assert api.checkProximitySensorEx2(prox, up, 2, 1, 2, 5.0, 0)[0] == 1  # back faces asked
    assert api.checkProximitySensorEx2(prox, down, 2, 1, 1, 0.5, 0)[0] == 0  # beyond the threshold
    far = [4, 4, 3, 5, 6, 3, 6, 4, 3]
    assert api.checkProximitySensorEx2(prox, far, 2, 1, 1, 5.0, 0)[0] == 0  # beyond the 2 m range
    assert api.checkProximitySensorEx2(prox, [5, 5, 1], 0, 1, 3, 5.0, 0)[0] == 0  # a point: no area
    with pytest.raises(ArgumentError, match="itemCount"):
        api.checkProximitySensorEx2(prox, down, 2, 2, 1, 5.0, 0)


def test_proximity_check_tests_are_bounded_and_made_in_pieces(api, monkeypatch):
    """``checkProximitySensorEx2``'s rays x triangles are bounded before any test
    (``links.MAX_TESTS``; 4,000,000 held the simulation thread 7.1 s and took 450 MB, issue 84),
    and made a piece of the triangles at a time: the nearest hit is found across the pieces."""
    from simx_server.api.sim import links

    prox = api.createProximitySensor(api.proximitysensor_ray, 0, 0, [0] * 8, [0, 2] + [0] * 13)
    api.setObjectPosition(prox, -1, [5, 5, 0])  # one ray, up, 2 m
    layers = [[4, 4, z, 5, 6, z, 6, 4, z] for z in (1.5, 1.25, 0.75, 1.0)]  # the nearest third
    pieces = []
    nearest = links._nearest_hit
    monkeypatch.setattr(links, "_nearest_hit", lambda local, *a: pieces.append(len(local)) or nearest(local, *a))
    monkeypatch.setattr(links, "_PIECE_TESTS", 1)  # one triangle a piece
    res, dist, point, _ = api.checkProximitySensorEx2(prox, sum(layers, []), 2, 4, 1, 5.0, 0)
    assert pieces == [1, 1, 1, 1] and res == 1 and dist == pytest.approx(0.75)
    monkeypatch.setattr(links, "MAX_TESTS", 3)
    pieces.clear()
    with pytest.raises(ArgumentError, match="MAX_TESTS"):
        api.checkProximitySensorEx2(prox, sum(layers, []), 2, 4, 1, 5.0, 0)
    assert not pieces  # refused before any test
