"""The pure part of ``simx-dataset`` (:mod:`simx_client.dataset`): YOLO boxes from a colour-coded
image, where objects may be placed in a sensor's view, preview drawing, and the parsing of the
command line's numbers. No ``simx*`` call here: numpy and OpenCV only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

MIN_BOX_PIXELS = 16  # visible pixels an object needs to be labelled
MIN_BOX_SIDE = 4  # pixels each side of its box needs


class DatasetError(RuntimeError):
    """A call failed or an argument names something the scene does not have."""


# ---------------------------------------------------------------------------- pure helpers
@dataclass
class Box:
    cls: int
    x0: int  # first column of the object's visible pixels
    y0: int  # first row (top-down)
    x1: int  # last column + 1
    y1: int  # last row + 1
    pixels: int  # visible pixel count

    def yolo(self, width: int, height: int) -> str:
        """The box as a YOLO label line: ``class cx cy w h``, normalised to the image's size.

        Args:
            width: the image's width, pixels.
            height: its height, pixels.

        Returns:
            The line, without a newline.
        """
        cx, cy = (self.x0 + self.x1) / 2 / width, (self.y0 + self.y1) / 2 / height
        w, h = (self.x1 - self.x0) / width, (self.y1 - self.y0) / height
        return f"{self.cls} {cx:.6f} {cy:.6f} {w:.6f} {h:.6f}"


def boxes(handles: np.ndarray, classes: list[list[int]], min_pixels: int = MIN_BOX_PIXELS,
          min_side: int = MIN_BOX_SIDE) -> list[Box]:
    """One box per visible object of each class (``handles``: rows top-down), as YOLO labels
    mean instances: the bounding box of the object's visible pixels, dropped below
    ``min_pixels`` or ``min_side``. A class of several objects gives a box for each of them.

    Args:
        handles: (h, w) int32 handles of a colour-coded image (:func:`decode_handles`).
        classes: per class, the handles of its objects.
        min_pixels: the fewest visible pixels of a box.
        min_side: the shortest side of a box, pixels.

    Returns:
        The boxes, class by class.
    """
    out = []
    for cls, members in enumerate(classes):
        for member in members:
            mask = handles == member
            n = int(np.count_nonzero(mask))
            if n == 0 or n < min_pixels:
                continue
            rows = np.flatnonzero(mask.any(axis=1))
            cols = np.flatnonzero(mask.any(axis=0))
            box = Box(cls, int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1, n)
            if box.x1 - box.x0 < min_side or box.y1 - box.y0 < min_side:
                continue
            out.append(box)
    return out


#: Share of the vision sensor's view angles within which objects are placed: their whole body,
#: not only their origin, should be in the image.
VIEW_SHARE = 0.8


def view_footprint(position, quaternion, angle: float, width: int, height: int, z: float,
                   share: float = VIEW_SHARE) -> np.ndarray | None:
    """The polygon (4, 2) where a vision sensor at ``position`` (m) with ``quaternion`` (x, y, z,
    w; V-REP's sensor frame: it looks along +z, +x across the image's width) and perspective
    angle ``angle`` (rad, over the larger side) sees the plane at height ``z``, its angles shrunk
    to ``share``; None when a corner ray does not meet the plane ahead of the sensor.

    Args:
        position: the sensor's position (3,), m.
        quaternion: its orientation, (x, y, z, w).
        angle: its perspective angle, rad.
        width: its resolution x, pixels.
        height: its resolution y, pixels.
        z: the plane's height, m.
        share: the share of the view's angles kept, 0..1.

    Returns:
        Array (4, 2) of (x, y) in m, or None.
    """
    half_x = math.atan(math.tan(angle / 2) * (1 if width >= height else width / height)) * share
    half_y = math.atan(math.tan(angle / 2) * (1 if height >= width else height / width)) * share
    p = np.asarray(position, float)
    corners = []
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        ray = quat_rotate(quaternion, np.array([sx * math.tan(half_x), sy * math.tan(half_y), 1.0]))
        if ray[2] >= -1e-9:
            return None
        t = (z - p[2]) / ray[2]
        if t <= 0:
            return None
        corners.append((p + t * ray)[:2])
    return np.array(corners)


def _inside(polygon: np.ndarray, point: np.ndarray) -> bool:
    """Whether ``point`` (2,) lies in the convex ``polygon`` (n, 2), either winding."""
    edges = np.roll(polygon, -1, axis=0) - polygon
    cross = edges[:, 0] * (point[1] - polygon[:, 1]) - edges[:, 1] * (point[0] - polygon[:, 0])
    return bool(np.all(cross >= 0) or np.all(cross <= 0))


def place_in_view(rng: np.random.Generator, area, footprint: np.ndarray | None,
                  tries: int = 200) -> tuple[float, float, bool]:
    """A random spot ``(x, y, seen)`` of the surface ``area`` (x0, x1, y0, y1, z) that the sensor
    sees (inside ``footprint``), or of the whole surface (``seen`` False) when they do not meet.

    Args:
        rng: the random generator.
        area: ``(x0, x1, y0, y1, z)`` in m.
        footprint: :func:`view_footprint`, or None.
        tries: random points tried inside the footprint before giving up.

    Returns:
        ``(x, y, seen)``; x and y in m.
    """
    x0, x1, y0, y1, _ = area
    if footprint is not None:
        lo, hi = np.maximum(footprint.min(axis=0), (x0, y0)), np.minimum(footprint.max(axis=0), (x1, y1))
        if np.all(lo < hi):
            for _ in range(tries):
                point = rng.uniform(lo, hi)
                if _inside(footprint, point):
                    return float(point[0]), float(point[1]), True
    return float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)), False


def draw(image_bgr: np.ndarray, found: list[Box], names: list[str]) -> np.ndarray:
    """A copy of the image with each box and its class name drawn.

    Args:
        image_bgr: (h, w, 3) uint8 BGR image, rows top-down.
        found: the boxes.
        names: the class names.

    Returns:
        The new image.
    """
    out = image_bgr.copy()
    for b in found:
        colour = _colour(b.cls)
        cv2.rectangle(out, (b.x0, b.y0), (b.x1 - 1, b.y1 - 1), colour, 1)
        cv2.putText(out, names[b.cls], (b.x0, max(b.y0 - 4, 10)), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    colour, 1, cv2.LINE_AA)
    return out


def _colour(i: int) -> tuple[int, int, int]:
    palette = [(0, 255, 0), (255, 128, 0), (0, 200, 255), (255, 0, 255), (0, 0, 255), (255, 255, 0)]
    return palette[i % len(palette)]


def parse_floats(text: str, n: int | None, what: str) -> list[float]:
    """The numbers of a comma-separated command-line value.

    Args:
        text: the value, ``"1,2.5,3"``.
        n: how many there must be, or None for any.
        what: the option, for the message.

    Returns:
        The numbers.

    Raises:
        DatasetError: not numbers, or not ``n`` of them.
    """
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise DatasetError(f"{what}: {text!r} is not a comma-separated list of numbers") from None
    if n is not None and len(values) != n:
        raise DatasetError(f"{what}: expected {n} numbers, got {len(values)} in {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise DatasetError(f"{what}: {text!r} has a non-finite number")
    return values


def quat_rotate(q_xyzw, v: np.ndarray) -> np.ndarray:
    """Rotate ``v`` by a V-REP quaternion (x, y, z, w).

    Args:
        q_xyzw: a unit quaternion.
        v: a vector (3,).

    Returns:
        The rotated vector (3,).
    """
    x, y, z, w = q_xyzw
    u = np.array([x, y, z])
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)
