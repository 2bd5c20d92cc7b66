"""The vision filters that measure the work image and return a packet: blob detection
(``simVision.blobDetectionOnWorkImg``), the binary image's moments (``simVision.binaryWorkImg``),
both with their optional overlay lines, and changed pixels (``simVision.changedPixelsOnWorkImg``);
and colour segmentation (``simVision.colorSegmentationOnWorkImg``), as CoppeliaSim's ``simVision``
plugin computes them (``LUA_BLOBDETECTIONONWORKIMG_CALLBACK``, ``LUA_BINARYWORKIMG_CALLBACK``,
``LUA_CHANGEDPIXELSONWORKIMG_CALLBACK``, ``LUA_COLORSEGMENTATIONONWORKIMG_CALLBACK`` and
``drawLine`` in ``sourceCode/simVision.cpp``; V-REP 3.x's ``CSimpleFilter::processAndTrigger_*``
are the same computations). The chain that calls them is :mod:`simx_server.sim.vision_filters`.

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


def intensity(work: np.ndarray) -> np.ndarray:
    """(R + G + B) / 3 of each pixel of a float32 work image: (h, w) float32 (the planes added in
    order, as a reduction over the last axis adds them, 4x faster).

    Args:
        work: (h, w, 3) float32.

    Returns:
        (h, w) float32.
    """
    total = work[..., 0] + work[..., 1]
    total += work[..., 2]
    total /= np.float32(3.0)
    return total


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


def draw_lines(work: np.ndarray, lines: list[int], colour) -> None:
    """simVision's ``drawLines``: each ``(x0, y0, x1, y1)`` of ``lines`` (pixels, y from the
    bottom) drawn in ``colour`` by its Bresenham walk, the end pixel left out, pixels outside the
    image skipped.

    Args:
        work: (h, w, 3) float32 work image, rows bottom-up (changed).
        lines: 4 ints per line.
        colour: 3 floats.
    """
    h, w = work.shape[:2]
    xs, ys = [], []
    for x0, y0, x1, y1 in np.asarray(lines, np.int64).reshape(-1, 4):
        dx, dy = abs(x1 - x0), abs(y1 - y0)
        sx, sy = (1 if x1 >= x0 else -1), (1 if y1 >= y0 else -1)
        major, minor = (dx, dy) if dx >= dy else (dy, dx)
        k = np.arange(major)
        # the minor coordinate moved m times after k steps: the largest m with m * major < k * minor
        m = np.maximum(0, (k * minor - 1) // max(major, 1))
        if dx >= dy:
            xs.append(x0 + sx * k)
            ys.append(y0 + sy * m)
        else:
            xs.append(x0 + sx * m)
            ys.append(y0 + sy * k)
    if not xs:
        return
    x, y = np.concatenate(xs), np.concatenate(ys)
    inside = (x >= 0) & (x < w) & (y >= 0) & (y < h)
    work[y[inside], x[inside]] = np.asarray(colour, np.float32)


def blob_detection(work: np.ndarray, threshold: float, min_size: float, colour: bool,
                   overlay=None) -> list[float]:
    """``simVision.blobDetectionOnWorkImg(handle, threshold, minBlobSize, diffColor)`` on
    ``work`` (changed in place when ``colour``): pixels of intensity >= ``threshold`` joined
    through their 8 neighbours are blobs; blobs smaller than ``min_size`` (a fraction of the
    image's pixels) are blacked out and not reported.

    Args:
        work: (h, w, 3) float32 work image, rows bottom-up.
        threshold: intensity threshold, 0..1.
        min_size: smallest blob reported, a fraction of the image's pixels.
        colour: paint each blob in one of V-REP's 7 blob colours and the rest black.
        overlay: None, or 3 floats: the colour of each reported blob's box drawn on ``work``.

    Returns:
        V-REP's packet: ``[blobCount, 6, then per blob: relative size, orientation (rad),
        centre x, centre y (0..1, y from the bottom), width, height (0..1)]``; blobs in the
        order of their first pixel scanning rows from the bottom (V-REP's order, but for
        blobs whose labels it merged out of order).
    """
    h, w = work.shape[:2]
    fg = intensity(work) >= np.float32(threshold)
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
    lines: list[int] = []
    for b, (angle, bw, bh, cx, cy) in zip(keep, boxes):
        packet += [float(np.float32(rel[b])), float(np.float32(-angle)), float(np.float32((cx + 0.5) / w)),
                   float(np.float32((cy + 0.5) / h)), float(np.float32(bw / w)), float(np.float32(bh / h))]
        if overlay is not None:  # the box's 4 sides, corner to corner as the plugin lists them
            c, s = math.cos(-angle), math.sin(-angle)
            ux, uy = (cx + 0.5) / w, (cy + 0.5) / h
            vx, vy = bw * 0.5 / w, bh * 0.5 / h
            corners = [(ux + a * vx * c - b2 * vy * s, uy + a * vx * s + b2 * vy * c)
                       for a, b2 in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            for (px, py), (qx, qy) in zip(corners, corners[1:] + corners[:1]):
                lines += [int(w * px), int(h * py), int(w * qx), int(h * qy)]
    if lines:
        draw_lines(work, lines, overlay)
    return packet


def _angle_minus(a: float, b: float) -> float:
    """a - b wrapped to -pi..pi (the plugin's ``angleMinusAlpha``)."""
    return math.atan2(math.sin(a) * math.cos(b) - math.cos(a) * math.sin(b),
                      math.cos(a) * math.cos(b) + math.sin(a) * math.sin(b))


def binary(work: np.ndarray, threshold: float, trigger_args: tuple[float, ...], trigger: bool,
           overlay=None) -> tuple[bool, list[float]]:
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
        overlay: None, or 3 floats: the colour of the orientation line and the centre's cross
            drawn on ``work``.

    Returns:
        ``(triggered, [proportion, centre x, centre y (0..1, y from the bottom), angle (rad),
        roundness])``.
    """
    h, w = work.shape[:2]
    fg = intensity(work) >= np.float32(threshold)
    work[...] = fg[..., None].astype(np.float32)
    area = float(np.count_nonzero(fg))
    angle, roundness = 0.0, 1.0
    lines: list[int] = []
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
            length = 0.3 - roundness * 0.25
            rx, ry = cmx / w, cmy / h
            lines += [int(w * (rx - math.cos(angle) * length)), int(h * (ry - math.sin(angle) * length)),
                      int(w * (rx + math.cos(angle) * length)), int(h * (ry + math.sin(angle) * length))]
        px, py = int(cmx + 0.5), int(cmy + 0.5)  # the centre's cross
        lines += [px, py - 4, px, py + 4, px - 4, py, px + 4, py]
    else:  # V-REP's value for an empty image: 0.5 pixel (so 0.5 / w in the packet)
        cmx, cmy = 0.5, 0.5
    proportion = area / float(w * h)
    packet = [proportion, cmx / w, cmy / h, angle, roundness]
    hit = False
    if trigger:
        p, pt, x, xt, y, yt, ang, angt, rmax = trigger_args
        hit = (abs(p - proportion) < pt and abs(x - cmx / w) < xt and abs(y - cmy / h) < yt
               and abs(_angle_minus(ang, angle)) < angt and roundness <= rmax)
    if overlay is not None and lines:
        draw_lines(work, lines, overlay)
    return hit, [float(np.float32(v)) for v in packet]


def changed_pixels(work: np.ndarray, buffer2: np.ndarray, threshold: float) -> list[float]:
    """``simVision.changedPixelsOnWorkImg(handle, threshold)`` on ``work`` (in place): a pixel whose
    intensity changed by at least ``threshold`` relative to buffer 2's (0 counts as 0.001) becomes
    white (brighter) or black (darker) and buffer 2 keeps its new intensity; the others become
    grey (0.5) and buffer 2 keeps what it had.

    Args:
        work: (h, w, 3) float32 work image, rows bottom-up.
        buffer2: (h, w, 3) float32, the intensities last recorded (changed).
        threshold: the relative change, e.g. 0.1.

    Returns:
        ``[+1 or -1, x, y, ...]`` per changed pixel (x, y in pixels from the bottom left, rows
        from the bottom), empty when none changed.
    """
    now = work.astype(np.float64).sum(axis=2) / 3.0
    before = buffer2.astype(np.float64).sum(axis=2) / 3.0
    diff = now - before
    changed = np.abs(diff) / np.where(before == 0.0, 0.001, before) >= threshold
    brighter = diff > 0
    buffer2[changed] = now[changed][:, None].astype(np.float32)
    work[...] = np.where(changed, np.where(brighter, np.float32(1.0), np.float32(0.0)), np.float32(0.5))[..., None]
    ys, xs = np.nonzero(changed)
    sign = np.where(brighter[ys, xs], 1.0, -1.0)
    return np.stack([sign, xs, ys], axis=1).astype(np.float32).ravel().tolist()


#: Pixels compared, over all colours, before colour segmentation gives up (about 0.3 s).
MAX_SEGMENTATION_WORK = 60_000_000


def colour_segmentation(work: np.ndarray, distance: float) -> None:
    """``simVision.colorSegmentationOnWorkImg(handle, maxColorColorDistance)`` on ``work`` (in
    place): scanning rows from the bottom, a pixel takes the first colour of the list within
    ``distance`` of its own (RGB, Euclidean), else its colour joins the list. Done one listed
    colour at a time: each takes every later pixel not yet taken within reach.

    Args:
        work: (h, w, 3) float32 work image, rows bottom-up.
        distance: the largest colour distance, 0..sqrt(3).

    Raises:
        ValueError: so many colours that the comparisons pass :data:`MAX_SEGMENTATION_WORK`.
    """
    flat = work.reshape(-1, 3)
    colours = flat.astype(np.float64)
    out = colours.copy()
    squared = float(distance) * float(distance)
    rest = np.arange(len(colours))
    done = 0
    while len(rest):
        first, rest = rest[0], rest[1:]
        done += len(rest)
        if done > MAX_SEGMENTATION_WORK:
            raise ValueError(f"colorSegmentationOnWorkImg: too many colours at distance {distance:g} "
                             f"(more than simx's bound of {MAX_SEGMENTATION_WORK} comparisons): use a larger distance")
        near = ((colours[rest] - colours[first]) ** 2).sum(axis=1) < squared
        out[rest[near]] = colours[first]
        rest = rest[~near]
    flat[...] = out.astype(np.float32)
