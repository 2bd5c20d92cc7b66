"""The two vision filters that measure the work image and return a packet: blob detection
(``simVision.blobDetectionOnWorkImg``) and the binary image's moments
(``simVision.binaryWorkImg``), as CoppeliaSim's ``simVision`` plugin computes them
(``LUA_BLOBDETECTIONONWORKIMG_CALLBACK`` and ``LUA_BINARYWORKIMG_CALLBACK`` in
``sourceCode/simVision.cpp``; V-REP 3.x's ``CSimpleFilter::processAndTrigger_blobExtraction``
and ``..._binary`` are the same computations). The chain that calls them is
:mod:`simx_server.sim.vision_filters`.

Work images are (h, w, 3) float32 in 0..1 in V-REP's layout: row 0 is the image's *bottom*
row, so a packet's y coordinates count from the bottom, as V-REP's did.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

#: V-REP's blob colours (``colorsR/G/B``): blob k is drawn in colour k % 7, darker every 7 blobs.
_BLOB_COLOURS = np.array([[1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1], [1, 1, 1]],
                         dtype=np.float32)


def _intensity(work: np.ndarray) -> np.ndarray:
    """(R + G + B) / 3 of each pixel: (h, w) float32."""
    return work.sum(axis=2, dtype=np.float32) / np.float32(3.0)


def _best_boxes(vx: np.ndarray, vy: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """V-REP's smallest bounding box of each blob's outline pixels ``(vx, vy)`` (grouped by
    blob, group k starting at ``starts[k]``): 4 orientations 22.5 degrees apart, then 3 rounds
    of 4 finer ones around the best so far, keeping the first of equal areas. Returns (n, 5)
    float64: angle (rad), width, height, centre x, centre y (pixels, before V-REP's +0.5)."""
    n = len(starts)
    best = np.zeros((n, 5))
    area = np.full(n, np.inf)

    def trial(angle: np.ndarray) -> None:
        a = np.repeat(angle, np.diff(np.append(starts, len(vx))))
        cos, sin = np.cos(a), np.sin(a)
        x, y = vx * cos - vy * sin, vx * sin + vy * cos
        x0, x1 = np.minimum.reduceat(x, starts), np.maximum.reduceat(x, starts)
        y0, y1 = np.minimum.reduceat(y, starts), np.maximum.reduceat(y, starts)
        s = (x1 - x0) * (y1 - y0)
        better = s < area
        cx, cy = (x0 + x1) * 0.5, (y0 + y1) * 0.5
        # the box centre rotated back: c * cos(-a) - ..., as the plugin does
        back = np.stack([angle, x1 - x0, y1 - y0, cx * np.cos(-angle) - cy * np.sin(-angle),
                         cx * np.sin(-angle) + cy * np.cos(-angle)], axis=1)
        best[better] = back[better]
        area[better] = s[better]

    step = 0.392699081  # 22.5 degrees
    for j in range(4):
        trial(np.full(n, step * j))
    for _ in range(3):
        step /= 3.0
        centre = best[:, 0].copy()
        for j in (-2, -1, 1, 2):
            trial(centre + step * j)
    return best


def blob_detection(work: np.ndarray, threshold: float, min_size: float, colour: bool) -> list[float]:
    """``simVision.blobDetectionOnWorkImg(handle, threshold, minBlobSize, diffColor)`` on
    ``work`` (changed in place when ``colour``): pixels of intensity >= ``threshold`` joined
    through their 8 neighbours are blobs; blobs smaller than ``min_size`` (a fraction of the
    image's pixels) are blacked out and not reported.

    Args:
        work: (h, w, 3) float32 work image, rows bottom-up.
        threshold: intensity threshold, 0..1.
        min_size: smallest blob reported, a fraction of the image's pixels.
        colour: paint each blob in one of V-REP's 7 blob colours and the rest black.

    Returns:
        V-REP's packet: ``[blobCount, 6, then per blob: relative size, orientation (rad),
        centre x, centre y (0..1, y from the bottom), width, height (0..1)]``; blobs in the
        order of their first pixel scanning rows from the bottom (V-REP's order, but for
        blobs whose labels it merged out of order).
    """
    h, w = work.shape[:2]
    fg = _intensity(work) >= np.float32(threshold)
    count, labels = cv2.connectedComponents(fg.view(np.uint8), connectivity=8, ltype=cv2.CV_32S)
    flat = labels.ravel()
    # blobs in the order of their first pixel (raster order from the bottom row)
    ids, first = np.unique(flat, return_index=True)
    ids, first = ids[ids > 0], first[ids > 0]
    order = ids[np.argsort(first)]
    rank = np.zeros(count, dtype=np.int64)
    rank[order] = np.arange(len(order))
    sizes = np.bincount(flat, minlength=count).astype(np.float64)
    rel = sizes / float(w * h)
    if colour:
        k = rank[labels]
        shade = np.float32(0.8) - (k // 7).astype(np.float32) * np.float32(0.2)
        while np.any(shade < 0.19):
            shade = np.where(shade < 0.19, shade + np.float32(0.7), shade)
        painted = _BLOB_COLOURS[k % 7] * shade[..., None]
        work[...] = np.where(fg[..., None], painted, np.float32(0.0))
    small = rel < min_size
    small[0] = False
    work[small[labels]] = 0.0
    # outline pixels: at the image's border, or with a background pixel among their 8 neighbours
    bg = (~fg).view(np.uint8)
    near_bg = cv2.dilate(bg, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0)
    edge = fg & (near_bg > 0)
    edge[0, :], edge[-1, :], edge[:, 0], edge[:, -1] = fg[0, :], fg[-1, :], fg[:, 0], fg[:, -1]
    keep = [int(b) for b in order if not small[b]]
    packet = [float(len(keep)), 6.0]
    if not keep:
        return packet
    ey, ex = np.nonzero(edge)
    el = labels[ey, ex]
    sel = np.isin(el, keep)
    ey, ex, el = ey[sel], ex[sel], el[sel]
    by = np.argsort(rank[el], kind="stable")
    ex, ey, el = ex[by].astype(np.float64), ey[by].astype(np.float64), el[by]
    starts = np.flatnonzero(np.r_[True, el[1:] != el[:-1]])
    boxes = _best_boxes(ex, ey, starts)
    for b, (angle, bw, bh, cx, cy) in zip(keep, boxes):
        packet += [float(np.float32(rel[b])), float(np.float32(-angle)), float(np.float32((cx + 0.5) / w)),
                   float(np.float32((cy + 0.5) / h)), float(np.float32(bw / w)), float(np.float32(bh / h))]
    return packet


def _angle_minus(a: float, b: float) -> float:
    """a - b wrapped to -pi..pi (the plugin's ``angleMinusAlpha``)."""
    return math.atan2(math.sin(a) * math.cos(b) - math.cos(a) * math.sin(b),
                      math.cos(a) * math.cos(b) + math.sin(a) * math.sin(b))


def binary(work: np.ndarray, threshold: float, trigger_args: tuple[float, ...], trigger: bool) -> tuple[bool, list[float]]:
    """``simVision.binaryWorkImg(handle, threshold, proportion, proportionTol, cmX, cmXTol, cmY,
    cmYTol, angle, angleTol, roundness, enableTrigger)`` on ``work`` (in place): pixels of
    intensity >= ``threshold`` become white, the others black; the packet describes the white
    area's proportion, centre of mass and orientation (second moments).

    Args:
        work: (h, w, 3) float32 work image, rows bottom-up.
        threshold: intensity threshold, 0..1.
        trigger_args: proportion, its tolerance, centre x, its tolerance, centre y, its
            tolerance, angle (rad), its tolerance, largest roundness.
        trigger: whether the sensor triggers when every value is within its tolerance.

    Returns:
        ``(triggered, [proportion, centre x, centre y (0..1, y from the bottom), angle (rad),
        roundness])``.
    """
    h, w = work.shape[:2]
    fg = _intensity(work) >= np.float32(threshold)
    work[...] = fg[..., None].astype(np.float32)
    area = float(np.count_nonzero(fg))
    angle, roundness = 0.0, 1.0
    if area:
        ys, xs = np.nonzero(fg)
        cmx, cmy = float(xs.mean()), float(ys.mean())
        dx, dy = xs - cmx, ys - cmy
        a, b, c = float((dx * dx).sum()), 2.0 * float((dx * dy).sum()), float((dy * dy).sum())
        if b != 0.0 or a != c:
            denom = math.sqrt(b * b + (a - c) * (a - c))
            s_max, s_min, c_max, c_min = -b / denom, b / denom, -(a - c) / denom, (a - c) / denom
            i_max = 0.5 * (c + a) - 0.5 * (a - c) * c_max - 0.5 * b * s_max
            i_min = 0.5 * (c + a) - 0.5 * (a - c) * c_min - 0.5 * b * s_min
            roundness = i_min / i_max if i_max else 1.0
            angle = math.acos(max(-1.0, min(1.0, c_min))) * 0.5 * (-1.0 if s_min < 0 else 1.0)
    else:  # V-REP's value for an empty image: 0.5 pixel (so 0.5 / w in the packet)
        cmx, cmy = 0.5, 0.5
    proportion = area / float(w * h)
    packet = [proportion, cmx / w, cmy / h, angle, roundness]
    hit = False
    if trigger:
        p, pt, x, xt, y, yt, ang, angt, rmax = trigger_args
        hit = (abs(p - proportion) < pt and abs(x - cmx / w) < xt and abs(y - cmy / h) < yt
               and abs(_angle_minus(ang, angle)) < angt and roundness <= rmax)
    return hit, [float(np.float32(v)) for v in packet]
