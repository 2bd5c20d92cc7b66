"""CoppeliaSim 4.x's ``sim.generateTimeOptimalTrajectory``: the fastest timing of a path under
per-joint velocity and acceleration limits, as CoppeliaSim computes it with TOPP-RA.

The path (configurations at ``pathLengths``) is interpolated by a cubic spline in the path
parameter s (``'not-a-knot'``, ``'natural'`` or ``'clamped'`` ends), sampled at
``trajPtSamples`` points; the squared path speed x = (ds/dt)² then gets the largest values the
limits allow (velocity: ``minVel <= q'(s) sdot <= maxVel``; acceleration:
``minAccel <= q''(s) x + q'(s) u <= maxAccel`` with u = d²s/dt²) by TOPP-RA's two passes: backward
the controllable sets (bisection on each interval's upper end), forward the greedy largest
acceleration. The motion starts and ends at rest.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text

MAX_SAMPLES, MAX_POINTS = 10_000, 5_000


def _spline(s: np.ndarray, q: np.ndarray, ends: str) -> tuple[np.ndarray, np.ndarray]:
    """Second derivatives M (n, dof) of the cubic spline through (s, q) with the given ends."""
    n = len(s)
    h = np.diff(s)
    a = np.zeros((n, n))
    rhs = np.zeros_like(q)
    for i in range(1, n - 1):
        a[i, i - 1:i + 2] = h[i - 1], 2 * (h[i - 1] + h[i]), h[i]
        rhs[i] = 6 * ((q[i + 1] - q[i]) / h[i] - (q[i] - q[i - 1]) / h[i - 1])
    if ends == "natural" or n < 4:
        a[0, 0] = a[-1, -1] = 1.0
    elif ends == "clamped":  # zero first derivative at both ends
        a[0, :2] = 2 * h[0], h[0]
        rhs[0] = 6 * (q[1] - q[0]) / h[0]
        a[-1, -2:] = h[-1], 2 * h[-1]
        rhs[-1] = -6 * (q[-1] - q[-2]) / h[-1]
    else:  # not-a-knot: the third derivative continuous at the second and next-to-last points
        a[0, :3] = h[1], -(h[0] + h[1]), h[0]
        a[-1, -3:] = h[-1], -(h[-2] + h[-1]), h[-2]
    return h, np.linalg.solve(a, rhs)


def _evaluate(s: np.ndarray, q: np.ndarray, h: np.ndarray, mm: np.ndarray, t: np.ndarray):
    """q(t), q'(t), q''(t) of the spline at parameters t."""
    i = np.clip(np.searchsorted(s, t, side="right") - 1, 0, len(s) - 2)
    a, b = (s[i + 1] - t)[:, None], (t - s[i])[:, None]
    hi = h[i][:, None]
    m0, m1, q0, q1 = mm[i], mm[i + 1], q[i], q[i + 1]
    pos = (m0 * a ** 3 + m1 * b ** 3) / (6 * hi) + (q0 / hi - m0 * hi / 6) * a + (q1 / hi - m1 * hi / 6) * b
    vel = (-m0 * a ** 2 + m1 * b ** 2) / (2 * hi) - (q0 / hi - m0 * hi / 6) + (q1 / hi - m1 * hi / 6)
    acc = (m0 * a + m1 * b) / hi
    return pos, vel, acc


def _u_range(dq: np.ndarray, ddq: np.ndarray, x: float, amin: np.ndarray, amax: np.ndarray) -> tuple[float, float]:
    """The path accelerations u allowed at squared speed x: (lo, hi), lo > hi when none."""
    lo, hi = -np.inf, np.inf
    moving = np.abs(dq) > 1e-12
    if np.any(~moving & ((ddq * x < amin - 1e-9) | (ddq * x > amax + 1e-9))):
        return 1.0, -1.0
    d, c = dq[moving], ddq[moving] * x
    a1, a2 = (amin[moving] - c) / d, (amax[moving] - c) / d
    if len(d):
        lo, hi = float(np.minimum(a1, a2).max()), float(np.maximum(a1, a2).min())
    return lo, hi


# Time-optimal path timing.

@sim_function("generateTimeOptimalTrajectory")
def generateTimeOptimalTrajectory(ctx: CallContext, path: Any, pathLengths: Any, minMaxVel: Any, minMaxAccel: Any,  # noqa: N802, N803
                                  trajPtSamples: Any = 1000, boundaryCondition: Any = "not-a-knot",  # noqa: N803
                                  timeout: Any = 5) -> tuple[list[float], list[float]]:
    """``path, times``: ``trajPtSamples`` configurations along the path (flat, ``dof`` numbers
    each, ``dof`` = len(path) / len(pathLengths)) and the time (s) at which the fastest motion
    within the limits reaches each. ``minMaxVel`` / ``minMaxAccel``: per dof a minimum and a
    maximum (``{min1, max1, min2, max2...}``; minimum < 0 < maximum). Errors: a path of
    fewer than 2 configurations, path lengths not increasing, limits that stop the motion.

    ``sim.generateTimeOptimalTrajectory``.

    Args:
        path: n * dof numbers (rad or m).
        pathLengths: n increasing numbers.
        minMaxVel: 2 * dof numbers (per second).
        minMaxAccel: 2 * dof numbers (per second²).
        trajPtSamples: how many samples.
        boundaryCondition: the spline's end condition.
        timeout: s.

    Returns:
        ``(path, times)``: trajPtSamples * dof floats and trajPtSamples floats (s).

    Raises:
        ArgumentError: as said above.
    """
    lengths = np.array([_num(v, "pathLengths[i]") for v in (pathLengths or [])], dtype=float)
    n = len(lengths)
    if not 2 <= n <= MAX_POINTS or not isinstance(path, (list, tuple)) or len(path) % n:
        raise ArgumentError(f"give 2..{MAX_POINTS} configurations and one path length per configuration")
    dof = len(path) // n
    q = np.array([_num(v, "path[i]") for v in path], dtype=float).reshape(n, dof)
    if np.any(np.diff(lengths) <= 0):
        raise ArgumentError("pathLengths must increase strictly (remove repeated configurations)")
    vel = np.array([_num(v, "minMaxVel[i]") for v in (minMaxVel or [])], dtype=float)
    acc = np.array([_num(v, "minMaxAccel[i]") for v in (minMaxAccel or [])], dtype=float)
    if len(vel) != 2 * dof or len(acc) != 2 * dof:
        raise ArgumentError(f"minMaxVel and minMaxAccel must hold a minimum and a maximum per dof ({2 * dof})")
    vmin, vmax, amin, amax = vel[0::2], vel[1::2], acc[0::2], acc[1::2]
    if np.any(vmin >= 0) or np.any(vmax <= 0) or np.any(amin >= 0) or np.any(amax <= 0):
        raise ArgumentError("each minimum must be negative and each maximum positive")
    samples = _int(trajPtSamples, "trajPtSamples")
    if not 2 <= samples <= MAX_SAMPLES:
        raise ArgumentError(f"trajPtSamples must lie in 2..{MAX_SAMPLES}")
    ends = _text(boundaryCondition, "boundaryCondition")
    if ends not in ("not-a-knot", "natural", "clamped"):
        raise ArgumentError("boundaryCondition must be 'not-a-knot', 'natural' or 'clamped'")
    _num(timeout, "timeout")
    h, mm = _spline(lengths, q, ends)
    grid = np.linspace(lengths[0], lengths[-1], samples)
    pos, dq, ddq = _evaluate(lengths, q, h, mm, grid)
    step = grid[1] - grid[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = np.where(dq > 1e-12, vmax / dq, np.where(dq < -1e-12, vmin / dq, np.inf))
    xvel = np.minimum(np.min(bound, axis=1) ** 2, 1e12)
    # backward: K[i], the largest squared speed at i from which the end is reached at rest
    k = np.zeros(samples)
    for i in range(samples - 2, -1, -1):
        def ok(x: float, i: int = i) -> bool:
            lo, hi = _u_range(dq[i], ddq[i], x, amin, amax)
            return lo <= hi and x + 2 * step * lo <= k[i + 1] + 1e-12 and x + 2 * step * hi >= -1e-12
        lo_x, hi_x = 0.0, float(xvel[i])
        if ok(hi_x):
            k[i] = hi_x
            continue
        for _ in range(50):
            mid = (lo_x + hi_x) / 2
            lo_x, hi_x = (mid, hi_x) if ok(mid) else (lo_x, mid)
        k[i] = lo_x
    # forward: from rest, the largest acceleration that stays controllable
    x = np.zeros(samples)
    for i in range(samples - 1):
        _, hi = _u_range(dq[i], ddq[i], x[i], amin, amax)
        x[i + 1] = max(0.0, min(k[i + 1], x[i] + 2 * step * hi))
    speed = np.sqrt(x)
    pair = speed[:-1] + speed[1:]
    if np.any(pair <= 1e-12):
        raise ArgumentError("the limits stop the motion along this path (no time-optimal timing)")
    times = np.concatenate([[0.0], np.cumsum(2 * step / pair)])
    return pos.reshape(-1).tolist(), times.tolist()


