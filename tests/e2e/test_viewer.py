"""simx-viewer and the server's viewer feed (issue 14, part 1).

Protocol level (no window): the state is published only while a subscriber exists, several
viewers receive it, and the generation and model follow a scene edit and a scene load. Under
Xvfb with MuJoCo's GLFW backend on Mesa: the ``simx-viewer`` window shows the arm, stays the
same while nothing moves, and changes where the arm is after a legacy client turns
``UR5_joint1`` by 45 degrees (the screenshots are saved as PNGs in the test's folder).
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import time

import mujoco
import numpy as np
import pytest
import zenoh

try:
    from conftest import ROOT, SCENE, ServerProcess, free_port, wait_until
    from xdisplay import FIX_HINT, VirtualDisplay, find_window, have_x_tools, send_keys
except ImportError:  # run as a package
    from tests.conftest import ROOT, SCENE, ServerProcess, free_port, wait_until
    from tests.xdisplay import FIX_HINT, VirtualDisplay, find_window, have_x_tools, send_keys

from simx_client import protocol as P
from simx_client.connection import client_config
from simx_viewer import NoServerError, ViewerLink

WAIT = 0x010000  # simx_opmode_blocking


def _model_state(session: zenoh.Session):
    """A raw Zenoh query of the model (no subscriber declared): (generation, state time).
    Asked again while it ends without a reply (Zenoh not yet aware of the queryable)."""
    def ask():
        for reply in session.get(P.viewer_model_key(), timeout=10):
            _, generation, _, _, state = P.unpack_viewer_model(reply.ok.payload.to_bytes())
            return generation, P.unpack_viewer_state(state)[2]
    return wait_until(ask, what="an answer to the viewer model query")


def _published_counts(log: str, what: str) -> list[int]:
    return [int(n) for n in re.findall(rf"viewer feed: {what} \((\d+) states published so far\)", log)]


def test_state_is_published_only_while_a_viewer_subscribes():
    server = ServerProcess(str(SCENE), renderers="on-demand")
    try:
        with zenoh.open(client_config("127.0.0.1", server.port)) as session:
            t0 = _model_state(session)[1]
            # (model queries as the clock, at most limits.MAX_VIEWER_MODELS_PER_SECOND: every 0.3 s)
            wait_until(lambda: _model_state(session)[1] > t0 + 0.3, period=0.3, what="the simulation running unwatched")
            received = []
            sub = session.declare_subscriber(P.viewer_state_key(),
                                             lambda s: received.append(P.unpack_viewer_state(s.payload.to_bytes())))
            wait_until(lambda: len(received) >= 5, what="5 states for the subscriber")
            sub.undeclare()
            t1 = _model_state(session)[1]
            wait_until(lambda: _model_state(session)[1] > t1 + 0.3, period=0.3,
                       what="the simulation running unwatched again")
            again = []
            sub = session.declare_subscriber(P.viewer_state_key(), lambda s: again.append(s))
            wait_until(lambda: again, what="a state for the second subscription")
            sub.undeclare()
        times = [m[2] for m in received]
        assert times == sorted(times) and len(set(times)) == len(times), "one state per step, in order"
        assert all(len(m[3]) == 8 * 15 for m in received), "qpos of the UR5 scene: 15 float64"
    finally:
        log = server.stop()
    watched, unwatched = _published_counts(log, "a viewer is watching"), _published_counts(log, "no viewer is watching")
    assert len(watched) == 2 and len(unwatched) == 2, log[-2000:]
    assert watched[0] == 0, "states were published before any viewer subscribed"
    assert watched[1] == unwatched[0] >= len(received), "states were published while nobody watched"


def test_two_viewers_follow_an_edit_and_a_scene_load():
    other = ROOT / "tests" / "scenes" / "sensors.xml"
    server = ServerProcess(str(SCENE), "--scene-path", str(other.parent), renderers="on-demand")
    import vrep

    cid = -1
    try:
        with ViewerLink("127.0.0.1", server.port) as a, ViewerLink("127.0.0.1", server.port) as b:
            first = a.fetch_model()
            assert first.model.nbody == 14 and b.fetch_model().generation == first.generation
            for link in (a, b):
                wait_until(lambda: (s := link.next_state(0.1)) and s.generation == first.generation
                           and s.time > first.state.time, what="both viewers following the steps")
            cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
            assert cid >= 0
            # An edit that recompiles the model (World.replace_model): a new generation.
            rc, sphere = vrep.simxGetObjectHandle(cid, "Sphere", WAIT)
            assert rc == 0 and vrep.simxRemoveObject(cid, sphere, WAIT) == 0
            for link in (a, b):
                wait_until(lambda: (s := link.next_state(0.1)) and s.generation == first.generation + 1,
                           what="the edit's generation in both viewers' states")
            edited = a.fetch_model()
            assert edited.generation == first.generation + 1 and edited.model.nbody == 13
            # Another scene (simxLoadScene, simulation stopped): its model and generation.
            assert vrep.simxStopSimulation(cid, WAIT) == 0
            assert vrep.simxLoadScene(cid, str(other), 0, WAIT) == 0
            bodies = mujoco.MjModel.from_xml_path(str(other)).nbody
            loaded = wait_until(lambda: (m := b.fetch_model()).model.nbody == bodies and m,
                                what="the loaded scene's model")
            assert loaded.generation > edited.generation and loaded.state.qpos.size == loaded.model.nq
            wait_until(lambda: (s := a.next_state(0.1)) and s.generation == loaded.generation,
                       what="the loaded scene's generation in the watching viewer's states")
    finally:
        if cid >= 0:
            vrep.simxFinish(cid)
        log = server.stop()
    assert "viewer feed: a viewer is watching" in log


def test_no_server_is_a_clean_message_and_exit_status_1():
    port = free_port()
    with pytest.raises(NoServerError, match=f"127.0.0.1:{port}"):
        ViewerLink("127.0.0.1", port).fetch_model(timeout=1)
    env = dict(os.environ, MUJOCO_GL="egl")
    done = subprocess.run([sys.executable, "-m", "simx_viewer.app", "--port", str(port), "--timeout", "1"],
                          capture_output=True, text=True, timeout=60, env=env)
    assert done.returncode == 1, done.stderr
    assert f"127.0.0.1:{port}" in done.stderr and "--host/--port" in done.stderr
    assert "Traceback" not in done.stderr and ".cargo" not in done.stderr and ".rs:" not in done.stderr


# ----------------------------------------------------------------- the window, under Xvfb
needs_x = pytest.mark.skipif(not have_x_tools() and not os.environ.get("CI"),
                             reason=f"needs Xvfb and xdotool: {FIX_HINT}")
_SCREEN = (1200, 900)  # the viewer's window takes 2/3 of it: 800 x 600 at (0, 0)
_VIEW: list[str] = []  # issue 20: the window's defaults frame the scene's objects (the arm whole)


def _window(shot: np.ndarray) -> np.ndarray:
    return shot[:_SCREEN[1] * 2 // 3, :_SCREEN[0] * 2 // 3]


def _changed(a: np.ndarray, b: np.ndarray) -> int:
    """Pixels whose colour differs by more than 40 (of 255) in some channel."""
    return int((np.abs(a.astype(np.int16) - b.astype(np.int16)).max(axis=2) > 40).sum())


@needs_x
def test_viewer_window_shows_the_arm_moving(tmp_path):
    import cv2
    import vrep

    server = ServerProcess(str(SCENE), renderers="on-demand")
    viewer = None
    cid = -1
    with VirtualDisplay(*_SCREEN, fbdir=str(tmp_path)) as xd:
        try:
            env = xd.env(dict(os.environ, MUJOCO_GL="glfw"))
            viewer = subprocess.Popen([sys.executable, "-m", "simx_viewer.app", "--port", str(server.port), *_VIEW],
                                      env=env, stdout=subprocess.DEVNULL, stderr=open(tmp_path / "viewer.log", "w"))
            find_window(xd.display, "MuJoCo", timeout=60)

            def steady_shot():
                """A screenshot of a drawn scene (not a uniform window), equal to the next one taken
                after the server stepped 5 more times and at least 1 s later (a viewer starved of
                the CPU can leave one frame up for a while); as a 1-tuple (wait_until tests truth)."""
                before = _window(xd.screenshot())
                t, wall = sim_time(), time.monotonic() + 1.0
                wait_until(lambda: sim_time() >= t + 0.25 and time.monotonic() >= wall, what="5 more steps")
                after = _window(xd.screenshot())
                return (after,) if after.std() > 20 and _changed(before, after) < 50 else None

            cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
            assert cid >= 0

            def sim_time() -> float:
                vrep.simxGetPingTime(cid)
                return vrep.simxGetLastCmdTime(cid) / 1000

            first, = wait_until(steady_shot, timeout=60, what="a steady first view")
            cv2.imwrite(str(tmp_path / "viewer-before.png"), first)
            # A drawn scene, not a blank or uniform window: many colours.
            assert len(np.unique(first.reshape(-1, 3), axis=0)) > 500
            rc, joint = vrep.simxGetObjectHandle(cid, "UR5_joint1", WAIT)
            assert rc == 0
            target = math.radians(45)
            assert vrep.simxSetJointTargetPosition(cid, joint, target, WAIT) == 0
            wait_until(lambda: abs(vrep.simxGetJointPosition(cid, joint, WAIT)[1] - target) < 0.01,
                       timeout=20, what="UR5_joint1 at 45 degrees")
            # The viewer may lag the server on a loaded machine (software GL): a steady view that
            # shows the turn, within 60 s (a viewer that stopped following never shows it).
            second, = wait_until(lambda: (s := steady_shot()) and _changed(first, s[0]) > 2000 and s,
                                 timeout=60, what="a steady view of the turned arm (> 2,000 pixels changed)")
            cv2.imwrite(str(tmp_path / "viewer-after.png"), second)
            rows, _ = np.nonzero(np.abs(first.astype(np.int16) - second.astype(np.int16)).max(axis=2) > 40)
            assert rows.min() < second.shape[0] // 2, "the change is where the arm's upper part is"

            # Space pauses the view: the arm turning back is not shown until space again.
            window = find_window(xd.display, "MuJoCo")
            viewer_log = tmp_path / "viewer.log"
            send_keys(xd.display, window, "space")
            wait_until(lambda: "view paused" in viewer_log.read_text(), what="the viewer's pause")
            # The view the pause froze (a lagging viewer may have drawn a state or two more after
            # the steady shot above), then the arm turns back: the view stays as it was.
            paused, = wait_until(steady_shot, timeout=60, what="a steady paused view")
            assert vrep.simxSetJointTargetPosition(cid, joint, 0.0, WAIT) == 0
            wait_until(lambda: abs(vrep.simxGetJointPosition(cid, joint, WAIT)[1]) < 0.01,
                       timeout=20, what="UR5_joint1 back at 0")
            still, = wait_until(steady_shot, timeout=60, what="a steady paused view after the turn back")
            assert _changed(paused, still) < 50, "the paused view followed the arm"
            send_keys(xd.display, window, "space")
            resumed, = wait_until(lambda: (s := steady_shot()) and _changed(paused, s[0]) > 2000 and s,
                                  timeout=60, what="the resumed view showing the arm turned back")

            # An edit (the table removed): a new generation, the window reopens on the new model.
            rc, table = vrep.simxGetObjectHandle(cid, "Table", WAIT)
            assert rc == 0 and vrep.simxRemoveObject(cid, table, WAIT) == 0
            wait_until(lambda: "showing generation 2" in viewer_log.read_text(), timeout=60,
                       what="the viewer reloading the edited scene")
            edited, = wait_until(steady_shot, timeout=60, what="a steady view of the edited scene")
            cv2.imwrite(str(tmp_path / "viewer-edited.png"), edited)
            assert _changed(resumed, edited) > 5000, "the table is still shown"
            viewer.terminate()  # SIGTERM: a clean stop with status 0, as the server's (it was 143)
            assert viewer.wait(10) == 0
        finally:
            if cid >= 0:
                vrep.simxFinish(cid)
            if viewer is not None:
                viewer.terminate()
                viewer.wait(10)
            log = server.stop()
    assert "viewer feed: a viewer is watching" in log, log[-2000:]


def test_model_queries_waiting_are_bounded(monkeypatch):
    """Zenoh's thread queues at most limits.MAX_VIEWER_QUERIES model queries for the simulation
    thread; the next one is answered "server busy" at once, and answering frees a place. Answers
    are also limited to limits.MAX_VIEWER_MODELS_PER_SECOND (a token bucket of
    MAX_VIEWER_QUERIES): the queries of a loop beyond it are refused, naming the bound."""
    from simx_server.base import limits
    from simx_server.legacy import viewer_feed
    from simx_server.legacy.viewer_feed import ViewerFeed
    from simx_server.sim.world import World

    clock = [1000.0]
    monkeypatch.setattr(viewer_feed.time, "monotonic", lambda: clock[0])

    class Query:
        key_expr = P.viewer_model_key()

        def __init__(self):
            self.replies: list[bytes] = []

        def reply(self, key, payload: bytes) -> None:
            self.replies.append(payload)

        def drop(self) -> None:
            pass

    queued: list = []
    feed = ViewerFeed(P.DEFAULT_PREFIX, queued.append, lambda lane, job: job())  # sends at once
    queries = [Query() for _ in range(limits.MAX_VIEWER_QUERIES + 1)]
    for q in queries:
        feed._on_query(q)
    assert len(queued) == limits.MAX_VIEWER_QUERIES and not queries[0].replies
    with pytest.raises(P.ProtocolError, match="server busy"):
        P.unpack_viewer_model(queries[-1].replies[0])
    world = World(ROOT / "tests" / "scenes" / "sensors.xml", 0.05)
    feed.answer(queued[0][1], world)  # the simulation thread's answer: the model, generation 1
    _, generation, version, mjb, state = P.unpack_viewer_model(queries[0].replies[0])
    assert generation == 1 and version == mujoco.mj_versionString()
    assert mujoco.MjModel.from_binary_path("m.mjb", {"m.mjb": mjb}).nbody == world.model.nbody
    again = Query()
    feed._on_query(again)  # a place is free, but the bucket is empty: refused for the rate
    with pytest.raises(P.ProtocolError, match="MAX_VIEWER_MODELS_PER_SECOND"):
        P.unpack_viewer_model(again.replies[0])
    clock[0] += 1 / limits.MAX_VIEWER_MODELS_PER_SECOND  # one answer's worth of time later
    again = Query()
    feed._on_query(again)
    assert len(queued) == limits.MAX_VIEWER_QUERIES + 1 and not again.replies
    refused = Query()
    feed._on_query(refused)  # at once again: the bucket is empty
    assert refused.replies and len(queued) == limits.MAX_VIEWER_QUERIES + 1
    # A colour set in place (sim.setShapeColor writes geom_rgba): a new generation and model.
    world.model.geom_rgba[0] = (0.1, 0.9, 0.1, 1)
    feed.answer(queued[1][1], world)
    _, generation, _, mjb, _ = P.unpack_viewer_model(queries[1].replies[0])
    assert generation == 2
    assert tuple(mujoco.MjModel.from_binary_path("m.mjb", {"m.mjb": mjb}).geom_rgba[0]) == pytest.approx((0.1, 0.9, 0.1, 1))


def test_images_come_through_the_legacy_streaming_calls():
    """--images: every vision sensor of the model is streamed and read back as an RGB image,
    top row first; without an OpenCV GUI the viewer is told how to get one."""
    import cv2
    from simx_viewer.images import SensorImages

    server = ServerProcess(str(SCENE))
    images = None
    try:
        with ViewerLink("127.0.0.1", server.port) as link:
            model = link.fetch_model().model
        if "NONE" in next(l for l in cv2.getBuildInformation().splitlines() if "GUI:" in l):
            with pytest.raises(RuntimeError, match="needs OpenCV with a GUI: `pip install opencv-python`"):
                SensorImages("127.0.0.1", server.port, model)
        images = SensorImages("127.0.0.1", server.port, model, gui=False)
        assert [name for name, *_ in images.sensors] == ["kinect_rgb", "kinect_depth"]
        for _, handle, depth in images.sensors:
            image, = wait_until(lambda: (i := images.read(handle, depth)) is not None and (i,),
                                what="a streamed image")
            assert image.shape == (480, 640, 3) and image.dtype == np.uint8 and image.std() > 0
    finally:
        if images is not None:
            images.close()
        server.stop()


def test_the_default_view_frames_the_scenes_objects():
    """The box around the bodies' geoms (the floor plane left out) and a view that holds it: the
    UR5's top (the Kinect) and the table's corners are inside it, the floor does not widen it."""
    import mujoco

    from simx_viewer.framing import default_view, scene_box

    m = mujoco.MjModel.from_xml_path(str(SCENE))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    low, high = scene_box(m, d)
    kinect = d.body("kinect").xpos
    assert np.all(low <= kinect) and np.all(kinect <= high)
    assert high[2] < 2.5 and np.all(np.abs(low[:2]) < 2)  # not the 10 m floor
    lookat, distance, azimuth, elevation = default_view(m, d)
    assert np.allclose(lookat, (low + high) / 2) and (azimuth, elevation) == (135.0, -25.0)
    assert 1.0 < distance < 6.0
