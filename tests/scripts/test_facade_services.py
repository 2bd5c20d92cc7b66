"""CoppeliaSim 4.x's image files, object queries and services of the one ``sim`` facade (issue 32):
saveImage / loadImage, getObjectAliasRelative, getModelBB, joints' child poses,
removeReferencedObjects, createPureShape, getThreadId."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from simx_client.protocol import ArgumentError, RemoteError
import facade_fixtures
from facade_fixtures import SENSORS, running

api = facade_fixtures.api  # the shared fixture (over this module's own sim)


@pytest.fixture
def sim(tmp_path):
    """The scene copied beside the test's files (the calls under test write next to it)."""
    scene = tmp_path / "sensors.xml"
    shutil.copy(SENSORS, scene)
    s = running(scene)
    yield s
    s.stop()
    s.close()


def test_images_round_trip_through_files_and_buffers(api, tmp_path):
    w, h = 4, 3
    img = np.zeros((h, w, 3), np.uint8)
    img[0] = [255, 0, 0]  # the bottom row (buffers are bottom-up) red
    png = api.saveImage(img.tobytes(), [w, h], 0, ".png", -1)
    assert png[:4] == b"\x89PNG"
    back, res = api.loadImage(0, png)
    assert res == [w, h] and back == img.tobytes()
    api.saveImage(img.tobytes(), [w, h], 0, "shot.png", -1)
    import cv2  # noqa: PLC0415
    on_disk = cv2.imread(str(tmp_path / "shot.png"))
    assert on_disk[-1, 0].tolist() == [0, 0, 255]  # the file is top-down, BGR: red at the bottom
    rgba, res = api.loadImage(1, "shot.png")
    assert len(rgba) == w * h * 4 and rgba[:4] == b"\xff\x00\x00\xff"
    with pytest.raises(ArgumentError, match="4x3x3"):
        api.saveImage(b"\x00" * 5, [w, h], 0, ".png", -1)
    with pytest.raises(RemoteError, match="refused"):
        api.saveImage(img.tobytes(), [w, h], 0, "/tmp/../etc/x.png", -1)
    with pytest.raises(ArgumentError, match="image file name"):
        api.loadImage(0, "scene.xml")


@pytest.mark.renderers_on_demand  # no image read
def test_alias_relative_model_bb_and_pure_shapes(api):
    payload, mount = api.getObject("/mount/payload"), api.getObject("/mount")
    assert api.getObjectAliasRelative(payload, mount) == "./payload"
    assert api.getObjectAliasRelative(payload, api.getObject("/blockA")) == "/mount/payload"
    assert api.getObjectAliasRelative(mount, mount) == "."
    # mount: a 0.1 m cube at its origin, payload a 0.1 m cube 0.2 below and 0.1 along x
    assert api.getModelBB(mount) == pytest.approx([0.2, 0.1, 0.3])
    s = api.createPureShape(0, 16, [0.1, 0.2, 0.3], 2.5)
    assert api.getShapeBB(s) == pytest.approx([0.1, 0.2, 0.3]) and api.getShapeMass(s) == pytest.approx(2.5)
    # CoppeliaSim 4.1's addPrimitiveShape clears collidable, measurable, detectable and renderable;
    # options bit 3 (8) respondable: off here
    assert api.getObjectSpecialProperty(s) == 0 and api.getObjectInt32Param(s, 3004) == 0
    api.setObjectPosition(s, -1, api.getObjectPosition(mount, -1))  # in the mount
    assert api.checkCollision(mount, api.handle_all)[0] == 0
    r = api.createPureShape(1, 8 | 16, [0.1, 0.1, 0.1], 1.0)
    assert api.getObjectInt32Param(r, 3004) == 1
    api.setObjectSpecialProperty(s, 1)
    assert api.checkCollision(mount, api.handle_all) == (1, [mount, s])
    with pytest.raises(ArgumentError, match="primitiveType"):
        api.createPureShape(9, 0, [0.1, 0.1, 0.1], 1)
    # 4.1 clamps the mass to [1e-6, 1e4] kg (RLBench's wipe_desk makes its dirt with mass 0)
    dirt = api.createPureShape(0, 16, [0.005, 0.005, 0.001], 0)
    assert api.getShapeMass(dirt) == pytest.approx(1e-6)
    assert api.getShapeMass(api.createPureShape(1, 0, [0.1, 0.1, 0.1], 1e9)) == pytest.approx(1e4)


@pytest.mark.renderers_on_demand  # no image read
def test_joint_child_pose_is_its_motion(api, sim):
    hinge, ball = api.getObject("/hinge"), api.getObject("/ball")
    api.setJointPosition(hinge, 0.5)
    pose = api.getObjectChildPose(hinge)
    assert pose == pytest.approx([0, 0, 0, 0, 0, math.sin(0.25), math.cos(0.25)])
    api.setObjectChildPose(hinge, [0, 0, 0, 0, 0, math.sin(-0.3), math.cos(-0.3)])
    assert api.getJointPosition(hinge) == pytest.approx(-0.6)
    q = [0, 0, 0, math.sin(0.2), 0, 0, math.cos(0.2)]  # 0.4 rad about x
    api.setObjectChildPose(ball, q)
    assert api.getObjectChildPose(ball) == pytest.approx(q)
    with pytest.raises(ArgumentError, match="not a joint"):
        api.getObjectChildPose(api.getObject("/blockA"))


@pytest.mark.renderers_on_demand  # no image read
def test_referenced_objects_are_removed(api, sim):
    a, b = api.getObject("/blockA"), api.getObject("/blockB")
    d = api.createDummy(0.01)
    api.setReferencedHandles(a, [b, d], "parts")
    api.removeReferencedObjects(a, "parts")
    assert b not in sim.world.objects and api.getReferencedHandles(a, "parts") == []
    assert isinstance(api.getThreadId(), int)


@pytest.mark.renderers_on_demand  # no image read
def test_move_to_pose_in_steps_places_the_object(api):
    d = api.createDummy(0.01)
    api.setObjectPose(d, [0, 0, 0, 0, 0, 0, 1])
    goal = [0.3, -0.2, 0.1, 0, 0, math.sin(0.5), math.cos(0.5)]  # 1 rad about z
    data = api.moveToPose_init({"object": d, "targetPose": goal, "maxVel": [1, 1, 1, 2], "maxAccel": [2] * 4,
                                "maxJerk": [20] * 4, "timeStep": 0.01})
    res, steps, path = 0, 0, []
    while res == 0 and steps < 2000:
        res, data = api.moveToPose_step(data)
        path.append(api.getObjectPose(d)[:3])
        steps += 1
    api.moveToPose_cleanup(data)
    assert res == 1 and 10 < steps < 2000
    assert api.getObjectPose(d) == pytest.approx(goal, abs=1e-6)
    mid = np.array(path[len(path) // 2])
    assert 0 < mid[0] < 0.3  # on the way, not jumped
    with pytest.raises(ArgumentError, match="targetPose"):
        api.moveToPose_init({"object": d})


def test_property_flags_and_value_conversion(api):
    a, d = api.getObject("/blockA"), api.createDummy(0.01)
    assert api.getObjectSpecialProperty(a) == 1 | 2 | 496 | 512  # V-REP's default for a shape
    # not respondable (contype 0) but collidable all the same: the flags are not MuJoCo's contact bits
    assert api.getObjectSpecialProperty(api.getObject("/target")) == 1 | 2 | 496 | 512
    assert api.getObjectSpecialProperty(d) == 0  # a dummy's default
    api.setObjectSpecialProperty(a, api.objectspecialproperty_detectable_all | api.objectspecialproperty_renderable)
    assert api.getObjectSpecialProperty(a) == 496 | 512
    geom = int(api.context.world.model.body("blockA").geomadr[0])
    assert api.context.world.model.geom_contype[geom] == 1  # it still collides physically (respondable)
    assert api.getObjectProperty(a) == api.objectproperty_selectable
    api.setObjectProperty(a, api.objectproperty_collapsed)
    assert api.getObjectProperty(a) == api.objectproperty_collapsed
    assert api.getModelProperty(a) == api.modelproperty_not_model
    api.setModelProperty(a, api.modelproperty_not_visible)
    assert api.getModelProperty(a) == api.modelproperty_not_visible
    conv = api.convertPropertyValue
    assert conv(3.7, api.propertytype_float, api.propertytype_int) == 3
    assert conv("hé", api.propertytype_string, api.propertytype_buffer) == "hé".encode()
    q = [0, 0, math.sin(0.5), math.cos(0.5)]
    m = conv(q, api.propertytype_quaternion, api.propertytype_matrix3x3)
    assert m[:2] == pytest.approx([math.cos(1), -math.sin(1)])
    assert conv(m, api.propertytype_matrix3x3, api.propertytype_quaternion) == pytest.approx(q)
    m4 = conv([1, 2, 3, *q], api.propertytype_pose, api.propertytype_matrix4x4)
    assert m4[3] == 1 and m4[7] == 2 and m4[12:] == [0, 0, 0, 1]
    assert conv([1, 2, 3], api.propertytype_vector3, api.propertytype_floatarray) == [1, 2, 3]
    with pytest.raises(ArgumentError, match="holds 3 numbers"):
        conv([1, 2], api.propertytype_floatarray, api.propertytype_vector3)
    with pytest.raises(ArgumentError, match="no conversion"):
        conv("x", api.propertytype_string, api.propertytype_pose)


def test_sensors_created_at_run_time_see_and_detect(api, sim):
    a = api.getObject("/blockA")  # a 0.2 m cube at (0, 2, 0.5)
    cam = api.createVisionSensor(1, [32, 24, 0, 0], [0.01, 5, math.radians(60), 0.1, 0.1, 0.1, 0, 0, 0, 0, 0])
    assert api.getObjectType(cam) == api.object_visionsensor_type
    assert api.getVisionSensorRes(cam) == [32, 24]
    assert api.getObjectMatrix(cam, -1) == pytest.approx([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0], abs=1e-9)
    api.setObjectPosition(cam, -1, [0, 2, 0.0])  # under the cube, looking up (+z) at it
    img, res = api.getVisionSensorImg(cam)
    px = np.frombuffer(img, np.uint8).reshape(24, 32, 3)[12, 16]
    assert res == [32, 24] and px[1] > 150 and px[0] < 100  # blockA is green
    prox = api.createProximitySensor(api.proximitysensor_ray, 0, 0, [0] * 8, [0, 2] + [0] * 13)
    assert api.getObjectType(prox) == api.object_proximitysensor_type
    api.setObjectPosition(prox, -1, [0, 2, 0.0])
    res, dist, _, hit, _ = api.readProximitySensor(prox)
    assert (res, hit) == (1, a) and dist == pytest.approx(0.4, abs=1e-6)
    cone = api.createProximitySensor(api.proximitysensor_cone, 0, 0, [0] * 8, [0, 2] + [0] * 7 + [0.5] + [0] * 5)
    api.setObjectPosition(cone, -1, [0.15, 2, 0.0])  # beside the cube: only the cone's slanted rays reach it
    assert api.readProximitySensor(cone)[0] == 1
    with pytest.raises(Exception, match="ray .34. and cone"):
        api.createProximitySensor(api.proximitysensor_pyramid, 0, 0, [0] * 8, [0, 2] + [0] * 13)
    with pytest.raises(ArgumentError, match="near clipping"):
        api.createVisionSensor(1, [32, 24, 0, 0], [5, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0])


@pytest.mark.renderers_on_demand  # no image read
def test_time_optimal_trajectory_is_bang_bang_on_a_line(api):
    path, lengths = [0.0, 0.25, 0.5, 0.75, 1.0], [0.0, 0.25, 0.5, 0.75, 1.0]
    pts, times = api.generateTimeOptimalTrajectory(path, lengths, [-0.5, 0.5], [-1, 1], 1000)
    assert len(pts) == len(times) == 1000 and pts[0] == 0 and pts[-1] == pytest.approx(1)
    # accelerate 0.5 s to 0.5 m/s, cruise 0.75 m, brake 0.5 s: 2.5 s
    assert times[-1] == pytest.approx(2.5, rel=0.01)
    speed = np.diff(pts) / np.diff(times)
    assert speed.max() <= 0.5 * 1.01
    # two joints: the slower one sets the pace
    pts2, t2 = api.generateTimeOptimalTrajectory([0, 0, 1, 2], [0, 1], [-1, 1, -1, 1], [-10, 10, -10, 10], 500)
    assert t2[-1] > 2.0 and np.array(pts2).reshape(-1, 2)[-1] == pytest.approx([1, 2])
    with pytest.raises(ArgumentError, match="negative"):
        api.generateTimeOptimalTrajectory(path, lengths, [0.5, 0.5], [-1, 1])
    with pytest.raises(ArgumentError, match="increase"):
        api.generateTimeOptimalTrajectory([0, 0], [0, 0], [-1, 1], [-1, 1])


def test_proximity_check_with_threshold_and_angle(api):
    a = api.getObject("/blockA")  # a 0.2 m cube at (0, 2, 0.5)
    prox = api.createProximitySensor(api.proximitysensor_ray, 0, 0, [0] * 8, [0, 2] + [0] * 13)
    api.setObjectPosition(prox, -1, [0, 2, 0.0])  # 0.4 m under the cube, looking up at its face
    res, dist, _, hit, normal = api.checkProximitySensorEx(prox, api.handle_all, 1, 1.0, 0)
    assert (res, hit) == (1, a) and dist == pytest.approx(0.4, abs=1e-6)
    assert api.checkProximitySensorEx(prox, a, 1, 0.3, 0)[0] == 0  # beyond the threshold
    api.setObjectOrientation(prox, -1, [0.2, 0, 0])  # tilted 0.2 rad: the face is seen at 0.2 rad
    assert api.checkProximitySensorEx(prox, a, 1 | 8, 1.0, 0.3)[0] == 1
    assert api.checkProximitySensorEx(prox, a, 1 | 8, 1.0, 0.1)[0] == 0
    assert api.checkProximitySensorEx(prox, a, 1, 1.0, 0.1)[0] == 1  # bit 3 off: no angle limit
    with pytest.raises(Exception, match="front faces"):
        api.checkProximitySensorEx(prox, a, 2, 1.0, 0)


def test_scripts_share_the_remote_programs_object_calls(api, sim):
    hinge, mount = api.getObject("/hinge"), api.getObject("/mount")
    assert api.getJointType(hinge) == api.joint_revolute_subtype
    assert api.getJointType(api.getObject("/target_x")) == api.joint_prismatic_subtype
    assert api.getObjectChild(mount, 0) == api.getObject("/mount/payload") and api.getObjectChild(mount, 5) == -1
    assert api.isHandle(mount) and not api.isHandle(987654)
    api.setJointTargetVelocity(hinge, 0.0)
    assert api.getJointVelocity(hinge) == pytest.approx(0.0, abs=1e-9)
    cam = api.createVisionSensor(1, [8, 6, 0, 0], [0.01, 5, 1.0, 0, 0, 0, 0, 0, 0, 0, 0])
    depth, res = api.getVisionSensorDepth(cam)
    assert res == [8, 6] and len(depth) == 8 * 6 * 4
    b = api.getObject("/blockB")
    api.removeObjects([b])
    assert not api.isHandle(b)
