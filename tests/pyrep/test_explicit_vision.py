"""A vision sensor with explicit handling keeps the image of its last handling, as CoppeliaSim's
sensor buffers do (coppeliaSimLib ``CVisionSensor::handleSensor`` renders into ``_rgbBuffer`` /
``_depthBuffer``, which ``simGetVisionSensorImg_internal``, ``simGetVisionSensorDepth_internal``
and ``simReadVisionSensor_internal`` read): RLBench's cameras, handled then read each step. The
world moving on (steps, a pose set, an edit of the scene) changes nothing read until the sensor
is handled again; a sensor without explicit handling shows each pass's state. Read through
PyRep (the ``sim`` table the ZMQ clients call too) and the legacy payloads of
``simxGetVisionSensorImage`` / ``simxGetVisionSensorDepthBuffer``; the small PyRep scene."""

from __future__ import annotations

import numpy as np

from pyrep.backend import sim as backend


def _legacy(pr, h: int) -> tuple[bytes, bytes]:
    """``simxGetVisionSensorImage`` and ``simxGetVisionSensorDepthBuffer``'s bytes."""
    vision = pr.simulation.vision
    return vision.image_bytes(h, 0)[1], vision.depth_bytes(h)[1]


def test_reads_return_the_last_handling_until_handled_again(pr):
    from pyrep.const import PrimitiveShape
    from pyrep.objects import Shape, VisionSensor

    cam = VisionSensor("cam")
    cube = Shape("cube")
    h = cam.get_handle()
    cam.set_explicit_handling(1)
    cube.set_position([0.0, 0.0, 0.3])  # in view
    cam.handle_explicitly()
    rgb, depth = cam.capture_rgb(), cam.capture_depth(True)
    packets = backend.call("readVisionSensor", h)
    legacy = _legacy(pr, h)
    cube.set_position([5.0, 0.0, 0.3])  # out of view
    for _ in range(3):
        pr.step()
    Shape.create(type=PrimitiveShape.CUBOID, size=[0.1, 0.1, 0.1], position=[3.0, 3.0, 0.05])  # an edit of the scene
    assert np.array_equal(cam.capture_rgb(), rgb) and np.array_equal(cam.capture_depth(True), depth)
    assert backend.call("readVisionSensor", h) == packets and _legacy(pr, h) == legacy
    now = backend.call("checkVisionSensorEx", h, -2, True)  # CVisionSensor::checkSensorEx: this state
    assert backend.call("checkVisionSensor", h, -2) != packets
    assert np.array_equal(cam.capture_rgb(), rgb)  # the handling stays
    cam.handle_explicitly()  # the new state
    moved = cam.capture_rgb()
    assert not np.array_equal(moved, rgb) and not np.array_equal(cam.capture_depth(True), depth)
    assert np.array_equal(np.rint(np.flipud(np.reshape(now, moved.shape)) * 255), np.rint(moved * 255))
    cam.set_explicit_handling(0)  # handled each pass: the state now, which is the one just handled
    assert np.array_equal(cam.capture_rgb(), moved)


def test_a_buffer_not_read_at_the_handling_is_the_handled_states(pr):
    """The depth buffer, read only after the world moved, is the one of the handled state, bit
    for bit (drawn from that state, kept while the sensor's handling lasts)."""
    from pyrep.objects import Shape, VisionSensor

    cam = VisionSensor("cam")
    vision = pr.simulation.vision
    h = cam.get_handle()
    Shape("cube").set_position([0.0, 0.0, 0.3])
    expected = vision.depth(h)  # the reference: this state's depth
    vision._cache.clear()  # its frame forgotten: the read below must draw it again
    cam.set_explicit_handling(1)
    cam.handle_explicitly()  # draws the image alone
    Shape("cube").set_position([5.0, 0.0, 0.3])
    pr.step()
    renders = vision.renders
    assert np.array_equal(vision.depth(h), expected) and vision.renders == renders + 1


def test_a_sensor_without_explicit_handling_shows_each_pass(pr):
    from pyrep.objects import Shape, VisionSensor

    cam = VisionSensor("cam")
    Shape("cube").set_position([0.0, 0.0, 0.3])
    pr.step()
    seen = cam.capture_rgb()
    Shape("cube").set_position([5.0, 0.0, 0.3])
    pr.step()
    assert not np.array_equal(cam.capture_rgb(), seen)


def test_before_its_first_handling_a_sensor_shows_its_cleared_buffer(tmp_path):
    """A sensor saved with explicit handling and never handled shows what CoppeliaSim's
    ``CVisionSensor::_clearBuffers`` leaves: its background colour (black), depth 1 (the far
    plane); a new resolution clears it again (``setResolution`` -> ``_reserveBuffers``)."""
    from pyrep import PyRep
    from pyrep.objects import VisionSensor

    from tests.conftest import PYREP_SCENE

    path = tmp_path / "explicit.xml"
    path.write_text(PYREP_SCENE.replace("</mujoco>", '<custom><text name="simx:cam" data="explicit=true"/>'
                                                     "</custom>\n</mujoco>"))
    pr = PyRep()
    pr.launch(str(path), headless=True)
    try:
        pr.start()
        pr.step()
        cam = VisionSensor("cam")
        h = cam.get_handle()
        assert backend.call("getExplicitHandling", h) == 1
        assert not cam.capture_rgb().any() and (cam.capture_depth() == 1).all()
        image, depth = _legacy(pr, h)
        assert not any(image) and np.all(np.frombuffer(depth, np.float32) == 1)
        cam.handle_explicitly()
        assert cam.capture_rgb().any()
        cam.set_resolution([16, 12])
        assert cam.capture_rgb().shape == (12, 16, 3) and not cam.capture_rgb().any()
    finally:
        pr.shutdown()
