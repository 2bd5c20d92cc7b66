"""V-REP's colour-coded handles render mode (``sim_visionintparam_render_mode``, 1017, mode 2).

In that mode a vision sensor's image shows, at each pixel, the handle of the shape seen there
(``h = r + 256 g + 65536 b``) and white (0xFFFFFF) where no shape is (simx_server.sim.handle_render).
In process with the bundled scene at the tutorial pose (``kinect_rgb`` sees the ball ``Sphere``
on the table) and with a small scene of its own (unnamed bodies, a world geom, the MJCF
setting), then through a real server with ``import vrep``.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import vrep
from simx_client.protocol import ObjectTypeError, UnsupportedError
from simx_server.commands import parameters as cmd_parameters
from simx_server.sim import handle_render as HR
from simx_server.scene.simulation import Simulation
from simx_server.sim.world import SHAPE

try:
    from conftest import SCENE
except ImportError:  # tests/ imported as a package
    from tests.conftest import SCENE

TUTORIAL_POSE = [90, -45, 90, 0, -100, 0]  # degrees (tests/sim/test_tutorial_pose.py)
B = vrep.simx_opmode_blocking
RES_X, RES_Y = 640, 480

SMALL = """<mujoco model="handles">
  <worldbody>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.5 0.5 0.5 1"/>
    <body name="box" pos="0 0 0.5">
      <geom type="box" size="0.1 0.1 0.1"/>
      <body pos="0.3 0 0">
        <geom name="unnamed_body_geom" type="sphere" size="0.1"/>
      </body>
    </body>
    <body name="cam_mount" pos="0.15 0 3">
      <camera name="top" fovy="40" resolution="64 48"/>
    </body>
  </worldbody>
  <custom><text name="simx:top" data="render_mode=handles"/></custom>
</mujoco>
"""


def tutorial_sim() -> Simulation:
    """The bundled scene with the arm teleported to the tutorial pose (the ball in view)."""
    sim = Simulation(SCENE, dt=0.05, realtime=False)
    w = sim.world
    for i, a in enumerate(TUTORIAL_POSE, 1):
        w.set_joint_position(w.resolve(f"UR5_joint{i}").handle, math.radians(a))
    mujoco.mj_forward(w.model, w.data)
    w.changed()
    return sim


@pytest.fixture(scope="module")
def tutorial():
    sim = tutorial_sim()
    yield sim
    sim.close()


def red_mask(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[:, :, i].astype(int) for i in range(3))
    return (r > 150) & (g < 80) & (b < 80)


def test_ball_pixels_decode_to_the_ball_and_the_rest_to_shapes_or_white(tutorial):
    sim, w = tutorial, tutorial.world
    cam, ball = w.resolve("kinect_rgb").handle, w.resolve("Sphere").handle
    rgb = sim.vision.image(cam, False)
    cmd_parameters.set_object_int_parameter(sim, [cam, 1017, 2])
    try:
        assert cmd_parameters.get_object_int_parameter(sim, [cam, 1017]) == 2
        coded = sim.vision.image(cam, False)
    finally:
        cmd_parameters.set_object_int_parameter(sim, [cam, 1017, 0])
    assert coded.shape == (RES_Y, RES_X, 3) and coded.dtype == np.uint8
    handles = HR.decode(coded)
    shapes = set(w.objects_of_type(SHAPE))
    seen = set(np.unique(handles).tolist())
    assert seen <= shapes | {HR.BACKGROUND}, f"not shapes: {seen - shapes - {HR.BACKGROUND}}"
    assert {ball, w.resolve("Table").handle, HR.BACKGROUND} <= seen
    # the red ball of the ordinary image is the ball's handle in the coded one, pixel for pixel
    red, is_ball = red_mask(rgb), handles == ball
    assert red.sum() >= 200 and (red & is_ball).sum() >= 0.99 * red.sum()  # red is ball...
    assert red.sum() >= 0.8 * is_ball.sum()  # ...and most of the ball is red (its shaded rim is not)
    # the white background is what the RGB image shows above the table (sky, the floor plane:
    # the world body's geoms are no V-REP object); bottom row (rows are bottom-up) is table
    assert (handles[-1] == HR.BACKGROUND).all() and (coded[-1] == 255).all()
    assert (handles[0, 20:-20] == w.resolve("Table").handle).all()
    # back to OpenGL: the ordinary image again (two renders of a state may differ by 1 here and
    # there: the GL rasteriser is not bit-exact between frames)
    assert np.abs(sim.vision.image(cam, False).astype(int) - rgb).max() <= 2


def test_depth_buffer_and_grey_option_in_coded_mode(tutorial):
    sim, w = tutorial, tutorial.world
    cam, ball = w.resolve("kinect_rgb").handle, w.resolve("Sphere").handle
    depth = sim.vision.depth(cam)
    cmd_parameters.set_object_int_parameter(sim, [cam, 1017, 2])
    try:
        coded = sim.vision.image(cam, False)
        grey = sim.vision.image(cam, True)
        # the depth buffer is the scene's (a render of the same state: equal but for the last bit
        # a software rasteriser may round differently between two renders)
        np.testing.assert_allclose(sim.vision.depth(cam), depth, rtol=0, atol=1e-6)
    finally:
        cmd_parameters.set_object_int_parameter(sim, [cam, 1017, 0])
    assert np.array_equal(grey, (coded.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8))
    assert ball < 256 and set(np.unique(grey[HR.decode(coded) == ball]).tolist()) == {ball // 3}


def test_parameter_errors_and_stop_restores_the_scene_mode():
    sim = tutorial_sim()  # its own: the stop below also undoes the module's tutorial pose
    try:
        _parameter_errors_and_stop(sim)
    finally:
        sim.close()


def _parameter_errors_and_stop(sim) -> None:
    w = sim.world
    cam = w.resolve("kinect_rgb").handle
    for mode, name in ((1, "auxchannels"), (3, "povray"), (5, "extrenderer"), (42, "render mode 42")):
        with pytest.raises(UnsupportedError, match=f"1017.*{name}"):
            cmd_parameters.set_object_int_parameter(sim, [cam, 1017, mode])
    assert cmd_parameters.get_object_int_parameter(sim, [cam, 1017]) == 0
    cmd_parameters.set_object_int_parameter(sim, [cam, 1017, 7])  # OpenGL3: the same visible colours
    assert cmd_parameters.get_object_int_parameter(sim, [cam, 1017]) == 7
    cmd_parameters.set_object_int_parameter(sim, [cam, 1017, 0])
    with pytest.raises(ObjectTypeError):
        cmd_parameters.set_object_int_parameter(sim, [w.resolve("UR5_joint1").handle, 1017, 2])
    with pytest.raises(ObjectTypeError):
        cmd_parameters.get_object_int_parameter(sim, [w.resolve("Sphere").handle, 1017])
    sim.start()
    cmd_parameters.set_object_int_parameter(sim, [cam, 1017, 2])
    sim.stop()  # run-time changes to sensors are undone, as the clipping planes
    assert cmd_parameters.get_object_int_parameter(sim, [cam, 1017]) == 0


def test_mjcf_setting_unnamed_bodies_and_world_geoms(tmp_path):
    scene = tmp_path / "handles.xml"
    scene.write_text(SMALL)
    sim = Simulation(scene, dt=0.05, realtime=False)
    try:
        w = sim.world
        cam, box = w.resolve("top").handle, w.resolve("box").handle
        assert cmd_parameters.get_object_int_parameter(sim, [cam, 1017]) == 2  # from render_mode=handles
        colours = HR.geom_colours(w)
        m = w.model
        g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "unnamed_body_geom")
        assert colours[g] == box  # an unnamed body's geom belongs to its named ancestor
        assert colours[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")] == HR.BACKGROUND
        assert colours[-1] == HR.BACKGROUND
        handles = HR.decode(sim.vision.image(cam, False))
        assert set(np.unique(handles).tolist()) == {box, HR.BACKGROUND}
        assert (handles == box).sum() > 30  # the box and the sphere of its unnamed child body
    finally:
        sim.close()
    bad = tmp_path / "bad.xml"
    bad.write_text(SMALL.replace("render_mode=handles", "render_mode=povray"))
    with pytest.raises(ValueError, match="render_mode='povray'"):
        Simulation(bad, dt=0.05, realtime=False)


def test_reading_a_colour_coded_sensor_draws_no_depth_frame(tmp_path):
    """Its packet lists the handles it sees and reads no depth: RLBench handles five such mask
    cameras every step, and each drew a depth frame nobody read (issue 58)."""
    from simx_server.sim import sensors

    scene = tmp_path / "handles.xml"
    scene.write_text(SMALL)
    sim = Simulation(scene, dt=0.05, realtime=False)
    try:
        cam, box = sim.world.resolve("top").handle, sim.world.resolve("box").handle
        before = sim.vision.renders
        triggered, packets = sensors.vision_read_job(sim, cam)()  # sim.handleVisionSensor's frames
        assert not triggered and packets == [[box + 0.5]]
        assert sim.vision.renders == before + 1  # the handles' frame alone
    finally:
        sim.close()


def test_encoding_round_trip():
    handles = np.array([[0, 1, 255, 256], [65535, 65536, 123456, HR.BACKGROUND]])
    colours = np.append(handles.ravel().astype(np.uint32), np.uint32(HR.BACKGROUND))
    seg = np.stack([np.arange(8).reshape(2, 4), np.full((2, 4), int(mujoco.mjtObj.mjOBJ_GEOM))], axis=-1)
    seg[0, 0] = (-1, -1)  # nothing: background
    seg[0, 1, 1] = int(mujoco.mjtObj.mjOBJ_SKIN)  # not a geom: background
    img = HR.coded_image(seg.astype(np.int32), colours)
    assert img.tolist()[1][2] == [123456 & 255, (123456 >> 8) & 255, 123456 >> 16]  # r low byte
    expected = handles.copy()
    expected[0, :2] = HR.BACKGROUND
    assert np.array_equal(HR.decode(img), expected)


def test_through_a_server(vrep_client):
    """``import vrep``: simxSetObjectIntParameter(1017, 2), then simxGetVisionSensorImage is coded."""
    cid = vrep_client
    handle = lambda name: vrep.simxGetObjectHandle(cid, name, B)[1]  # noqa: E731
    cam, ball = handle("kinect_rgb"), handle("Sphere")
    for i, a in enumerate(TUTORIAL_POSE, 1):
        assert vrep.simxSetJointPosition(cid, handle(f"UR5_joint{i}"), math.radians(a), B) == 0
    rc, shapes = vrep.simxGetObjects(cid, vrep.sim_object_shape_type, B)
    assert rc == 0
    assert vrep.simxGetObjectIntParameter(cid, cam, vrep.sim_visionintparam_render_mode, B) == (0, 0)
    assert vrep.simxSetObjectIntParameter(cid, cam, vrep.sim_visionintparam_render_mode, 2, B) == 0
    try:
        assert vrep.simxGetObjectIntParameter(cid, cam, vrep.sim_visionintparam_render_mode, B) == (0, 2)
        rc, res, raw = vrep.simxGetVisionSensorImage(cid, cam, 0, B)
        assert rc == 0 and list(res) == [RES_X, RES_Y]
        handles = HR.decode(np.array(raw, dtype=np.uint8).reshape(RES_Y, RES_X, 3))
        seen = set(np.unique(handles).tolist())
        assert ball in seen and (handles == ball).sum() >= 200
        assert seen <= set(shapes) | {HR.BACKGROUND}
        rc = vrep.simxSetObjectIntParameter(cid, cam, vrep.sim_visionintparam_render_mode, 3, B)
        assert rc & vrep.simx_return_remote_error_flag
    finally:
        vrep.simxSetObjectIntParameter(cid, cam, vrep.sim_visionintparam_render_mode, 0, B)
    rc, _, raw = vrep.simxGetVisionSensorImage(cid, cam, 0, B)
    assert rc == 0 and not (set(np.unique(HR.decode(np.array(raw, dtype=np.uint8).reshape(RES_Y, RES_X, 3))))
                            <= set(shapes) | {HR.BACKGROUND})  # the scene's colours again
