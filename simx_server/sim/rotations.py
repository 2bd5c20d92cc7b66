"""Rotations in V-REP's conventions: Euler angles (R = Rx(a) Ry(b) Rz(g)), quaternions in
V-REP's order (x, y, z, w) and rotation matrices (3, 3). Pure functions, no MuJoCo state."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import quote


def euler_from_matrix(r: np.ndarray) -> list[float]:
    """V-REP's Euler angles [alpha, beta, gamma] (rad) of a rotation (3, 3): R = Rx(a) Ry(b) Rz(g).

    Args:
        r: rotation matrix (3, 3).

    Returns:
        ``[alpha, beta, gamma]`` in rad; at gimbal lock (beta = ±pi/2) gamma is 0.
    """
    beta = math.asin(max(-1.0, min(1.0, r[0, 2])))
    if abs(r[0, 2]) < 1 - 1e-9:
        return [math.atan2(-r[1, 2], r[2, 2]), beta, math.atan2(-r[0, 1], r[0, 0])]
    return [math.atan2(r[2, 1], r[1, 1]), beta, 0.0]  # gimbal lock: everything in alpha


def matrix_from_euler(alpha: float, beta: float, gamma: float) -> np.ndarray:
    """Rotation (3, 3) of V-REP's Euler angles (rad): R = Rx(alpha) Ry(beta) Rz(gamma).

    Args:
        alpha: rad.
        beta: rad.
        gamma: rad.

    Returns:
        Array (3, 3).
    """
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    cg, sg = math.cos(gamma), math.sin(gamma)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cg, -sg, 0], [sg, cg, 0], [0, 0, 1]])
    return rx @ ry @ rz


def matrix_from_quaternion(x: float, y: float, z: float, w: float) -> np.ndarray:
    """Rotation (3, 3) of a quaternion in V-REP's order; raises ArgumentError for a zero one.

    Args:
        x: component x.
        y: component y.
        z: component z.
        w: the scalar part (any scale: the quaternion is normalised).

    Returns:
        Array (3, 3).

    Raises:
        ArgumentError: a zero, NaN or infinite quaternion.
    """
    q = np.array([w, x, y, z], dtype=float)
    if not np.isfinite(q).all():
        raise ArgumentError(f"quaternion must be finite, got {quote([x, y, z, w])}")
    big = np.abs(q).max()
    if big > 1.0:
        q /= big  # huge components: normalise without overflow
    norm = np.linalg.norm(q)
    if norm < 1e-12:
        raise ArgumentError("quaternion must not be zero")
    r = np.empty(9)
    mujoco.mju_quat2Mat(r, q / norm)
    return r.reshape(3, 3)


def quaternion_from_matrix(r: np.ndarray) -> list[float]:
    """Quaternion of a rotation (3, 3) in V-REP's order [x, y, z, w].

    Args:
        r: rotation matrix (3, 3).

    Returns:
        ``[x, y, z, w]``, unit length.
    """
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(r).reshape(9))
    w, x, y, z = q.tolist()
    return [x, y, z, w]


def rotation_angle(r: np.ndarray) -> float:
    """The angle of rotation ``r`` (3, 3) about its axis, rad in [0, pi]: ``acos((tr r - 1) / 2)``,
    the cosine clipped to [-1, 1] against rounding.

    Args:
        r: rotation matrix (3, 3).

    Returns:
        The angle, rad.
    """
    return math.acos(max(-1.0, min(1.0, (float(np.trace(r)) - 1.0) / 2.0)))


def _frame_with_z(z_axis: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """A rotation whose z column is ``z_axis``, turned from ``reference`` by the least rotation."""
    z = np.asarray(z_axis, dtype=float)
    z = z / np.linalg.norm(z)
    rz = reference[:, 2]
    axis = np.cross(rz, z)
    s, c = np.linalg.norm(axis), float(np.dot(rz, z))
    if s < 1e-12:
        return reference.copy() if c > 0 else reference @ np.diag([1.0, -1.0, -1.0])
    quat = np.empty(4)
    mujoco.mju_axisAngle2Quat(quat, axis / s, math.atan2(s, c))
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, quat)
    return rot.reshape(3, 3) @ reference
