"""V-REP's old path objects (``sim_object_path_type``, 3.x up to CoppeliaSim 4.1): control points,
the Bezier points CoppeliaSim computes from them, lengths along the path and poses on it, as
coppeliaSimLib's ``CPathCont_old`` has them.

A path keeps its control points (simple points: pose in the path's frame, Bezier point count and
factors, maximum relative velocity, on-spot distance, auxiliary flags and channels), its
attributes (``sim_pathproperty_*``), length calculation method and coefficients, and its
position along the path (m of virtual length). From them, as ``CPathCont_old::actualizePath``:
the Bezier points (``_recomputeBezierPoints``), coincident ones merged
(``_removeDoubleBezierPoints``), automatic orientation where the attribute says so
(``_computeAutomaticOrientation``, on the control points and the Bezier points), and the
virtual lengths between them (``_recomputeBezierPathElementLengths``). A pose at a normalized
virtual distance interpolates the two Bezier points around it
(``getTransformationOnBezierCurveAtNormalizedVirtualDistance``).

Poses are ``(position (3,), quaternion (4,) w x y z)``, m.
"""

from __future__ import annotations

import math

import numpy as np

from simx_wire.protocol import ArgumentError

CLOSED, AUTO_ORIENTATION, FLAT, KEEP_X_UP = 4, 8, 64, 2048
#: Values per control point: pose (x y z qw qx qy qz), factor before, after, Bezier point count,
#: max relative velocity, on-spot distance, aux flags, 4 aux channels.
POINT_SIZE = 17
MAX_POINTS = 10_000
_DEG = math.pi / 180


def _qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def slerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """``C4Vector::buildInterpolation``: from ``a`` towards ``b`` (the shorter way) by ``t``.

    Args:
        a: quaternion w x y z.
        b: quaternion w x y z.
        t: 0..1.

    Returns:
        The unit quaternion w x y z.
    """
    if float(np.dot(a, b)) < 0:
        a = -a
    d = _qmul(np.array([a[0], -a[1], -a[2], -a[3]]), b)
    if d[0] < 0:
        d = -d
    angle = 2 * math.acos(min(1.0, float(d[0]) / max(float(np.linalg.norm(d)), 1e-300)))
    s = math.sin(angle / 2)
    axis = d[1:] / s if abs(s) >= 5e-5 else d[1:]
    h = angle * t / 2
    q = _qmul(a, np.array([math.cos(h), *(axis * math.sin(h))]))
    return q / np.linalg.norm(q)


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """``C4Vector::getAngleBetweenQuaternions``.

    Args:
        a: quaternion w x y z.
        b: quaternion w x y z.

    Returns:
        The angle, rad.
    """
    return 2 * math.acos(min(1.0, abs(float(np.dot(a, b)))))


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of a unit quaternion.

    Args:
        q: quaternion w x y z.

    Returns:
        (3, 3) matrix.
    """
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """The unit quaternion of a rotation matrix (MuJoCo's ``mju_mat2Quat``).

    Args:
        m: (3, 3) matrix.

    Returns:
        Quaternion w x y z.
    """
    import mujoco  # only MuJoCo's conversion, no model

    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(m, dtype=float).reshape(9))
    return q


class _Bezier:
    """One Bezier point: pose, on-spot distance, cumulative and segment virtual lengths."""

    __slots__ = ("pos", "quat", "on_spot", "vcum", "vseg")

    def __init__(self, pos, quat, on_spot):
        self.pos, self.quat, self.on_spot = np.asarray(pos, float), np.asarray(quat, float), float(on_spot)
        self.vcum = self.vseg = 0.0


def _lerp_pose(p0, q0, p1, q1, t):
    return p0 + (p1 - p0) * t, slerp(q0, q1, t)


class OldPath:
    """One old path's container (``CPathCont_old``). ``data``: what
    :mod:`simx_server.scene.ttt.kinds` writes (points, attributes, length_method, angle_coeff,
    on_spot_coeff, position); empty for a new path (``sim.createPath``'s defaults)."""

    def __init__(self, data: dict | None = None):
        data = data or {}
        pts = np.array(data.get("points", []), dtype=float).reshape(-1, POINT_SIZE)[:MAX_POINTS]
        self.points = pts
        self.attributes = int(data.get("attributes", 1 | 2 | 8 | 32 | 128 | 1024))
        self.length_method = int(data.get("length_method", 5))
        self.angle_coeff = float(data.get("angle_coeff", 0.1 / (90 * _DEG)))
        self.on_spot_coeff = float(data.get("on_spot_coeff", 1.0))
        self.position = float(data.get("position", 0.0))
        self.actualize()

    # ------------------------------------------------------------ CPathCont_old::actualizePath
    def actualize(self) -> None:
        for i in range(len(self.points)):
            self.points[i, 3:7] /= np.linalg.norm(self.points[i, 3:7]) or 1.0
        if len(self.points) < 3:
            self.attributes &= ~CLOSED
        self.bezier = self._bezier_points()
        self._remove_doubles()
        if len(self.bezier) < 3:
            self.attributes &= ~CLOSED
        if self.attributes & AUTO_ORIENTATION:
            quats = _auto_orientation([p[:3] for p in self.points], self.attributes)
            for i, q in enumerate(quats):
                if q is not None:
                    self.points[i, 3:7] = q
            for b, q in zip(self.bezier, _auto_orientation([b.pos for b in self.bezier], self.attributes)):
                if q is not None:
                    b.quat = q
        self._lengths()
        self.set_position(self.position)

    def _bezier_points(self) -> list[_Bezier]:
        """``CPathCont_old::_recomputeBezierPoints``."""
        pts, out = self.points, []
        n, closed = len(pts), bool(self.attributes & CLOSED)
        if n < 3:
            return [_Bezier(p[:3], p[3:7], p[11]) for p in pts]
        for i in range(n):
            b = pts[i - 1] if i > 0 else (pts[-1] if closed else None)
            m = pts[i]
            a = pts[i + 1] if i < n - 1 else (pts[0] if closed else None)
            if a is None or b is None:
                out.append(_Bezier(m[:3], m[3:7], m[11]))
                continue
            x0, x1, x2 = b[:3], m[:3], a[:3]
            lin = ang = spot = False
            if int(m[9]) != 1:
                d0, d1 = x0 - x1, x1 - x2
                if np.linalg.norm(d0) != 0 and np.linalg.norm(d1) != 0 and \
                        float(np.dot(d0 / np.linalg.norm(d0), d1 / np.linalg.norm(d1))) < 0.99999:
                    lin = True
                if angle_between(b[3:7], m[3:7]) > _DEG and angle_between(m[3:7], a[3:7]) > _DEG:
                    ax_a, ax_b = _axis(b[3:7], m[3:7]), _axis(m[3:7], a[3:7])
                    ang = float(np.dot(ax_a, ax_b)) < 0.99
                spot = b[11] != m[11] and m[11] != a[11]
            if lin or ang or spot:
                pm, qm = _lerp_pose(x0, b[3:7], x1, m[3:7], 0.5)
                pn, qn = _lerp_pose(x1, m[3:7], x2, a[3:7], 0.5)
                bf0, bf1 = m[7], m[8]
                pi_, qi = _lerp_pose(pm, qm, x1, m[3:7], 1 - bf0)
                pj, qj = _lerp_pose(pn, qn, x1, m[3:7], 1 - bf1)
                spot_i = (b[11] + m[11]) / 2 * bf0 + m[11] * (1 - bf0)
                spot_j = (m[11] + a[11]) / 2 * bf1 + m[11] * (1 - bf1)
                out.append(_Bezier(pi_, qi, spot_i))
                div = int(m[9]) - 1
                for k in range(1, div):
                    t = k / div
                    p0, q0 = _lerp_pose(pi_, qi, x1, m[3:7], t)
                    p1, q1 = _lerp_pose(x1, m[3:7], pj, qj, t)
                    p, q = _lerp_pose(p0, q0, p1, q1, t)
                    s0, s1 = spot_i * (1 - t) + m[11] * t, m[11] * (1 - t) + spot_j * t
                    out.append(_Bezier(p, q, s0 * (1 - t) + s1 * t))
                out.append(_Bezier(pj, qj, spot_j))
            else:
                out.append(_Bezier(x1, m[3:7], m[11]))
        return out

    def _remove_doubles(self) -> None:
        """``CPathCont_old::_removeDoubleBezierPoints(0.0001, 0.5 deg)``."""
        i = 0
        while i < len(self.bezier) - 1:
            a, b = self.bezier[i], self.bezier[i + 1]
            if np.linalg.norm(a.pos - b.pos) < 1e-4 and angle_between(a.quat, b.quat) < 0.5 * _DEG \
                    and a.on_spot == b.on_spot:
                del self.bezier[i + 1]
            else:
                i += 1

    def _lengths(self) -> None:
        """``CPathCont_old::_recomputeBezierPathElementLengths``: virtual lengths."""
        bz, closed, cum = self.bezier, bool(self.attributes & CLOSED), 0.0
        for i in range(len(bz)):
            a, b = bz[i], bz[(i + 1) % len(bz)]
            dl = float(np.linalg.norm(a.pos - b.pos))
            da = angle_between(a.quat, b.quat) * self.angle_coeff
            v = {0: dl, 1: da, 2: max(dl, da), 3: dl + da, 4: math.hypot(dl, da),
                 5: dl if dl >= 5e-5 else da, 6: da if da >= 0.01 * _DEG else dl}.get(self.length_method, dl)
            v += abs(a.on_spot - b.on_spot) * self.on_spot_coeff
            cum += v
            if closed or i != len(bz) - 1:
                b.vcum, b.vseg = cum, v
            else:
                b.vcum = b.vseg = 0.0

    # ------------------------------------------------------------ queries
    def length(self) -> float:
        """``CPathCont_old::getBezierVirtualPathLength``.

        Returns:
            The virtual length, m (0 for fewer than 2 Bezier points).
        """
        if len(self.bezier) < 2:
            return 0.0
        return self.bezier[0].vcum if self.attributes & CLOSED else self.bezier[-1].vcum

    def _locate(self, length: float) -> tuple[int, float] | None:
        """``CPathCont_old::_getPointOnBezierCurveAtVirtualDistance``: (index, t) or None (empty)."""
        bz = self.bezier
        if not bz:
            return None
        total = self.length()
        if len(bz) < 2 or total == 0.0:
            return 0, 0.0
        closed = bool(self.attributes & CLOSED)
        length = math.fmod(length, total) % total if closed else min(max(length, 0.0), total)
        c = 0
        for passes in range(len(bz) + 1):
            nxt = c + 1
            if nxt >= len(bz):
                if not closed:
                    break
                nxt = 0
            if bz[nxt].vcum >= length:
                ps = length if passes == 0 else length - bz[c].vcum
                return c, 0.0 if bz[nxt].vseg == 0 else ps / bz[nxt].vseg
            c = nxt
        return None

    def pose_at(self, relative: float) -> tuple[np.ndarray, np.ndarray]:
        """The pose in the path's frame at ``relative`` (0..1) of its virtual length, or of control
        point ``-(relative + 1)`` where ``relative`` <= -0.5 (``simGetPositionOnPath_internal``).

        Args:
            relative: 0..1, or <= -0.5.

        Returns:
            ``(position (3,) m, quaternion w x y z)``.

        Raises:
            ArgumentError: the path is empty, or no such control point.
        """
        if relative <= -0.5:
            i = int(-relative - 0.5)
            if not 0 <= i < len(self.points):
                raise ArgumentError(f"control point {i} does not exist (the path has {len(self.points)})")
            return self.points[i, :3].copy(), self.points[i, 3:7].copy()
        where = self._locate(relative * self.length())
        if where is None:
            raise ArgumentError("the path is empty")
        i, t = where
        a, b = self.bezier[i], self.bezier[(i + 1) % len(self.bezier)]
        return _lerp_pose(a.pos, a.quat, b.pos, b.quat, t)

    def closest(self, point: np.ndarray) -> float:
        """``CPathCont_old::getPositionOnPathClosestTo``: the virtual distance along the path of
        the point of its Bezier segments closest to ``point`` (path's frame).

        Args:
            point: (3,) m, in the path's frame.

        Returns:
            The distance along the path, m of virtual length.

        Raises:
            ArgumentError: the path is empty.
        """
        bz, closed = self.bezier, bool(self.attributes & CLOSED)
        if not bz:
            raise ArgumentError("the path is empty")
        best, where = math.inf, 0.0
        for i in range(len(bz) - (0 if closed and len(bz) - 1 != 2 else 1)):
            b0, b1 = bz[i], bz[(i + 1) % len(bz)]
            vd = b1.pos - b0.pos
            n2 = float(np.dot(vd, vd))
            c = 0.0 if n2 == 0 else min(max(float(np.dot(point - b0.pos, vd)) / n2, 0.0), 1.0)
            d = float(np.linalg.norm(b0.pos + c * vd - point))
            if d < best:
                best = d
                if n2 == 0:
                    where = b0.vcum
                elif i != 0 or not closed:
                    where = b0.vcum * (1 - c) + b1.vcum * c
                else:
                    where = b1.vcum * c
        return where

    def set_position(self, p: float) -> None:
        """``CPathCont_old::setPosition``: wrapped (closed) or clamped to the length.

        Args:
            p: the position, m of virtual length.
        """
        total = self.length()
        if self.attributes & CLOSED and total > 0:
            p = math.fmod(p, total) % total
        else:
            p = min(max(p, 0.0), total)
        self.position = p

    # ------------------------------------------------------------ edits
    def insert(self, start: int, points: np.ndarray, closed: bool) -> None:
        """``simInsertPathCtrlPoints_internal``: control points at ``start`` (clamped), the closed
        attribute as given; values limited as ``CSimplePathPoint_old``'s setters do.

        Args:
            start: the index of the first new point.
            points: (k, POINT_SIZE) control points.
            closed: the path is closed.

        Raises:
            ArgumentError: more than MAX_POINTS points in all.
        """
        pts = points.copy()
        pts[:, 7:9] = np.clip(pts[:, 7:9], 0.1, 0.99)
        counts = np.clip(np.rint(pts[:, 9]), 1, 100)
        pts[:, 9] = np.where(counts < 3, 1, counts)
        pts[:, 10] = np.clip(pts[:, 10], 0.0, 1.0)
        pts[:, 11] = np.clip(pts[:, 11], 0.0, 1000.0)
        if self.attributes & FLAT:
            pts[:, 2] = 0.0
        if len(self.points) + len(pts) > MAX_POINTS:
            raise ArgumentError(f"a path holds at most {MAX_POINTS} control points")
        start = min(max(start, 0), len(self.points))
        self.points = np.vstack([self.points[:start], pts, self.points[start:]])
        self.attributes = (self.attributes | CLOSED) if closed else (self.attributes & ~CLOSED)
        self.actualize()

    def cut(self, start: int, count: int) -> None:
        """``simCutPathCtrlPoints_internal``: ``count`` points from ``start``; every point when
        either is negative.

        Args:
            start: the first point removed.
            count: how many.
        """
        if start < 0 or count < 0:
            self.points = self.points[:0]
        else:
            keep = [i for i in range(len(self.points)) if not start <= i < start + count]
            self.points = self.points[keep]
        self.actualize()


def _axis(q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """The unit axis of ``q0^-1 q1`` (``getAngleAndAxis``)."""
    d = _qmul(np.array([q0[0], -q0[1], -q0[2], -q0[3]]), q1)
    if d[0] < 0:
        d = -d
    n = np.linalg.norm(d[1:])
    return d[1:] / n if n > 1e-12 else np.array([0.0, 0, 1])


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v)
    return v / n if n > 0 else v


def _colinear(a: np.ndarray, b: np.ndarray, tol: float) -> bool:
    """``C3Vector::isColinear``: |cos| of the angle between them >= ``tol``."""
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    return na == 0 or nb == 0 or abs(float(np.dot(a, b))) / (na * nb) >= tol


def _default_frame(v: np.ndarray) -> np.ndarray:
    z = _unit(v)
    y = np.array([0.0, 0, 1]) if z[2] < 0.9 else np.array([1.0, 0, 0])
    x = _unit(np.cross(y, z))
    return np.column_stack([x, _unit(np.cross(z, x)), z])


def _auto_orientation(positions: list, attributes: int) -> list:
    """``CPathCont_old::_computeAutomaticOrientation``: z along the path, y outwards; a
    quaternion per point (None: left as it is)."""
    pts = [np.asarray(p, float) for p in positions]
    closed = bool(attributes & CLOSED)
    groups: list[list[int]] = []  # distinct consecutive positions
    for i, p in enumerate(pts):
        if groups and np.linalg.norm(p - pts[groups[-1][0]]) == 0:
            groups[-1].append(i)
        else:
            groups.append([i])
    if closed and len(groups) > 1 and np.linalg.norm(pts[groups[0][0]] - pts[groups[-1][0]]) == 0:
        groups[0] += groups.pop()
    n = len(groups)
    X = [pts[g[0]] for g in groups]
    M = [np.eye(3) for _ in range(n)]
    if n == 0:
        return [None] * len(pts)
    if n == 2:
        v = X[1] - X[0]
        if attributes & KEEP_X_UP:
            z = _unit(v)
            m = np.column_stack([np.array([0.0, 0, 1]), _unit(np.cross(z, [0.0, 0, 1])), z])
        else:
            m = _default_frame(v)
        M = [m, m]
    elif n > 2:
        level = [0] * n
        for i in range(n):
            vm = X[i]
            if i == 0 and not closed:
                M[i][:, 2], level[i] = _unit(X[1] - vm), 1
                continue
            if i == n - 1 and not closed:
                M[i][:, 2], level[i] = _unit(vm - X[i - 1]), 1
                continue
            wb, wa = _unit(vm - X[i - 1]), _unit(X[(i + 1) % n] - vm)
            if not _colinear(wb, wa, 1.0):
                x, y = _unit(np.cross(wb, wa)), _unit(wb - wa)
                M[i] = np.column_stack([x, y, _unit(np.cross(x, y))])
                level[i] = 2
            else:
                M[i][:, 2], level[i] = wb, 1
        first = -1
        for i in range(n):
            if level[i] != 2:
                continue
            first = i if first == -1 else first
            up = n + first + 1 if closed else n
            cum, prev = 0.0, X[i]
            for j in range(i + 1, up):
                jj = j % n
                cum += float(np.linalg.norm(prev - X[jj]))
                prev = X[jj]
                if level[jj] != 2:
                    continue
                if j == i + 1:
                    break
                y0, y1, tot, prev2 = M[i][:, 1].copy(), M[jj][:, 1].copy(), 0.0, X[i]
                for k in range(i + 1, j):
                    kk = k % n
                    tot += float(np.linalg.norm(X[kk] - prev2))
                    prev2 = X[kk]
                    t = tot / cum
                    if not _colinear(y0, y1, 0.999) or float(np.dot(y0, y1)) > 0:
                        y = y0 + (y1 - y0) * t
                    else:
                        aux = -M[i][:, 0]
                        y = y0 + (aux - y0) * (t / 0.5) if t <= 0.5 else aux + (y1 - aux) * ((t - 0.5) / 0.5)
                    z = M[kk][:, 2]
                    x = _unit(np.cross(y, z))
                    M[kk] = np.column_stack([x, _unit(np.cross(z, x)), z])
                    level[kk] = 2
                break
        if not closed:
            for i, o in ((0, 1), (n - 1, n - 2)):
                z = M[i][:, 2]
                x = _unit(np.cross(M[o][:, 1], z))
                M[i] = np.column_stack([x, _unit(np.cross(z, x)), z])
        v = X[1] - X[0]
        if all(_colinear(v, X[i + 1] - X[i], 0.99999) for i in range(1, n - 1)):
            M = [_default_frame(v)] * n
        if attributes & KEEP_X_UP:
            for i in range(n):
                z = M[i][:, 2]
                if float(z[2]) < 1.0:
                    y = _unit(np.cross(z, [0.0, 0, 1]))
                    M[i] = np.column_stack([_unit(np.cross(y, z)), y, z])
                else:
                    M[i] = np.eye(3)
    out: list = [None] * len(pts)
    for g, m in zip(groups, M):
        for i in g:
            out[i] = matrix_to_quat(m)
    return out
