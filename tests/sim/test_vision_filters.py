"""The filter steps of :mod:`simx_server.sim.vision_filters` against references written here with
numpy, OpenCV and colorsys (V-REP's semantics: simVision's functions of the same names)."""

from __future__ import annotations

import colorsys
import math

import cv2
import numpy as np
import pytest

from simx_server.sim import vision_filters as VF

RNG = np.random.default_rng(7)


def run(text: str, rgb: np.ndarray, depth: np.ndarray | None = None, state: VF.FilterState | None = None):
    return VF.apply_chain(VF.parse_chain(text, "cam"), rgb, depth, state or VF.FilterState())


def out_bytes(work: np.ndarray) -> np.ndarray:
    """simVision's setVisionSensorImage: value x 255.1, truncated."""
    return np.clip(work * np.float32(255.1), 0, 255).astype(np.uint8)


@pytest.fixture()
def rgb():
    return RNG.integers(0, 256, (24, 32, 3), dtype=np.uint8)


def test_parse_chain_names_what_is_wrong():
    assert VF.parse_chain("sensorImgToWorkImg;edgeDetectionOnWorkImg(0.2);workImgToSensorImg", "cam") == (
        VF.Step("sensorImgToWorkImg"), VF.Step("edgeDetectionOnWorkImg", (0.2,)), VF.Step("workImgToSensorImg"))
    with pytest.raises(ValueError, match="'cam': unknown filter step 'coordinatesFromWorkImg"):
        VF.parse_chain("coordinatesFromWorkImg(32,32,1)", "cam")
    with pytest.raises(ValueError, match="takes 1 finite numbers"):
        VF.parse_chain("edgeDetectionOnWorkImg", "cam")
    with pytest.raises(ValueError, match="takes 1 finite"):
        VF.parse_chain("edgeDetectionOnWorkImg(nan)", "cam")


def test_identity_flips_and_invert(rgb):
    work = rgb / np.float32(255.0)
    assert np.array_equal(run("sensorImgToWorkImg;workImgToSensorImg", rgb).image, out_bytes(work))
    assert np.array_equal(run("sensorImgToWorkImg;horizontalFlipWorkImg;workImgToSensorImg", rgb).image,
                          out_bytes(cv2.flip(work, 1)))
    assert np.array_equal(run("sensorImgToWorkImg;verticalFlipWorkImg;workImgToSensorImg", rgb).image,
                          out_bytes(cv2.flip(work, 0)))
    # V-REP's inversion: scale and offset colours by -1, then +1
    inverted = run("sensorImgToWorkImg;scaleAndOffsetWorkImg(0,0,0,-1,-1,-1,1,1,1,1);workImgToSensorImg", rgb)
    assert np.array_equal(inverted.image, out_bytes(1 - work))
    assert run("sensorImgToWorkImg", rgb).image is None  # no output step: the rendered image stays


def test_intensity_scale_grey_and_colour(rgb):
    mean = rgb.astype(np.float32).sum(axis=2) / 255 / 3
    grey = run("sensorImgToWorkImg;intensityScaleOnWorkImg(0.2,0.8,1);workImgToSensorImg", rgb).image
    assert np.array_equal(grey[..., 0], grey[..., 2])
    assert np.abs(grey[..., 0].astype(int) - out_bytes(0.2 + 0.6 * mean)).max() <= 1
    colour = run("sensorImgToWorkImg;intensityScaleOnWorkImg(0,1,0);workImgToSensorImg", rgb).image
    # simVision's colour table: black, blue, red, yellow at 0, 1/3, 2/3, 1
    k = np.unravel_index(np.argmax(mean), mean.shape)
    i = float(mean[k])
    expect = np.interp(i, [0, 1 / 3, 2 / 3, 1], [0, 0, 1, 1]), np.interp(i, [0, 1 / 3, 2 / 3, 1], [0, 0, 0, 1]), \
        np.interp(i, [0, 1 / 3, 2 / 3, 1], [0, 1, 0, 0])
    assert np.abs(colour[k].astype(int) - [int(v * 255.1) for v in expect]).max() <= 1


def test_selective_colour_rgb_and_hsl(rgb):
    kept = run("sensorImgToWorkImg;selectiveColorOnWorkImg(0.5,0.5,0.5,0.25,0.25,0.25,1,1,0);workImgToSensorImg", rgb)
    inside = np.all(np.abs(rgb / 255.0 - 0.5) <= 0.25, axis=2)
    assert np.array_equal(kept.image, np.where(inside[..., None], out_bytes(rgb / np.float32(255)), 0))
    # HSL: keep reds (hue 0 +- 0.05, any saturation and lightness); removed parts go to buffer 1
    text = ("sensorImgToWorkImg;selectiveColorOnWorkImg(0,0.5,0.5,0.05,0.5,0.5,0,1,1);workImgToSensorImg;"
            "buffer1ToWorkImg;workImgToSensorImg")
    st = VF.FilterState()
    removed = run(text, rgb, state=st).image
    hue = np.array([[colorsys.rgb_to_hls(*(p / 255.0))[0] for p in row] for row in rgb])
    red = (hue <= 0.05 + 1e-6) | (hue >= 0.95 - 1e-6)
    grey = np.all(rgb == rgb[..., :1], axis=2)
    check = ~grey & (np.abs(hue - 0.05) > 1e-4) & (np.abs(hue - 0.95) > 1e-4)  # away from the bounds
    assert np.array_equal(removed[check], np.where(red[check][:, None], 0, out_bytes(rgb[check] / np.float32(255))))


def test_edge_detection_and_sharpen_match_a_bordered_3x3_reference():
    img = np.zeros((20, 30, 3), np.uint8)
    img[5:15, 8:20] = 200
    work = img / np.float32(255.0)

    def ref(kernel):  # simVision's filter3x3RgbImage: in-image neighbours, rescaled by 9 / their count
        pad = np.pad(work, ((1, 1), (1, 1), (0, 0)))
        ones = np.pad(np.ones(work.shape[:2]), 1)
        acc, cnt = np.zeros_like(work, dtype=np.float64), np.zeros(work.shape[:2])
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                acc += kernel[dy + 1, dx + 1] * pad[1 + dy:21 + dy, 1 + dx:31 + dx]
                cnt += ones[1 + dy:21 + dy, 1 + dx:31 + dx]
        return acc / (cnt / 9)[..., None]

    edge = np.full((3, 3), -3.0)
    edge[1, 1] = 24
    expect = (ref(edge).mean(axis=2) > 0.3)
    out = run("sensorImgToWorkImg;edgeDetectionOnWorkImg(0.3);workImgToSensorImg", img).image
    assert np.array_equal(out[..., 0] > 0, expect) and expect.sum() > 30 and not expect[10, 14]
    sharp = np.full((3, 3), -0.1111)
    sharp[1, 1] = 1.8888
    out = run("sensorImgToWorkImg;sharpenWorkImg;workImgToSensorImg", img).image
    assert np.abs(out.astype(int) - out_bytes(np.clip(ref(sharp), 0, 1).astype(np.float32))).max() <= 1


def test_buffers_depth_and_uniform(rgb):
    depth = RNG.random(rgb.shape[:2], dtype=np.float32)
    st = VF.FilterState()
    res = run("sensorDepthMapToWorkImg;workImgToBuffer1;uniformImgToWorkImg(0.25,0.5,1);addBuffer1ToWorkImg;"
              "workImgToSensorImg;buffer1ToWorkImg;workImgToSensorDepthMap", rgb, depth, st)
    assert np.array_equal(res.image, out_bytes(np.minimum(np.float32([0.25, 0.5, 1.0]) + depth[..., None], 1)))
    assert np.allclose(res.depth, depth)
    # buffers live on: the next frame reads buffer 1 as the last left it
    again = run("buffer1ToWorkImg;workImgToSensorImg", rgb, None, st)
    assert np.array_equal(again.image, out_bytes(np.repeat(depth[..., None], 3, axis=2)))


def test_blob_packet_of_a_rectangle_and_a_turned_one():
    img = np.zeros((60, 80, 3), np.uint8)
    img[10:20, 30:50] = 255  # rows 10..19 (from the bottom), columns 30..49
    res = run("sensorImgToWorkImg;blobDetectionOnWorkImg(0.5,0,1);workImgToSensorImg", img)
    n, six, size, angle, x, y, w, h = res.packets[0]
    assert (n, six) == (1, 6) and size == pytest.approx(200 / 4800) and angle == pytest.approx(0, abs=1e-6)
    # V-REP: the outline's span (19 x 9 pixels) and its centre + half a pixel
    assert (x, y, w, h) == pytest.approx((40 / 80, 15 / 60, 19 / 80, 9 / 60))
    assert np.all(res.image[12, 35] == [204, 0, 0])  # the first blob's colour: red x 0.8
    turned = np.zeros((120, 120), np.uint8)
    box = cv2.boxPoints(((60, 50), (60, 20), 30.0))
    cv2.fillPoly(turned, [np.round(box).astype(np.int32)], 255)
    two = np.repeat(turned[..., None], 3, axis=2)
    two[100:110, 5:15] = 255  # a second, smaller blob above: reported second (scan order from the bottom)
    res = run("sensorImgToWorkImg;blobDetectionOnWorkImg(0.5,0.005,0)", two)
    packet = res.packets[0]
    assert packet[0] == 2 and len(packet) == 14
    # turned 30 degrees: V-REP's search (0 to 67.5 degrees) finds the box at 30 or 60 (sides swapped)
    assert abs(math.sin(2 * packet[3])) == pytest.approx(math.sin(math.radians(60)), abs=0.05)
    assert packet[4:6] == pytest.approx([60.5 / 120, 50.5 / 120], abs=1 / 120)
    assert sorted([packet[6] * 120, packet[7] * 120]) == pytest.approx([19, 59], abs=2.5)
    assert packet[10:12] == pytest.approx([10 / 120, 105 / 120], abs=1 / 120)
    tiny = run("sensorImgToWorkImg;blobDetectionOnWorkImg(0.5,0.01,0)", two).packets[0]
    assert tiny[0] == 1  # the 100-pixel blob is under 1 % of the image


def test_binary_packet_and_trigger():
    img = np.zeros((40, 40, 3), np.uint8)
    img[0:10, 0:40] = 255  # the bottom quarter
    hit = "sensorImgToWorkImg;binaryWorkImg(0.5,0.25,0.05,0.5,0.1,0.125,0.1,0,0.2,1,1)"
    res = run(hit, img)
    proportion, cx, cy, angle, roundness = res.packets[0]
    assert proportion == pytest.approx(0.25) and cx == pytest.approx(19.5 / 40) and cy == pytest.approx(4.5 / 40)
    assert angle == pytest.approx(0, abs=1e-6) and roundness < 0.1 and res.trigger
    assert not run(hit.replace("0.25,0.05", "0.5,0.05"), img).trigger


def test_rotate_and_resize_take_the_nearest_pixel_about_the_centre(rgb):
    """simVision's rotateWorkImg / resizeWorkImg, against their loops written out."""
    h, w = rgb.shape[:2]
    work = rgb / np.float32(255.0)

    def ref(source):  # (i, j) -> where the pixel comes from, in pixels (C's int() truncation)
        out = np.zeros_like(work)
        for j in range(h):
            for i in range(w):
                x, y = (int(v) for v in source(i + 0.5 - w / 2, j + 0.5 - h / 2))
                if 0 <= x < w and 0 <= y < h:
                    out[j, i] = work[y, x]
        return out_bytes(out)

    c, s = math.cos(-0.3), math.sin(-0.3)
    rotated = run("sensorImgToWorkImg;rotateWorkImg(0.3);workImgToSensorImg", rgb).image
    assert np.array_equal(rotated, ref(lambda dx, dy: (w / 2 + dx * c - dy * s, h / 2 + dx * s + dy * c)))
    resized = run("sensorImgToWorkImg;resizeWorkImg(1.5,0.75);workImgToSensorImg", rgb).image
    assert np.array_equal(resized, ref(lambda dx, dy: (w / 2 + dx / 1.5, h / 2 + dy / 0.75)))
