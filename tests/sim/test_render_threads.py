"""Streamed frames render on a render thread of their own (issue 23): a client's streams of huge
images (1.5 s a frame at 4096x4096 on llvmpipe) made another client's image request wait
behind them for seconds. Requests render on the request thread; streams, once their thread's
renderers are warm, on the stream thread."""

from __future__ import annotations

import gc
import os
import threading
import weakref
from concurrent.futures import Future
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import pytest  # noqa: E402

from simx_server.scene.simulation import Simulation  # noqa: E402

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "sensors.xml"


@pytest.fixture
def sim():
    s = Simulation(SCENE, dt=0.05, realtime=False)
    assert s.vision.wait_ready(30)
    yield s
    s.close()


def test_small_streamed_frames_stay_on_the_request_thread(sim):
    vision = sim.vision
    cam = sim.world.resolve("cam").handle  # 32x24: far below limits.STREAM_THREAD_PIXELS
    vision.for_streams = True
    try:
        streamed = vision.image_deferred(cam, 0)
    finally:
        vision.for_streams = False
    assert streamed.thread is vision._thread and vision._streaming is None
    assert streamed.future.result(30)[0] == [32, 24]


def test_a_request_does_not_wait_behind_the_stream_thread(sim, monkeypatch):
    from simx_server.base import limits

    monkeypatch.setattr(limits, "STREAM_THREAD_PIXELS", 1)  # every streamed frame: the stream thread
    vision = sim.vision
    cam = sim.world.resolve("cam").handle
    vision.for_streams = True
    try:  # the first streamed image renders on the request thread while the stream thread warms up
        first = vision.image_deferred(cam, 0)
        assert first.future.result(30)[0] == [32, 24]
        assert vision._streaming_ready.result(30) is None
        busy, release = threading.Event(), threading.Event()
        vision._streaming.executor.submit(lambda: (busy.set(), release.wait(30)))  # the stream thread is held
        assert busy.wait(10)
        sim.world.version += 1  # a new state (as a step makes): frames not cached
        streamed = vision.image_deferred(cam, 0)
    finally:
        vision.for_streams = False
    try:
        (w, h), data = vision.image_bytes(cam, 0)  # a request: the stream thread is still held
        assert (w, h) == (32, 24) and len(data) == 32 * 24 * 3
        assert not streamed.future.done()
    finally:
        release.set()
    assert streamed.future.result(30)[1] == data  # the same state, drawn on each thread


def test_after_all_waits_for_frames_of_either_thread_and_keeps_no_cycle(sim):
    from simx_server.sim.vision import Deferred

    vision = sim.vision
    frame: Future = Future()

    class Payload:  # stands for a frame's bytes: must not outlive its use
        pass

    payload = Payload()
    alive = weakref.ref(payload)

    def job(p=payload) -> str:
        return type(p).__name__

    result = vision.after_all([Deferred(frame)], job)
    del payload, job
    assert not result.done()
    frame.set_result(None)
    assert result.result(10) == "Payload"
    gc.disable()  # only reference counting: a cycle through the frame's callbacks would keep it
    try:
        assert alive() is None
    finally:
        gc.enable()


def test_the_gl_lock_lets_frames_share_and_context_making_wait_for_them():
    from simx_server.sim.render_thread import GLLock

    lock, events = GLLock(), []
    drawing, release = threading.Event(), threading.Event()

    def draw() -> None:
        with lock.shared():
            events.append("draw")
            drawing.set()
            release.wait(10)
            events.append("drawn")

    def make() -> None:
        with lock.exclusive():
            events.append("make")

    first = threading.Thread(target=draw)
    first.start()
    assert drawing.wait(10)
    with lock.shared():  # frames share the lock
        events.append("second draw")
    maker = threading.Thread(target=make)
    maker.start()
    maker.join(0.2)
    assert maker.is_alive() and "make" not in events  # waits for the frame in progress
    release.set()
    first.join(10)
    maker.join(10)
    assert events == ["draw", "second draw", "drawn", "make"]


@pytest.mark.parametrize("kind", ["rgb", "depth", "handles"])
def test_a_frame_drawn_in_bands_equals_the_whole_frame(kind):
    """The stream render thread draws frames in bands of limits.STREAM_BAND_PIXELS (so that on
    llvmpipe, one rasteriser queue for every GL context, another thread's frame waits for one
    band, not a whole 4096x4096 scene): here 480 rows in bands of 100, the last one cut."""
    import mujoco
    import numpy as np

    from simx_server.sim.render_thread import RenderThread, render_bands

    model = mujoco.MjModel.from_xml_path(str(Path(__file__).resolve().parents[2] / "scenes" / "ur5_rg2_kinect.xml"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()  # the table, the arm and the ball, with shadows
    camera.lookat[:], camera.distance, camera.elevation, camera.azimuth = [0, 0, 0.8], 2.0, -30, 120
    whole, banded = RenderThread("test-whole"), RenderThread("test-bands", band_pixels=640 * 100)

    def draw(thread: RenderThread) -> np.ndarray:
        def job():
            r = thread.renderer(model, 640, thread.band_rows(640, 480))
            {"depth": r.enable_depth_rendering, "handles": r.enable_segmentation_rendering}.get(kind, lambda: None)()
            r.update_scene(data, camera=camera)
            return render_bands(r, 480), r.height
        return thread.executor.submit(job).result(60)

    try:
        (a, rows_a), (b, rows_b) = draw(whole), draw(banded)
    finally:
        for thread in (whole, banded):
            thread.executor.submit(thread.free).result(30)
            thread.executor.shutdown()
    assert (rows_a, rows_b) == (480, 100) and a.shape == b.shape and a.dtype == b.dtype
    if kind == "rgb":
        assert a.std() > 20 and np.abs(a.astype(int) - b.astype(int)).max() <= 2
    elif kind == "depth":
        # the same to 1e-4 m but for a pixel or two on a silhouette (rounding of the cut frustum)
        assert np.ptp(a) > 1.0 and (np.abs(a - b) > 1e-4).sum() <= 5
    else:  # segmentation: the same object at (almost) every pixel
        assert len(np.unique(a[..., 0])) > 5 and (a != b).any(axis=2).mean() < 1e-3


def test_a_render_thread_draws_every_size_in_one_gl_context_as_mujoco_does():
    """A render thread makes one GL context and, in it, an ``MjrContext`` per size (a fresh
    context's first one costs 1-1.5 s on llvmpipe, a further one 0.2 s: a sensor set to a new
    size made the ur5 environment's first synchronous step take 3.7 s, over 5 s under load).
    Sizes drawn alternately, each into its own offscreen buffer, equal ``mujoco.Renderer``'s
    frames of a context of their own, pixel for pixel; closing the thread frees the context."""
    import mujoco
    import numpy as np

    from simx_server.sim.render_thread import RenderThread, SensorRenderer

    model = mujoco.MjModel.from_xml_path(str(Path(__file__).resolve().parents[2] / "scenes" / "ur5_rg2_kinect.xml"))
    model.vis.global_.offwidth, model.vis.global_.offheight = 640, 480
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    camera = mujoco.MjvCamera()
    camera.lookat[:], camera.distance, camera.elevation, camera.azimuth = [0, 0, 0.8], 2.0, -30, 120
    sizes = [(96, 72), (64, 48), (96, 72)]
    thread = RenderThread("test-one-context")

    def frames(r: mujoco.Renderer) -> tuple:
        r.update_scene(data, camera=camera)
        rgb = r.render().copy()
        r.enable_depth_rendering()
        r.update_scene(data, camera=camera)
        depth = r.render().copy()
        r.disable_depth_rendering()
        return rgb, depth

    def ours() -> tuple:
        drawn = [frames(thread.renderer(model, w, h)) for w, h in sizes]
        renderers = list(thread.renderers.values())
        assert all(type(r) is SensorRenderer and r._gl_context is thread.context for r in renderers)
        return drawn, len(renderers)

    try:
        drawn, made = thread.executor.submit(ours).result(60)
        assert made == 2 and thread.context is not None
    finally:
        thread.executor.submit(thread.close).result(30)
        thread.executor.shutdown()
    assert thread.context is None and not thread.renderers
    # mujoco.Renderers of their own contexts, drawing in the same order (a renderer's second
    # frame may differ from its first by one level here and there: compared in turn)
    own = {size: mujoco.Renderer(model, size[1], size[0]) for size in dict.fromkeys(sizes)}
    try:
        for (w, h), (rgb, depth) in zip(sizes, drawn):
            want_rgb, want_depth = frames(own[(w, h)])
            assert rgb.shape == (h, w, 3) and rgb.std() > 20
            assert np.array_equal(rgb, want_rgb) and np.array_equal(depth, want_depth)
    finally:
        for r in own.values():
            r.close()


def test_the_stream_thread_owes_its_drawing_time_less_its_share():
    """limits.STREAM_RENDER_SHARE: the stream render thread's drawing time, less the share per
    second since, is what it owes; past limits.STREAM_RENDER_DEBT_SECONDS image streams of large
    frames skip steps (the publisher asks VisionSensors.streams_over_share)."""
    from simx_server.sim.render_thread import RenderThread

    thread = RenderThread("test-share", band_pixels=1024 * 1024)
    try:
        assert thread.debt(0.5) == 0.0
        thread.charge(1.2, 0.5)  # a 1.2 s frame
        at = thread._busy_at
        assert thread.debt(0.5, at) == 1.2
        assert abs(thread.debt(0.5, at + 1.0) - 0.7) < 1e-9  # 1 s later: half a second less
        assert thread.debt(0.5, at + 10.0) == 0.0  # never below nothing
    finally:
        thread.executor.shutdown()


def test_streamed_frames_of_the_stream_thread_count_against_its_share(sim, monkeypatch):
    """A frame drawn on the stream thread is charged to it, and its debt decides whether streams
    skip steps. The debt's fall with time (tested above, with explicit times) is stopped here
    (a share of 0): the time between drawing and reading the debt, which machine load decides,
    then changes nothing (with the real share the debt had fallen to 0 once under load)."""
    from simx_server.base import limits

    monkeypatch.setattr(limits, "STREAM_RENDER_SHARE", 0.0)  # what is owed stays owed
    vision = sim.vision
    cam = sim.world.resolve("cam").handle
    vision.for_streams = True
    try:
        vision.image_deferred(cam, 0).future.result(30)  # 32x24: the request thread, nothing owed
        assert vision._streaming is None and not vision.streams_over_share()
        monkeypatch.setattr(limits, "STREAM_THREAD_PIXELS", 1)  # every streamed frame: the stream thread
        sim.world.version += 1  # a new state (as a step makes): frames not cached
        vision.image_deferred(cam, 0).future.result(30)  # drawn on the request thread while it warms up
        assert vision._streaming_ready.result(30) is None
        sim.world.version += 1  # a new state: not cached
        streamed = vision.image_deferred(cam, 0)
        assert streamed.thread is vision._streaming
        streamed.future.result(30)
    finally:
        vision.for_streams = False
    owed = vision._streaming.debt(limits.STREAM_RENDER_SHARE)
    assert owed > 0  # the frames' drawing time on the stream thread
    monkeypatch.setattr(limits, "STREAM_RENDER_DEBT_SECONDS", owed / 2)
    assert vision.streams_over_share()
    monkeypatch.setattr(limits, "STREAM_RENDER_DEBT_SECONDS", 10.0)
    assert not vision.streams_over_share()


def test_a_resolution_set_at_run_time_makes_its_renderer_at_once(sim):
    """simxSetObjectIntParameter 1002/1003: the GL context of the new size is made on the request
    thread when the size is set, not in the client's first image call of that size."""
    vision = sim.vision
    cam = sim.world.resolve("cam").handle
    vision.set_resolution(cam, 64, 48)
    vision.after(lambda: None).result(30)  # the request thread has done what was queued
    assert (64, 48) in vision._thread.renderers
    renders = vision.renders
    (w, h), data = vision.image_bytes(cam, 0)
    assert (w, h) == (64, 48) and len(data) == 64 * 48 * 3 and vision.renders == renders + 1


def test_renderers_on_demand_are_made_at_the_first_image_and_draw_the_same_frames():
    """``--renderers on-demand`` (Simulation(renderers_at_load=False)): no renderer (GL context)
    exists before an image is asked for, also after an edit; the first image makes it and is
    the frame a server with its renderers made at load gives; a resolution set at run time
    still makes its renderer at once."""
    from simx_server.scene.editor import refresh_vision

    eager = Simulation(SCENE, dt=0.05, realtime=False)
    lazy = Simulation(SCENE, dt=0.05, realtime=False, renderers_at_load=False)
    try:
        assert eager.vision.wait_ready(30) and lazy.vision.wait_ready(30)
        assert len(eager.vision._thread.renderers) == 2  # one per sensor size, made at load
        assert not lazy.vision._thread.renderers
        cam = lazy.world.resolve("cam").handle
        refresh_vision(lazy)  # what an edit or a scene load does: the new sensors stay on demand
        assert not lazy.vision.at_load and lazy.vision.wait_ready(30)
        assert not lazy.vision._thread.renderers and lazy.vision.renders == 0
        assert lazy.vision.image_bytes(cam, 0) == eager.vision.image_bytes(cam, 0)
        assert lazy.vision.depth_deferred(cam).future.result(30) == eager.vision.depth_deferred(cam).future.result(30)
        assert list(lazy.vision._thread.renderers) == [(32, 24)] and lazy.vision.renders == 2
        lazy.vision.set_resolution(cam, 64, 48)  # a user's change: its renderer is warmed at once
        lazy.vision.after(lambda: None).result(30)
        assert (64, 48) in lazy.vision._thread.renderers
    finally:
        eager.close()
        lazy.close()
