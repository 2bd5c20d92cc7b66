"""Depth frames: each plane drawn as one quad (depth_frames.flat_planes), not MuJoCo's lighting
grid: the same depths, the same edges, for infinite planes with and without a material's
``texrepeat`` and for a finite, tilted one; a frame's depths do not depend on the camera
drawn before it; no colour is written (depth_frames.colour_mask), and colour frames drawn
after one are as before."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402

from simx_server.scene.simulation import Simulation  # noqa: E402
from simx_server.sim import vision  # noqa: E402
from simx_server.sim.depth_frames import flat_planes  # noqa: E402

# An infinite floor whose material repeats its texture 3 x 5 times per metre, an infinite wall
# without a material at the left, a finite tilted plane, a box; a wide camera low over the floor sees the
# floor out to MuJoCo's far plane (the grid's edge at the sides) and the wall.
SCENE = """
<mujoco>
  <visual><quality offsamples="0"/><map znear="0.01" zfar="4"/></visual>
  <statistic extent="2" center="0 0 0"/>
  <asset><material name="tiles" texrepeat="3 5" rgba="0.5 0.5 0.5 1"/></asset>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.1" material="tiles"/>
    <geom name="wall" type="plane" size="0 0 0.1" pos="-3 0 0" euler="0 90 0"/>
    <geom name="ramp" type="plane" size="0.6 0.4 0.1" pos="0.3 1.2 0.3" euler="30 20 0"/>
    <body name="box" pos="-0.4 1 0.2"><geom type="box" size="0.2 0.2 0.2"/></body>
    <camera name="wide" pos="0.2 -0.5 0.4" xyaxes="1 0 0 0 0.3 1" resolution="160 120" fovy="100"/>
    <camera name="down" pos="0 1 2.5" resolution="160 120" fovy="70"/>
    <camera name="flat" pos="0 1 3" projection="orthographic" resolution="160 120" fovy="4"/>
  </worldbody>
  <custom>
    <text name="simx:wide" data="near=0.05 far=7.9 image=depth"/>
    <text name="simx:down" data="near=0.05 far=3 image=depth"/>
    <text name="simx:flat" data="near=0.05 far=3 image=depth"/>
  </custom>
</mujoco>
"""


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "planes.xml"
    path.write_text(SCENE)
    s = Simulation(path, dt=0.05, realtime=False)
    yield s
    s.close()


def depths(sim: Simulation, name: str) -> np.ndarray:
    sim.world.changed()  # a new state: the frame is drawn again, not taken from the cache
    return sim.vision.depth(sim.world.resolve(name).handle)


@pytest.mark.parametrize("camera", ["wide", "down"])
def test_depth_with_flat_planes_equals_the_grid(sim, monkeypatch, camera):
    flat = depths(sim, camera)
    with monkeypatch.context() as m:
        m.setattr(vision, "flat_planes", lambda scene, model, data: 0)  # MuJoCo's own plane grid
        grid = depths(sim, camera)
    assert flat.shape == grid.shape
    # The frame shows planes, near and far (not all background, not all one plane).
    assert 0.0 < grid.min() and (grid < 1.0).mean() > 0.5
    if camera == "wide":
        assert (grid == 1.0).sum() > 0  # beyond the far plane: the sky
    # Within rounding of the rasteriser (normalised depth; far - near is metres), but for a
    # pixel or two on an edge of a plane (the wide camera sees the floor's grid end at the
    # side), which the quads' different rounding puts on the other side.
    off = np.abs(flat - grid) > 1e-5
    assert off.sum() <= 2
    assert np.abs(flat - grid)[~off].max() < 1e-5
    assert ((flat == 1.0) != (grid == 1.0)).sum() <= off.sum()


def test_flat_planes_gives_each_plane_its_grid_extent(sim):
    m = sim.world.model
    scene = mujoco.MjvScene(m, maxgeom=100)
    mujoco.mjv_updateScene(m, sim.world.data, mujoco.MjvOption(), None, mujoco.MjvCamera(),
                           mujoco.mjtCatBit.mjCAT_ALL, scene)
    planes = {scene.geoms[i].objid: scene.geoms[i] for i in range(scene.ngeom)
              if scene.geoms[i].type == mujoco.mjtGeom.mjGEOM_PLANE}
    assert flat_planes(scene, m, sim.world.data) == 3
    zfar = 4 * 2  # map.zfar x extent
    cells = mujoco.mjMAXPLANEGRID

    def infinite(step: float) -> float:
        return (2.1 * zfar + 2 * step) / cells * (cells // 2)

    floor, wall, ramp = (planes[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, n)] for n in ("floor", "wall", "ramp"))
    assert floor.size[:2] == pytest.approx([infinite(2 / 3), infinite(2 / 5)])
    assert wall.size[:2] == pytest.approx([infinite(2.1 * zfar / (cells - 2))] * 2)
    assert ramp.size[:2] == pytest.approx([0.6, 0.4])
    assert all(g.dataid == -1 for g in (floor, wall, ramp))


def primitives(sim: Simulation, name: str, kind: str) -> int:
    """Primitives GL draws for one ``kind`` frame of camera ``name`` (a GL query on the render
    thread, which owns the context)."""
    from OpenGL import GL

    v = sim.vision
    spec = v.spec(sim.world.resolve(name).handle)

    def count() -> int:
        query = int(np.ravel(GL.glGenQueries(1))[0])
        try:
            GL.glBeginQuery(GL.GL_PRIMITIVES_GENERATED, query)
            v._draw(v._thread, sim.world.model, sim.world.data, spec, kind)
            GL.glEndQuery(GL.GL_PRIMITIVES_GENERATED)
            return int(GL.glGetQueryObjectuiv(query, GL.GL_QUERY_RESULT))
        finally:
            GL.glDeleteQueries(1, [query])

    return v.after(count).result()


def test_depth_frame_draws_no_plane_grid(sim):
    # The floor's grid is 200 x 200 quads (two triangles each), lit per vertex in a colour
    # frame; a depth frame draws 16 quads a plane, the box, and nothing else.
    assert primitives(sim, "down", "rgb") > 200 * 200 * 2
    assert primitives(sim, "down", "depth") < 1000


def test_depth_does_not_depend_on_the_camera_drawn_before(sim):
    # mjv_updateScene centres an infinite plane on the previous frame's camera; the depth frame
    # centres it on its own, so the same state gives the same depths whatever was drawn between.
    # (Both cameras have one size: one renderer, one MjvScene, draws them in turn.)
    depths(sim, "down")
    after_down = depths(sim, "wide")
    assert np.array_equal(depths(sim, "wide"), after_down)


def test_depth_frame_writes_no_colour_and_leaves_colour_frames_as_they_were(sim, monkeypatch):
    from simx_server.sim import depth_frames

    assert depth_frames.colour_mask() is not None  # found on this GL platform
    down, wide = sim.world.resolve("down").handle, sim.world.resolve("wide").handle
    sim.world.changed()
    reference = sim.vision._frame(down, "rgb").result()
    other = sim.vision._frame(wide, "rgb").result()  # the same renderer (one size) draws both
    masked = depths(sim, "down")  # (a new state, the same scene)
    # Drawn after the depth frame: colour written again (else it would show the wide view).
    assert np.array_equal(sim.vision._frame(down, "rgb").result(), reference)
    assert not np.array_equal(other, reference)
    monkeypatch.setattr(depth_frames, "_GL_COLOR_MASK", [None])  # colour written, as MuJoCo does
    assert np.array_equal(depths(sim, "down"), masked)


@pytest.mark.parametrize("camera", ["wide", "down", "flat"])
def test_depth_read_back_equals_mujoco_renderers(sim, camera):
    # draw_depth against mujoco.Renderer.render's own depth path (colour written, float64
    # copies, rows flipped by a copy) on the same renderer and scene: equal, value for value,
    # for perspective and orthographic cameras.
    v = sim.vision
    spec = v.spec(sim.world.resolve(camera).handle)

    def both() -> tuple[np.ndarray, np.ndarray]:
        r = v._thread.renderer(sim.world.model, spec.width, spec.height)
        r.enable_depth_rendering()
        try:
            r.update_scene(sim.world.data, camera=spec.camera, scene_option=v._thread.option)
            assert bool(r.scene.camera[0].orthographic) == (camera == "flat")
            ours = r.render()
            return ours, mujoco.Renderer.render(r)
        finally:
            r.disable_depth_rendering()

    ours, theirs = v.after(both).result()
    assert ours.dtype == theirs.dtype == np.float32 and ours.shape == theirs.shape
    assert np.array_equal(ours, theirs) and 0 < theirs.min() < theirs.max()
