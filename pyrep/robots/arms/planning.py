"""Path helpers of ``Arm``: pose interpolation along a line, and path spacing. Planning itself is
OMPL's, through the table's ``simOMPL`` (:mod:`pyrep.robots.arms.arm`)."""

from __future__ import annotations

import numpy as np

from pyrep.backend import sim


def rotation_angle(r: np.ndarray) -> float:
    """The angle of rotation ``r`` (3, 3) about its axis, rad in [0, pi]: ``acos((tr r - 1) / 2)``,
    the cosine clipped to [-1, 1] against rounding."""
    return float(np.arccos(np.clip((np.trace(r) - 1) / 2, -1.0, 1.0)))


def table_matrix(pose: np.ndarray) -> list[float]:
    """A pose (4, 4) as the table's matrices take it: 12 numbers, its first three rows."""
    return [float(v) for v in np.asarray(pose, dtype=float)[:3, :4].reshape(12)]


def interpolate_poses(start: np.ndarray, goal: np.ndarray, steps: int) -> list[np.ndarray]:
    """``steps`` poses (4, 4) from just after ``start`` to ``goal``: positions on the line,
    rotations on the shortest arc about the rotation's own axis, a half turn included (the
    table's ``sim.interpolateMatrices``)."""
    a, b = table_matrix(start), table_matrix(goal)
    poses = []
    for i in range(1, steps + 1):
        m = np.eye(4)
        m[:3, :4] = np.reshape(sim.call("interpolateMatrices", a, b, i / steps), (3, 4))
        poses.append(m)
    return poses


def densify(configs: np.ndarray, max_step: float) -> np.ndarray:
    """The configurations (n, j) with points inserted so that no joint moves more than
    ``max_step`` between two; flat."""
    out = [configs[0]]
    for a, b in zip(configs[:-1], configs[1:]):
        n = max(int(np.ceil(np.max(np.abs(b - a)) / max_step)), 1)
        out.extend(a + (b - a) * (i / n) for i in range(1, n + 1))
    return np.array(out).reshape(-1)
