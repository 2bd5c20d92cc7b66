"""Each ``simVision`` function (simx_server/api/simvision/) called as a script calls it, on a
sensor's work image, against references written here with numpy and plain loops that follow
CoppeliaRobotics/simVision's ``sourceCode/simVision.cpp`` (the plug-in's loops, not simx's code).

The scene: a passive 32x24 sensor ``ext`` (images written by the test), a perspective 40x30
sensor ``cam`` and an orthographic one ``ortho``, both 1.5 m above a floor with a box on it,
looking down (near 0.5 m, far 2.5 m)."""

from __future__ import annotations

import colorsys
import math

import numpy as np
import pytest

from simx_client.protocol import ArgumentError, ObjectTypeError
from simx_server.api import script_sim
from simx_server.scene.simulation import Simulation
from simx_server.sim import vision_blobs

SCENE = """<mujoco model="simvision">
  <worldbody>
    <light pos="0 0 3" dir="0 0 -1"/>
    <geom name="floor" type="plane" size="3 3 0.1" rgba="0.5 0.5 0.5 1"/>
    <body name="box" pos="0.2 0.1 0.2"><geom type="box" size="0.2 0.15 0.2" rgba="0.9 0.2 0.1 1"/></body>
    <camera name="ext" pos="-2 0 1" resolution="32 24"/>
    <camera name="cam" pos="0 0 1.5" xyaxes="1 0 0 0 1 0" fovy="60" resolution="40 30"/>
    <camera name="ortho" pos="0 0 1.5" xyaxes="1 0 0 0 1 0" projection="orthographic" fovy="1.2"
            resolution="40 30"/>
  </worldbody>
  <custom>
    <text name="simx:ext" data="image=external"/>
    <text name="simx:cam" data="near=0.5 far=2.5"/>
    <text name="simx:ortho" data="near=0.5 far=2.5"/>
  </custom>
</mujoco>
"""
RNG = np.random.default_rng(11)
F32 = np.float32


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    path = tmp_path_factory.mktemp("simvision") / "scene.xml"
    path.write_text(SCENE)
    s = Simulation(path, realtime=False)
    ext = s.world.resolve("ext").handle
    sim = script_sim(s.world, ext, s.signals, simulation=s)
    yield s, sim, sim.context.simvision
    s.close()


def h_of(s, name: str) -> int:
    return s.world.resolve(name).handle


def load(rig, rgb: np.ndarray) -> np.ndarray:
    """Write ``rgb`` into ``ext`` and read it into the work image; the work image as the plug-in
    makes it (bytes / 255)."""
    s, sim, sv = rig
    h = h_of(s, "ext")
    sim.setVisionSensorImg(h, rgb.tobytes())
    sv.sensorImgToWorkImg(h)
    return rgb / F32(255.0)


def work(rig, name: str = "ext") -> np.ndarray:
    s = rig[0]
    return s.vision.work_state(h_of(s, name)).work.copy()


def buffer(rig, k: int, name: str = "ext") -> np.ndarray:
    s = rig[0]
    return s.vision.work_state(h_of(s, name)).buffers[k].copy()


def out_bytes(img: np.ndarray) -> np.ndarray:
    return (np.clip(img, 0, 1) * F32(255.1)).astype(np.uint8)


def image(n=(24, 32)) -> np.ndarray:
    return RNG.integers(0, 256, (*n, 3), dtype=np.uint8)


def test_read_write_and_the_work_image_dropped(rig):
    """sensorImgToWorkImg / workImgToSensorImg round trip (outside a callback the passive
    sensor's image is written); the work image is dropped unless asked or a buffer was used;
    sim.handle_self is the script's sensor; other objects are refused."""
    s, sim, sv = rig
    h = h_of(s, "ext")
    rgb = image()
    ref = load(rig, rgb)
    assert np.array_equal(work(rig), ref)
    assert sv.horizontalFlipWorkImg(sim.handle_self) is False  # the plug-in's result of a step
    assert sv.workImgToSensorImg(h) is False
    img, res = sim.getVisionSensorImg(h)
    assert res == [32, 24] and img == out_bytes(ref[:, ::-1]).tobytes()
    with pytest.raises(ArgumentError, match="work image not initialized"):
        sv.horizontalFlipWorkImg(h)
    load(rig, rgb)
    sv.workImgToSensorImg(h, False)
    sv.verticalFlipWorkImg(h)  # kept
    sv.workImgToBuffer2(h)
    sv.workImgToSensorImg(h)  # a buffer was used: kept
    assert np.array_equal(work(rig), ref[::-1])
    with pytest.raises(ObjectTypeError, match="not a vision sensor"):
        sv.sensorImgToWorkImg(h_of(s, "box"))


def test_depth_in_and_out_and_a_write_lasts_while_the_state_does(rig):
    s, sim, sv = rig
    h = h_of(s, "cam")
    depth = s.vision.depth(h)
    sv.sensorDepthMapToWorkImg(h)
    assert np.array_equal(work(rig, "cam"), np.repeat(depth[..., None], 3, axis=2))
    sv.uniformImgToWorkImg(h, [0.25, 0.5, 0.75])
    sv.workImgToSensorDepthMap(h)
    assert np.allclose(s.vision.depth(h), 0.5)
    s.world.changed()  # the world's state changed: the sensor is rendered again
    assert np.array_equal(s.vision.depth(h), depth)


def test_buffers_and_their_arithmetic(rig):
    s, sim, sv = rig
    h = h_of(s, "ext")
    s.vision.drop_work_state(h)  # (what the tests before left)
    a, b = load(rig, image()), image() / F32(255.0)
    sv.workImgToBuffer1(h)
    sv.buffer2ToWorkImg(h)  # unused buffer 2: black
    assert not work(rig).any()
    sv.uniformImgToWorkImg(h, [0.5, 0.25, 1.0])
    u = np.broadcast_to(F32([0.5, 0.25, 1.0]), a.shape)
    sv.workImgToBuffer2(h)
    sv.swapBuffers(h)
    assert np.array_equal(buffer(rig, 0), u) and np.array_equal(buffer(rig, 1), a)
    sv.buffer2ToWorkImg(h)
    sv.swapWorkImgWithBuffer1(h)
    assert np.array_equal(work(rig), u) and np.array_equal(buffer(rig, 0), a)
    sv.addBuffer1ToWorkImg(h)
    assert np.array_equal(work(rig), np.minimum(u + a, 1))
    sv.subtractBuffer1FromWorkImg(h)
    assert np.array_equal(work(rig), np.maximum(np.minimum(u + a, 1) - a, 0))
    load(rig, (b * 255).astype(np.uint8))
    b = work(rig)
    sv.multiplyWorkImgWithBuffer1(h)
    assert np.allclose(work(rig), np.minimum(b * a, 1))
    sv.addWorkImgToBuffer1(h)
    sv.subtractWorkImgFromBuffer1(h)
    assert np.allclose(buffer(rig, 0), np.maximum(np.minimum(a + b * a, 1) - b * a, 0))


def _moved(src: np.ndarray, where) -> np.ndarray:
    """Each pixel (i, j) takes the source pixel where(i, j) gives (C's int() of it), black outside."""
    h, w = src.shape[:2]
    out = np.zeros_like(src)
    for j in range(h):
        for i in range(w):
            x, y = (int(v) for v in where(i, j))
            if 0 <= x < w and 0 <= y < h:
                out[j, i] = src[y, x]
    return out


def test_geometry(rig):
    s, sim, sv = rig
    h = h_of(s, "ext")
    a = load(rig, image())
    sv.horizontalFlipWorkImg(h)
    assert np.array_equal(work(rig), a[:, ::-1])
    a = load(rig, image())
    sv.shiftWorkImg(h, [0.25, -0.1], False)  # 8 pixels right, 2 (of 24: -2.4 rounded) down, no wrap
    ref = np.zeros_like(a)
    ref[:-2, 8:] = a[2:, :-8]
    assert np.array_equal(work(rig), ref)
    a = load(rig, image())
    sv.shiftWorkImg(h, [-0.1, 0.5], True)
    assert np.array_equal(work(rig), np.roll(a, (12, -3), axis=(0, 1)))
    a = load(rig, image())
    sv.rotateWorkImg(h, 0.4)
    c, sn = math.cos(-0.4), math.sin(-0.4)
    ref = _moved(a, lambda i, j: (16 + (i + 0.5 - 16) * c - (j + 0.5 - 12) * sn,
                                  12 + (i + 0.5 - 16) * sn + (j + 0.5 - 12) * c))
    assert np.array_equal(work(rig), ref)
    a = load(rig, image())
    sv.resizeWorkImg(h, [0.7, 1.6])
    assert np.array_equal(work(rig), _moved(a, lambda i, j: (16 + (i + 0.5 - 16) / 0.7, 12 + (j + 0.5 - 12) / 1.6)))
    with pytest.raises(ArgumentError, match="scaling must not be 0"):
        sv.resizeWorkImg(h, [0, 1])
    with pytest.raises(ArgumentError, match="table of 2 numbers"):
        sv.shiftWorkImg(h, [0.1], True)


def _filtered(img: np.ndarray, m: np.ndarray) -> np.ndarray:
    """simVision's filter3x3RgbImage / filter5x5RgbImage: the in-image neighbours weighted by
    ``m`` (rows = y), the sum divided by (their count / n^2)."""
    n, h, w = m.shape[0], *img.shape[:2]
    r = n // 2
    out = np.zeros(img.shape)
    for j in range(h):
        for i in range(w):
            acc, cnt = np.zeros(3), 0
            for l in range(-r, r + 1):
                for k in range(-r, r + 1):
                    if 0 <= i + k < w and 0 <= j + l < h:
                        acc += img[j + l, i + k] * m[l + r, k + r]
                        cnt += 1
            out[j, i] = acc / (cnt / (n * n))
    return out


def test_convolutions_sharpen_and_edges(rig):
    s, sim, sv = rig
    h = h_of(s, "ext")
    a = load(rig, image())
    sv.matrix3x3OnWorkImg(h, 1, 1.0)  # no matrix: the plug-in's Gaussian (sigma 2)
    g = np.exp(-np.add.outer(np.arange(-1, 2) ** 2, np.arange(-1, 2) ** 2) / 8.0)
    assert np.allclose(work(rig), np.clip(_filtered(a, g / g.sum()), 0, 1), atol=1e-5)
    a = load(rig, image())
    m5 = RNG.normal(0, 0.1, (5, 5))
    sv.matrix5x5OnWorkImg(h, 2, 0.5, m5.ravel().tolist())
    assert np.allclose(work(rig), np.clip(_filtered(_filtered(a, 0.5 * m5), 0.5 * m5), 0, 1), atol=1e-5)
    a = load(rig, image())
    sv.sharpenWorkImg(h)
    sharp = np.full((3, 3), -0.1111)
    sharp[1, 1] = 1.8888
    assert np.allclose(work(rig), np.clip(_filtered(a, sharp), 0, 1), atol=1e-5)
    a = load(rig, image())
    sv.edgeDetectionOnWorkImg(h, 0.4)
    edge = np.full((3, 3), -3.0)
    edge[1, 1] = 24
    ref = _filtered(a, edge).mean(axis=2) > 0.4
    assert np.array_equal(work(rig)[..., 0] > 0, ref) and 0 < ref.sum() < ref.size
    with pytest.raises(ArgumentError, match="passes must be at most"):
        sv.matrix3x3OnWorkImg(h, 10_000, 1.0)


def test_cuts_normalize_intensity_and_colours(rig):
    s, sim, sv = rig
    h = h_of(s, "ext")
    a = load(rig, image())
    sv.rectangularCutWorkImg(h, [0.5, 0.25], True)
    dy, dx = np.mgrid[0:24, 0:32] + 0.5 - np.array([12, 16])[:, None, None]
    out = (np.abs(dx) > 8) | (np.abs(dy) > 3)
    assert np.array_equal(work(rig), np.where(out[..., None], 0, a))
    assert np.array_equal(buffer(rig, 0), np.where(out[..., None], a, 0))
    a = load(rig, image())
    sv.circularCutWorkImg(h, 0.5, False)
    assert np.array_equal(work(rig), np.where((dx * dx + dy * dy > 36)[..., None], 0, a))
    a = load(rig, image()) * F32(0.5) + F32(0.2)
    sv.scaleAndOffsetWorkImg(h, [0, 0, 0], [0.5, 0.5, 0.5], [0.2, 0.2, 0.2], True)
    sv.normalizeWorkImg(h)
    assert np.allclose(work(rig), (a - a.min()) / (a.max() - a.min()), atol=1e-6)
    a = load(rig, image())
    sv.intensityScaleOnWorkImg(h, 0.8, 0.2, True)
    assert np.allclose(work(rig), (0.8 - 0.6 * a.mean(axis=2))[..., None].repeat(3, axis=2), atol=1e-6)
    a = load(rig, image())
    sv.selectiveColorOnWorkImg(h, [0.5, 0.5, 0.5], [0.3, 0.3, 0.3], True, False, True)  # remove greys
    inside = np.all(np.abs(a - 0.5) <= 0.3, axis=2)
    assert np.array_equal(work(rig), np.where(inside[..., None], 0, a))
    assert np.array_equal(buffer(rig, 0), np.where(inside[..., None], a, 0))
    # HSL: lightness x 0.5 + 0.25
    a = load(rig, image())
    sv.scaleAndOffsetWorkImg(h, [0, 0, 0], [1, 1, 0.5], [0, 0, 0.25], False)
    hls = [colorsys.rgb_to_hls(*p) for p in a.reshape(-1, 3)]
    ref = np.array([colorsys.hls_to_rgb(hh, 0.25 + 0.5 * ll, ss) for hh, ll, ss in hls]).reshape(a.shape)
    assert np.allclose(work(rig), ref, atol=1e-4)


def test_colour_segmentation_follows_the_plugins_scan(rig):
    s, sim, sv = rig
    h = h_of(s, "ext")
    palette = np.array([[0.9, 0.1, 0.1], [0.1, 0.8, 0.2], [0.2, 0.2, 0.9], [0.5, 0.5, 0.5]])
    pick = RNG.integers(0, 4, (24, 32))
    rgb = np.clip((palette[pick] + RNG.normal(0, 0.06, (24, 32, 3))) * 255, 0, 255).astype(np.uint8)
    a = load(rig, rgb).reshape(-1, 3).astype(np.float64)
    sv.colorSegmentationOnWorkImg(h, 0.25)
    good, ref = [], a.copy()
    for i, p in enumerate(a):  # the plug-in's loop: the first colour kept within the distance
        for c in good:
            if ((p - c) ** 2).sum() < 0.25 ** 2:
                ref[i] = c
                break
        else:
            good.append(p)
    assert np.allclose(work(rig).reshape(-1, 3), ref, atol=1e-6) and 4 <= len(good) < 60


def test_changed_pixels_against_the_plugins_loop(rig):
    s, sim, sv = rig
    h = h_of(s, "ext")
    s.vision.drop_work_state(h)
    first = image()
    load(rig, first)
    assert sv.changedPixelsOnWorkImg(h, 0.2)[0] is False  # buffer 2 black: every lit pixel changed
    before = buffer(rig, 1)[..., 0].astype(np.float64)
    second = first.copy()
    second[5:9, 10:20] = 255 - second[5:9, 10:20]
    a = load(rig, second)
    trig, packet = sv.changedPixelsOnWorkImg(h, 0.2)
    ref, ref_work = [], np.full(a.shape[:2], 0.5)
    for j in range(24):
        for i in range(32):
            now = float(a[j, i].astype(np.float64).sum()) / 3.0
            was = before[j, i]
            diff = now - was
            if abs(diff) / (was if was != 0 else 0.001) >= 0.2:
                ref += [1.0 if diff > 0 else -1.0, float(i), float(j)]
                ref_work[j, i] = 1.0 if diff > 0 else 0.0
    assert trig is False and np.frombuffer(packet, "<f4").tolist() == ref and len(ref) > 30
    assert np.array_equal(work(rig)[..., 0], ref_work.astype(F32))


def draw_line(img: np.ndarray, col, x0: int, y0: int, x1: int, y1: int) -> None:
    """simVision's drawLine, written out: a Bresenham walk, the end pixel left out."""
    h, w = img.shape[:2]
    x, y, dx, dy = x0, y0, x1 - x0, y1 - y0
    ix, iy = (-1 if dx < 0 else 1), (-1 if dy < 0 else 1)
    if abs(dx) >= abs(dy):
        p = abs(dx)
        while x != x1:
            p -= abs(dy)
            if 0 <= x < w and 0 <= y < h:
                img[y, x] = col
            if p < 0:
                y, p = y + iy, p + abs(dx)
            x += ix
    else:
        p = abs(dy)
        while y != y1:
            p -= abs(dx)
            if 0 <= x < w and 0 <= y < h:
                img[y, x] = col
            if p < 0:
                x, p = x + ix, p + abs(dy)
            y += iy


def test_overlay_lines_walk_as_the_plugins():
    img, ref = np.zeros((30, 40, 3), F32), np.zeros((30, 40, 3), F32)
    lines = RNG.integers(-8, 48, (60, 4)).tolist() + [[5, 5, 5, 5], [0, 29, 39, 0], [39, 0, 0, 29]]
    vision_blobs.draw_lines(img, [v for line in lines for v in line], (1.0, 0.5, 0.25))
    for x0, y0, x1, y1 in lines:
        draw_line(ref, (1.0, 0.5, 0.25), x0, y0, x1, y1)
    assert np.array_equal(img, ref)


def test_binary_and_blob_packets_and_their_overlays(rig):
    s, sim, sv = rig
    h = h_of(s, "ext")
    rgb = np.zeros((24, 32, 3), np.uint8)
    rgb[8:18, 10:30] = 200  # rows 8..17 from the bottom, columns 10..29
    rgb[2:4, 2:4] = 200  # 4 pixels: under the blobs' minimum size
    load(rig, rgb)
    trig, packet = sv.binaryWorkImg(h, 0.5, 0.27, 0.05, 0.6, 0.05, 0.5, 0.1, 0.1, 0.1, 1, True, [0, 1, 0])
    ys, xs = np.nonzero(rgb[..., 0])
    cx, cy = xs.mean(), ys.mean()
    a_, b_, c_ = ((xs - cx) ** 2).sum(), 2 * ((xs - cx) * (ys - cy)).sum(), ((ys - cy) ** 2).sum()
    d = math.hypot(b_, a_ - c_)  # second moments: the axis of least inertia, and their ratio
    angle = 0.5 * math.acos((a_ - c_) / d) * (-1 if b_ < 0 else 1)
    i_max, i_min = 0.5 * (a_ + c_) + 0.5 * d, 0.5 * (a_ + c_) - 0.5 * d
    p = np.frombuffer(packet, "<f4")
    assert p.tolist() == pytest.approx([len(xs) / 768, cx / 32, cy / 24, angle, i_min / i_max], abs=1e-6)
    assert trig is True and 0.05 < angle < 0.2  # the small square turns the axis a little
    ref = (rgb[..., :1] > 0).repeat(3, axis=2).astype(F32)
    length = 0.3 - i_min / i_max * 0.25
    draw_line(ref, (0, 1, 0), int(32 * (cx / 32 - math.cos(angle) * length)),
              int(24 * (cy / 24 - math.sin(angle) * length)), int(32 * (cx / 32 + math.cos(angle) * length)),
              int(24 * (cy / 24 + math.sin(angle) * length)))
    px, py = int(cx + 0.5), int(cy + 0.5)
    for line in ((px, py - 4, px, py + 4), (px - 4, py, px + 4, py)):
        draw_line(ref, (0, 1, 0), *line)
    assert np.array_equal(work(rig), ref)
    # blobs: the small one is blacked out; the rectangle's box drawn corner to corner
    a = load(rig, rgb)
    trig, packet = sv.blobDetectionOnWorkImg(h, 0.5, 0.01, False, [0, 0, 1])
    p = np.frombuffer(packet, "<f4")
    assert trig is False and p.tolist() == pytest.approx([1, 6, 200 / 768, 0, 20 / 32, 13 / 24, 19 / 32, 9 / 24])
    ref = a.copy()
    ref[2:4, 2:4] = 0
    corners = [(29, 17), (10, 17), (10, 8), (29, 8)]
    for (x0, y0), (x1, y1) in zip(corners, corners[1:] + corners[:1]):
        draw_line(ref, (0, 0, 1), x0, y0, x1, y1)
    assert np.array_equal(work(rig), ref)


def points_ref(work, nx, ny, angular, persp, near, far, xa, size, velodyne=None):
    """coordinatesFromWorkImg's (and with ``velodyne`` = the vertical angle, velodyneDataFromWorkImg's)
    loops written out, in the sensor's frame: (n, 4) points."""
    h, w = work.shape[:2]
    ya = xa
    if w > h:
        ya = 2 * math.atan(math.tan(xa / 2) / (w / h))
    else:
        xa = 2 * math.atan(math.tan(xa / 2) * (w / h))

    def depth(col, row):
        return near + float(work[row, col].astype(np.float64).sum()) / 3.0 * (far - near)

    def clamp(v, z):
        length = math.sqrt(sum(c * c for c in v))
        return [*(c / length * far for c in v), far] if length > far else [*v, length]

    spread = (lambda n, a: [(-a / 2 + k * a / (n - 1)) if n > 1 else 0.0 for k in range(n)])
    out = []
    if velodyne is not None:
        for xd in spread(nx, xa):
            tx = math.tan(xd) * 0.5 / math.tan(xa / 2)
            col = min(max(int((0.5 - tx) * (w - 0.5)), 0), w - 1)
            for yd in spread(ny, velodyne):
                ty = math.tan(yd) / math.cos(xd) * 0.5 / math.tan(ya / 2)
                row = min(max(int((ty + 0.5) * (h - 0.5)), 0), h - 1)
                z = depth(col, row)
                out.append(clamp([tx * 2 * math.tan(xa / 2) * z, ty * 2 * math.tan(ya / 2) * z, z], z))
        return np.array(out)
    xs, ys = (size, size / (w / h)) if w > h else (size * (w / h), size)
    for yd in (spread(ny, ya) if persp else spread(ny, ys)):
        for xd in (spread(nx, xa) if persp else spread(nx, xs)):
            if not persp:
                col, row = int((1 - (xd + xs / 2) / xs) * (w - 0.5)), int((yd + ys / 2) / ys * (h - 0.5))
                z = depth(col, row)
                out.append([xd, yd, z, z])
            elif angular:
                tx, ty = math.tan(xd) * 0.5 / math.tan(xa / 2), math.tan(yd) * 0.5 / math.tan(ya / 2)
                z = depth(int((0.5 - tx) * (w - 0.5)), int((ty + 0.5) * (h - 0.5)))
                out.append(clamp([tx * 2 * math.tan(xa / 2) * z, ty * 2 * math.tan(ya / 2) * z, z], z))
            else:
                z = depth(int((0.5 - xd / xa) * (w - 0.5)), int((0.5 + yd / ya) * (h - 0.5)))
                out.append(clamp([math.tan(xa / 2) * xd / (xa / 2) * z, math.tan(ya / 2) * yd / (ya / 2) * z, z], z))
    return np.array(out)


@pytest.mark.parametrize("name,angular", [("cam", True), ("cam", False), ("ortho", False)])
def test_coordinates_from_a_depth_map(rig, name, angular):
    """The plug-in's grid of points; in the world's frame the floor's points lie at z = 0 and the
    box's top at 0.4 m."""
    s, sim, sv = rig
    h = h_of(s, name)
    sv.sensorDepthMapToWorkImg(h)
    sv.workImgToBuffer1(h)  # colours: the depth as grey
    trig, packet, colours = sv.coordinatesFromWorkImg(h, [9, 7], angular, True)
    p = np.frombuffer(packet, "<f4")
    persp = name == "cam"
    xa = s.world.model.cam_fovy[s.vision.spec(h).camera]
    angle = 2 * math.atan(math.tan(math.radians(xa) / 2) * 40 / 30)
    ref = points_ref(work(rig, name), 9, 7, angular, persp, 0.5, 2.5, angle, 1.2 * 40 / 30)
    assert trig is False and p[:2].tolist() == [9, 7]
    assert np.allclose(p[2:].reshape(-1, 4), ref, atol=1e-5)
    assert len(colours) == 63 * 3 + 3
    world = np.frombuffer(sv.coordinatesFromWorkImg(h + 0x800000, [9, 7], angular)[1], "<f4")[2:].reshape(-1, 4)
    heights = {float(v) for v in np.round(world[:, 2].astype(float), 2)}
    assert heights == {0.0, 0.4}


def test_velodyne_data_from_a_depth_map(rig):
    s, sim, sv = rig
    h = h_of(s, "cam")
    sv.sensorDepthMapToWorkImg(h)
    trig, packet = sv.velodyneDataFromWorkImg(h, [8, 5], 0.5)
    angle = 2 * math.atan(math.tan(math.radians(30)) * 40 / 30)
    ref = points_ref(work(rig, "cam"), 8, 5, True, True, 0.5, 2.5, angle, 0, velodyne=0.5)
    assert np.allclose(np.frombuffer(packet, "<f4")[2:].reshape(-1, 4), ref, atol=1e-5)
    world = np.frombuffer(sv.velodyneDataFromWorkImg(h + 0x800000, [8, 5], 0.5)[1], "<f4")[2:].reshape(-1, 4)
    assert {float(v) for v in np.round(world[:, 2].astype(float), 2)} == {0.0, 0.4}
