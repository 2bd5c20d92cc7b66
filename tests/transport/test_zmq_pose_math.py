"""CoppeliaSim's pose arithmetic over ZMQ (simx_server.api.sim.posemath), in-process: layouts of
matrices (12 numbers, row by row) and poses (x y z qx qy qz qw), and rotateAroundAxis."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simx_client.protocol import ArgumentError
from simx_server.api import CallContext, Callers

m = CallContext(None, -1, caller=Callers.CLIENTS).sim  # no scene: the arithmetic needs none


def test_pose_and_matrix_round_trip():
    pose = m.buildPose([0.1, 0.2, 0.3], [0.3, -0.2, 0.5])
    matrix = m.buildMatrix([0.1, 0.2, 0.3], [0.3, -0.2, 0.5])
    assert np.allclose(m.poseToMatrix(pose), matrix)
    assert np.allclose(m.matrixToPose(matrix), pose)
    assert np.allclose(m.getEulerAnglesFromMatrix(matrix), [0.3, -0.2, 0.5])
    assert np.allclose(m.multiplyPoses(pose, m.getPoseInverse(pose)), [0, 0, 0, 0, 0, 0, 1], atol=1e-12)
    assert np.allclose(m.multiplyMatrices(matrix, m.getMatrixInverse(matrix)), m.buildIdentityMatrix(), atol=1e-12)


def test_rotate_around_axis_keeps_the_layout():
    pose = [1.0, 0.0, 0.5, 0, 0, 0, 1]
    turned = m.rotateAroundAxis(pose, [0, 0, 1], [0, 0, 0], math.pi / 2)
    assert len(turned) == 7 and np.allclose(turned[:3], [0, 1, 0.5])
    assert np.allclose(turned[3:], [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    matrix = m.rotateAroundAxis(m.poseToMatrix(pose), [1, 0, 0], [1, 0, 0], math.pi)
    assert len(matrix) == 12 and np.allclose(np.array(matrix)[[3, 7, 11]], [1, 0, -0.5])


def test_interpolation_and_vectors():
    a, b = [0, 0, 0, 0, 0, 0, 1], [2, 0, 0, 0, 0, 1, 0]
    mid = m.interpolatePoses(a, b, 0.5)
    assert np.allclose(mid, [1, 0, 0, 0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    assert np.allclose(m.multiplyVector(b, [1, 0, 0, 0, 1, 0]), [1, 0, 0, 2, -1, 0])


def test_bad_shapes_are_argument_errors():
    for call in (lambda: m.poseToMatrix([1, 2, 3]), lambda: m.rotateAroundAxis([0] * 5, [0, 0, 1], [0, 0, 0], 1),
                 lambda: m.rotateAroundAxis([0] * 7, [0, 0, 0], [0, 0, 0], 1),
                 lambda: m.multiplyVector([0, 0, 0, 0, 0, 0, 1], [1, 2])):
        with pytest.raises(ArgumentError):
            call()


def test_the_4_4_quaternion_matrix_calls_round_trip():
    """``buildMatrixQ`` / ``getQuaternionFromMatrix`` (CoppeliaSim 4.0-4.4's, which the 4.4 ZMQ
    client's own ``moveToPose`` calls) agree with the pose layout."""
    pose = m.buildPose([0.1, 0.2, 0.3], [0.3, -0.2, 0.5])
    matrix = m.buildMatrixQ(pose[:3], pose[3:])
    assert np.allclose(matrix, m.poseToMatrix(pose))
    assert m.buildMatrixQ(pose, pose[3:]) == matrix  # the 4.4 client passes the whole pose as position
    q = m.getQuaternionFromMatrix(matrix)
    assert np.allclose(q, pose[3:]) or np.allclose(q, -np.asarray(pose[3:]))
    with pytest.raises(ArgumentError):
        m.buildMatrixQ([0, 0, 0], [0, 0, 0, 0])
