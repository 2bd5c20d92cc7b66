"""simx-dataset (simx_client/dataset.py): YOLO labels from the colour-coded-handles render.

Against a real server on the bundled scene: at the tutorial pose the ball's box is the pinhole
projection of its sphere within 2 px; a ball hidden under the table top (inside the view, but
occluded) gets no label; 50 images from random poses and placements make the Ultralytics
layout, with labels that parse, data.yaml's names, previews and RGB+depth pairs. Then the pure
helpers (decoding, thresholds) and the import without tqdm.
"""

from __future__ import annotations

import math
import subprocess
import sys

import cv2
import numpy as np
import pytest

import vrep
from simx_client import dataset as D

try:
    from conftest import ROOT, SCENE, ServerProcess, free_port
except ImportError:  # tests/ imported as a package
    from tests.conftest import ROOT, SCENE, ServerProcess, free_port

B = vrep.simx_opmode_blocking
TUTORIAL_POSE = [90, -45, 90, 0, -100, 0]  # degrees (tests/sim/test_tutorial_pose.py)
BALL_RADIUS = 0.03  # m, the Sphere's geom in scenes/ur5_rg2_kinect.xml
W, H = 640, 480


@pytest.fixture(scope="module")
def srv():
    """A server whose simulation runs (asynchronously): the generator freezes it with
    synchronous mode while it works. Two ports: a process has one connection per address and
    port (as V-REP's), the tests' own client takes the second."""
    s = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port(), free_port()])
    yield s
    s.stop()


@pytest.fixture
def frozen(srv):
    """A client in synchronous mode (nothing steps while the test sets up and checks the
    scene), with the arm teleported to the tutorial pose; the ball and the arm are put back."""
    cid = vrep.simxStart("127.0.0.1", srv.ports[1], True, True, 5000, 5)
    assert cid >= 0
    assert vrep.simxSynchronous(cid, True) == 0
    h = {n: vrep.simxGetObjectHandle(cid, n, B)[1] for n in
         ["kinect_rgb", "Sphere", *D.DEFAULT_JOINTS]}
    ball_home = vrep.simxGetObjectPosition(cid, h["Sphere"], -1, B)[1]
    for j, a in zip(D.DEFAULT_JOINTS, TUTORIAL_POSE):
        assert vrep.simxSetJointPosition(cid, h[j], math.radians(a), B) == 0
    yield cid, h
    vrep.simxSetObjectPosition(cid, h["Sphere"], -1, ball_home, B)
    for j in D.DEFAULT_JOINTS:
        vrep.simxSetJointPosition(cid, h[j], 0.0, B)
    vrep.simxSynchronous(cid, False)
    vrep.simxFinish(cid)


def run(srv, out, *args: str) -> None:
    assert D.main(["--port", str(srv.port), "--out", str(out), "--no-progress", *args]) == 0


def labels(path) -> list[list[float]]:
    rows = [line.split() for line in path.read_text().splitlines()]
    assert all(len(r) == 5 for r in rows), rows
    return [[int(r[0])] + [float(v) for v in r[1:]] for r in rows]


def sphere_extent(p: list[float], radius: float, focal: float) -> tuple[float, float, float, float]:
    """Exact pinhole extent (u0, u1, v0, v1) in pixels of a sphere at ``p`` in V-REP sensor
    coordinates (looks along +z, +x left, +y up; u right, v down, edges at 0 and W/H): the
    image-vertical and image-horizontal planes through the eye tangent to the sphere."""
    x, y, z = p
    def span(a: float) -> tuple[float, float]:
        theta, alpha = math.atan2(a, z), math.asin(radius / math.hypot(a, z))
        return focal * math.tan(theta - alpha), focal * math.tan(theta + alpha)
    ax0, ax1 = span(x)
    ay0, ay1 = span(y)
    return W / 2 - ax1, W / 2 - ax0, H / 2 - ay1, H / 2 - ay0


def test_ball_box_is_its_pinhole_projection_within_2px(srv, frozen, tmp_path):
    cid, h = frozen
    rc, p = vrep.simxGetObjectPosition(cid, h["Sphere"], h["kinect_rgb"], B)
    rc2, angle = vrep.simxGetObjectFloatParameter(cid, h["kinect_rgb"], 1004, B)  # the larger (x) angle
    assert rc == rc2 == 0
    focal = (max(W, H) / 2) / math.tan(angle / 2)
    u0, u1, v0, v1 = sphere_extent(p, BALL_RADIUS, focal)

    run(srv, tmp_path, "--class", "ball=Sphere", "--pose", ",".join(map(str, TUTORIAL_POSE)),
        "--count", "1", "--val-fraction", "0")
    [[cls, cx, cy, bw, bh]] = labels(tmp_path / "labels" / "train" / "000000.txt")
    assert cls == 0
    x0, x1, y0, y1 = (cx - bw / 2) * W, (cx + bw / 2) * W, (cy - bh / 2) * H, (cy + bh / 2) * H
    for name, got, want in (("left", x0, u0), ("right", x1, u1), ("top", y0, v0), ("bottom", y1, v1)):
        assert abs(got - want) <= 2.0, (
            f"{name} edge of the ball's box at {got:.2f} px, the pinhole projection of the sphere "
            f"(sensor frame {np.round(p, 4).tolist()}) at {want:.2f} px; box {x0:.1f}..{x1:.1f} x "
            f"{y0:.1f}..{y1:.1f}, projection {u0:.1f}..{u1:.1f} x {v0:.1f}..{v1:.1f}")
    # the generator put the arm back where it found it (the tutorial pose) and the sensor's mode
    assert vrep.simxGetObjectIntParameter(cid, h["kinect_rgb"], 1017, B) == (0, 0)
    rc, q1 = vrep.simxGetJointPosition(cid, h["UR5_joint1"], B)
    assert abs(q1 - math.radians(90)) < 1e-6


def test_occluded_ball_has_no_label(srv, frozen, tmp_path):
    cid, h = frozen
    # under the table top (z 0.71..0.75 m), straight below where it rests: in the sensor's
    # field of view but hidden by the top
    rc, ball = vrep.simxGetObjectPosition(cid, h["Sphere"], -1, B)
    assert vrep.simxSetObjectPosition(cid, h["Sphere"], -1, [ball[0], ball[1], 0.45], B) == 0
    rc, p = vrep.simxGetObjectPosition(cid, h["Sphere"], h["kinect_rgb"], B)
    rc2, angle = vrep.simxGetObjectFloatParameter(cid, h["kinect_rgb"], 1004, B)
    focal = (W / 2) / math.tan(angle / 2)
    u0, u1, v0, v1 = sphere_extent(p, BALL_RADIUS, focal)
    assert 0 < u0 < u1 < W and 0 < v0 < v1 < H, "the hidden ball should be inside the view"

    run(srv, tmp_path, "--class", "ball=Sphere", "--class", "table=Table",
        "--pose", ",".join(map(str, TUTORIAL_POSE)), "--count", "1", "--val-fraction", "0")
    rows = labels(tmp_path / "labels" / "train" / "000000.txt")
    assert [r[0] for r in rows] == [1], f"only the table is labelled: {rows}"


def test_fifty_images_make_the_yolo_layout(srv, tmp_path):
    out = tmp_path / "ds"
    run(srv, out, "--class", "ball=Sphere", "--class", "gripper=RG2,RG2_finger1,RG2_finger2",
        "--pose", ",".join(map(str, TUTORIAL_POSE)), "--pose-noise", "4",
        "--place", "Sphere", "--surface=-0.05,0.2,0.65,0.9,0.75",
        "--count", "50", "--val-fraction", "0.2", "--seed", "7", "--preview", "3", "--depth")
    train = sorted(p.stem for p in (out / "images" / "train").iterdir())
    val = sorted(p.stem for p in (out / "images" / "val").iterdir())
    assert (len(train), len(val)) == (40, 10)
    assert sorted(train + val) == [f"{i:06d}" for i in range(50)]
    for split, stems in (("train", train), ("val", val)):
        assert sorted(p.stem for p in (out / "labels" / split).iterdir()) == stems
        assert all(p.suffix == ".jpg" for p in (out / "images" / split).iterdir())
    rows = [r for p in (out / "labels").glob("*/*.txt") for r in labels(p)]
    balls = [r for r in rows if r[0] == 0]
    assert len(balls) >= 25, f"the ball on the table in view in most images ({len(balls)} of 50)"
    assert all(0 <= v <= 1 for r in rows for v in r[1:]) and all(r[3] > 0 and r[4] > 0 for r in rows)
    img = cv2.imread(str(out / "images" / "train" / f"{train[0]}.jpg"))
    assert img.shape == (H, W, 3)
    yaml = (out / "data.yaml").read_text()
    assert "train: images/train" in yaml and "val: images/val" in yaml and "nc: 2" in yaml
    assert "  0: ball" in yaml and "  1: gripper" in yaml
    assert sorted(p.name for p in (out / "preview").iterdir()) == [f"{i:06d}.png" for i in range(3)]
    assert len(list((out / "saveImg" / "rgbImg").glob("*_rgb.jpg"))) == 50
    assert len(list((out / "saveImg" / "depthImg").glob("*_depth.jpg"))) == 50
    # the same seed gives the same views, whatever the count and split
    again = tmp_path / "again"
    run(srv, again, "--class", "ball=Sphere", "--class", "gripper=RG2,RG2_finger1,RG2_finger2",
        "--pose", ",".join(map(str, TUTORIAL_POSE)), "--pose-noise", "4",
        "--place", "Sphere", "--surface=-0.05,0.2,0.65,0.9,0.75",
        "--count", "5", "--val-fraction", "0", "--seed", "7")
    for i in range(5):  # the ball's box exactly; the gripper's fingers, which the simulation moves
        # between the two runs (the RG2 settling), within 2 pixels
        a, b = (labels(next(root.glob(f"labels/*/{i:06d}.txt"))) for root in (again, out))
        assert [r for r in a if r[0] == 0] == [r for r in b if r[0] == 0]
        assert len(a) == len(b) and all(ra[0] == rb[0] and np.allclose(ra[1:], rb[1:], atol=2 / W)
                                        for ra, rb in zip(a, b)), (a, b)


def test_errors_name_the_cause_and_exit_2(srv, tmp_path, capsys):
    base = ["--port", str(srv.port), "--out", str(tmp_path), "--no-progress", "--count", "2"]
    assert D.main(base + ["--class", "ball=Nope"]) == 2
    assert "no object 'Nope'" in capsys.readouterr().err
    assert D.main(base + ["--class", "ball=Sphere", "--pose", "1e12,0,0,0,0,0"]) == 2
    assert "refused a command: simxSetJointPosition" in capsys.readouterr().err
    assert not list(tmp_path.glob("images/*/*"))
    assert D.main(base + ["--class", "ball=Sphere", "--place", "Sphere"]) == 2
    assert "--place needs --surface" in capsys.readouterr().err


def test_boxes_thresholds_and_decoding():
    handles = np.full((20, 30), D.BACKGROUND, dtype=np.int32)
    handles[2:8, 3:12] = 5  # 6 x 9 = 54 px
    handles[10:13, 0:30] = 7  # a 3 px high strip: below the side threshold
    handles[15, 15] = 9  # one pixel
    found = D.boxes(handles, [[5], [7], [9], [42]])
    assert [(b.cls, b.x0, b.y0, b.x1, b.y1, b.pixels) for b in found] == [(0, 3, 2, 12, 8, 54)]
    assert found[0].yolo(30, 20) == "0 0.250000 0.250000 0.300000 0.300000"
    assert [b.cls for b in D.boxes(handles, [[5], [7]], min_pixels=1, min_side=1)] == [0, 1]
    assert [b.cls for b in D.boxes(handles, [[7, 9]], min_pixels=1, min_side=1)] == [0, 0]  # a box per object
    rgb = np.array([[[255, 255, 255], [5, 1, 0], [0, 0, 1]]], dtype=np.uint8)
    assert D.decode_handles(rgb).tolist() == [[D.BACKGROUND, 261, 65536]]


def test_simx_client_imports_without_tqdm():
    code = ("import sys; sys.modules['tqdm'] = None\n"
            "import simx_client, vrep, simx_client.dataset as d\n"
            "try:\n    d._progress(1, True)\nexcept ImportError:\n    print('ok')\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr


def test_named_surface_is_the_top_of_its_bounding_box(srv):
    scene = D.Scene("127.0.0.1", srv.port)
    try:
        area = D.surface_area(scene, "Table", 0.03)
        assert D.surface_area(scene, "0,1,2,3,0.5", 0.03) == (0, 1, 2, 3, 0.5)
    finally:
        scene.close()
    # the table top: centre (0.1, 0.35), half sizes 0.6 x 0.7, top at z 0.75 (the scene's MJCF)
    np.testing.assert_allclose(area, (-0.47, 0.67, -0.32, 1.02, 0.75), atol=1e-3)


def test_the_readmes_command_puts_the_ball_where_the_kinect_sees_it(srv, tmp_path, capsys):
    """Issue 20 part 4: --surface Table covers more than the Kinect sees; objects are now placed
    where the sensor sees the surface at each drawn pose (21 of 30 images were empty before)."""
    out = tmp_path / "readme"
    run(srv, out, "--class", "ball=Sphere", "--pose", "90,-45,90,0,-100,0", "--pose-noise", "4",
        "--place", "Sphere", "--surface", "Table", "--count", "30", "--seed", "1")
    files = list((out / "labels").glob("*/*.txt"))
    full = [p for p in files if p.read_text().strip()]
    assert len(files) == 30 and len(full) >= 27, f"{30 - len(full)} of 30 images without the ball"
    printed = capsys.readouterr().out
    assert "30 images" in printed
    assert ("without a box" not in printed) == (len(full) == 30)


def test_a_class_of_several_objects_gives_a_box_per_object(srv, tmp_path):
    """--class gripper=RG2,RG2_finger1,RG2_finger2 gave one box joining both fingertips, as wide
    as the image (the Kinect sits between them): each object is an instance, as YOLO means."""
    out = tmp_path / "gripper"
    run(srv, out, "--class", "gripper=RG2,RG2_finger1,RG2_finger2", "--pose", "90,-45,90,0,-100,0",
        "--count", "3", "--seed", "2")
    rows = [r for p in (out / "labels").glob("*/*.txt") for r in labels(p)]
    assert rows and all(r[3] < 0.9 for r in rows), rows  # no box spans the image
    per_image = [len(labels(p)) for p in (out / "labels").glob("*/*.txt")]
    assert max(per_image) >= 2  # the two fingers, each its own box
