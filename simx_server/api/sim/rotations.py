"""CoppeliaSim 4.x's rotation arithmetic of ``sim`` (``sim.getRotationAxis``,
``sim.interpolateMatrices``, ``sim.yawPitchRollToAlphaBetaGamma`` ...): rotation axes, matrix interpolation,
yaw-pitch-roll and V-REP's Euler angles, quaternion inverse, configuration distance.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.base.arguments import as_number as _num, as_vector as _vector
from simx_wire.protocol import ArgumentError
from simx_server.sim.rotations import matrix_from_euler, rotation_angle


# Rotation axes, interpolation, Euler angle conversions, configuration distance.

@sim_function("getRotationAxis")
def getRotationAxis(ctx: CallContext, matrixStart: Any, matrixGoal: Any) -> tuple[list[float], float]:  # noqa: N802, N803
    """``axis, angle``: the rotation (world axis, rad in [0, pi]) from one 12-number matrix
    (or 7-number pose) to another.

    ``sim.getRotationAxis``.

    Args:
        matrixStart: 12 numbers (3x4 row-major) or a 7-number pose.
        matrixGoal: 12 numbers or a 7-number pose.

    Returns:
        ``(axis, angle)``: 3 floats (unit vector, world frame) and rad.

    Raises:
        ArgumentError: not 12 (or 7) numbers.
    """
    ra, rb = (_rotation(v, n) for v, n in ((matrixStart, "matrixStart"), (matrixGoal, "matrixGoal")))
    r = rb @ ra.T
    angle = rotation_angle(r)
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    n = np.linalg.norm(axis)
    if n < 1e-9:  # 0 or pi: the axis from the symmetric part
        if angle < 1e-9:
            return [0.0, 0.0, 1.0], 0.0
        w, v = np.linalg.eigh((r + np.eye(3)) / 2)
        axis, n = v[:, int(np.argmax(w))], 1.0
    return (axis / n).tolist(), angle


def _rotation(value: Any, what: str) -> np.ndarray:
    if isinstance(value, (list, tuple)) and len(value) == 7:
        x, y, z, w = _vector(value, 7, what)[3:]
        from simx_server.sim.rotations import matrix_from_quaternion
        return np.asarray(matrix_from_quaternion(x, y, z, w))
    return np.array(_vector(value, 12, what)).reshape(3, 4)[:, :3]


@sim_function("interpolateMatrices")
def interpolateMatrices(ctx: CallContext, matrixIn1: Any, matrixIn2: Any, interpolFactor: Any) -> list[float]:  # noqa: N802, N803
    """The matrix ``interpolFactor`` (0..1) of the way: positions linear, rotation along the
    shortest arc (12 numbers).

    ``sim.interpolateMatrices``.

    Args:
        matrixIn1: 12 numbers (3x4 row-major, m).
        matrixIn2: 12 numbers.
        interpolFactor: 0..1 (not clamped).

    Returns:
        12 floats.

    Raises:
        ArgumentError: not 12 numbers, or a factor that is not a number.
    """
    a = np.array(_vector(matrixIn1, 12, "matrixIn1")).reshape(3, 4)
    b = np.array(_vector(matrixIn2, 12, "matrixIn2")).reshape(3, 4)
    t = _num(interpolFactor, "interpolFactor")
    axis, angle = getRotationAxis(ctx, matrixIn1, matrixIn2)
    k = np.array(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    th = t * angle
    rot = np.eye(3) + math.sin(th) * kx + (1 - math.cos(th)) * kx @ kx
    out = np.hstack([rot @ a[:, :3], (a[:, 3] + t * (b[:, 3] - a[:, 3])).reshape(3, 1)])
    return out.reshape(12).tolist()


@sim_function("yawPitchRollToAlphaBetaGamma")
def yawPitchRollToAlphaBetaGamma(ctx: CallContext, yawAngle: Any, pitchAngle: Any, rollAngle: Any) -> tuple[float, float, float]:  # noqa: N802, N803
    """CoppeliaSim's conversion: R = Rz(yaw) Ry(pitch) Rx(roll) as Euler angles alpha, beta,
    gamma (R = Rx(alpha) Ry(beta) Rz(gamma)), rad.

    ``sim.yawPitchRollToAlphaBetaGamma``.

    Args:
        yawAngle: rad.
        pitchAngle: rad.
        rollAngle: rad.

    Returns:
        ``(alpha, beta, gamma)``, rad.

    Raises:
        ArgumentError: not numbers.
    """
    y, p, r = (_num(v, n) for v, n in ((yawAngle, "yawAngle"), (pitchAngle, "pitchAngle"), (rollAngle, "rollAngle")))
    rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    return _euler_xyz(rz @ ry @ rx)


@sim_function("alphaBetaGammaToYawPitchRoll")
def alphaBetaGammaToYawPitchRoll(ctx: CallContext, alphaAngle: Any, betaAngle: Any, gammaAngle: Any) -> tuple[float, float, float]:  # noqa: N802, N803
    """The inverse of :func:`yawPitchRollToAlphaBetaGamma` (rad).

    ``sim.alphaBetaGammaToYawPitchRoll``.

    Args:
        alphaAngle: rad.
        betaAngle: rad.
        gammaAngle: rad.

    Returns:
        ``(yaw, pitch, roll)``, rad.

    Raises:
        ArgumentError: not numbers.
    """
    r = np.asarray(matrix_from_euler(*(_num(v, n) for v, n in ((alphaAngle, "alphaAngle"), (betaAngle, "betaAngle"),
                                                                 (gammaAngle, "gammaAngle")))))
    pitch = math.asin(max(-1.0, min(1.0, -r[2, 0])))
    if abs(r[2, 0]) < 1 - 1e-12:
        return math.atan2(r[1, 0], r[0, 0]), pitch, math.atan2(r[2, 1], r[2, 2])
    return math.atan2(-r[0, 1], r[1, 1]), pitch, 0.0


@sim_function("getQuaternionInverse")
def getQuaternionInverse(ctx: CallContext, quat: Any) -> list[float]:  # noqa: N802
    """The inverse of a unit quaternion ``[x, y, z, w]``.

    ``sim.getQuaternionInverse``.

    Args:
        quat: 4 numbers ``[x, y, z, w]``.

    Returns:
        4 floats.

    Raises:
        ArgumentError: not 4 numbers.
    """
    x, y, z, w = _vector(quat, 4, "quat")
    return [-x, -y, -z, w]


@sim_function("getConfigDistance")
def getConfigDistance(ctx: CallContext, configA: Any, configB: Any, metric: Any = None, types: Any = None) -> float:  # noqa: N802, N803
    """Weighted Euclidean distance between two configurations (``metric``: weights, default
    1s); ``types`` 1 revolute (angles wrap: the shorter way round), 0 others.

    ``sim.getConfigDistance``.

    Args:
        configA: n numbers (rad or m).
        configB: n numbers.
        metric: n weights, or None.
        types: n joint types (1 revolute), or None.

    Returns:
        The distance.

    Raises:
        ArgumentError: lengths that differ, or not numbers.
    """
    a, b = (np.array(_vector(v, len(v) if isinstance(v, (list, tuple)) else -1, n))
            for v, n in ((configA, "configA"), (configB, "configB")))
    if a.shape != b.shape:
        raise ArgumentError("configA and configB differ in length")
    d = b - a
    if types is not None:
        t = np.array(_vector(types, len(a), "types"))
        d = np.where(t == 1, (d + np.pi) % (2 * np.pi) - np.pi, d)
    w = np.ones(len(a)) if metric is None else np.array(_vector(metric, len(a), "metric"))
    return float(np.sqrt(np.sum((w * d) ** 2)))




def _euler_xyz(r: np.ndarray) -> tuple[float, float, float]:
    """alpha, beta, gamma of R = Rx(alpha) Ry(beta) Rz(gamma) (V-REP's Euler angles)."""
    beta = math.asin(max(-1.0, min(1.0, r[0, 2])))
    if abs(r[0, 2]) < 1 - 1e-12:
        return math.atan2(-r[1, 2], r[2, 2]), beta, math.atan2(-r[0, 1], r[0, 0])
    return math.atan2(r[2, 1], r[1, 1]), beta, 0.0
