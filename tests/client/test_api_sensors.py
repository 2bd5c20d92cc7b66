"""Sensors, collision/distance, group data and parameters through a real server: legacy return
shapes and types, success and failure paths (the in-process details are in test_sensors.py)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

import vrep
from conftest import ROOT, ServerProcess

B = vrep.simx_opmode_blocking
SCENE = ROOT / "tests" / "scenes" / "sensors.xml"


@pytest.fixture(scope="module")
def cid():
    srv = ServerProcess(str(SCENE), "--speed", "0", "--stopped")
    client = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    assert client >= 0
    yield client
    vrep.simxFinish(client)
    srv.stop()


def h(cid: int, name: str) -> int:
    rc, handle = vrep.simxGetObjectHandle(cid, name, B)
    assert rc == 0, name
    return handle


def test_object_types(cid):
    assert h(cid, "prox") in vrep.simxGetObjects(cid, vrep.sim_object_proximitysensor_type, B)[1]
    assert h(cid, "ft") in vrep.simxGetObjects(cid, vrep.sim_object_forcesensor_type, B)[1]
    assert h(cid, "cam") in vrep.simxGetObjects(cid, vrep.sim_object_visionsensor_type, B)[1]


def test_proximity_sensor(cid):
    rc, state, point, detected, normal = vrep.simxReadProximitySensor(cid, h(cid, "prox"), B)
    assert rc == 0 and state is True and detected == h(cid, "target")
    assert len(point) == 3 and len(normal) == 3 and all(isinstance(v, float) for v in point + normal)
    assert point[2] == pytest.approx(0.9, abs=0.06)  # 1 m ahead, box half-size 0.1 (turned 30 deg)
    assert vrep.simxReadProximitySensor(cid, h(cid, "ft"), B) == (8, False, [0.0] * 3, 0, [0.0] * 3)


def test_force_sensor(cid):
    vrep.simxStartSimulation(cid, B)
    try:
        vrep.simxGetPingTime(cid)
        rc, state, force, torque = vrep.simxReadForceSensor(cid, h(cid, "ft"), B)
        assert rc == 0 and state & 1 and len(force) == 3 and len(torque) == 3
        assert abs(force[2]) == pytest.approx(2 * 9.81, rel=0.05)
        assert vrep.simxBreakForceSensor(cid, h(cid, "ft"), B) == 0
        rc, state, force, _ = vrep.simxReadForceSensor(cid, h(cid, "ft"), B)
        assert rc == 0 and state & 2 and force == [0.0, 0.0, 0.0]
    finally:
        vrep.simxStopSimulation(cid, B)
    assert vrep.simxReadForceSensor(cid, h(cid, "prox"), B)[0] == 8


def test_collision_and_distance(cid):
    rc, touching = vrep.simxGetCollisionHandle(cid, "touching", B)
    assert rc == 0 and touching > 0
    assert vrep.simxReadCollision(cid, touching, B) == (0, True)
    assert vrep.simxReadCollision(cid, vrep.simxGetCollisionHandle(cid, "apart", B)[1], B) == (0, False)
    rc, gap = vrep.simxGetDistanceHandle(cid, "gapAB", B)
    assert vrep.simxReadDistance(cid, gap, B) == (0, pytest.approx(0.05, abs=1e-3))
    a, b_ = h(cid, "blockA"), h(cid, "blockB")
    assert vrep.simxCheckCollision(cid, a, b_, B) == (0, False)
    assert vrep.simxCheckCollision(cid, a, h(cid, "blockC"), B) == (0, True)
    assert vrep.simxCheckDistance(cid, a, b_, B) == (0, pytest.approx(0.05, abs=1e-3))
    assert vrep.simxGetCollisionHandle(cid, "nope", B) == (8, 0)
    assert vrep.simxReadDistance(cid, 999, B) == (8, 0.0)


def test_joint_matrix_and_spherical_joint(cid):
    rc, matrix = vrep.simxGetJointMatrix(cid, h(cid, "ball"), B)
    assert rc == 0 and len(matrix) == 12
    turned = [0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]  # 90 deg about z
    assert vrep.simxSetSphericalJointMatrix(cid, h(cid, "ball"), turned, B) == 0
    assert vrep.simxGetJointMatrix(cid, h(cid, "ball"), B)[1] == pytest.approx(turned, abs=1e-5)
    assert vrep.simxSetSphericalJointMatrix(cid, h(cid, "hinge"), turned, B) == 8
    assert vrep.simxGetJointPosition(cid, h(cid, "ball"), B) == (8, 0.0)


def test_vision_sensor_read_set_and_parameters(cid):
    cam, passive = h(cid, "cam"), h(cid, "passive")
    rc, detected, packets = vrep.simxReadVisionSensor(cid, cam, B)
    assert rc == 0 and detected is False and len(packets) == 1 and len(packets[0]) == 15
    assert vrep.simxGetObjectIntParameter(cid, cam, vrep.sim_visionintparam_resolution_x, B) == (0, 32)
    assert vrep.simxGetObjectInt32Param(cid, cam, vrep.sim_visionintparam_resolution_y, B) == (0, 24)
    rc, near = vrep.simxGetObjectFloatParameter(cid, cam, vrep.sim_visionfloatparam_near_clipping, B)
    assert rc == 0 and near > 0
    image = [10, 20, 30] * (8 * 6)
    assert vrep.simxSetVisionSensorImage(cid, passive, image, 0, B) == 0
    assert vrep.simxGetVisionSensorImage(cid, passive, 0, B) == (0, [8, 6], image)
    assert vrep.simxSetVisionSensorImage(cid, passive, image[:-1], 0, B) == 8
    assert vrep.simxSetVisionSensorImage(cid, cam, [0] * (32 * 24 * 3), 0, B) == 8  # not passive


def test_vision_sensor_resolution_set_at_run_time(cid):
    """V-REP let a program set a sensor's resolution (1002/1003): the next image has the new
    size and shows the same view (the angle spans the larger side); bad sizes are refused;
    many sizes in turn keep working (GL contexts bounded); a stop restores the MJCF's."""
    cam = h(cid, "cam")
    rx, ry = vrep.sim_visionintparam_resolution_x, vrep.sim_visionintparam_resolution_y
    rc, res, full = vrep.simxGetVisionSensorImage(cid, cam, 0, B)
    assert rc == 0 and res == [32, 24]
    assert vrep.simxSetObjectIntParameter(cid, cam, rx, 64, B) == 0
    assert vrep.simxSetObjectIntParameter(cid, cam, ry, 48, B) == 0
    assert vrep.simxGetObjectIntParameter(cid, cam, rx, B) == (0, 64)
    assert vrep.simxGetObjectIntParameter(cid, cam, ry, B) == (0, 48)
    rc, res, big = vrep.simxGetVisionSensorImage(cid, cam, 0, B)
    assert rc == 0 and res == [64, 48] and len(big) == 64 * 48 * 3
    small = np.array(full, dtype=np.uint8).reshape(24, 32, 3).astype(float)
    halved = cv2.resize(np.array(big, dtype=np.uint8).reshape(48, 64, 3), (32, 24), interpolation=cv2.INTER_AREA)
    assert small.std() > 5 and np.abs(halved - small).mean() < 0.05 * small.std()  # the same view (mirrored: 0.08 std)
    rc, dres, depth = vrep.simxGetVisionSensorDepthBuffer(cid, cam, B)
    assert rc == 0 and dres == [64, 48] and len(depth) == 64 * 48
    for bad in (0, -3, 5000):
        assert vrep.simxSetObjectIntParameter(cid, cam, rx, bad, B) == 8
    assert vrep.simxGetObjectIntParameter(cid, cam, rx, B) == (0, 64)
    for side in range(8, 8 + 2 * 12, 2):  # more sizes than limits.MAX_RENDERERS
        assert vrep.simxSetObjectIntParameter(cid, cam, rx, side, B) == 0
        rc, res, img = vrep.simxGetVisionSensorImage(cid, cam, 1, B)
        assert rc == 0 and res == [side, 48] and len(img) == side * 48
    assert vrep.simxSetObjectIntParameter(cid, h(cid, "hinge"), rx, 64, B) == 8  # not a sensor
    assert vrep.simxStartSimulation(cid, B) == 0  # (a stop of a stopped simulation changes nothing)
    assert vrep.simxStopSimulation(cid, B) == 0
    assert vrep.simxGetObjectIntParameter(cid, cam, rx, B) == (0, 32)
    rc, res, again = vrep.simxGetVisionSensorImage(cid, cam, 0, B)
    assert rc == 0 and res == [32, 24] and len(again) == len(full)


def test_group_data_and_velocity(cid):
    rc, handles, ints, floats, strings = vrep.simxGetObjectGroupData(cid, vrep.sim_handle_all, 0, B)
    assert rc == 0 and len(handles) == len(strings) and "prox" in strings and ints == [] and floats == []
    rc, handles, ints, floats, strings = vrep.simxGetObjectGroupData(cid, vrep.sim_object_joint_type, 3, B)
    assert rc == 0 and len(floats) == 3 * len(handles)
    assert vrep.simxGetObjectGroupData(cid, vrep.sim_handle_all, 99, B) == (8, [], [], [], [])
    rc, linear, angular = vrep.simxGetObjectVelocity(cid, h(cid, "faller"), B)
    assert rc == 0 and len(linear) == 3 and len(angular) == 3
