"""A scene's look for vision sensors (simx_server/sim/vision_look.py): MJCF scenes keep MuJoCo's
unless ``<text name="simx:scene:vision" data="look=vrep"/>`` asks for V-REP's (ambient light
only from the headlight, V-REP's default material on geoms without one, OpenGL's distant viewer)."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from simx_server.scene.simulation import Simulation  # noqa: E402

SCENE = """<mujoco>
  <visual><headlight ambient="0.2 0.2 0.2" diffuse="0.5 0.5 0.5" specular="0.3 0.3 0.3"/></visual>
  <worldbody>
    <light name="sun" directional="true" dir="0 0 -1" diffuse="0.4 0.4 0.4" specular="0.5 0.5 0.5"/>
    <geom type="box" size="0.5 0.5 0.05" pos="0 0 -0.05" rgba="0.6 0.4 0.2 1"/>
    <camera name="top" pos="0 0 1" resolution="16 16" projection="orthographic" fovy="0.5"/>
  </worldbody>
  {custom}
</mujoco>
"""


def centre(tmp_path, custom: str) -> np.ndarray:
    path = tmp_path / "look.xml"
    path.write_text(SCENE.format(custom=custom))
    sim = Simulation(path, realtime=False)
    try:
        (w, h), data = sim.vision.image_bytes(sim.world.resolve("top").handle, 0)
    finally:
        sim.close()
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[h // 2, w // 2].astype(int)


def test_mjcf_scenes_keep_mujocos_look_unless_they_ask_for_vreps(tmp_path):
    rgb = np.array([0.6, 0.4, 0.2])
    # MuJoCo: the headlight's ambient, diffuse and specular (0.5 x 0.3 with MuJoCo's default
    # material specular) plus the sun's diffuse and specular, both facing the surface
    mujoco_look = np.clip(0.2 * rgb + 0.5 * rgb + 0.4 * rgb + 0.5 * (0.3 + 0.5), 0, 1) * 255
    np.testing.assert_allclose(centre(tmp_path, ""), mujoco_look, atol=6)
    # V-REP: the headlight's ambient only, the sun, V-REP's default specular 0.25
    vrep_look = np.clip(0.2 * rgb + 0.4 * rgb + 0.25 * 0.5, 0, 1) * 255
    asked = '<custom><text name="simx:scene:vision" data="look=vrep"/></custom>'
    np.testing.assert_allclose(centre(tmp_path, asked), vrep_look, atol=6)


def test_a_look_simx_cannot_give_refuses_the_scene(tmp_path):
    with pytest.raises(ValueError, match="look='pov' is not one of mujoco, vrep"):
        centre(tmp_path, '<custom><text name="simx:scene:vision" data="look=pov"/></custom>')


GLOSSY = """<mujoco>
  <visual><headlight ambient="0.2 0.2 0.2" diffuse="0 0 0" specular="0 0 0"/></visual>
  <asset><material name="gloss" rgba="0.5 0.5 0.6 1" specular="0.5" shininess="0.375"/></asset>
  <worldbody>
    <light name="down" directional="true" dir="0 0 -1" diffuse="0.6 0.6 0.6" specular="0.6 0.6 0.6"/>
    <geom type="box" size="0.15 0.15 0.05" pos="0 0 -0.05" material="gloss"/>
    <geom type="box" size="0.15 0.15 0.05" pos="0.8 0 -0.05" material="gloss"/>
    <camera name="eye" pos="0 0 2" resolution="64 64" fovy="60"/>
  </worldbody>
  {custom}
</mujoco>
"""


def tiles(tmp_path, custom: str) -> tuple[np.ndarray, np.ndarray]:
    """The centre pixel of the tile under a perspective camera and of the one 22 degrees off its axis."""
    path = tmp_path / "glossy.xml"
    path.write_text(GLOSSY.format(custom=custom))
    sim = Simulation(path, realtime=False)
    try:
        (w, h), data = sim.vision.image_bytes(sim.world.resolve("eye").handle, 0)
    finally:
        sim.close()
    image = np.frombuffer(data, np.uint8).reshape(h, w, 3).astype(int)
    off = int(w / 2 + 0.8 / (2 * np.tan(np.radians(30))) * w / 2)  # world +x is image right
    return image[h // 2, w // 2], image[h // 2, off]


def test_vreps_look_keeps_a_highlight_across_a_perspective_view_and_mujocos_does_not(tmp_path):
    # V-REP (OpenGL's distant viewer): the light straight above gives both tiles its highlight
    centre, side = tiles(tmp_path, '<custom><text name="simx:scene:vision" data="look=vrep"/></custom>')
    want = np.clip(0.2 * np.array([0.5, 0.5, 0.6]) + 0.6 * np.array([0.5, 0.5, 0.6]) + 0.5 * 0.6, 0, 1) * 255
    np.testing.assert_allclose(centre, want, atol=3)
    np.testing.assert_allclose(side, want, atol=3)
    # MuJoCo's look keeps its local viewer: the tile off the axis loses most of its highlight
    centre, side = tiles(tmp_path, "")
    assert (centre - side).min() > 20, (centre, side)
