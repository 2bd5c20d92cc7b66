"""Issue 12 part 8: a vision sensor sees the scene only, not MuJoCo's visualisation extras
(the dm_control quadruped's camera showed its rangefinder rays): no rays, no sites (simx's
dummies), no contact points, while the scene's geoms still show."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from simx_server.scene.simulation import Simulation  # noqa: E402

# Seen from above: a grey floor, a blue box resting on it (contacts), a rangefinder on a site
# beside the box casting its ray along +x over the floor, and a green marker site. The extras
# get colours nothing in the scene has: the ray magenta, contact points cyan.
SCENE = """
<mujoco>
  <visual>
    <rgba rangefinder="1 0 1 1" contactpoint="0 1 1 1"/>
    <scale contactwidth="0.3" contactheight="0.1"/>
    <headlight ambient="0.4 0.4 0.4" diffuse="0.6 0.6 0.6"/>
  </visual>
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.5 0.5 0.5 1"/>
    <body name="box" pos="0 0.4 0.1">
      <freejoint/>
      <geom type="box" size="0.1 0.1 0.1" rgba="0 0 1 1"/>
    </body>
    <body name="post" pos="-0.8 -0.3 0.3">  <!-- not the world body: its geoms are the ray's to hit -->
      <site name="ranger" zaxis="1 0 -0.2" size="0.02" rgba="0.5 0.5 0.5 1"/>
    </body>
    <site name="marker" pos="0.5 0.5 0.05" size="0.08" rgba="0 1 0 1"/>
    <camera name="cam" pos="0 0 2.2" resolution="128 128" fovy="60"/>
  </worldbody>
  <sensor><rangefinder name="range" site="ranger"/></sensor>
</mujoco>
"""


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "extras.xml"
    path.write_text(SCENE)
    s = Simulation(path, dt=0.05, realtime=False)
    s.world.step()  # the box rests on the floor: contacts exist
    yield s
    s.close()


def _pixels(img: np.ndarray, test) -> int:
    """How many pixels of an RGB image pass ``test(r, g, b)`` (int arrays)."""
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return int(test(r, g, b).sum())


def magenta(img: np.ndarray) -> int:
    return _pixels(img, lambda r, g, b: (r > 150) & (b > 150) & (g < 80))


def green(img: np.ndarray) -> int:
    return _pixels(img, lambda r, g, b: (g > 150) & (r < 80) & (b < 80))


def cyan(img: np.ndarray) -> int:
    return _pixels(img, lambda r, g, b: (g > 150) & (b > 150) & (r < 80))


def blue(img: np.ndarray) -> int:
    return _pixels(img, lambda r, g, b: (b > 150) & (r < 60) & (g < 60))


def default_render(sim: Simulation, option: mujoco.MjvOption) -> np.ndarray:
    """The same camera through MuJoCo's own Renderer and the given options (render thread)."""
    camera = sim.vision.specs[sim.world.resolve("cam").handle].camera

    def job():
        with mujoco.Renderer(sim.world.model, 128, 128) as r:
            r.update_scene(sim.world.data, camera=camera, scene_option=option)
            return r.render()[::-1].copy()

    return sim.vision.after(job).result()


def test_sensor_images_show_no_visualisation_extras(sim):
    (w, h), data = sim.vision.image_bytes(sim.world.resolve("cam").handle, 0)
    sensor = np.frombuffer(data, np.uint8).reshape(h, w, 3)
    option = mujoco.MjvOption()  # MuJoCo's defaults: rays and sites drawn
    option.flags[mujoco.mjtVisFlag.mjVIS_CONTACTPOINT] = True
    extras = default_render(sim, option)
    if os.environ.get("SIMX_SAVE_PNG"):  # look at them: SIMX_SAVE_PNG=/tmp pytest ...
        import zlib, struct  # noqa: E401

        def png(path, img):
            raw = b"".join(b"\0" + img[::-1][y].tobytes() for y in range(img.shape[0]))
            chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))  # noqa
            open(path, "wb").write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                                   + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
        png(f"{os.environ['SIMX_SAVE_PNG']}/sensor.png", sensor)
        png(f"{os.environ['SIMX_SAVE_PNG']}/extras.png", extras)
    # The extras are in view (so their absence below means something)...
    assert magenta(extras) > 20 and green(extras) > 20 and cyan(extras) > 5
    # ...and the sensor draws none of them, but the scene itself.
    assert (magenta(sensor), green(sensor), cyan(sensor)) == (0, 0, 0)
    assert blue(sensor) > 100 and blue(sensor) == pytest.approx(blue(extras), rel=0.3)


def test_grey_images_are_v_reps_integer_mean():
    """V-REP's grey image (options bit 0): (R + G + B) // 3 per pixel, by a table (exact)."""
    from simx_server.sim.vision_chain import grey_of as _grey

    img = np.random.default_rng(3).integers(0, 256, (64, 48, 3), dtype=np.uint8)
    expected = (img.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8)
    assert _grey(img).dtype == np.uint8 and np.array_equal(_grey(img), expected)


@pytest.mark.parametrize("shape, low, high", [((64, 48, 3), 0, 256), ((1, 1, 3), 0, 256), ((3, 7, 3), 250, 256),
                                              ((32, 32, 3), 9, 10)])
def test_the_default_packet_is_v_reps_per_pixel_statistics(shape, low, high):
    """V-REP's default vision packet (``sensorResult``): min, max and truncated average of the
    intensity ((R + G + B) // 3) and of each channel, / 255, then the depth's; computed from
    planes and histograms, it equals the plain per-pixel definition (a strided view too)."""
    from simx_server.sim.vision_chain import default_packet

    rng = np.random.default_rng(shape[0])
    img = rng.integers(low, high, (shape[0], 2 * shape[1], 3), dtype=np.uint8)[:, ::2]  # not contiguous
    depth = rng.random(shape[:2], dtype=np.float32)
    px = img.reshape(-1, 3).astype(np.int64)
    values = np.column_stack([px.sum(axis=1) // 3, px])  # intensity, R, G, B of each pixel
    stats = [values.min(axis=0), values.max(axis=0), values.sum(axis=0) // len(px)]
    depths = [depth.min(), depth.max(), np.float32(depth.astype(np.float64).mean())]
    expected = [v for k in range(3) for v in [float(np.float32(x / 255.0)) for x in stats[k]] + [float(depths[k])]]
    assert default_packet(img, depth) == expected
