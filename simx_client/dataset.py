"""``simx-dataset``: a labelled YOLO data set from any scene served by simx-server.

A pure client (only ``simx*`` calls, numpy, OpenCV and tqdm). It connects to a running server
(``--host``/``--port`` as ``simxStart``), and for each view

1. moves the scene: the arm's joints teleported (``simxSetJointPosition``) to a random pose
   around ``--pose`` (uniform noise of ``--pose-noise`` degrees per joint) and/or the
   ``--place`` objects set (``simxSetObjectPosition``) at random spots of a surface;
2. reads the sensor's image (``simxGetVisionSensorImage``), switches the sensor to V-REP's
   colour-coded handles (``sim_visionintparam_render_mode`` 1017 = 2), reads the same state
   again, and switches it back. The whole run is in synchronous mode (``simxSynchronous``)
   without triggers, so no simulation step comes between the two renders (a stopped or paused
   simulation does not step either);
3. labels every class object by its *visible* pixels in the coded image: the box is the
   bounding box of the pixels whose handle is the object's, so occluded parts do not count and
   an object fully hidden or out of view has no label. A box is dropped when it has fewer than
   ``--min-box-pixels`` visible pixels (default 16) or a side shorter than ``--min-box-side``
   pixels (default 4): slivers at the image border or behind an occluder that a detector
   cannot learn from.

It writes the Ultralytics YOLO layout::

    OUT/images/train/000000.jpg   OUT/labels/train/000000.txt   (class cx cy w h, in 0..1)
    OUT/images/val/...            OUT/labels/val/...
    OUT/data.yaml                 (path, train, val, nc, names)
    OUT/preview/*.png             (--preview K: the first K images with their boxes drawn)
    OUT/saveImg/rgbImg/000000_rgb.jpg, OUT/saveImg/depthImg/000000_depth.jpg
                                  (--depth: pairs as the tutorial's robotControl.py saved them)

and puts the scene back as it found it (joints, placed objects, render mode, synchronous mode).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

import simx_client as vrep
from simx_client.images import decode_handles, set_lazy_image_lists  # noqa: F401 (decode_handles: API)

B = vrep.simx_opmode_blocking
ONESHOT = vrep.simx_opmode_oneshot
RENDER_MODE = 1017  # sim_visionintparam_render_mode
RESOLUTION_X, RESOLUTION_Y = 1002, 1003  # sim_visionintparam_resolution_x / _y
PERSPECTIVE_ANGLE = 1004  # sim_visionfloatparam_perspective_angle (rad)
COLOR_CODED = 2  # sim_rendermode_colorcoded
BACKGROUND = 0xFFFFFF  # what a colour-coded pixel with no object decodes to
DEFAULT_JOINTS = [f"UR5_joint{i}" for i in range(1, 7)]
DEFAULT_POSE = "90,-45,90,0,-100,0"  # the tutorial's DDPG start pose (deg): the ball in view
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


# ---------------------------------------------------------------------------- the client side
class Scene:
    """The calls the generator makes on one connection; every failure is a DatasetError."""

    def __init__(self, host: str, port: int, timeout_ms: int = 5000):
        self.cid = vrep.simxStart(host, port, True, True, timeout_ms, 5)
        if self.cid < 0:
            raise DatasetError(f"no simx server answers at {host}:{port}")
        set_lazy_image_lists(self.cid)  # images only become arrays here: no legacy list needed

    def close(self) -> None:
        vrep.simxFinish(self.cid)

    def _ok(self, rc: int, call: str):
        if rc != vrep.simx_return_ok:
            raise DatasetError(f"{call} failed (return code {rc})")

    def handle(self, name: str) -> int:
        """The handle of the object called ``name`` (``simxGetObjectHandle``).

        Args:
            name: the object's name.

        Returns:
            The handle.

        Raises:
            DatasetError: no such object.

        """
        rc, h = vrep.simxGetObjectHandle(self.cid, name, B)
        if rc != vrep.simx_return_ok:
            raise DatasetError(f"the scene has no object {name!r} (simxGetObjectHandle rc {rc})")
        return h

    def joint_position(self, h: int) -> float:
        """A joint's position (``simxGetJointPosition``).

        Args:
            h: the joint's handle.

        Returns:
            rad or m.

        Raises:
            DatasetError: the call failed (not a joint, no such object).

        """
        rc, q = vrep.simxGetJointPosition(self.cid, h, B)
        self._ok(rc, "simxGetJointPosition")
        return q

    def position(self, h: int, rel: int = -1) -> list[float]:
        """An object's position (``simxGetObjectPosition``).

        Args:
            h: the object's handle.
            rel: -1 (world) or an object's handle.

        Returns:
            ``[x, y, z]``, m.

        Raises:
            DatasetError: the call failed.

        """
        rc, p = vrep.simxGetObjectPosition(self.cid, h, rel, B)
        self._ok(rc, "simxGetObjectPosition")
        return list(p)

    def orientation(self, h: int) -> list[float]:
        """An object's Euler angles in the world frame (``simxGetObjectOrientation``).

        Args:
            h: the object's handle.

        Returns:
            ``[alpha, beta, gamma]``, rad.

        Raises:
            DatasetError: the call failed.

        """
        rc, e = vrep.simxGetObjectOrientation(self.cid, h, -1, B)
        self._ok(rc, "simxGetObjectOrientation")
        return list(e)

    def quaternion(self, h: int) -> list[float]:
        """An object's orientation in the world frame (``simxGetObjectQuaternion``).

        Args:
            h: the object's handle.

        Returns:
            ``[qx, qy, qz, qw]``.

        Raises:
            DatasetError: the call failed.

        """
        rc, q = vrep.simxGetObjectQuaternion(self.cid, h, -1, B)
        self._ok(rc, "simxGetObjectQuaternion")
        return list(q)

    def bbox(self, h: int) -> tuple[np.ndarray, np.ndarray]:
        """The object's bounding box in its own frame (params 15..20): (min xyz, max xyz).

        Args:
            h: the object's handle.

        Returns:
            Two float arrays of shape (3,), m.

        Raises:
            DatasetError: a call failed.
        """
        vals = []
        for pid in range(15, 21):
            rc, v = vrep.simxGetObjectFloatParameter(self.cid, h, pid, B)
            self._ok(rc, f"simxGetObjectFloatParameter({pid})")
            vals.append(v)
        return np.array(vals[:3]), np.array(vals[3:])

    def float_param(self, h: int, pid: int) -> float:
        """A float parameter of an object (``simxGetObjectFloatParameter``).

        Args:
            h: the object's handle.
            pid: a ``sim_*floatparam_*`` id.

        Returns:
            The value (in the parameter's unit).

        Raises:
            DatasetError: the call failed.

        """
        rc, v = vrep.simxGetObjectFloatParameter(self.cid, h, pid, B)
        self._ok(rc, f"simxGetObjectFloatParameter({pid})")
        return float(v)

    def int_param(self, h: int, pid: int) -> int:
        """An integer parameter of an object (``simxGetObjectIntParameter``).

        Args:
            h: the object's handle.
            pid: a ``sim_*intparam_*`` id.

        Returns:
            The value.

        Raises:
            DatasetError: the call failed.

        """
        rc, v = vrep.simxGetObjectIntParameter(self.cid, h, pid, B)
        self._ok(rc, f"simxGetObjectIntParameter({pid})")
        return v

    def set_int_param(self, h: int, pid: int, value: int) -> None:
        """Set an integer parameter of an object (``simxSetObjectIntParameter``).

        Args:
            h: the object's handle.
            pid: a ``sim_*intparam_*`` id.
            value: the value.

        Raises:
            DatasetError: the call failed.

        """
        self._ok(vrep.simxSetObjectIntParameter(self.cid, h, pid, value, B),
                 f"simxSetObjectIntParameter({pid}, {value})")

    def set_state(self, joints: dict[int, float], places: dict[int, list[float]],
                  orientations: dict[int, list[float]] | None = None) -> None:
        """Joints teleported and objects moved in one batch (applied before the next read).

        Args:
            joints: joint handle -> position (rad or m).
            places: object handle -> ``[x, y, z]`` (m, world frame).
            orientations: object handle -> ``[alpha, beta, gamma]`` (rad, world frame), or None.
        """
        vrep.simxPauseCommunication(self.cid, True)
        for h, q in joints.items():
            vrep.simxSetJointPosition(self.cid, h, q, ONESHOT)
        for h, p in places.items():
            vrep.simxSetObjectPosition(self.cid, h, -1, p, ONESHOT)
        for h, e in (orientations or {}).items():
            vrep.simxSetObjectOrientation(self.cid, h, -1, e, ONESHOT)
        vrep.simxPauseCommunication(self.cid, False)

    def image(self, sensor: int) -> np.ndarray:
        """(h, w, 3) uint8 RGB, rows top-down.

        Args:
            sensor: the vision sensor's handle.

        Returns:
            The image (``simxGetVisionSensorImage``).

        Raises:
            DatasetError: the call failed.
        """
        rc, res, raw = vrep.simxGetVisionSensorImage(self.cid, sensor, 0, B)
        self._ok(rc, "simxGetVisionSensorImage")
        return np.asarray(raw, dtype=np.uint8).reshape(res[1], res[0], 3)[::-1]

    def coded(self, sensor: int) -> np.ndarray:
        """Handles (h, w) int32 seen by ``sensor`` now, rows top-down (the sensor is switched to
        colour-coded handles for this one image).

        Args:
            sensor: the vision sensor's handle.

        Returns:
            The (h, w) int32 array of handles (0xFFFFFF: background).

        Raises:
            DatasetError: the image could not be read.
        """
        vrep.simxSetObjectIntParameter(self.cid, sensor, RENDER_MODE, COLOR_CODED, ONESHOT)
        try:
            img = self.image(sensor)
        finally:
            vrep.simxSetObjectIntParameter(self.cid, sensor, RENDER_MODE, 0, ONESHOT)
        return decode_handles(img)

    def check_errors(self) -> None:
        """A oneshot command that failed (a joint without a motor, a bad position) shows here."""
        rc, errors = vrep.simxGetLastErrors(self.cid, B)
        if rc == vrep.simx_return_ok and errors:
            raise DatasetError("the server refused a command: " + "; ".join(errors))


# ---------------------------------------------------------------------------- the generator
@dataclass
class Options:
    out: Path
    classes: list[tuple[str, list[str]]]
    host: str = "127.0.0.1"
    port: int = 19999
    sensor: str = "kinect_rgb"
    joints: list[str] = field(default_factory=lambda: list(DEFAULT_JOINTS))
    pose: list[float] | None = None  # degrees; None: the arm is not moved
    pose_noise: float = 0.0  # degrees, uniform per joint
    place: list[str] = field(default_factory=list)
    surface: str | None = None  # "x0,x1,y0,y1,z" or a shape's name
    count: int = 100
    val_fraction: float = 0.2
    seed: int = 0
    min_box_pixels: int = MIN_BOX_PIXELS
    min_box_side: int = MIN_BOX_SIDE
    depth: bool = False
    depth_sensor: str = "kinect_depth"
    preview: int = 0
    image_format: str = "jpg"
    progress: bool = True


@dataclass
class Result:
    out: Path
    images: int
    labels: int  # boxes written
    empty: int  # images without a box
    seconds: float
    outside: int = 0  # objects placed where the sensor does not see the surface (no overlap)


def surface_area(scene: Scene, spec: str, margin: float) -> tuple[float, float, float, float, float]:
    """(x0, x1, y0, y1, z) from "x0,x1,y0,y1,z" (as given) or a shape's name (the top face of its
    world bounding box, shrunk by ``margin`` m each side).

    Args:
        scene: the connection.
        spec: ``"x0,x1,y0,y1,z"`` (m) or a shape's name.
        margin: m.

    Returns:
        ``(x0, x1, y0, y1, z)`` in m.

    Raises:
        DatasetError: bad numbers, or no such object.
    """
    if spec.count(",") == 4:
        x0, x1, y0, y1, z = parse_floats(spec, 5, "--surface")
        return x0, x1, y0, y1, z
    h = scene.handle(spec)
    lo, hi = scene.bbox(h)
    p, q = np.array(scene.position(h)), scene.quaternion(h)
    corners = np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                        for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    world = np.array([p + quat_rotate(q, c) for c in corners])
    wlo, whi = world.min(axis=0), world.max(axis=0)
    x0, x1, y0, y1 = wlo[0] + margin, whi[0] - margin, wlo[1] + margin, whi[1] - margin
    if x0 > x1 or y0 > y1:
        raise DatasetError(f"--surface {spec}: its top ({wlo[:2]}..{whi[:2]}) is smaller than the margin")
    return x0, x1, y0, y1, float(whi[2])


def generate(opts: Options) -> Result:
    """Write a YOLO data set (``simx-dataset``) from the running server's scene.

    For each image: the arm is posed and the objects placed at random (``opts``), the sensor's
    RGB image is taken, then its colour-coded-handles image of the same state, whose objects'
    pixels give the boxes. The scene's joints, objects and render mode are put back afterwards.

    Args:
        opts: what to make and where.

    Returns:
        What was written, and how long it took.

    Raises:
        DatasetError: bad options, no server, an unknown object, or a failed call.
    """
    if not opts.classes:
        raise DatasetError("name at least one class: --class NAME=OBJECT")
    if opts.count < 1:
        raise DatasetError("--count must be at least 1")
    if not 0.0 <= opts.val_fraction < 1.0:
        raise DatasetError("--val-fraction must be in [0, 1)")
    if opts.place and opts.surface is None:
        raise DatasetError("--place needs --surface")
    if opts.image_format not in ("jpg", "png"):
        raise DatasetError("--image-format is jpg or png")
    scene = Scene(opts.host, opts.port)
    try:
        return _generate(scene, opts)
    finally:
        scene.close()


def _generate(scene: Scene, opts: Options) -> Result:
    rng = np.random.default_rng(opts.seed)
    sensor = scene.handle(opts.sensor)
    class_handles = [[scene.handle(o) for o in objs] for _, objs in opts.classes]
    names = [n for n, _ in opts.classes]
    depth_sensor = scene.handle(opts.depth_sensor) if opts.depth else None
    joints = [scene.handle(j) for j in opts.joints] if opts.pose is not None else []
    if opts.pose is not None and len(opts.pose) != len(joints):
        raise DatasetError(f"--pose has {len(opts.pose)} angles for {len(joints)} joints")
    placed = [scene.handle(o) for o in opts.place]
    extents = {h: scene.bbox(h) for h in placed}
    # a named surface keeps the placed objects whole on its top: shrunk by their largest reach
    margin = max((float(np.abs(np.concatenate([lo[:2], hi[:2]])).max()) for lo, hi in extents.values()),
                 default=0.0)
    area = surface_area(scene, opts.surface, margin) if placed else None
    # height of each placed object's origin above the surface: it rests on it
    lift = {h: -float(lo[2]) + 1e-3 for h, (lo, hi) in extents.items()}

    # what to put back afterwards
    saved_joints = {h: scene.joint_position(h) for h in joints}
    saved_places = {h: scene.position(h) for h in placed}
    saved_orient = {h: scene.orientation(h) for h in placed}
    saved_mode = scene.int_param(sensor, RENDER_MODE)

    n_val = int(round(opts.count * opts.val_fraction))
    split_rng = np.random.default_rng([opts.seed, 1])  # views do not depend on --count/--val-fraction
    val_index = set(split_rng.choice(opts.count, size=n_val, replace=False).tolist()) if n_val else set()
    out = opts.out
    for split in ("train", "val"):
        (out / "images" / split).mkdir(parents=True, exist_ok=True)
        (out / "labels" / split).mkdir(parents=True, exist_ok=True)
    if opts.preview:
        (out / "preview").mkdir(parents=True, exist_ok=True)
    if opts.depth:
        (out / "saveImg" / "rgbImg").mkdir(parents=True, exist_ok=True)
        (out / "saveImg" / "depthImg").mkdir(parents=True, exist_ok=True)

    bar = _progress(opts.count, opts.progress)
    labels = empty = unseen = 0
    angle = scene.float_param(sensor, PERSPECTIVE_ANGLE)
    width0, height0 = scene.int_param(sensor, RESOLUTION_X), scene.int_param(sensor, RESOLUTION_Y)
    t0 = time.perf_counter()
    vrep.simxSynchronous(scene.cid, True)  # no step between the two renders of a view
    try:
        if saved_mode != 0:
            scene.set_int_param(sensor, RENDER_MODE, 0)
        for i in range(opts.count):
            target = {}
            if joints:
                noise = rng.uniform(-opts.pose_noise, opts.pose_noise, len(joints)) if opts.pose_noise else 0
                target = dict(zip(joints, np.radians(np.asarray(opts.pose) + noise).tolist()))
            places = {}
            if placed:  # where the sensor sees the surface at this pose: the pose first
                scene.set_state(target, {})
                footprint = view_footprint(scene.position(sensor), scene.quaternion(sensor), angle,
                                           width0, height0, area[4])
            for h in placed:
                x, y, seen = place_in_view(rng, area, footprint)
                unseen += not seen
                places[h] = [x, y, area[4] + lift[h]]
            scene.set_state(target, places)
            rgb = scene.image(sensor)
            handles = scene.coded(sensor)
            scene.check_errors()  # a refused oneshot set: nothing is written for this view
            found = boxes(handles, class_handles, opts.min_box_pixels, opts.min_box_side)
            height, width = handles.shape
            split = "val" if i in val_index else "train"
            stem = f"{i:06d}"
            bgr = np.ascontiguousarray(rgb[..., ::-1])
            _write(out / "images" / split / f"{stem}.{opts.image_format}", bgr)
            (out / "labels" / split / f"{stem}.txt").write_text(
                "".join(b.yolo(width, height) + "\n" for b in found))
            labels += len(found)
            empty += not found
            if i < opts.preview:
                _write(out / "preview" / f"{stem}.png", draw(bgr, found, names))
            if depth_sensor is not None:
                grey = scene.image(depth_sensor)[..., ::-1]  # as robotControl: BGR, top-down,
                _write(out / "saveImg" / "rgbImg" / f"{stem}_rgb.jpg", bgr)
                _write(out / "saveImg" / "depthImg" / f"{stem}_depth.jpg",
                       np.ascontiguousarray(255 - grey))  # ...inverted (near bright)
            bar.update(1)
    finally:
        bar.close()
        try:
            scene.set_state(saved_joints, saved_places, saved_orient)
            vrep.simxSetObjectIntParameter(scene.cid, sensor, RENDER_MODE, saved_mode, ONESHOT)
            vrep.simxGetPingTime(scene.cid)
        finally:
            vrep.simxSynchronous(scene.cid, False)
    seconds = time.perf_counter() - t0
    _write_yaml(out, names)
    return Result(out, opts.count, labels, empty, seconds, unseen)


def _write(path: Path, image: np.ndarray) -> None:
    if not cv2.imwrite(str(path), image):
        raise DatasetError(f"could not write {path}")


def _write_yaml(out: Path, names: list[str]) -> None:
    lines = [f"path: {out.resolve()}", "train: images/train", "val: images/val",
             f"nc: {len(names)}", "names:"]
    lines += [f"  {i}: {n}" for i, n in enumerate(names)]
    (out / "data.yaml").write_text("\n".join(lines) + "\n")


def _progress(total: int, enabled: bool):
    from tqdm import tqdm  # a client-side extra: simx_client imports without it

    return tqdm(total=total, unit="img", disable=not enabled, desc="simx-dataset")


# ---------------------------------------------------------------------------- command line
def _class(text: str) -> tuple[str, list[str]]:
    name, sep, objs = text.partition("=")
    if not sep or not name or not objs:
        raise argparse.ArgumentTypeError(f"--class {text!r}: expected NAME=OBJECT[,OBJECT...]")
    return name, objs.split(",")


def parser() -> argparse.ArgumentParser:
    """The command line of ``simx-dataset``.

    Returns:
        The parser.
    """
    p = argparse.ArgumentParser(
        prog="simx-dataset",
        description="Write a labelled YOLO data set (Ultralytics layout) from a running simx-server's scene: "
                    "boxes from the colour-coded-handles render of the same sensor in the same state.")
    p.add_argument("--host", default="127.0.0.1", help="server address, as simxStart (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=19999, help="server port (default 19999)")
    p.add_argument("--sensor", default="kinect_rgb", help="vision sensor (default kinect_rgb)")
    p.add_argument("--class", dest="classes", action="append", type=_class, default=[],
                   metavar="NAME=OBJECT[,OBJECT...]",
                   help="a class and the scene object(s) it is (repeatable; class ids in this order)")
    p.add_argument("--joints", default=",".join(DEFAULT_JOINTS), help="joints --pose sets, comma-separated")
    p.add_argument("--pose", default=None,
                   help=f"joint angles (deg) the views are taken around, e.g. {DEFAULT_POSE}; "
                        "omitted: the arm stays where it is")
    p.add_argument("--pose-noise", type=float, default=0.0, help="uniform noise per joint, +- deg (default 0)")
    p.add_argument("--place", action="append", default=[], metavar="OBJECT",
                   help="an object placed at a random spot of --surface in each view (repeatable)")
    p.add_argument("--surface", default=None,
                   help="where --place puts objects: x0,x1,y0,y1,z (m, world; write --surface=-0.5,... when it starts with a minus) or a shape's name (its top face)")
    p.add_argument("--count", type=int, default=100, help="images (default 100)")
    p.add_argument("--val-fraction", type=float, default=0.2, help="share of images in val (default 0.2)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--min-box-pixels", type=int, default=MIN_BOX_PIXELS,
                   help=f"visible pixels an object needs to be labelled (default {MIN_BOX_PIXELS})")
    p.add_argument("--min-box-side", type=int, default=MIN_BOX_SIDE,
                   help=f"pixels each side of a box needs (default {MIN_BOX_SIDE})")
    p.add_argument("--depth", action="store_true",
                   help="also save RGB + depth JPEG pairs as robotControl.py did (saveImg/rgbImg, saveImg/depthImg)")
    p.add_argument("--depth-sensor", default="kinect_depth", help="sensor of --depth (default kinect_depth)")
    p.add_argument("--preview", type=int, default=0, metavar="K", help="draw the boxes on the first K images (preview/)")
    p.add_argument("--image-format", default="jpg", choices=("jpg", "png"), help="image files (default jpg)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--out", default="dataset", help="output folder (default ./dataset)")
    return p


def main(argv: list[str] | None = None) -> int:
    """``simx-dataset``: :func:`generate` with the command line's options.

    Args:
        argv: the arguments, or None for ``sys.argv[1:]``.

    Returns:
        The process exit status: 0, or 2 with one line on stderr.
    """
    args = parser().parse_args(argv)
    try:
        opts = Options(
            out=Path(args.out), classes=args.classes, host=args.host, port=args.port, sensor=args.sensor,
            joints=[j for j in args.joints.split(",") if j],
            pose=parse_floats(args.pose, None, "--pose") if args.pose is not None else None,
            pose_noise=args.pose_noise, place=args.place, surface=args.surface, count=args.count,
            val_fraction=args.val_fraction, seed=args.seed, min_box_pixels=args.min_box_pixels,
            min_box_side=args.min_box_side, depth=args.depth, depth_sensor=args.depth_sensor,
            preview=args.preview, image_format=args.image_format, progress=not args.no_progress)
        result = generate(opts)
    except DatasetError as e:
        print(f"simx-dataset: {e}", file=sys.stderr)
        return 2
    rate = result.images / result.seconds if result.seconds > 0 else float("inf")
    print(f"simx-dataset: {result.images} images ({result.labels} boxes, {result.empty} without any) "
          f"in {result.seconds:.1f} s ({rate:.1f} images/s)")
    if result.empty:
        why = (f"{result.outside} placements fell where the sensor does not see the surface" if result.outside
               else "every object was placed in the sensor's view: hidden behind others or too small (--min-box-*)")
        print(f"simx-dataset: {result.empty} images without a box: {why}")
    print(f"data set: {result.out.resolve()}  (YOLO: {(result.out / 'data.yaml').resolve()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
