"""CoppeliaSim 4.x's pose and matrix arithmetic for remote programs (``sim.rotateAroundAxis``,
``sim.poseToMatrix``, ``sim.multiplyPoses`` ...), which child scripts and ZMQ clients call alike.

Pure arithmetic, no scene. CoppeliaSim's layouts: a *matrix* is 12 numbers row by row
``[Xx Yx Zx Px  Xy Yy Zy Py  Xz Yz Zz Pz]`` (rotation columns, then the position, m); a *pose*
is 7 numbers ``[x y z qx qy qz qw]`` (position in m, unit quaternion). Angles in rad. Bad
shapes raise ArgumentError naming the argument.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_number as _num, as_vector as _vector
from simx_server.sim.rotations import euler_from_matrix, matrix_from_euler, matrix_from_quaternion, quaternion_from_matrix


def _frame(value: Any, what: str) -> tuple[np.ndarray, np.ndarray, bool]:
    """``(position, rotation matrix, is_pose)`` of a 7-number pose or a 12-number matrix."""
    n = len(value) if isinstance(value, (list, tuple)) else 0
    if n == 7:
        v = _vector(value, 7, what)
        q = np.array(v[3:])
        norm = np.linalg.norm(q)
        if not norm > 0:
            raise ArgumentError(f"{what}: the quaternion part is zero")
        return np.array(v[:3]), matrix_from_quaternion(*(q / norm)), True
    if n == 12:
        m = np.array(_vector(value, 12, what)).reshape(3, 4)
        return m[:, 3].copy(), m[:, :3].copy(), False
    raise ArgumentError(f"{what} must be a pose (7 numbers: x y z qx qy qz qw) or a matrix (12 numbers)")


def _first(value: Any, n: int) -> Any:
    """The first ``n`` items of a longer list (CoppeliaSim's Lua API reads the numbers it needs
    from a table and ignores the rest); anything else unchanged, for ``as_vector`` to judge."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    return value[:n] if isinstance(value, (list, tuple)) and len(value) > n else value


def _pose(p: np.ndarray, r: np.ndarray) -> list[float]:
    return [float(x) for x in p] + [float(x) for x in quaternion_from_matrix(r)]


def _matrix(p: np.ndarray, r: np.ndarray) -> list[float]:
    return np.hstack([r, np.reshape(p, (3, 1))]).reshape(12).tolist()


def _out(p: np.ndarray, r: np.ndarray, as_pose: bool) -> list[float]:
    return _pose(p, r) if as_pose else _matrix(p, r)


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix of ``angle`` about the unit vector ``axis`` (Rodrigues)."""
    x, y, z = axis
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


# ``sim.*`` pose and matrix arithmetic (CoppeliaSim 4.x names and layouts).

@sim_function("buildIdentityMatrix")
def buildIdentityMatrix(ctx: CallContext) -> list[float]:  # noqa: N802 (CoppeliaSim's names)
    """The identity as a 12-number matrix.

    Returns:
        12 floats, ``[1 0 0 0  0 1 0 0  0 0 1 0]``.
    """
    return _matrix(np.zeros(3), np.eye(3))


@sim_function("buildMatrix")
def buildMatrix(ctx: CallContext, position: Any, eulerAngles: Any) -> list[float]:  # noqa: N802, N803
    """A 12-number matrix from a position (m) and Euler angles alpha, beta, gamma (rad).

    Args:
        position: ``[x, y, z]`` in m.
        eulerAngles: ``[alpha, beta, gamma]`` in rad.

    Returns:
        12 floats, row by row (rotation columns and position).

    Raises:
        ArgumentError: not 3 numbers each.
    """
    return _matrix(np.array(_vector(position, 3, "position")),
                   matrix_from_euler(*_vector(eulerAngles, 3, "eulerAngles")))


@sim_function("buildPose")
def buildPose(ctx: CallContext, position: Any, eulerAnglesOrAxis: Any, mode: Any = 0,  # noqa: N802, N803
              axis2: Any = None) -> list[float]:
    """A 7-number pose from a position (m) and Euler angles (``mode`` 0; the other modes,
    which build the frame from axes, are not implemented and say so).

    Args:
        position: ``[x, y, z]`` in m.
        eulerAnglesOrAxis: ``[alpha, beta, gamma]`` in rad.
        mode: 0.
        axis2: unused (mode 0).

    Returns:
        ``[x, y, z, qx, qy, qz, qw]``.

    Raises:
        ArgumentError: not 3 numbers each.
        UnsupportedError: a mode other than 0.
    """
    if int(_num(mode, "mode")) != 0:
        raise UnsupportedError("sim.buildPose: only mode 0 (Euler angles) is implemented in simx")
    return _pose(np.array(_vector(position, 3, "position")),
                 matrix_from_euler(*_vector(eulerAnglesOrAxis, 3, "eulerAngles")))


@sim_function("poseToMatrix")
def poseToMatrix(ctx: CallContext, pose: Any) -> list[float]:  # noqa: N802
    """The 12-number matrix of a 7-number pose.

    Args:
        pose: ``[x, y, z, qx, qy, qz, qw]`` (m; any non-zero quaternion length).

    Returns:
        12 floats.

    Raises:
        ArgumentError: not 7 numbers, or a zero quaternion.
    """
    p, r, _ = _frame(_vector(pose, 7, "pose"), "pose")
    return _matrix(p, r)


@sim_function("matrixToPose")
def matrixToPose(ctx: CallContext, matrix: Any) -> list[float]:  # noqa: N802
    """The 7-number pose of a 12-number matrix.

    Args:
        matrix: 12 numbers.

    Returns:
        ``[x, y, z, qx, qy, qz, qw]``, unit quaternion.

    Raises:
        ArgumentError: not 12 numbers.
    """
    p, r, _ = _frame(_vector(matrix, 12, "matrix"), "matrix")
    return _pose(p, r)


@sim_function("buildMatrixQ")
def buildMatrixQ(ctx: CallContext, position: Any, quaternion: Any) -> list[float]:  # noqa: N802
    """A 12-number matrix from a position (m) and a quaternion ``[qx, qy, qz, qw]``
    (CoppeliaSim 4.0-4.4's ``sim.buildMatrixQ``, which its 4.4 ZMQ client's ``moveToPose`` calls).

    Args:
        position: ``[x, y, z]`` in m; as CoppeliaSim, a longer table's first 3 numbers (the
            4.4 client passes a whole pose).
        quaternion: ``[qx, qy, qz, qw]`` (the first 4 numbers of a longer table), normalised here.

    Returns:
        12 floats, row by row (rotation columns and position).

    Raises:
        ArgumentError: fewer than 3 and 4 numbers, or a zero quaternion.
    """
    p = np.asarray(_vector(_first(position, 3), 3, "position"), float)
    return _matrix(p, matrix_from_quaternion(*_vector(_first(quaternion, 4), 4, "quaternion")))


@sim_function("getQuaternionFromMatrix")
def getQuaternionFromMatrix(ctx: CallContext, matrix: Any) -> list[float]:  # noqa: N802
    """The rotation of a 12-number matrix as a quaternion ``[qx, qy, qz, qw]``
    (CoppeliaSim 4.0-4.4's ``sim.getQuaternionFromMatrix``).

    Args:
        matrix: 12 numbers.

    Returns:
        ``[qx, qy, qz, qw]``, unit quaternion.

    Raises:
        ArgumentError: not 12 numbers.
    """
    _, r, _ = _frame(_vector(matrix, 12, "matrix"), "matrix")
    return list(quaternion_from_matrix(r))


@sim_function("getEulerAnglesFromMatrix")
def getEulerAnglesFromMatrix(ctx: CallContext, matrix: Any) -> list[float]:  # noqa: N802
    """Euler angles alpha, beta, gamma (rad) of a 12-number matrix's rotation.

    Args:
        matrix: 12 numbers.

    Returns:
        ``[alpha, beta, gamma]`` in rad.

    Raises:
        ArgumentError: not 12 numbers.
    """
    _, r, _ = _frame(_vector(matrix, 12, "matrix"), "matrix")
    return list(euler_from_matrix(r))


@sim_function("multiplyMatrices")
def multiplyMatrices(ctx: CallContext, matrixIn1: Any, matrixIn2: Any) -> list[float]:  # noqa: N802, N803
    """``matrixIn1 * matrixIn2`` (12 numbers each).

    Args:
        matrixIn1: 12 numbers.
        matrixIn2: 12 numbers.

    Returns:
        12 floats.

    Raises:
        ArgumentError: not 12 numbers each.
    """
    p1, r1, _ = _frame(_vector(matrixIn1, 12, "matrixIn1"), "matrixIn1")
    p2, r2, _ = _frame(_vector(matrixIn2, 12, "matrixIn2"), "matrixIn2")
    return _matrix(p1 + r1 @ p2, r1 @ r2)


@sim_function("multiplyPoses")
def multiplyPoses(ctx: CallContext, poseIn1: Any, poseIn2: Any) -> list[float]:  # noqa: N802, N803
    """``poseIn1 * poseIn2`` (7 numbers each).

    Args:
        poseIn1: 7 numbers.
        poseIn2: 7 numbers.

    Returns:
        7 floats.

    Raises:
        ArgumentError: not 7 numbers each, or a zero quaternion.
    """
    p1, r1, _ = _frame(_vector(poseIn1, 7, "poseIn1"), "poseIn1")
    p2, r2, _ = _frame(_vector(poseIn2, 7, "poseIn2"), "poseIn2")
    return _pose(p1 + r1 @ p2, r1 @ r2)


@sim_function("getMatrixInverse")
def getMatrixInverse(ctx: CallContext, matrix: Any) -> list[float]:  # noqa: N802
    """The inverse of a 12-number matrix.

    Args:
        matrix: 12 numbers.

    Returns:
        12 floats.

    Raises:
        ArgumentError: not 12 numbers.
    """
    p, r, _ = _frame(_vector(matrix, 12, "matrix"), "matrix")
    return _matrix(-r.T @ p, r.T)


@sim_function("getPoseInverse")
def getPoseInverse(ctx: CallContext, pose: Any) -> list[float]:  # noqa: N802
    """The inverse of a 7-number pose.

    Args:
        pose: 7 numbers.

    Returns:
        7 floats.

    Raises:
        ArgumentError: not 7 numbers, or a zero quaternion.
    """
    p, r, _ = _frame(_vector(pose, 7, "pose"), "pose")
    return _pose(-r.T @ p, r.T)


@sim_function("interpolatePoses")
def interpolatePoses(ctx: CallContext, poseIn1: Any, poseIn2: Any, interpolFactor: Any) -> list[float]:  # noqa: N802, N803
    """The pose at ``interpolFactor`` (0..1) between two poses: positions linearly, rotations
    by spherical linear interpolation.

    Args:
        poseIn1: 7 numbers.
        poseIn2: 7 numbers.
        interpolFactor: 0 gives ``poseIn1``, 1 ``poseIn2``.

    Returns:
        7 floats.

    Raises:
        ArgumentError: not 7 numbers each, or a zero quaternion.
    """
    t = _num(interpolFactor, "interpolFactor")
    a, b = _vector(poseIn1, 7, "poseIn1"), _vector(poseIn2, 7, "poseIn2")
    q1, q2 = np.array(a[3:]), np.array(b[3:])
    q1, q2 = q1 / np.linalg.norm(q1), q2 / np.linalg.norm(q2)
    if q1 @ q2 < 0:
        q2 = -q2
    dot = min(1.0, float(q1 @ q2))
    theta = math.acos(dot)
    if theta < 1e-9:
        q = q1
    else:
        q = (math.sin((1 - t) * theta) * q1 + math.sin(t * theta) * q2) / math.sin(theta)
    p = (1 - t) * np.array(a[:3]) + t * np.array(b[:3])
    return [float(x) for x in p] + (q / np.linalg.norm(q)).tolist()


@sim_function("multiplyVector")
def multiplyVector(ctx: CallContext, matrixOrPose: Any, inVectors: Any) -> list[float]:  # noqa: N802, N803
    """Points (3 numbers each, one after the other) transformed by a matrix or a pose.

    Args:
        matrixOrPose: 12 or 7 numbers.
        inVectors: 3n numbers (m).

    Returns:
        3n floats (m).

    Raises:
        ArgumentError: not a matrix or pose, or not 3 numbers per point.
    """
    p, r, _ = _frame(matrixOrPose, "matrix")
    n = len(inVectors) if isinstance(inVectors, (list, tuple)) else 0
    if n == 0 or n % 3:
        raise ArgumentError("inVectors must be 3 numbers per point")
    pts = np.array(_vector(inVectors, n, "inVectors")).reshape(-1, 3)
    return (pts @ r.T + p).reshape(-1).tolist()


@sim_function("rotateAroundAxis")
def rotateAroundAxis(ctx: CallContext, matrixOrPose: Any, axis: Any, axisPos: Any, angle: Any) -> list[float]:  # noqa: N802, N803
    """A matrix or pose turned by ``angle`` (rad) about the line through ``axisPos`` (m)
    along ``axis`` (world frame); returns the same layout it was given.

    Args:
        matrixOrPose: 12 or 7 numbers.
        axis: the axis's direction (3 numbers, not zero).
        axisPos: a point of the axis, m.
        angle: rad.

    Returns:
        12 or 7 floats.

    Raises:
        ArgumentError: not a matrix or pose, or a zero axis.
    """
    p, r, as_pose = _frame(matrixOrPose, "matrixIn")
    a = np.array(_vector(axis, 3, "axis"))
    norm = np.linalg.norm(a)
    if not norm > 0:
        raise ArgumentError("axis must not be zero")
    rot = _axis_angle(a / norm, _num(angle, "angle"))
    c = np.array(_vector(axisPos, 3, "axisPos"))
    return _out(rot @ (p - c) + c, rot @ r, as_pose)


