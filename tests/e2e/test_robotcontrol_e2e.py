"""End to end: the tutorial's keyboard program ``robotControl.py``, unmodified, driven by real keys.

``../shared/legacy/robotControl.py`` runs byte for byte from where it lies (never copied
into the project) as a subprocess on a private Xvfb display, against a real
``simx-server`` on the port it hard-codes (19999).  The test types into its pygame window
with xdotool, as a person would, and checks the effects from a second client in the
test process:

* Q x10 turns ``UR5_joint1`` to +10 degrees;
* T closes the RG2 (``RG2_openCloseJoint`` falls), Y opens it again (rises); on the tutorial's
  own ``scene.ttt`` also in a bent pose (joint 2 at 31, joint 3 at 30 degrees: issue 41's), set
  from the test's client, opening to its limit;
* SPACE saves ``saveImg\\rgbImg\\<8 chars>_rgb.jpg`` and ``saveImg\\depthImg\\<8 chars>_depth.jpg``
  (Windows-style paths: on Linux plain file names with backslashes, in the program's cwd);
  the RGB one is a real picture, the depth one kinect_depth's grey depth image inverted by the
  program (near pixels bright), as on V-REP;
* P exits with status 0 (waited for at most 30 s);
* the server still serves a new client afterwards.
"""

from __future__ import annotations

import importlib.util
import math
import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

try:
    from conftest import LEGACY, SCENE, SHARED, ServerProcess, require_shared
    from xdisplay import VirtualDisplay, find_window, have_x_tools, send_keys
except ImportError:  # tests/ imported as a package
    from tests.conftest import LEGACY, SCENE, SHARED, ServerProcess, require_shared
    from tests.xdisplay import VirtualDisplay, find_window, have_x_tools, send_keys

PROGRAM = LEGACY / "robotControl.py"
# the tutorial's own V-REP scene file, served through its MJCF conversion (simx_server.scene.ttt)
TUTORIAL_TTT = SHARED / "ttt-corpus" / "Ianlande+Vrep_yolov3_ddpg_pytorch__scenes_scene.ttt"
PORT = 19999  # hard-coded in robotControl.py
BENT_POSE = [0, 31, 30, 0, 0, 0]  # joint 2 at 31, joint 3 at 30 degrees (issue 41)
PNGS = Path(os.environ.get("SIMX_TEST_PNGS", "/nonexistent"))  # where to keep the saved images, to look at
TITLE = "Vrep yolov3 ddpg pytorch"
FRAME = "imgTemp\\frame.jpg"  # one file name with a backslash (the program's Windows path)
RGB_NAME = re.compile(r"^saveImg\\rgbImg\\([A-Za-z0-9]{8})_rgb\.jpg$")
DEPTH_NAME = re.compile(r"^saveImg\\depthImg\\([A-Za-z0-9]{8})_depth\.jpg$")

_missing = [m for m in ("pygame", "cv2") if importlib.util.find_spec(m) is None]
pytestmark = [
    pytest.mark.skipif(not have_x_tools(),
                       reason="needs Xvfb and xdotool: run `scripts/system-deps.sh --with-x`"),
    pytest.mark.skipif(bool(_missing),
                       reason=f"robotControl.py needs {', '.join(_missing)}: pip install -e '.[test]' "
                              "opencv-python-headless"),
]


def _port_in_use(port: int) -> bool:
    """True when something listens on 127.0.0.1:port (TIME_WAIT leftovers do not count)."""
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return True
    return False


@pytest.fixture(scope="module", params=["mjcf", "ttt"])
def server19999(request):
    """A server of our own on the program's hard-coded port 19999 (the program itself first: a plain
    clone has no ../shared, see conftest.require_shared), on the bundled MJCF scene and on the
    tutorial's original ``scene.ttt``."""
    require_shared(PROGRAM)
    scene = SCENE if request.param == "mjcf" else require_shared(TUTORIAL_TTT)
    if _port_in_use(PORT):
        pytest.skip(f"port {PORT} (hard-coded in robotControl.py) is already in use on 127.0.0.1")
    try:
        srv = ServerProcess(str(scene), ports=[PORT])
    except RuntimeError as exc:
        if "cannot listen" in str(exc):  # lost a race for the port
            pytest.skip(f"port {PORT} (hard-coded in robotControl.py) was taken: {exc}")
        raise
    srv.kind = request.param  # which scene the test runs on (and names the images kept for SIMX_TEST_PNGS)
    yield srv
    srv.stop()


def _tail(path: Path, n: int = 3000) -> str:
    try:
        return path.read_text(errors="replace")[-n:]
    except OSError:
        return "<unreadable>"


class Program:
    """robotControl.py running under Xvfb, with its output in files (a full pipe cannot block it)."""

    def __init__(self, xd: VirtualDisplay, cwd: Path):
        self.cwd = cwd
        self.out_path = cwd / "robotControl.stdout"
        self.err_path = cwd / "robotControl.stderr"
        env = xd.env()
        env["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"
        env["PYTHONUNBUFFERED"] = "1"  # so its prints ("save image") show up as they happen
        env["SDL_AUDIODRIVER"] = "dummy"  # pygame.init() opens audio too; there is no sound card
        with open(self.out_path, "wb") as out, open(self.err_path, "wb") as err:
            self.proc = subprocess.Popen([sys.executable, str(PROGRAM)], cwd=cwd, env=env,
                                         stdin=subprocess.DEVNULL, stdout=out, stderr=err)

    def diagnostics(self) -> str:
        rc = self.proc.poll()
        return (f"\nrobotControl.py {'running' if rc is None else f'exit status {rc}'}"
                f"\n--- stdout (tail) ---\n{_tail(self.out_path)}"
                f"\n--- stderr (tail) ---\n{_tail(self.err_path)}"
                f"\n--- files in cwd ---\n{sorted(os.listdir(self.cwd))}")

    def fail(self, why) -> None:
        pytest.fail(f"{why}{self.diagnostics()}")

    def wait_for(self, what, predicate, timeout: float, period: float = 0.1):
        """Poll ``predicate`` until truthy; fail with the program's output if it dies or time runs out.

        ``what`` describes the condition: a string, or a callable giving one (evaluated on failure).
        """
        deadline = time.monotonic() + timeout
        while True:
            value = predicate()
            if value:
                return value
            if self.proc.poll() is not None:
                self.fail(f"robotControl.py exited while waiting for {what() if callable(what) else what}")
            if time.monotonic() > deadline:
                self.fail(f"timed out after {timeout:.0f} s waiting for {what() if callable(what) else what}")
            time.sleep(period)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()  # by PID: only the process this test started
            self.proc.wait(timeout=10)


def press(display: str, window_id: str, key: str, times: int = 1) -> None:
    """Tap ``key`` ``times`` times, each tap a separate xdotool call with no hold time.

    robotControl.py calls ``pygame.key.set_repeat(200, 50)`` and pumps events only once per
    frame (0.3 s or more here).  pygame's repeat timer starts when a KEYDOWN is pumped and
    stops when the KEYUP is pumped, so a key whose release arrives one frame after its press
    repeats (every 50 ms after 200 ms): ``xdotool key --delay 50 q q ...`` holds each key
    for part of the delay, and turned 10 Q taps into 15-17 with slow frames.  Press and release back to back
    (``--delay 0``) leave no frame boundary in between.  Separate calls, rather than one
    ``key --delay 0 q q ...``, because SDL takes a release followed by a press of the same key
    within 2 ms for X autorepeat and drops both.
    """
    for _ in range(times):
        send_keys(display, window_id, key, delay_ms=0)


def _check_depth_image(saved, vrep, cid: int, kinect: int) -> None:
    """robotControl's depth image is kinect_depth's grey depth image, inverted (255 - value,
    rows top-down): grey, and bright where the sensor's depth buffer is near."""
    import numpy as np

    assert np.abs(saved.astype(int) - saved[..., :1]).max() <= 12, "the depth image is not grey (JPEG aside)"
    rc, res, buf = vrep.simxGetVisionSensorDepthBuffer(cid, kinect, vrep.simx_opmode_blocking)
    assert rc == 0
    depth = np.asarray(buf, np.float32).reshape(res[1], res[0])[::-1]  # rows top-down, as saved
    grey = saved[..., 0].astype(np.float64)
    near, far = depth < 0.6, depth > 0.95  # 0..1 between the sensor's near and far planes
    assert near.sum() > 100 and far.sum() > 100, "kinect_depth should see near and far things"
    assert grey[near].mean() > grey[far].mean() + 30, "near pixels are not brighter than far ones"
    expected = 255 - (depth * np.float32(255.1)).astype(np.uint8).astype(np.float64)
    assert np.corrcoef(grey.ravel(), expected.ravel())[0, 1] > 0.95


def _saved(cwd: Path, pattern: re.Pattern) -> list[str]:
    return [n for n in os.listdir(cwd) if pattern.match(n)]


@pytest.mark.timeout(180)
def test_robotcontrol_keyboard_session(server19999, tmp_path):
    import cv2
    import vrep

    B = vrep.simx_opmode_blocking

    with VirtualDisplay() as xd:
        prog = Program(xd, tmp_path)
        cid = -1
        try:
            try:
                wid = find_window(xd.display, re.escape(TITLE), timeout=60.0)
            except RuntimeError as exc:
                prog.fail(exc)
            # The main loop runs: it has rendered the Kinect image to its temp file.
            prog.wait_for(f"{FRAME!r} to be written", lambda: (tmp_path / FRAME).exists(), 60)

            cid = vrep.simxStart("127.0.0.1", PORT, True, True, 5000, 5)
            assert cid >= 0, "test client could not connect to the server on 19999" + prog.diagnostics()
            rc, j1 = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)
            rc2, grip = vrep.simxGetObjectHandle(cid, "RG2_openCloseJoint", B)
            assert rc == 0 and rc2 == 0, prog.diagnostics()

            def joint(h: int) -> float:
                rc, q = vrep.simxGetJointPosition(cid, h, B)
                assert rc == 0, f"simxGetJointPosition rc {rc}" + prog.diagnostics()
                return q

            def settled(h: int, what: str) -> float:
                """The joint's position once it stops moving: two reads 0.3 s of simulation time
                apart agree (0.3 s of wall clock was less simulation on a loaded machine, where
                a joint still moving slowly looked settled)."""
                last = [joint(h), vrep.simxGetLastCmdTime(cid)]  # the position, its time (ms)

                def still():
                    q, t = joint(h), vrep.simxGetLastCmdTime(cid)
                    if t - last[1] < 300:
                        return False
                    done = abs(q - last[0]) < 1e-4
                    last[:] = [q, t]
                    return done

                prog.wait_for(what, still, 60, period=0.05)
                return last[0]

            # --- Q x10: joint 1 by +1 degree each, to +10 degrees.
            assert abs(math.degrees(joint(j1))) < 0.5, "joint 1 should start at 0" + prog.diagnostics()
            press(xd.display, wid, "q", 10)
            seen = []  # joint 1 readings, degrees, for the failure message

            def at_10_deg() -> bool:
                seen.append(round(math.degrees(joint(j1)), 2))
                return abs(seen[-1] - 10.0) <= 0.5

            prog.wait_for(lambda: f"UR5_joint1 to reach +10 deg +- 0.5 (read {seen[-5:]})", at_10_deg, 60)

            def close_and_open(where: str) -> None:
                """T closes the RG2, Y opens it again (each to where it stops)."""
                open_pos = joint(grip)
                press(xd.display, wid, "t")
                prog.wait_for(f"RG2_openCloseJoint to fall from {open_pos:.4f} (close, {where})",
                              lambda: joint(grip) < open_pos - 0.02, 60)
                # Let it travel, then check that Y reverses it.
                closed_pos = settled(grip, f"the RG2 to finish closing ({where})")
                assert closed_pos < open_pos - 0.03, where + prog.diagnostics()
                press(xd.display, wid, "y")
                prog.wait_for(f"RG2_openCloseJoint to rise from {closed_pos:.4f} (open, {where})",
                              lambda: joint(grip) > closed_pos + 0.02, 60)
                if server19999.kind == "ttt":  # the .ttt's RG2: open to its limit again
                    assert settled(grip, f"the RG2 to finish opening ({where})") > 0.05, where + prog.diagnostics()

            # --- T closes the RG2, Y opens it again.
            close_and_open("joint 1 at 10 degrees")
            if server19999.kind == "ttt":
                # On the tutorial's own scene.ttt, also in a bent pose (set by this test's client:
                # the program sends joint targets only when a key moves one); the DDPG part's pose
                # and three others are test_ttt_tutorial_rg2's and test_gripper_drives'.
                for where, pose in (("a bent pose", BENT_POSE),):
                    handles = [vrep.simxGetObjectHandle(cid, f"UR5_joint{i + 1}", B)[1] for i in range(6)]
                    for h, angle in zip(handles, pose):
                        assert vrep.simxSetJointTargetPosition(cid, h, math.radians(angle), B) == 0
                    prog.wait_for(f"the arm to reach {where} {pose}",
                                  lambda: all(abs(math.degrees(joint(h)) - a) < 1.0 for h, a in zip(handles, pose)), 60)
                    close_and_open(where)
                for h in handles:  # back where the program left them (its L key would do the same)
                    vrep.simxSetJointTargetPosition(cid, h, 0.0, B)
                vrep.simxSetJointTargetPosition(cid, j1, math.radians(10.0), B)
                prog.wait_for("the arm back at joint 1 = 10 degrees",
                              lambda: abs(math.degrees(joint(j1)) - 10.0) < 0.5
                              and all(abs(joint(h)) < 0.01 for h in handles[1:]), 60)

            # --- SPACE saves an RGB and a depth JPEG under Windows-style names (the gripper still,
            # so that the depth buffer read below shows what the saved image shows).
            settled(grip, "the RG2 to finish opening")
            rc, camera = vrep.simxGetObjectHandle(cid, "DetectionCamera", B)
            if rc == 0:  # the tutorial's scene.ttt: its Kinect looks along -x at nothing within 3.5 m;
                # 1.2 m in front of the robot it sees it (kinect_depth: V-REP's grey depth image)
                assert vrep.simxSetObjectPosition(cid, camera, -1, [1.2, 0.35, 1.0], B) == 0
            rc, kinect = vrep.simxGetObjectHandle(cid, "kinect_depth", B)
            assert rc == 0, prog.diagnostics()
            press(xd.display, wid, "space")
            prog.wait_for("'save image' on stdout",
                          lambda: "save image" in _tail(prog.out_path, 10_000), 90, period=0.2)

            def saved_pairs():
                """Ids of complete (RGB, depth) pairs once every save has printed 'save image'."""
                rgb_ids = {RGB_NAME.match(n)[1] for n in _saved(tmp_path, RGB_NAME)}
                depth_ids = {DEPTH_NAME.match(n)[1] for n in _saved(tmp_path, DEPTH_NAME)}
                done = _tail(prog.out_path, 100_000).count("save image")
                return sorted(rgb_ids) if rgb_ids == depth_ids and len(rgb_ids) == done else None

            ids = prog.wait_for("matching saveImg\\rgbImg / saveImg\\depthImg files", saved_pairs, 30)
            assert len(ids) >= 1
            for i in ids:
                rgb = cv2.imread(str(tmp_path / f"saveImg\\rgbImg\\{i}_rgb.jpg"))
                depth = cv2.imread(str(tmp_path / f"saveImg\\depthImg\\{i}_depth.jpg"))
                assert rgb is not None and rgb.shape == (480, 640, 3), f"bad RGB image {i}{prog.diagnostics()}"
                assert float(rgb.std()) > 10.0, f"RGB image {i} is blank (std {rgb.std():.2f})"
                assert depth is not None and depth.shape == (480, 640, 3), f"bad depth image {i}{prog.diagnostics()}"
                if PNGS.is_dir():  # to look at
                    cv2.imwrite(str(PNGS / f"robotcontrol_{server19999.kind}_depth.png"), depth)
                    cv2.imwrite(str(PNGS / f"robotcontrol_{server19999.kind}_rgb.png"), rgb)
                _check_depth_image(depth, vrep, cid, kinect)

            # --- P quits with status 0 (waited for at most 30 s).
            press(xd.display, wid, "p")
            try:  # a bound on the wait only: the program exits on P
                rc = prog.proc.wait(timeout=30.0)
            except subprocess.TimeoutExpired:
                prog.fail("robotControl.py did not exit within 30 s of P")
            assert rc == 0, f"exit status {rc} after P" + prog.diagnostics()
        finally:
            prog.kill()
            if cid >= 0:
                vrep.simxFinish(cid)

    # The server outlived the program and its client: a new client is served.
    cid = vrep.simxStart("127.0.0.1", PORT, True, True, 5000, 5)
    assert cid >= 0, "server on 19999 refused a new client after robotControl.py quit"
    try:
        rc, j1 = vrep.simxGetObjectHandle(cid, "UR5_joint1", B)
        assert rc == 0
        rc, q = vrep.simxGetJointPosition(cid, j1, B)
        assert rc == 0 and abs(math.degrees(q) - 10.0) <= 0.5
    finally:
        vrep.simxFinish(cid)
    assert server19999.proc.poll() is None, "server died"
