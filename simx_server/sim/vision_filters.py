"""A vision sensor's filter chain: V-REP's image-processing components applied to its output.

V-REP 3.x gave each vision sensor a chain of filter components (``CComposedFilter`` of
``CSimpleFilter``); CoppeliaSim 4 turns each component into a call of its ``simVision``
plugin in the sensor's vision callback (``CSimpleFilter::getCodeEquivalent`` in
coppeliaSimLib). simx keeps the chain in the sensor's ``simx:NAME`` custom text with those
calls' names and arguments (the sensor handle left out), steps separated by ``;``::

    filters=sensorDepthMapToWorkImg;intensityScaleOnWorkImg(1,0,0);workImgToSensorImg

Booleans are 0/1. The steps simx applies (:data:`STEPS`, each as ``simVision``'s function of
that name does it, ``sourceCode/simVision.cpp``) work on a float image in 0..1 (the *work
image*) and two buffers, all kept per sensor from one image to the next as V-REP kept them
during a simulation. ``workImgToSensorImg`` makes the sensor's image (bytes = value x 255.1,
truncated, as ``setVisionSensorImage`` in simVision's ``vis.h``), ``workImgToSensorDepthMap``
its depth buffer; a chain without them leaves the rendered image (CoppeliaSim's behaviour).
A chain is applied to every image of the sensor; :mod:`simx_server.sim.vision_blobs` has the
steps that return a packet (blobs, binary moments), which ``simxReadVisionSensor`` /
``sim.readVisionSensor`` return after V-REP's default packet.

Images here are V-REP's layout: (h, w, 3) with row 0 the image's bottom row.
"""

from __future__ import annotations

import dataclasses
import math
import re
import threading

import cv2
import numpy as np

from simx_server.sim import vision_blobs

_F32 = np.float32
#: Arguments of each step (after the sensor handle): its simVision function's.
STEPS: dict[str, int | tuple[int, ...]] = {
    "sensorImgToWorkImg": 0, "sensorDepthMapToWorkImg": 0, "uniformImgToWorkImg": 3,
    "workImgToSensorImg": 0, "workImgToSensorDepthMap": 0,
    "workImgToBuffer1": 0, "workImgToBuffer2": 0, "buffer1ToWorkImg": 0, "buffer2ToWorkImg": 0,
    "swapBuffers": 0, "swapWorkImgWithBuffer1": 0, "addWorkImgToBuffer1": 0, "subtractWorkImgFromBuffer1": 0,
    "addBuffer1ToWorkImg": 0, "subtractBuffer1FromWorkImg": 0, "multiplyWorkImgWithBuffer1": 0,
    "horizontalFlipWorkImg": 0, "verticalFlipWorkImg": 0, "shiftWorkImg": 3, "rotateWorkImg": 1,
    "resizeWorkImg": 2,
    "matrix3x3OnWorkImg": 11, "matrix5x5OnWorkImg": 27, "sharpenWorkImg": 0, "edgeDetectionOnWorkImg": 1,
    "rectangularCutWorkImg": 3, "circularCutWorkImg": 2, "normalizeWorkImg": 0,
    "intensityScaleOnWorkImg": 3, "selectiveColorOnWorkImg": 9, "scaleAndOffsetWorkImg": 10,
    "binaryWorkImg": (11, 14), "blobDetectionOnWorkImg": (3, 6), "changedPixelsOnWorkImg": 1,
    "colorSegmentationOnWorkImg": 1,
}
_STEP = re.compile(r"^([A-Za-z0-9]+)(?:\(([^()]*)\))?$")
MAX_STEPS = 64  # a chain longer than this is refused (V-REP's dialogs made a handful)


@dataclasses.dataclass(frozen=True)
class Step:
    """One filter step: a :data:`STEPS` name and its numeric arguments."""

    name: str
    args: tuple[float, ...] = ()


def parse_chain(text: str, sensor: str) -> tuple[Step, ...]:
    """The steps of a ``filters=`` setting (see the module's docstring).

    Args:
        text: ``name(arg,...);name;...``.
        sensor: the sensor's name, for errors.

    Returns:
        The steps, in order.

    Raises:
        ValueError: an unknown step, a wrong number of arguments, a non-finite number, more
            than MAX_STEPS steps (the message names the sensor and the step).
    """
    steps = []
    items = [t for t in text.split(";") if t]
    if len(items) > MAX_STEPS:
        raise ValueError(f"vision sensor {sensor!r}: {len(items)} filter steps, more than {MAX_STEPS}")
    for item in items:
        m = _STEP.match(item)
        if m is None or m.group(1) not in STEPS:
            raise ValueError(f"vision sensor {sensor!r}: unknown filter step {item[:60]!r}; "
                             f"known: {', '.join(sorted(STEPS))}")
        name, raw = m.group(1), m.group(2)
        try:
            args = tuple(float(a) for a in raw.split(",")) if raw else ()
        except ValueError:
            raise ValueError(f"vision sensor {sensor!r}: filter step {item[:60]!r} has a non-number argument") from None
        counts = STEPS[name] if isinstance(STEPS[name], tuple) else (STEPS[name],)
        if len(args) not in counts or not all(math.isfinite(a) for a in args):
            raise ValueError(f"vision sensor {sensor!r}: filter step {name} takes "
                             f"{' or '.join(map(str, counts))} finite numbers, got {item[:60]!r}")
        steps.append(Step(name, args))
    return tuple(steps)


def uses_depth(steps: tuple[Step, ...]) -> bool:
    """Whether the chain reads the sensor's depth buffer (``sensorDepthMapToWorkImg``).

    Args:
        steps: the chain.

    Returns:
        True or False.
    """
    return any(s.name == "sensorDepthMapToWorkImg" for s in steps)


def writes_depth(steps: tuple[Step, ...]) -> bool:
    """Whether the chain makes the sensor's depth buffer (``workImgToSensorDepthMap``).

    Args:
        steps: the chain.

    Returns:
        True or False.
    """
    return any(s.name == "workImgToSensorDepthMap" for s in steps)


def writes_image(steps: tuple[Step, ...]) -> bool:
    """Whether the chain makes the sensor's image (``workImgToSensorImg``).

    Args:
        steps: the chain.

    Returns:
        True or False.
    """
    return any(s.name == "workImgToSensorImg" for s in steps)


@dataclasses.dataclass
class Filtered:
    """What a chain made of one frame.

    Attributes:
        image: (h, w, 3) uint8, rows bottom-up, or None (the rendered image stays).
        depth: (h, w) float32 in 0..1, rows bottom-up, or None (the rendered depth stays).
        trigger: whether a step triggered the sensor (``binaryWorkImg``).
        packets: the steps' packets, in order.
    """

    image: np.ndarray | None
    depth: np.ndarray | None
    trigger: bool
    packets: list[list[float]]


class FilterState:
    """A sensor's work image and buffers 1 and 2 (simVision's ``CVisionSensorData``), kept between
    frames (V-REP kept them for a whole simulation; a script's ``workImgToSensorImg`` may drop
    them); a lock serialises frames filtered on different render threads and a script's calls.

    Attributes:
        work: (h, w, 3) float32 in 0..1, rows bottom-up, or None before a first input step.
        buffers: buffers 1 and 2, each None until a step uses it (then black; a new size makes
            them black again, as simVision reallocates them).
    """

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.work: np.ndarray | None = None
        self.buffers: list[np.ndarray | None] = [None, None]

    def _fit(self, shape: tuple[int, int]) -> None:
        """A work image of the frame's size (black when new; a new size starts anew)."""
        full = (*shape, 3)
        if self.work is None or self.work.shape != full:
            self.work = np.zeros(full, _F32)
            self.buffers = [None if b is None else np.zeros(full, _F32) for b in self.buffers]

    def buffer(self, k: int) -> np.ndarray:
        """Buffer ``k + 1``, made black (the work image's size) on first use.

        Args:
            k: 0 for buffer 1, 1 for buffer 2.

        Returns:
            (h, w, 3) float32 RGB in 0..1, the buffer itself.
        """
        b = self.buffers[k]
        if b is None or b.shape != self.work.shape:
            b = self.buffers[k] = np.zeros(self.work.shape, _F32)
        return b


def _convolve(img: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """simVision's ``filter3x3RgbImage``/``filter5x5RgbImage``: the kernel (rows = y) over the
    pixels inside the image, scaled by (kernel size / pixels inside) at the borders."""
    k = kernel.astype(_F32)
    out = cv2.filter2D(img, -1, k, borderType=cv2.BORDER_CONSTANT)
    ones = np.ones(img.shape[:2], _F32)
    inside = cv2.filter2D(ones, -1, np.ones_like(k), borderType=cv2.BORDER_CONSTANT) / _F32(k.size)
    return out / inside[..., None]


def _intensity(img: np.ndarray) -> np.ndarray:
    return vision_blobs.intensity(img)


def _outside(c: np.ndarray, lo: np.ndarray, hi: np.ndarray, channels: range) -> np.ndarray:
    """Pixels of ``c`` (h, w, 3) outside ``lo..hi`` in any of ``channels`` (a channel at a time:
    5x faster than a reduction over the last axis)."""
    out = np.zeros(c.shape[:2], bool)
    for k in channels:
        out |= c[..., k] > hi[k]
        out |= c[..., k] < lo[k]
    return out


def _colour_map(i: np.ndarray) -> np.ndarray:
    """simVision's ``colorFromIntensity`` (table 0): black, blue, red, yellow along 0..1."""
    table = np.array([[0, 0, 0], [0, 0, 1], [1, 0, 0], [1, 1, 0]], _F32)
    i = np.clip(i, 0.0, 1.0)
    d = np.minimum((i * 3).astype(np.int64), 2)
    r = ((i - d / _F32(3.0)) * 3)[..., None]
    return table[d] * (1 - r) + table[d + 1] * r


def _to_hsl(rgb: np.ndarray) -> np.ndarray:
    """RGB to (hue, saturation, lightness), each 0..1 (OpenCV's HLS, hue scaled from degrees)."""
    hls = cv2.cvtColor(np.ascontiguousarray(rgb, _F32), cv2.COLOR_RGB2HLS)
    return np.stack([hls[..., 0] / _F32(360.0), hls[..., 2], hls[..., 1]], axis=-1)


def _from_hsl(hsl: np.ndarray) -> np.ndarray:
    hls = np.stack([hsl[..., 0] * _F32(360.0), hsl[..., 2], hsl[..., 1]], axis=-1).astype(_F32)
    return cv2.cvtColor(hls, cv2.COLOR_HLS2RGB)


def _selective(st: FilterState, a: tuple[float, ...]) -> None:
    """``selectiveColorOnWorkImg(colour, tolerance, inRgb, keep, removedToBuffer1)``."""
    work = st.work
    col, tol = np.array(a[0:3], _F32), np.array(a[3:6], _F32)
    rgb, keep, to_b1 = bool(a[6]), bool(a[7]), bool(a[8])
    lo, hi = col - tol, col + tol
    if rgb:
        out = _outside(work, lo, hi, range(3))
    else:
        c = _to_hsl(work)
        out = _outside(c, lo, hi, range(1, 3))
        if hi[0] - lo[0] < 1.0:  # hue wraps around
            h = c[..., 0]
            out |= ((h > hi[0]) & (h < 1 + lo[0])) | ((h < lo[0]) & (h > hi[0] - 1))
    removed = out if keep else ~out
    if to_b1:
        st.buffer(0)[...] = np.where(removed[..., None], work, _F32(0.0))
    work[removed] = 0.0


def _scale_offset(work: np.ndarray, a: tuple[float, ...]) -> None:
    """``scaleAndOffsetWorkImg(offsetBefore, scale, offsetAfter, inRgb)``."""
    pre, scale, post = (np.array(a[k:k + 3], _F32) for k in (0, 3, 6))
    c = work if a[9] else _to_hsl(work)
    c = np.clip(post + (c + pre) * scale, 0.0, 1.0).astype(_F32)
    work[...] = c if a[9] else _from_hsl(c)


def _shift(work: np.ndarray, a: tuple[float, ...]) -> None:
    """``shiftWorkImg({x, y}, wrap)``: x, y in image fractions (-1..1)."""
    h, w = work.shape[:2]
    xs = max(-w, min(w, int(a[0] * w + (0.5 if a[0] * w >= 0 else -0.5))))
    ys = max(-h, min(h, int(a[1] * h + (0.5 if a[1] * h >= 0 else -0.5))))
    work[...] = np.roll(work, (ys, xs), axis=(0, 1))
    if not a[2]:  # what wrapped around is black
        if xs > 0:
            work[:, :xs] = 0.0
        elif xs < 0:
            work[:, w + xs:] = 0.0
        if ys > 0:
            work[:ys] = 0.0
        elif ys < 0:
            work[h + ys:] = 0.0


def _gather(work: np.ndarray, src_x: np.ndarray, src_y: np.ndarray) -> None:
    """Each pixel takes the one at (trunc(src_x), trunc(src_y)) (pixel units, C's int()), black
    where that falls outside the image: simVision's nearest-pixel ``resizeWorkImg`` and
    ``rotateWorkImg``."""
    h, w = work.shape[:2]
    x, y = np.trunc(src_x).astype(np.int64), np.trunc(src_y).astype(np.int64)
    inside = (x >= 0) & (x < w) & (y >= 0) & (y < h)
    out = np.zeros_like(work)
    out[inside] = work[y[inside], x[inside]]
    work[...] = out


def _cut(st: FilterState, outside: np.ndarray, to_b1: bool) -> None:
    """Black the work image ``outside`` the cut; buffer 1 gets what was cut (if asked)."""
    if to_b1:
        st.buffer(0)[...] = np.where(outside[..., None], st.work, _F32(0.0))
    st.work[outside] = 0.0


def _centred(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel centres relative to the image centre: dy (h, 1), dx (1, w)."""
    return (np.arange(h, dtype=np.float64) + 0.5 - h / 2)[:, None], (np.arange(w, dtype=np.float64) + 0.5 - w / 2)[None, :]


_SHARPEN = np.array([-0.1111, -0.1111, -0.1111, -0.1111, 1.8888, -0.1111, -0.1111, -0.1111, -0.1111]).reshape(3, 3)
_EDGE = np.array([-3.0, -3, -3, -3, 24, -3, -3, -3, -3]).reshape(3, 3)


def _matrix(work: np.ndarray, a: tuple[float, ...], n: int) -> None:
    """``matrix3x3OnWorkImg`` / ``matrix5x5OnWorkImg(passes, multiplier, matrix)``."""
    kernel = np.array(a[2:], np.float64).reshape(n, n) * a[1]
    out = work
    for _ in range(max(0, int(a[0]))):
        out = _convolve(out, kernel)
    work[...] = np.clip(out, 0.0, 1.0)


def _step(st: FilterState, s: Step, rgb: np.ndarray | None, depth: np.ndarray | None, res: Filtered) -> None:
    """Apply one step to ``st`` (and ``res``'s outputs)."""
    work, a = st.work, s.args
    n = s.name
    if n == "sensorImgToWorkImg":
        work[...] = rgb / _F32(255.0)
    elif n == "sensorDepthMapToWorkImg":
        work[...] = depth[..., None]
    elif n == "uniformImgToWorkImg":
        work[...] = np.array(a, _F32)
    elif n == "workImgToSensorImg":
        res.image = np.clip(work * _F32(255.1), 0, 255).astype(np.uint8)
    elif n == "workImgToSensorDepthMap":
        res.depth = _intensity(work)
    elif n in ("workImgToBuffer1", "workImgToBuffer2"):
        st.buffer(int(n.endswith("2")))[...] = work
    elif n in ("buffer1ToWorkImg", "buffer2ToWorkImg"):
        work[...] = st.buffer(int(n.startswith("buffer2")))
    elif n == "swapBuffers":
        st.buffers = [st.buffer(1), st.buffer(0)]
    elif n == "swapWorkImgWithBuffer1":
        st.work, st.buffers[0] = st.buffer(0), work
    elif n in _BUFFER_ARITHMETIC:
        b1 = st.buffer(0)
        _BUFFER_ARITHMETIC[n](work, b1)
    elif n == "horizontalFlipWorkImg":
        work[...] = work[:, ::-1].copy()
    elif n == "verticalFlipWorkImg":
        work[...] = work[::-1].copy()
    elif n == "shiftWorkImg":
        _shift(work, a)
    elif n == "resizeWorkImg":  # scale x, y about the centre
        h, w = work.shape[:2]
        dy, dx = _centred(h, w)
        _gather(work, np.broadcast_to(w / 2 + dx / a[0], (h, w)), np.broadcast_to(h / 2 + dy / a[1], (h, w)))
    elif n == "rotateWorkImg":  # by a[0] rad about the centre
        h, w = work.shape[:2]
        dy, dx = _centred(h, w)
        c, sn = math.cos(-a[0]), math.sin(-a[0])
        _gather(work, w / 2 + dx * c - dy * sn, h / 2 + dx * sn + dy * c)
    elif n == "matrix3x3OnWorkImg":
        _matrix(work, a, 3)
    elif n == "matrix5x5OnWorkImg":
        _matrix(work, a, 5)
    elif n == "sharpenWorkImg":
        work[...] = np.clip(_convolve(work, _SHARPEN), 0.0, 1.0)
    elif n == "edgeDetectionOnWorkImg":
        edges = _intensity(_convolve(work, _EDGE)) > _F32(a[0])
        work[...] = edges[..., None].astype(_F32)
    elif n == "rectangularCutWorkImg":
        dy, dx = _centred(*work.shape[:2])
        h, w = work.shape[:2]
        _cut(st, (np.abs(dx) > a[0] * 0.5 * w) | (np.abs(dy) > a[1] * 0.5 * h), bool(a[2]))
    elif n == "circularCutWorkImg":
        dy, dx = _centred(*work.shape[:2])
        radius = a[0] * min(work.shape[:2]) * 0.5
        _cut(st, dx * dx + dy * dy > radius * radius, bool(a[1]))
    elif n == "normalizeWorkImg":
        lo, hi = float(work.min(initial=1.0)), float(work.max(initial=0.0))
        if hi - lo != 0.0:
            work[...] = (work - _F32(lo)) * _F32(1.0 / (hi - lo))
    elif n == "intensityScaleOnWorkImg":
        i = _intensity(work) * _F32(a[1] - a[0]) + _F32(a[0])
        work[...] = i[..., None] if a[2] else _colour_map(i)
    elif n == "selectiveColorOnWorkImg":
        _selective(st, a)
    elif n == "scaleAndOffsetWorkImg":
        _scale_offset(work, a)
    elif n == "colorSegmentationOnWorkImg":
        vision_blobs.colour_segmentation(work, a[0])
    elif n == "changedPixelsOnWorkImg":  # a packet only when pixels changed (simVision's)
        changed = vision_blobs.changed_pixels(work, st.buffer(1), a[0])
        if changed:
            res.packets.append(changed)
    elif n == "binaryWorkImg":
        hit, packet = vision_blobs.binary(work, a[0], a[1:10], bool(a[10]), a[11:14] or None)
        res.trigger |= hit
        res.packets.append(packet)
    elif n == "blobDetectionOnWorkImg":
        res.packets.append(vision_blobs.blob_detection(work, a[0], a[1], bool(a[2]), a[3:6] or None))


#: Steps that combine the work image and buffer 1: ``(work, buffer1)`` -> None (in place, clamped).
_BUFFER_ARITHMETIC = {
    "addWorkImgToBuffer1": lambda w, b: np.minimum(b + w, 1.0, out=b),
    "subtractWorkImgFromBuffer1": lambda w, b: np.maximum(b - w, 0.0, out=b),
    "addBuffer1ToWorkImg": lambda w, b: np.minimum(w + b, 1.0, out=w),
    "subtractBuffer1FromWorkImg": lambda w, b: np.maximum(w - b, 0.0, out=w),
    "multiplyWorkImgWithBuffer1": lambda w, b: np.minimum(w * b, 1.0, out=w),
}
#: The steps that make the work image from the sensor (the others need one already).
INPUTS = ("sensorImgToWorkImg", "sensorDepthMapToWorkImg")


class NoWorkImageError(LookupError):
    """A step needs the sensor's work image and there is none (simVision's "work image not
    initialized")."""


def run_step(state: FilterState, step: Step, rgb: np.ndarray | None = None,
             depth: np.ndarray | None = None) -> Filtered:
    """One step, as a script's call of the ``simVision`` function of its name runs it.

    Args:
        state: the sensor's work image and buffers (changed).
        step: the step (its arguments as :data:`STEPS` counts them).
        rgb: the sensor's image for ``sensorImgToWorkImg``, (h, w, 3) uint8, rows bottom-up.
        depth: its depth buffer for ``sensorDepthMapToWorkImg``, (h, w) float32 in 0..1.

    Returns:
        What the step made (``image``/``depth`` for the output steps, a packet, a trigger).

    Raises:
        NoWorkImageError: a step other than the input ones before any input step.
    """
    res = Filtered(None, None, False, [])
    with state.lock:
        if step.name in INPUTS:
            state._fit((rgb if step.name == INPUTS[0] else depth).shape[:2])
        elif state.work is None:
            raise NoWorkImageError(step.name)
        _step(state, step, rgb, depth, res)
    return res


def apply_chain(steps: tuple[Step, ...], rgb: np.ndarray, depth: np.ndarray | None, state: FilterState) -> Filtered:
    """Apply a sensor's chain to one frame (V-REP's ``CComposedFilter::processAndTrigger``).

    Args:
        steps: the chain (:func:`parse_chain`).
        rgb: the rendered image, (h, w, 3) uint8, rows bottom-up.
        depth: the rendered depth, (h, w) float32 in 0..1, rows bottom-up; may be None when
            the chain does not read it (:func:`uses_depth`).
        state: the sensor's work image and buffers (changed).

    Returns:
        The :class:`Filtered` outputs.
    """
    res = Filtered(None, None, False, [])
    with state.lock:
        state._fit(rgb.shape[:2])
        for s in steps:
            _step(state, s, rgb, depth, res)
    return res
