"""CoppeliaSim 4.x's path helpers on configurations, as its ``sim-1.lua`` computes them (they are
Lua-side in CoppeliaSim): ``sim.getPathLengths`` (``locals.getConfigDistance`` with the metric 1
on the first 3 numbers, 0 on the others: a pose path's length is its positions'),
``sim.getPathInterpolatedConfig`` (``linear`` and ``quadraticBezier`` with its ``strength``,
``closed`` / ``forceOpen``; ``types`` 0 plain, 1 cyclic revolute (-pi..pi), 2 quaternion x y z w
in 4 consecutive numbers, interpolated on the sphere), ``sim.closePath`` and ``sim.resamplePath``;
and the ``PATH`` data of a 4.3+ path object (:func:`through_control_points`).

A path is an ``(n, dof)`` array of configurations; lengths one per configuration, the first 0.
"""

from __future__ import annotations

import math

import numpy as np

from simx_wire.protocol import ArgumentError
from simx_server.sim.old_paths import matrix_to_quat, slerp


def lengths(path: np.ndarray) -> np.ndarray:
    """``sim.getPathLengths`` without a callback: cumulative distances, metric 1 on the first 3
    numbers of each configuration and 0 on the others (m for positions).

    Args:
        path: (n, dof) configurations.

    Returns:
        (n,) lengths, the first 0.
    """
    metric = np.array([1.0 if i < 3 else 0.0 for i in range(path.shape[1])])
    steps = np.sqrt((((path[1:] - path[:-1]) * metric) ** 2).sum(axis=1))
    return np.concatenate([[0.0], np.cumsum(steps)])


def close(path: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sim.closePath``: the first configuration appended, its length after the last's.

    Args:
        path: (n, dof) configurations.
        times: (n,) lengths.

    Returns:
        ``(path, times)`` with one configuration more.
    """
    extra = float(lengths(np.vstack([path[-1], path[0]]))[-1])
    return np.vstack([path, path[:1]]), np.append(times, times[-1] + extra)


def _lerp(a: np.ndarray, b: np.ndarray, t: float, types: list[int]) -> np.ndarray:
    """``locals.linearInterpolate``."""
    out = a * (1 - t) + b * t
    q = 0
    for i, kind in enumerate(types):
        if kind == 1:
            dx = math.atan2(math.sin(b[i] - a[i]), math.cos(b[i] - a[i]))
            v = a[i] + dx * t
            out[i] = math.atan2(math.sin(v), math.cos(v))
        elif kind == 2:
            q += 1
            if q == 4:
                q = 0
                qa, qb = a[i - 3:i + 1], b[i - 3:i + 1]  # x y z w
                r = slerp(np.array([qa[3], *qa[:3]]), np.array([qb[3], *qb[:3]]), t)
                out[i - 3:i + 1] = [r[1], r[2], r[3], r[0]]
    return out


def interpolated(path: np.ndarray, times: np.ndarray, t: float, method: dict | None = None,
                 types: list[int] | None = None) -> np.ndarray:
    """``sim.getPathInterpolatedConfig``: the configuration at length ``t`` (clamped).

    Args:
        path: (n, dof) configurations, n >= 2.
        times: n lengths.
        t: the length along the path.
        method: ``{type = 'linear' | 'quadraticBezier', strength, forceOpen, closed}``.
        types: one per number (0 plain, 1 cyclic, 2 quaternion); default all 0.

    Returns:
        (dof,) the configuration.

    Raises:
        ArgumentError: another interpolation type, or mismatched sizes.
    """
    method = method or {}
    kind = method.get("type", "linear")
    if kind not in ("linear", "quadraticBezier"):
        raise ArgumentError(f"interpolation {kind!r}: CoppeliaSim's are 'linear' and 'quadraticBezier'")
    closed = method.get("closed") is True
    force_open = method.get("forceOpen") is True if method.get("closed") is None else not closed
    strength = float(method.get("strength", 1.0))
    if closed:
        path, times = close(path, times)
    n, dof = path.shape
    types = list(types) if types is not None else [0] * dof
    if len(times) != n or len(types) != dof:
        raise ArgumentError("Bad table size.")
    t = max(t, 0.0)
    if t >= times[-1]:
        t = float(times[-1]) - 1e-8
    li = hi = 0
    for i in range(1, n):
        li, hi = i - 1, i
        if times[hi] > t:
            break
    span = times[hi] - times[li]
    t = (t - times[li]) / span if span != 0 else 0.0
    if kind == "linear":
        return _lerp(path[li], path[hi], t, types)
    w = max(0.05, strength)
    is_closed = not force_open and bool(np.all(path[0] == path[-1]))
    last = n - 1
    if t < 0.5:
        if (li == 0 and not is_closed) or t >= 0.5 * w:
            return _lerp(path[li], path[hi], t, types)
        i0 = last - 1 if li == 0 else li - 1
        a = _lerp(path[i0], path[li], 1 - 0.25 * w + t * 0.5, types)
        b = _lerp(path[li], path[hi], 0.25 * w + t * 0.5, types)
        return _lerp(a, b, 0.5 + t / w, types)
    if (hi == last and not is_closed) or t <= 1 - 0.5 * w:
        return _lerp(path[li], path[hi], t, types)
    i2 = 1 if hi == last else hi + 1
    t -= 1 - 0.5 * w
    a = _lerp(path[li], path[hi], 1 - 0.5 * w + t * 0.5, types)
    b = _lerp(path[hi], path[i2], t * 0.5, types)
    return _lerp(a, b, t / w, types)


def resample(path: np.ndarray, times: np.ndarray, count: int, method: dict | None = None,
             types: list[int] | None = None) -> np.ndarray:
    """``sim.resamplePath``: ``count`` configurations evenly spaced in length.

    Args:
        path: (n, dof) configurations.
        times: (n,) lengths.
        count: how many, at least 2.
        method: as :func:`interpolated`'s.
        types: as :func:`interpolated`'s.

    Returns:
        (count, dof) configurations.

    Raises:
        ArgumentError: as :func:`interpolated`.
    """
    method = dict(method or {})
    if method.get("closed") is True:
        path, times = close(path, times)
        method.pop("closed")
        method["forceOpen"] = False
    return np.vstack([interpolated(path, times, float(times[-1]) * i / (count - 1), method, types)
                      for i in range(count)])


_QUAT_TYPES = [0, 0, 0, 2, 2, 2, 2]


def through_control_points(ctrl: np.ndarray, options: int, count: int, smoothness: float, mode: int,
                           up: np.ndarray) -> np.ndarray:
    """A 4.3+ path object's ``PATH`` data from its control poses (``(n, 7)``: x y z qx qy qz qw),
    as CoppeliaSim's ``models/path_customization-2.lua`` computes it (``_S.path.computePaths``):
    ``options`` bit 1 closed (the first pose appended); with ``smoothness`` != 0, ``2 count``
    poses along the quadratic Bezier path of that strength, then ``count`` poses evenly spaced
    (linear between those); ``options`` bit 4: orientations recomputed along the path with
    ``up`` as up vector, ``mode`` 0..5 which axis goes along it (``recomputeOrientations``).

    Args:
        ctrl: (n, 7) control poses, n >= 2.
        options: the path's option bits.
        count: poses of the result, at least 2.
        smoothness: the Bezier strength (0: none).
        mode: the automatic orientation mode.
        up: (3,) the up vector.

    Returns:
        (count, 7) poses.

    Raises:
        ArgumentError: the control points all coincide.
    """
    closed = bool(options & 2)
    pts = np.vstack([ctrl, ctrl[:1]]) if closed else ctrl
    times = lengths(pts)
    if times[-1] <= 0:
        raise ArgumentError("the control points of a path must not all coincide")
    if smoothness != 0:
        bezier = {"type": "quadraticBezier", "forceOpen": False, "strength": smoothness}
        pts = np.vstack([interpolated(pts, times, i * times[-1] / (2 * count - 1), bezier, _QUAT_TYPES)
                         for i in range(2 * count)])
        times = lengths(pts)
    out = np.vstack([interpolated(pts, times, i * times[-1] / (count - 1), None, _QUAT_TYPES) for i in range(count)])
    return _orient(out, closed, mode, up) if options & 16 else out


def _orient(path: np.ndarray, closed: bool, mode: int, up: np.ndarray) -> np.ndarray:
    """``_S.path.recomputeOrientations``: each pose's axes from the direction along the path
    (``vf``) and ``vr = vf x up``, as orientation ``mode`` picks them."""
    n, out, prev_pose = len(path), path.copy(), None
    pos = path[:, :3]

    def before(i):
        return (i - 1) if i != 0 else (n - 2 if closed else None)

    def after(i):
        return (i + 1) if i != n - 1 else (1 if closed else None)

    for i in range(n):
        p1, i0 = pos[i], before(i)
        coincident = i0 is not None and np.linalg.norm(p1 - pos[i0]) < 1e-4
        if not (coincident and prev_pose is not None):
            for _ in range(n):
                if i0 is None or np.linalg.norm(p1 - pos[i0]) >= 1e-4:
                    break
                i0 = before(i0)
            i2 = after(i)
            for _ in range(n):
                if i2 is None or np.linalg.norm(p1 - pos[i2]) >= 1e-4:
                    break
                i2 = after(i2)
            if i0 is not None and i2 is not None:
                vf = pos[i2] - pos[i0]
            else:
                vf = pos[i2] - p1 if i0 is None else p1 - pos[i0]
            vf = vf / (np.linalg.norm(vf) or 1.0)
            vr = np.cross(vf, up)
            vr = vr / (np.linalg.norm(vr) or 1.0)
            axes = {0: (vf, np.cross(vr, vf), vr), 1: (vf, -vr, np.cross(vf, -vr)), 2: (np.cross(vr, vf), vf, -vr),
                    3: (vr, vf, np.cross(vr, vf)), 4: (np.cross(vr, vf), vr, vf),
                    5: (-vr, np.cross(vr, vf), vf)}.get(mode, (vf, np.cross(vr, vf), vr))
            w, x, y, z = matrix_to_quat(np.column_stack(axes))
            prev_pose = np.array([*p1, x, y, z, w])
        out[i] = prev_pose
    return out
