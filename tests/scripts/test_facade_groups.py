"""CoppeliaSim 4.x's regular API groups of the one ``sim`` facade (issue 32), in-process on a
Simulation: parameters, shapes, collision and distance, sensors, joints, GUI-only calls.
The same object serves Lua and Python scripts and (RemoteSim) ZMQ clients."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simx_client.protocol import ArgumentError, RemoteError, UnsupportedError
from simx_server.scene.simulation import Simulation
import facade_fixtures
from facade_fixtures import SENSORS

sim, api = facade_fixtures.sim, facade_fixtures.api  # the shared fixtures


def h(api, name):
    return api.getObject("/" + name)


@pytest.mark.renderers_on_demand  # no image read
def test_parameters_answer_a_4x_version(api, sim):
    assert api.getInt32Param(api.intparam_program_version) == 40800
    assert api.getInt32Param(api.intparam_program_full_version) == 4080000
    assert api.getInt32Param(api.intparam_dynamic_engine) == 4  # sim.physics_mujoco
    assert api.getFloatParam(api.floatparam_simulation_time_step) == pytest.approx(sim.world.dt)
    assert api.getBoolParam(api.boolparam_headless) is True
    assert api.getArrayParam(api.arrayparam_gravity) == pytest.approx([0, 0, -9.81])
    with pytest.raises(UnsupportedError, match="parameter 999"):
        api.getInt32Param(999)
    with pytest.raises(RemoteError, match="refused"):
        api.quitSimulator()
    api.setNamedStringParam("k", "v")
    assert api.getNamedStringParam("k") == "v" and api.getNamedInt32Param("none") is None
    assert 0 <= api.getRandom(7) < 1 and api.getRandom(7) == api.getRandom(7)


@pytest.mark.renderers_on_demand  # no image read
def test_shape_mass_inertia_colour_and_bounding_box(api, sim):
    a = h(api, "blockA")
    mass = api.getShapeMass(a)
    inertia, frame = api.getShapeInertia(a)
    api.setShapeMass(a, 2 * mass)
    assert api.getShapeMass(a) == pytest.approx(2 * mass)
    assert api.getShapeInertia(a)[0] == pytest.approx([2 * v for v in inertia])  # scales with the mass
    # MuJoCo's constants derived from masses follow (a stale subtree mass and constraint weights
    # made RLBench's procedural objects, given 0.1 kg, blow up on landing)
    m, body = sim.world.model, sim.world.objects[a].mj_id
    assert m.body_subtreemass[body] == pytest.approx(2 * mass + sum(
        m.body_mass[c] for c in range(m.nbody) if c != body and m.body_rootid[c] == body))
    assert len(frame) == 12
    size = api.getShapeBB(a)
    assert len(size) == 3 and all(s > 0 for s in size)
    api.setShapeColor(a, None, 0, [0.1, 0.2, 0.3])
    assert api.getShapeColor(a, None, 0) == (1, pytest.approx([0.1, 0.2, 0.3]))
    assert api.getObjectColor(a, 0, 0) == pytest.approx([0.1, 0.2, 0.3])
    verts, idx, normals = api.getShapeMesh(a)  # blockA is a box
    assert len(verts) == 24 and len(idx) == 36 and len(normals) == 108
    extent = np.array(verts).reshape(-1, 3)
    assert (extent.max(0) - extent.min(0)) == pytest.approx(size)


@pytest.mark.renderers_on_demand  # no image read
def test_primitive_shape_is_a_dynamic_body(api, sim):
    s = api.createPrimitiveShape(api.primitiveshape_cuboid, [0.1, 0.2, 0.3])
    assert api.getObjectType(s) == api.object_shape_type
    assert api.getShapeBB(s) == pytest.approx([0.1, 0.2, 0.3])
    assert api.getShapeMass(s) == pytest.approx(1000 * 0.006)
    with pytest.raises(UnsupportedError, match="cone"):
        api.createPrimitiveShape(6, [0.1, 0.1, 0.1])


@pytest.mark.renderers_on_demand  # no image read
def test_collision_and_distance(api):
    a, b, c = h(api, "blockA"), h(api, "blockB"), h(api, "blockC")
    assert api.checkCollision(a, c) == (1, [a, c])  # C overlaps A by 0.01 m
    assert api.checkCollision(a, b) == (0, [-1, -1])  # 0.05 m apart
    result, data, pair = api.checkDistance(a, b)
    assert result == 1 and data[6] == pytest.approx(0.05, abs=1e-6) and pair == [a, b]
    assert np.linalg.norm(np.array(data[:3]) - data[3:6]) == pytest.approx(0.05, abs=1e-6)
    assert api.checkDistance(a, b, 0.01)[0] == 0  # beyond the threshold
    assert api.checkDistance(h(api, "ball_above"), api.handle_all)[1][6] == pytest.approx(0.2002, abs=1e-4)
    assert api.checkCollision(h(api, "prox"), a) == (0, [-1, -1])  # a non-shape collides with nothing (4.1)


def test_sensors_handled_explicitly(api, sim):
    cam = h(api, "cam")
    count, packet = api.handleVisionSensor(cam)
    assert count == 0 and len(packet) == 15 and all(0 <= v <= 1 for v in packet)
    assert api.readVisionSensor(cam) == (0, pytest.approx(packet))
    assert api.handleVisionSensor(cam, False) == (0,)  # simx's own: rendered, no packets computed
    with pytest.raises(ArgumentError, match="packets"):
        api.handleVisionSensor(cam, "no")
    assert api.getVisionSensorResolution(cam) == [32, 24]
    img, w, hh = api.getVisionSensorCharImage(cam)
    assert (w, hh) == (32, 24) and len(img) == 32 * 24 * 3
    prox = h(api, "prox")
    detected, dist, point, hit, normal = api.handleProximitySensor(prox)
    assert api.readProximitySensor(prox)[:2] == (detected, pytest.approx(dist))
    assert api.checkProximitySensor(prox, api.handle_all)[0] == detected
    api.resetProximitySensor(prox)
    api.setExplicitHandling(cam, 1)
    assert api.getExplicitHandling(cam) == 1


@pytest.mark.renderers_on_demand  # no image read
def test_joints_interval_mode_and_dependency(api):
    j = h(api, "hinge")
    cyclic, interval = api.getJointInterval(j)
    api.setJointInterval(j, False, [-0.5, 1.0])
    assert api.getJointInterval(j) == (False, pytest.approx([-0.5, 1.0]))
    # a joint outside its new interval is put at its nearest end (simSetJointInterval_internal),
    # its motor's target left as it was
    api.setJointPosition(j, 0.0)
    api.setJointTargetPosition(j, 0.2)
    api.setJointInterval(j, False, [0.3, 0.1])
    assert api.getJointPosition(j) == pytest.approx(0.3) and api.getJointTargetPosition(j) == pytest.approx(0.2)
    api.setJointInterval(j, False, [-0.5, 1.0])
    assert api.getJointPosition(j) == pytest.approx(0.3)  # inside: stays
    api.setJointInterval(j, cyclic, interval)
    mode, _ = api.getJointMode(j)
    assert mode in (0, 5)
    assert api.getJointDependency(j) == (-1, 0.0, 1.0)
    with pytest.raises(UnsupportedError, match="kinematic"):
        api.setJointMode(j, 4)


@pytest.mark.renderers_on_demand  # no image read
def test_objects_uid_velocity_and_script_handles(api):
    f = h(api, "faller")
    assert api.getObjectUid(f) == f and api.getObjectFromUid(f) == f
    assert api.getObjectFromUid(10 ** 6, {"noError": True}) == -1
    lin, ang = api.getVelocity(f)
    assert lin[2] < 0  # it falls
    assert api.getScriptHandle(f) == -1  # no script on it


@pytest.mark.renderers_on_demand  # no image read
def test_gui_functions_answer_as_headless(api, caplog):
    console = api.auxiliaryConsoleOpen("out", 10, 0)
    with caplog.at_level("INFO", logger="simx.scripts"):
        assert api.auxiliaryConsolePrint(console, "hello console") == 1
    assert "hello console" in caplog.text
    assert api.auxiliaryConsoleClose(console) == 1 and api.auxiliaryConsolePrint(console, "x") == 0
    assert api.textEditorGetInfo(api.textEditorOpen("x")) == ("", [0, 0], [0, 0], False)
    assert api.getPage() == 0 and api.getNavigationMode() == 0
    api.setObjectSelection([h(api, "faller")])
    assert api.getObjectSelection() == [h(api, "faller")]


@pytest.mark.renderers_on_demand  # no image read
def test_bad_arguments_are_named(api):
    with pytest.raises(ArgumentError, match="sizes"):
        api.createPrimitiveShape(3, [0.1, 0.2])
    with pytest.raises(ArgumentError, match="mass"):
        api.setShapeMass(h(api, "blockA"), -1)
    assert not math.isnan(api.getShapeMass(h(api, "blockA")))


@pytest.mark.renderers_on_demand  # no image read
def test_pack_table_custom_data_and_properties(api, sim):
    table = {"a": [1, 2.5, "x"], "b": {"c": True}}
    assert api.unpackTable(api.packTable(table)) == table
    with pytest.raises(ArgumentError, match="CBOR"):
        api.unpackTable(b"\x00\x01")
    a = h(api, "blockA")
    api.writeCustomDataBlockEx(a, "tag", b"\x00raw")
    api.writeCustomTableData(api.handle_scene, "cfg", {"speed": 2})
    assert api.readCustomDataBlockEx(a, "tag") == b"\x00raw" and api.readCustomDataTags(a) == ["tag"]
    assert api.readCustomTableData(api.handle_scene, "cfg") == {"speed": 2}
    assert api.getProperty(api.handle_scene, "customData.cfg") == {"speed": 2}
    api.setProperty(a, "customData.n", [1, 2])
    assert api.getProperty(a, "customData.n") == [1, 2]
    api.setProperty(api.handle_scene, "signal.go", 3)
    assert api.getInt32Signal("go") == 3 and api.getProperty(api.handle_scene, "signal.go") == 3
    assert api.getProperty(a, "mass") == pytest.approx(api.getShapeMass(a))
    assert api.getProperty(a, "nothing", {"noError": True}) is None
    api.writeCustomDataBlockEx(a, "tag", b"")
    assert api.readCustomDataBlockEx(a, "tag") is None
    api.setBufferSignal("buf", b"\x01\x02")
    assert api.getBufferSignal("buf") == b"\x01\x02" and "buf" in [api.getSignalName(0, 2)]


@pytest.mark.renderers_on_demand  # no image read
def test_rotation_arithmetic(api):
    ident = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]
    turned = [0, -1, 0, 1, 1, 0, 0, 2, 0, 0, 1, 3]  # 90 degrees about z, moved
    axis, angle = api.getRotationAxis(ident, turned)
    assert axis == pytest.approx([0, 0, 1]) and angle == pytest.approx(math.pi / 2)
    mid = np.array(api.interpolateMatrices(ident, turned, 0.5)).reshape(3, 4)
    assert mid[:, 3] == pytest.approx([0.5, 1, 1.5])
    assert math.atan2(mid[1, 0], mid[0, 0]) == pytest.approx(math.pi / 4)
    abg = api.yawPitchRollToAlphaBetaGamma(0.3, -0.2, 0.5)
    assert api.alphaBetaGammaToYawPitchRoll(*abg) == pytest.approx((0.3, -0.2, 0.5))
    assert api.getConfigDistance([0, 0], [3, 4]) == pytest.approx(5)
    assert api.getConfigDistance([3.0], [-3.0], None, [1]) == pytest.approx(2 * math.pi - 6)


@pytest.mark.renderers_on_demand  # no image read
def test_typed_properties(api):
    a = h(api, "blockA")
    api.setIntProperty(a, "customData.count", 3)
    api.setVector3Property(api.handle_scene, "customData.goal", [1, 2, 3])
    api.setStringProperty(a, "customData.label", "box")
    assert api.getIntProperty(a, "customData.count") == 3
    assert api.getVector3Property(api.handle_scene, "customData.goal") == [1, 2, 3]
    assert api.getStringProperty(a, "customData.label") == "box"
    assert api.getFloatProperty(a, "mass") == pytest.approx(api.getShapeMass(a))
    with pytest.raises(ArgumentError, match="not a vector3"):
        api.getVector3Property(a, "customData.label")
    assert api.getPropertyInfo(a, "customData.count")[0] == api.propertytype_int
    assert api.getPropertyTypeString(api.propertytype_pose) == "pose"
    props = api.getProperties(a)
    assert props["customData.count"] == 3 and props["alias"] == "blockA"
    assert api.getPropertyName(a, 0)[0].startswith("customData.")


@pytest.mark.renderers_on_demand  # no image read
def test_paths_collections_and_drawing_objects(api):
    path = [0, 0, 0, 3, 0, 0, 3, 4, 0]  # 3 points in 3D
    lengths, total = api.getPathLengths(path, 3)
    assert lengths == [0, 3, 7] and total == 7
    assert api.getPathInterpolatedConfig(path, lengths, 5) == pytest.approx([3, 2, 0])
    assert api.resamplePath(path, lengths, 3) == pytest.approx([0, 0, 0, 3, 0.5, 0, 3, 4, 0])
    assert api.getClosestPosOnPath(path, lengths, [4, 1, 0]) == pytest.approx(4)
    p = api.createPath([0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 1], 0, 4)
    assert len(api.unpackDoubleTable(api.readCustomDataBlockEx(p, "PATH"))) == 4 * 7  # subdiv poses
    c = api.createCollection()
    api.addItemToCollection(c, api.handle_tree, h(api, "hinge"), 0)  # the joint and its link
    assert sorted(api.getCollectionObjects(c)) == sorted([h(api, "hinge"), h(api, "hinge_link")])
    api.addItemToCollection(c, api.handle_single, h(api, "hinge"), 1)  # removed again
    assert api.getCollectionObjects(c) == [h(api, "hinge_link")]
    api.destroyCollection(c)
    d = api.addDrawingObject(0, 2, 0, -1, 2)
    for i in range(3):
        assert api.addDrawingObjectItem(d, [i, 0, 0]) == 1
    api.removeDrawingObject(d)
    with pytest.raises(Exception, match="drawing object"):
        api.addDrawingObjectItem(d, [0, 0, 0])


@pytest.mark.renderers_on_demand  # no image read
def test_engine_parameters_and_application_queries(api, sim):
    assert api.getEngineInt32Param(api.mujoco_global_iterations, -1) == sim.world.model.opt.iterations
    api.setEngineFloatParam(api.mujoco_global_wind1, -1, 2.5)
    assert sim.world.model.opt.wind[0] == 2.5 and api.getEngineFloatParam(api.mujoco_global_wind1, -1) == 2.5
    api.setEngineBoolParam(api.mujoco_global_multiccd, -1, False)
    assert api.getEngineBoolParam(api.mujoco_global_multiccd, -1) is False
    with pytest.raises(UnsupportedError, match="no MuJoCo counterpart"):
        api.getEngineFloatParam(api.bullet_global_stepsize, -1)
    with pytest.raises(ArgumentError):
        api.setEngineInt32Param(api.mujoco_global_iterations, -1, 0)
    assert api.isDynamicallyEnabled(h(api, "faller")) and not api.isDynamicallyEnabled(h(api, "blockA"))
    api.writeCustomDataBlockEx(h(api, "blockB"), "graspable", b"1")
    assert api.getObjectsWithTag("graspable") == [h(api, "blockB")]
    order, total = api.getObjectHierarchyOrder(h(api, "blockA"))
    assert 0 <= order < total
    assert "sim.getObjectPosition" in api.getApiFunc(-1, "getObjectPos")
    assert "Position" in api.getApiInfo(-1, "sim.getObjectPosition")
    assert api.getSettingString("x") is None and api.getSimulatorMessage()[0] == -1


def test_images_references_alternates_and_saving(api, sim, tmp_path):
    img = bytes(range(12)) * 2  # 4x2 RGB
    out, res = api.getScaledImage(img, [4, 2], [2, 1])
    assert res == [2, 1] and len(out) == 6
    flipped = api.transformImage(img, [4, 2], 2)
    assert flipped[:12] == img[12:] and api.transformImage(flipped, [4, 2], 2) == img
    assert len(api.combineRgbImages(img, [4, 2], img, [4, 2], 1)) == 48
    assert np.frombuffer(api.transformBuffer(b"\x01\x02", 0, 2.0, 1.0, 6), np.float32).tolist() == [3, 5]
    depth = api.getVisionSensorDepthBuffer(h(api, "cam"))
    assert len(depth) == 32 * 24 and all(0 <= d <= 1 for d in depth)
    a, b = h(api, "blockA"), h(api, "blockB")
    api.setReferencedHandles(a, [b], "neighbour")
    api.addReferencedHandle(a, h(api, "blockC"), "neighbour")
    assert api.getReferencedHandles(a, "neighbour") == [b, h(api, "blockC")]
    assert api.getReferencedHandle(a, "neighbour") == b and api.getReferencedHandlesTags(a) == ["neighbour"]
    hinge = h(api, "hinge")
    sim.world.model.jnt_range[sim.world.get(hinge).mj_id] = [-7, 7]
    sim.world.model.jnt_limited[sim.world.get(hinge).mj_id] = 1
    alternates = api.getAlternateConfigs([hinge], [0.5])
    assert alternates == pytest.approx([0.5 - 2 * math.pi, 0.5, 0.5 + 2 * math.pi])
    api.saveScene("saved_api32.xml")
    saved = SENSORS.parent / "saved_api32.xml"
    try:
        assert "<mujoco" in saved.read_text()
        again = Simulation(saved, realtime=False)  # it loads back, with the scene's objects
        assert again.world.resolve("blockA").handle > 0
        again.close()
    finally:
        saved.unlink(missing_ok=True)
    with pytest.raises(RemoteError, match="refused"):
        api.saveScene(str(tmp_path / "elsewhere.xml"))
    with pytest.raises(ArgumentError, match=".xml"):
        api.saveScene("scene.ttt")


@pytest.mark.renderers_on_demand  # no image read
def test_entity_colours_lights_and_copies(api, sim):
    a = h(api, "blockA")
    before = api.getShapeColor(a, None, 0)[1]
    saved = api.changeEntityColor(a, [1, 0, 0])
    assert api.getShapeColor(a, None, 0)[1] == pytest.approx([1, 0, 0])
    api.restoreEntityColor(saved)
    assert api.getShapeColor(a, None, 0)[1] == pytest.approx(before)
    lamp = h(api, "lamp")
    api.setLightParameters(lamp, 0, None, [0.2, 0.3, 0.4])
    state, _, diffuse, _ = api.getLightParameters(lamp)
    assert state == 0 and diffuse == pytest.approx([0.2, 0.3, 0.4])
    count = len(sim.world.objects)
    copies = api.copyPasteObjects([h(api, "ball_above")])
    assert len(copies) == 1 and len(sim.world.objects) > count and copies[0] != h(api, "ball_above")


@pytest.mark.renderers_on_demand  # no image read
def test_ruckig_objects_step_to_their_target(api):
    r = api.ruckigPos(1, 0.01, 0, [0, 0, 0], [1, 2, 10], [1], [0.5, 0])
    for _ in range(1000):
        result, state, duration = api.ruckigStep(r, 0.05)
        if result == 1:
            break
    assert result == 1 and state[0] == pytest.approx(0.5) and duration > 0
    api.ruckigRemove(r)
    v = api.ruckigVel(1, 0.01, 0, [0, 0, 0], [2, 10], [1], [0.3])
    result, state, _ = api.ruckigStep(v, 2.0)
    assert result == 1 and state[1] == pytest.approx(0.3)
    with pytest.raises(Exception, match="Ruckig"):
        api.ruckigStep(r, 0.01)


@pytest.mark.renderers_on_demand  # no image read
def test_meshes_and_joint_dependency(api, sim):
    verts = [0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1]
    faces = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]
    s = api.createShape(0, 0, verts, faces)
    assert api.getObjectType(s) == api.object_shape_type
    size = api.getShapeBB(s)  # along the tetrahedron's main axes: x the smallest, z the largest
    assert size == sorted(size) and float(np.prod(size)) <= 0.001 + 1e-9
    api.exportMesh(0, "api32_tetra.obj", 0, 1.0, [verts], [faces])
    out = SENSORS.parent / "api32_tetra.obj"
    try:
        (v,), (f,) = api.importMesh(0, str(out))
        assert sorted(np.round(v, 6).tolist()) == sorted(np.round(verts, 6).tolist()) and len(f) == 12
    finally:
        out.unlink(missing_ok=True)
    two = SENSORS.parent / "api32_two_parts.obj"  # two objects, as RLBench's procedural _coll.obj files
    tetra = "\n".join(f"v {x} {y} {z}" for x, y, z in np.reshape(verts, (-1, 3)))
    shifted = "\n".join(f"v {x + 1} {y} {z}" for x, y, z in np.reshape(verts, (-1, 3)))
    tris = lambda base: "\n".join(f"f {a + base} {b + base} {c + base}" for a, b, c in np.reshape(faces, (-1, 3)))  # noqa: E731
    two.write_text(f"{tetra}\n{shifted}\no first\n{tris(1)}\no second\n{tris(5)}\n")
    try:
        vs, fs = api.importMesh(0, str(two))  # one mesh per object, each with its own vertices
        assert len(vs) == 2 and [len(f) for f in fs] == [12, 12]
        assert sorted(np.round(vs[0], 6).tolist()) == sorted(np.round(verts, 6).tolist())
        assert np.reshape(vs[1], (-1, 3))[:, 0].min() == pytest.approx(1.0)
        shape = api.importShape(0, str(two), 0, 0.0, 1.0)  # one shape of two meshes
        m = sim.world.model
        geoms = np.flatnonzero(m.geom_bodyid == sim.world.objects[shape].mj_id)
        assert [int(m.mesh_facenum[m.geom_dataid[g]]) for g in geoms] == [4, 4]
    finally:
        two.unlink(missing_ok=True)
    hinge, slide = h(api, "hinge"), h(api, "target_x")
    api.setJointDependency(slide, hinge, 0.1, 0.5)
    assert api.getJointDependency(slide) == (hinge, pytest.approx(0.1), pytest.approx(0.5))
    api.setJointDependency(slide, -1, 0, 1)
    assert api.getJointDependency(slide) == (-1, 0.0, 1.0)


@pytest.mark.renderers_on_demand  # no image read
def test_move_to_config_in_steps(api, sim):
    j = h(api, "target_x")
    data = api.moveToConfig_init({"joints": [j], "targetPos": [0.2], "maxVel": [0.5], "maxAccel": [2],
                                  "maxJerk": [20]})
    for n in range(200):
        result, data = api.moveToConfig_step(data)
        if result == 1:
            break
    assert result == 1 and data["pos"] == pytest.approx([0.2]) and n > 5
    assert api.getJointTargetPosition(j) == pytest.approx(0.2)
    api.moveToConfig_cleanup(data)


@pytest.mark.renderers_on_demand  # no image read
def test_scale_object(api):
    a = h(api, "blockA")
    mass = api.getShapeMass(a)
    api.scaleObject(a, 2, 1, 0.5)
    assert api.getShapeBB(a) == pytest.approx([0.4, 0.2, 0.1])
    assert api.getShapeMass(a) == pytest.approx(mass)  # 2 x 1 x 0.5: the same volume
    with pytest.raises(UnsupportedError, match="cannot be scaled"):
        api.scaleObject(h(api, "ball_above"), 2, 1, 1)  # a sphere scales evenly only
