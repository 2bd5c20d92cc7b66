"""Vision sensors draw no shadows or reflections unless their custom text asks for them
(V-REP's default vision-sensor renderer had neither)."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from simx_server.scene.simulation import Simulation  # noqa: E402

# A white box on a mirror floor under a low sun from +x: its shadow falls on the floor at -x.
# A red ball floats above a corner: seen from above, its reflection shows nearer the centre.
SCENE = """
<mujoco>
  <visual><quality shadowsize="1024" offsamples="0"/><headlight ambient="0.2 0.2 0.2" diffuse="0 0 0"/></visual>
  <asset><material name="mirror" reflectance="0.8" rgba="0.3 0.3 0.3 1"/></asset>
  <worldbody>
    <light name="sun" directional="true" castshadow="true" pos="2 0 1" dir="-1 0 -0.4" diffuse="1 1 1"/>
    <geom name="floor" type="plane" size="2 2 0.1" material="mirror"/>
    <body name="box" pos="0 0 0.2"><geom type="box" size="0.2 0.2 0.2" rgba="1 1 1 1"/></body>
    <body name="ball" pos="0.8 0.8 1"><geom type="sphere" size="0.12" rgba="1 0 0 1"/></body>
    <camera name="plain" pos="0 0 3" resolution="128 128" fovy="60"/>
    <camera name="shadowed" pos="0 0 3" resolution="128 128" fovy="60"/>
    <camera name="mirrored" pos="0 0 3" resolution="128 128" fovy="60"/>
  </worldbody>
  <custom>
    <text name="simx:shadowed" data="shadows=true"/>
    <text name="simx:mirrored" data="reflections=true"/>
  </custom>
</mujoco>
"""


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "shadows.xml"
    path.write_text(SCENE)
    s = Simulation(path, dt=0.05, realtime=False)
    yield s
    s.close()


def image(sim: Simulation, name: str) -> np.ndarray:
    (w, h), data = sim.vision.image_bytes(sim.world.resolve(name).handle, 0)
    return np.frombuffer(data, np.uint8).reshape(h, w, 3).astype(int)


def test_shadows_and_reflections_only_where_asked(sim):
    plain, shadowed, mirrored = (image(sim, n) for n in ("plain", "shadowed", "mirrored"))
    specs = {n: sim.vision.specs[sim.world.resolve(n).handle] for n in ("plain", "shadowed", "mirrored")}
    assert (specs["plain"].shadows, specs["plain"].reflections) == (False, False)
    assert specs["shadowed"].shadows and specs["mirrored"].reflections
    # The floor strip just beside the box, on the side away from the sun (-x: image columns
    # left of the box), is darker only when the sensor draws shadows.
    strip = (slice(56, 72), slice(28, 40))
    assert shadowed[strip].mean() < plain[strip].mean() - 10
    red = lambda img: int((img[..., 0] - img[..., 1] > 30).sum())  # noqa: E731
    assert red(plain) > 20 and red(shadowed) == red(plain)
    assert red(mirrored) > red(plain) + 10  # the ball and its reflection


def test_a_bad_flag_names_the_sensor(tmp_path):
    path = tmp_path / "bad.xml"
    path.write_text(SCENE.replace('data="shadows=true"', 'data="shadows=maybe"'))
    with pytest.raises(ValueError, match="shadowed.*shadows"):
        Simulation(path, dt=0.05, realtime=False)


# A white square seen at an angle on black, lit by ambient light only (every pixel of a face
# the same colour), in a scene that keeps MuJoCo's default 4 samples per pixel.
EDGES = """
<mujoco>
  <visual><headlight ambient="1 1 1" diffuse="0 0 0" specular="0 0 0"/></visual>
  <worldbody>
    <body pos="0 0 0" euler="0 0 0.3"><geom type="box" size="0.3 0.3 0.01" rgba="1 1 1 1"/></body>
    <camera name="cam" pos="0 0 2" resolution="64 64" fovy="45"/>
  </worldbody>
</mujoco>
"""


def test_sensor_images_are_not_anti_aliased(tmp_path):
    """V-REP's sensors draw into a framebuffer without samples (CFrameBufferObject): a
    slanted edge is a staircase of the face's colour and the background's, nothing between."""
    path = tmp_path / "edges.xml"
    path.write_text(EDGES)
    s = Simulation(path, dt=0.05, realtime=False)
    try:
        # the render thread sets the model's offsamples to 0 while it makes a renderer (under
        # GL_LOCK, as the server waits for before it serves): read the scene's value after that
        assert s.vision.wait_ready(60)
        assert s.world.model.vis.quality.offsamples == 4  # the scene asks for multisampling
        img = image(s, "cam")
        assert s.world.model.vis.quality.offsamples == 4  # and keeps it (the viewer's)
    finally:
        s.close()
    grey = img.sum(axis=2)
    lit, dark = grey.max(), grey.min()
    assert set(np.unique(grey)) == {lit, dark}  # no blended pixel on its slanted edges
    assert lit > 600 and (grey == lit).sum() > 500  # the square
    assert dark < 60 and (grey == dark).sum() > 500  # the background
