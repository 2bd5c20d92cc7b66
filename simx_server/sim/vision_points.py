"""Points from a vision sensor's work image read as a depth map: ``simVision.coordinatesFromWorkImg``
(a grid of points across the sensor's view) and ``simVision.velodyneDataFromWorkImg`` (columns of
a rotating scanner's rays), as CoppeliaSim's ``simVision`` plugin computes them
(``LUA_COORDINATESFROMWORKIMG_CALLBACK`` and ``LUA_VELODYNEDATAFROMWORKIMG_CALLBACK`` in
``sourceCode/simVision.cpp``).

A pixel's intensity (R + G + B) / 3 is its depth between the near and far planes
(``sensorDepthMapToWorkImg`` made it so). Points are in the sensor's frame (V-REP's: +z along
the view, +x toward the image's left, +y up), or in the world's when asked (the handle's
``sim.handleflag_abscoords``); a point farther than the far plane is brought back onto it. The
angle of a perspective sensor spans the larger side of its image, as its orthographic size does.
Work images are (h, w, 3) float32 with row 0 the image's bottom row.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np


@dataclasses.dataclass(frozen=True)
class View:
    """What the points need of the sensor.

    Attributes:
        perspective: perspective (True) or orthographic projection.
        near: m.
        far: m.
        angle: the perspective angle (rad) along the image's larger side.
        ortho_size: the orthographic view's size (m) along the larger side.
        pose: (3, 4) the sensor's world frame ``[R | p]`` (V-REP's axes), or None: points in
            the sensor's frame.
    """

    perspective: bool
    near: float
    far: float
    angle: float
    ortho_size: float
    pose: np.ndarray | None = None


def _angles(view: View, w: int, h: int) -> tuple[float, float]:
    """The view's angles along x and y (the given one spans the larger side)."""
    x = y = view.angle
    ratio = w / h
    if w > h:
        y = 2.0 * math.atan(math.tan(x / 2.0) / ratio)
    else:
        x = 2.0 * math.atan(math.tan(x / 2.0) * ratio)
    return x, y


def _steps(count: int, span: float) -> np.ndarray:
    """``count`` values from -span/2 by span/(count - 1), summed one after the other as the
    plugin's loop does (0 alone when count is 1)."""
    if count <= 1:
        return np.zeros(max(count, 0))
    return np.add.accumulate(np.r_[-span * 0.5, np.full(count - 1, span / (count - 1))])


def _index(value: np.ndarray, size: int) -> np.ndarray:
    """C's ``int()`` (toward zero), kept inside the image."""
    return np.clip(np.trunc(value), 0, size - 1).astype(np.int64)


def _points(work: np.ndarray, rows: np.ndarray, cols: np.ndarray, view: View, dirs: tuple | None,
            flat: tuple | None) -> np.ndarray:
    """(n, 4) points of the pixels at ``rows``/``cols``: x, y, z and the distance (brought back
    to the far plane); ``dirs`` (tx, ty) scale a perspective ray by its depth, ``flat`` (x, y)
    are an orthographic point's offsets (its 4th value is the depth)."""
    depth = view.near + work[rows, cols].astype(np.float64).sum(axis=1) / 3.0 * (view.far - view.near)
    if dirs is not None:
        v = np.stack([dirs[0] * depth, dirs[1] * depth, depth], axis=1)
        length = np.linalg.norm(v, axis=1)
        far = length > view.far
        v[far] *= (view.far / length[far])[:, None]
        dist = np.where(far, view.far, length)
    else:
        v = np.stack([flat[0], flat[1], depth], axis=1)
        dist = depth
    if view.pose is not None:
        v = v @ view.pose[:, :3].T + view.pose[:, 3]
    return np.column_stack([v, dist])


def _colours(buffer1: np.ndarray | None, rows: np.ndarray, cols: np.ndarray) -> bytes:
    """Buffer 1's RGB bytes at the points (value x 255.1, truncated), and 3 zero bytes more (the
    plugin's padding); empty without buffer 1."""
    if buffer1 is None:
        return b""
    rgb = (buffer1[rows, cols].astype(np.float64) * 255.1).astype(np.uint8)
    return rgb.tobytes() + b"\0\0\0"


def coordinates(work: np.ndarray, buffer1: np.ndarray | None, counts: tuple[int, int], angular: bool,
                view: View) -> tuple[np.ndarray, bytes]:
    """``simVision.coordinatesFromWorkImg(handle, {xCount, yCount}, evenlySpacedInAngularSpace,
    returnColorData)``: a grid of ``xCount`` x ``yCount`` points across the view, rows from the
    bottom.

    Args:
        work: (h, w, 3) float32 work image (a depth map), rows bottom-up.
        buffer1: buffer 1 for the points' colours, or None (no colours).
        counts: points along x and y (each >= 1).
        angular: perspective only: points evenly spaced in angle (else in the image plane).
        view: the sensor.

    Returns:
        ``(packet, colours)``: ``[xCount, yCount, then x, y, z, distance per point]`` (m; an
        orthographic point's 4th value is its depth), a float32 array; the RGB bytes of each
        point taken from buffer 1 (empty without it).
    """
    h, w = work.shape[:2]
    nx, ny = counts
    if view.perspective:
        xa, ya = _angles(view, w, h)
        xd, yd = _steps(nx, xa), _steps(ny, ya)
        X, Y = np.meshgrid(xd, yd)
        if angular:
            tx, ty = np.tan(X) * (0.5 / math.tan(xa * 0.5)), np.tan(Y) * (0.5 / math.tan(ya * 0.5))
            cols, rows = _index((0.5 - tx) * (w - 0.5), w), _index((ty + 0.5) * (h - 0.5), h)
            dirs = (tx * 2.0 * math.tan(xa * 0.5), ty * 2.0 * math.tan(ya * 0.5))
        else:
            cols, rows = _index((0.5 - X / xa) * (w - 0.5), w), _index((0.5 + Y / ya) * (h - 0.5), h)
            dirs = (math.tan(xa * 0.5) * X / (xa * 0.5), math.tan(ya * 0.5) * Y / (ya * 0.5))
        pts = _points(work, rows.ravel(), cols.ravel(), view, (dirs[0].ravel(), dirs[1].ravel()), None)
    else:
        xs = ys = view.ortho_size
        if w > h:
            ys = xs / (w / h)
        else:
            xs = xs * (w / h)
        X, Y = np.meshgrid(_steps(nx, xs), _steps(ny, ys))
        cols, rows = _index((1.0 - (X + xs * 0.5) / xs) * (w - 0.5), w), _index((Y + ys * 0.5) / ys * (h - 0.5), h)
        pts = _points(work, rows.ravel(), cols.ravel(), view, None, (X.ravel(), Y.ravel()))
    packet = np.r_[nx, ny, pts.ravel()].astype(np.float32)
    return packet, _colours(buffer1, rows.ravel(), cols.ravel())


def velodyne(work: np.ndarray, buffer1: np.ndarray | None, counts: tuple[int, int], vertical: float,
             view: View) -> tuple[np.ndarray, bytes]:
    """``simVision.velodyneDataFromWorkImg(handle, {xCount, yCount}, verticalAngle,
    returnColorData)``: ``xCount`` columns of ``yCount`` rays each, spread over the sensor's
    horizontal angle and ``vertical`` rad, read off a perspective depth map (as a rotating
    scanner's sensor does; the plugin treats every sensor as perspective).

    Args:
        work: (h, w, 3) float32 work image (a depth map), rows bottom-up.
        buffer1: buffer 1 for the points' colours, or None.
        counts: columns along x, rays per column (each >= 1).
        vertical: the vertical scan angle (rad).
        view: the sensor.

    Returns:
        ``(packet, colours)``: ``[xCount, yCount, then x, y, z, distance per point]``, column
        after column, a float32 array; the RGB bytes of each point from buffer 1 (empty without it).
    """
    h, w = work.shape[:2]
    nx, ny = counts
    xa, ya = _angles(view, w, h)
    xd = _steps(nx, xa)
    yd = _steps(ny, vertical)
    X, Y = np.meshgrid(xd, yd, indexing="ij")  # columns outer, rays inner
    tx = np.tan(X) * (0.5 / math.tan(xa * 0.5))
    ty = np.tan(Y) / np.cos(X) * (0.5 / math.tan(ya * 0.5))
    cols, rows = _index((0.5 - tx) * (w - 0.5), w), _index((ty + 0.5) * (h - 0.5), h)
    dirs = (tx.ravel() * 2.0 * math.tan(xa * 0.5), ty.ravel() * 2.0 * math.tan(ya * 0.5))
    pts = _points(work, rows.ravel(), cols.ravel(), view, dirs, None)
    packet = np.r_[nx, ny, pts.ravel()].astype(np.float32)
    return packet, _colours(buffer1, rows.ravel(), cols.ravel())
