"""The tutorial's eye-in-hand view: at the DDPG start pose the Kinect sees the ball where it should.

The tutorial (see ``../shared/legacy/README.md``) drives the UR5 to
``[90, -45, 90, 0, -100, 0]`` degrees with ``rotateAllAngle`` (target positions sent in one
paused batch) and expects the red ball ``Sphere`` in ``kinect_rgb``'s image.  These tests do
the same with ``import vrep`` against a real server and check that

* the ball is a clear red blob in the RGB image, and its centroid lies where the pinhole
  model of the sensor (640x480, 57 degrees horizontal field of view) projects the ball's
  position as the server reports it in the sensor's frame (V-REP convention: the sensor looks
  along +z, y is up and x points left in the image; image rows arrive bottom-up).  Done at
  the tutorial pose (ball near the centre, below it) and with joint 1 turned 6 degrees more
  (ball well right of the centre), this cross-checks the sensor pose, the image's row order
  and its left/right orientation together;
* ``kinect_depth``'s depth buffer at the ball's pixel, scaled by near/far, is the distance
  to the ball's surface along the view axis.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import vrep

try:
    from conftest import SCENE, wait_until
except ImportError:  # tests/ imported as a package
    from tests.conftest import SCENE, wait_until

B = vrep.simx_opmode_blocking
ONESHOT = vrep.simx_opmode_oneshot
JOINTS = [f"UR5_joint{i}" for i in range(1, 7)]
TUTORIAL_POSE = [90, -45, 90, 0, -100, 0]  # degrees
ZERO_POSE = [0, 0, 0, 0, 0, 0]
RES_X, RES_Y = 640, 480
FOV_X = math.radians(57.0)  # Kinect's horizontal field of view
FOCAL = (RES_X / 2) / math.tan(FOV_X / 2)  # pixels (square pixels)
NEAR, FAR = 0.01, 3.5  # m, kinect_depth's clipping planes
TOLERANCE_PX = 25
DEPTH_TOLERANCE_M = 0.03
MIN_BLOB_PX = 200


def _ball_radius() -> float:
    """Radius of the ball's geom in the scene (m); the scene is still being tuned."""
    geom = ET.parse(SCENE).getroot().find(".//body[@name='Sphere']/geom")
    assert geom is not None and geom.get("type") == "sphere", "scene has no sphere geom in body 'Sphere'"
    return float(geom.get("size").split()[0])


def handle(cid: int, name: str) -> int:
    rc, h = vrep.simxGetObjectHandle(cid, name, B)
    assert rc == 0, f"simxGetObjectHandle({name!r}): rc {rc}"
    return h


def joint_positions(cid: int, handles: list[int]) -> list[float]:
    out = []
    for h in handles:
        rc, q = vrep.simxGetJointPosition(cid, h, B)
        assert rc == 0, f"simxGetJointPosition: rc {rc}"
        out.append(q)
    return out


def rotate_all_angle(cid: int, handles: list[int], degrees: list[float], timeout: float = 60.0) -> None:
    """The tutorial's rotateAllAngle, then wait until every joint is within 0.1 deg of its target
    (settled: the motors hold their targets under gravity; at 0.5 deg the arm is still creeping in
    and an image taken then is a few pixels behind)."""
    targets = [math.radians(a) for a in degrees]
    vrep.simxPauseCommunication(cid, True)
    for h, t in zip(handles, targets):
        vrep.simxSetJointTargetPosition(cid, h, t, ONESHOT)
    vrep.simxPauseCommunication(cid, False)
    def reached() -> bool:
        return all(abs(a - t) <= math.radians(0.1) for a, t in zip(joint_positions(cid, handles), targets))

    wait_until(reached, timeout, 0.05, lambda: f"arm at {degrees} deg (it is at "
               f"{[round(math.degrees(a), 2) for a in joint_positions(cid, handles)]} deg)")


def rgb_image(cid: int, sensor: int) -> np.ndarray:
    """kinect_rgb as the tutorial converts it: (480, 640, 3) uint8 RGB, rows top-down."""
    rc, res, raw = vrep.simxGetVisionSensorImage(cid, sensor, 0, B)
    assert rc == 0, f"simxGetVisionSensorImage: rc {rc}"
    assert list(res) == [RES_X, RES_Y]
    img = np.array(raw).astype(np.uint8)  # legacy signed bytes -> 0..255
    return img.reshape(RES_Y, RES_X, 3)[::-1]  # V-REP rows are bottom-up


def red_blob(img: np.ndarray) -> tuple[int, float, float]:
    """(pixel count, centroid column, centroid row) of the saturated red pixels."""
    r, g, b = (img[:, :, i].astype(int) for i in range(3))
    mask = (r > 150) & (g < 80) & (b < 80)
    rows, cols = np.nonzero(mask)
    if len(rows) == 0:
        return 0, math.nan, math.nan
    return len(rows), float(cols.mean()), float(rows.mean())


def project(p_sensor: list[float]) -> tuple[float, float]:
    """Pinhole projection of a point in V-REP sensor coordinates to (column, row), rows top-down.

    The sensor looks along +z; +y is up in the image and +x points left.
    """
    x, y, z = p_sensor
    assert z > 0, f"point behind the sensor: {p_sensor}"
    return RES_X / 2 - FOCAL * x / z, RES_Y / 2 - FOCAL * y / z


def quat_rotate(q_xyzw: list[float], v: np.ndarray) -> np.ndarray:
    """Rotate ``v`` by a V-REP quaternion (x, y, z, w)."""
    x, y, z, w = q_xyzw
    u = np.array([x, y, z])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


@pytest.fixture
def arm(vrep_client):
    """(client id, joint handles); the arm goes back to zero after the test, whatever happens."""
    handles = [handle(vrep_client, n) for n in JOINTS]
    yield vrep_client, handles
    rotate_all_angle(vrep_client, handles, ZERO_POSE)


def check_ball_projection(cid: int, sensor: int, sphere: int, where: str) -> tuple[float, float]:
    img = rgb_image(cid, sensor)
    n, col, row = red_blob(img)
    assert n >= MIN_BLOB_PX, f"{where}: red ball not in kinect_rgb's view ({n} red pixels)"
    rc, p = vrep.simxGetObjectPosition(cid, sphere, sensor, B)
    assert rc == 0
    u, v = project(p)
    assert math.hypot(col - u, row - v) <= TOLERANCE_PX, (
        f"{where}: ball centroid at (col {col:.1f}, row {row:.1f}) but the sensor model projects "
        f"the Sphere (sensor frame {np.round(p, 4).tolist()}) to (col {u:.1f}, row {v:.1f})")
    return col, row


def test_ball_seen_where_the_camera_model_projects_it(arm):
    cid, joints = arm
    sensor, sphere = handle(cid, "kinect_rgb"), handle(cid, "Sphere")

    rotate_all_angle(cid, joints, TUTORIAL_POSE)
    col, row = check_ball_projection(cid, sensor, sphere, f"pose {TUTORIAL_POSE}")

    # The relative position agrees with the world poses (quaternion order x, y, z, w).
    rc1, p_ball = vrep.simxGetObjectPosition(cid, sphere, -1, B)
    rc2, p_cam = vrep.simxGetObjectPosition(cid, sensor, -1, B)
    rc3, q_cam = vrep.simxGetObjectQuaternion(cid, sensor, -1, B)
    rc4, p_rel = vrep.simxGetObjectPosition(cid, sphere, sensor, B)
    assert (rc1, rc2, rc3, rc4) == (0, 0, 0, 0)
    conj = [-q_cam[0], -q_cam[1], -q_cam[2], q_cam[3]]
    p_from_world = quat_rotate(conj, np.subtract(p_ball, p_cam))
    np.testing.assert_allclose(p_from_world, p_rel, atol=2e-3)
    # At this pose the camera looks down onto the table: the ball is in front, below the axis.
    assert p_rel[2] > 0.3 and quat_rotate(q_cam, np.array([0.0, 0.0, 1.0]))[2] < -0.3

    # Joint 1 six degrees further: the ball moves sideways in the image (catches a mirrored image).
    off_pose = [TUTORIAL_POSE[0] + 6] + TUTORIAL_POSE[1:]
    rotate_all_angle(cid, joints, off_pose)
    col2, _ = check_ball_projection(cid, sensor, sphere, f"pose {off_pose}")
    assert abs(col2 - col) > 2 * TOLERANCE_PX, (
        f"turning joint 1 by 6 deg should move the ball sideways in the image "
        f"(col {col:.1f} -> {col2:.1f})")


def test_depth_at_ball_is_distance_to_its_surface(arm):
    cid, joints = arm
    rgb, depth, sphere = handle(cid, "kinect_rgb"), handle(cid, "kinect_depth"), handle(cid, "Sphere")

    rotate_all_angle(cid, joints, TUTORIAL_POSE)
    n, col, row = red_blob(rgb_image(cid, rgb))
    assert n >= MIN_BLOB_PX, f"red ball not in kinect_rgb's view ({n} red pixels)"

    rc, res, buf = vrep.simxGetVisionSensorDepthBuffer(cid, depth, B)
    assert rc == 0 and list(res) == [RES_X, RES_Y]
    d = np.asarray(buf, dtype=float).reshape(RES_Y, RES_X)
    assert d.min() >= 0.0 and d.max() <= 1.0
    r, c = int(round(row)), int(round(col))
    measured = d[RES_Y - 1 - r, c] * (FAR - NEAR) + NEAR  # buffer rows are bottom-up

    rc, p = vrep.simxGetObjectPosition(cid, sphere, depth, B)
    assert rc == 0
    expected = p[2] - _ball_radius()  # nearest surface point along the view axis
    assert abs(measured - expected) <= DEPTH_TOLERANCE_M, (
        f"depth at the ball's pixel (col {c}, row {r}) is {measured:.3f} m, "
        f"expected {expected:.3f} m (ball centre at z {p[2]:.3f} m in kinect_depth's frame)")
    # The table around the ball is farther than the ball.
    ring = d[RES_Y - 1 - r, [max(c - 60, 0), min(c + 60, RES_X - 1)]] * (FAR - NEAR) + NEAR
    assert (ring > measured + 0.01).all(), f"depth beside the ball {ring} not behind it ({measured:.3f})"
