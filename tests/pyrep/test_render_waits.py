"""No image call waits for ever (issue 81): RLBench's ``test_executed_jp_action`` hung in
``handleVisionSensor`` on a frame whose future never resolved. A render that fails raises a
clear error at once; a render thread that does not answer is given up after
``limits.RENDER_WAIT_SECONDS`` (shortened here). The render is made to fail or to stall by
replacing the drawing of a frame; the small PyRep scene of the tests."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from simx_server.base import limits
from simx_server.sim.vision import VisionSensors


def test_a_failed_render_raises_a_clear_error(pr, monkeypatch):
    from pyrep.errors import CoppeliaSimError
    from pyrep.objects import Shape, VisionSensor

    def broken(*_args):
        raise RuntimeError("eglMakeCurrent failed: EGL_BAD_ACCESS")

    cam = VisionSensor("cam")
    cam.set_explicit_handling(1)
    monkeypatch.setattr(VisionSensors, "_draw", staticmethod(broken))
    Shape("cube").set_position([0.5, 0.0, 0.31])  # a new state: no frame of it cached
    with pytest.raises(CoppeliaSimError, match="the render failed: RuntimeError: eglMakeCurrent failed"):
        cam.handle_explicitly()
    with pytest.raises(CoppeliaSimError, match="the render failed"):
        cam.capture_rgb()
    monkeypatch.undo()
    Shape("cube").set_position([0.5, 0.0, 0.32])
    cam.handle_explicitly()  # the next state renders again
    assert cam.capture_rgb().max() > 0


def test_a_render_thread_that_does_not_answer_is_given_up(pr, monkeypatch):
    from pyrep.errors import CoppeliaSimError
    from pyrep.objects import Shape, VisionSensor

    release = threading.Event()
    draw = VisionSensors._draw

    def stalled(*args):
        release.wait(30)
        return draw(*args)

    cam = VisionSensor("cam")
    monkeypatch.setattr(limits, "RENDER_WAIT_SECONDS", 0.5)
    monkeypatch.setattr(VisionSensors, "_draw", staticmethod(stalled))
    Shape("cube").set_position([0.5, 0.0, 0.33])
    started = time.monotonic()
    try:
        with pytest.raises(CoppeliaSimError, match="no frame within RENDER_WAIT_SECONDS"):
            cam.capture_rgb()
        assert time.monotonic() - started < 20  # bounded (0.5 s here), not pytest's timeout
    finally:
        release.set()


def test_handle_explicitly_renders_without_computing_packets(pr, monkeypatch):
    """PyRep's ``handle_explicitly`` reads none of ``sim.handleVisionSensor``'s packets (V-REP's
    statistics, a mask's handles): it renders the sensor and computes none of them; the image
    read next is the handled state's."""
    from pyrep.objects import Shape, VisionSensor

    from simx_server.sim.vision_chain import VisionChain

    cam = VisionSensor("cam")
    cam.set_explicit_handling(1)
    computed = []
    real = VisionChain.default_packet_of
    monkeypatch.setattr(VisionChain, "default_packet_of",
                        staticmethod(lambda *a: computed.append(1) or real(*a)))
    Shape("cube").set_position([0.5, 0.0, 0.31])
    cam.handle_explicitly()
    before = cam.capture_rgb()
    assert computed == [] and before.max() > 0
    Shape("cube").set_position([5.0, 0.0, 0.31])  # out of view
    cam.handle_explicitly()
    assert not np.array_equal(cam.capture_rgb(), before) and computed == []
