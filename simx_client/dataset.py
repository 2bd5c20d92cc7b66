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
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

import simx_client as vrep
from simx_client.dataset_labels import (  # noqa: F401 (the labelling API, re-exported)
    MIN_BOX_PIXELS, MIN_BOX_SIDE, VIEW_SHARE, Box, DatasetError, boxes, draw, parse_floats, place_in_view, quat_rotate,
    view_footprint,
)
from simx_client.dataset_scene import (  # noqa: F401 (the scene API and its constants, re-exported)
    B, BACKGROUND, COLOR_CODED, ONESHOT, PERSPECTIVE_ANGLE, RENDER_MODE, RESOLUTION_X, RESOLUTION_Y, Scene,
)
from simx_client.images import decode_handles, set_lazy_image_lists  # noqa: F401 (decode_handles: API)

DEFAULT_JOINTS = [f"UR5_joint{i}" for i in range(1, 7)]
DEFAULT_POSE = "90,-45,90,0,-100,0"  # the tutorial's DDPG start pose (deg): the ball in view


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
