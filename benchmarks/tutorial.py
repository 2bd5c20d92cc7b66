"""7. The tutorial loop: frames per second of robotControl.py's own main loop, for reference.

``../shared/legacy/robotControl.py`` runs unchanged (from where it lies) on a private Xvfb
display (tests/e2e/xdisplay.py's VirtualDisplay), against a simx server of our own on the port it
hard-codes, 19999 (the figure is skipped, with a note, if that port is busy). Each pass of its
loop deletes ``imgTemp\\frame.jpg`` in its working directory, fetches the Kinect image
(blocking ``simxGetVisionSensorImage``), converts it with its own per-channel list
comprehensions, writes the JPEG, loads it with pygame and displays it. The file reappearing
marks the end of a fetch + conversion + write; we poll for it every 2 ms for ``window`` s.
The program is then killed by its PID, the server and Xvfb stopped.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import time

from benchmarks.common import Settings
from benchmarks.procs import ROOT, Server, child_env, port_in_use
from benchmarks.stats import Figure, rate_summary, skipped, unavailable

PROGRAM = ROOT.parent / "shared" / "legacy" / "robotControl.py"
PORT = 19999
FRAME = "imgTemp\\frame.jpg"
KEY, LABEL = "tutorial.fps", "robotControl.py loop under Xvfb: frames/s"


def run(s: Settings) -> list[Figure]:
    missing = [m for m in ("pygame", "cv2") if importlib.util.find_spec(m) is None]
    if missing:
        return [unavailable(KEY, LABEL, f"robotControl.py needs {', '.join(missing)}")]
    if not PROGRAM.is_file():
        return [unavailable(KEY, LABEL, f"{PROGRAM} not found (the tutorial's files, ../shared beside the checkout)")]
    sys.path.insert(0, str(ROOT))
    try:
        from tests.e2e.xdisplay import VirtualDisplay, have_x_tools
    except ImportError as exc:
        return [skipped(KEY, LABEL, f"tests/e2e/xdisplay.py not importable: {exc}")]
    if not have_x_tools():
        return [unavailable(KEY, LABEL, "Xvfb/xdotool not installed (scripts/system-deps.sh --with-x)")]
    deadline = time.monotonic() + s.t(45.0, 5.0)  # e.g. a test run holding it for a while
    while port_in_use(PORT):
        if time.monotonic() > deadline:
            return [unavailable(KEY, LABEL, f"port {PORT} (hard-coded in robotControl.py) is in use")]
        time.sleep(1.0)
    try:
        srv = Server(s.log_dir, port=PORT, name="tutorial")
    except RuntimeError as exc:
        return [skipped(KEY, LABEL, f"could not start a server on {PORT}: {str(exc)[-200:]}")]
    window = s.t(10.0, 4.0)
    cwd = s.log_dir / "tutorial"
    cwd.mkdir(parents=True, exist_ok=True)
    frame = cwd / FRAME
    try:
        with VirtualDisplay() as xd:
            env = child_env(**{k: v for k, v in xd.env().items() if k in ("DISPLAY", "SDL_VIDEODRIVER")})
            env.pop("WAYLAND_DISPLAY", None)
            env.update(PYGAME_HIDE_SUPPORT_PROMPT="1", SDL_AUDIODRIVER="dummy")
            with open(cwd / "robotControl.stdout", "wb") as out, open(cwd / "robotControl.stderr", "wb") as err:
                proc = subprocess.Popen([sys.executable, str(PROGRAM)], cwd=cwd, env=env,
                                        stdin=subprocess.DEVNULL, stdout=out, stderr=err)
            try:
                deadline = time.monotonic() + 90
                while not frame.exists():
                    if proc.poll() is not None or time.monotonic() > deadline:
                        tail = (cwd / "robotControl.stderr").read_text(errors="replace")[-500:]
                        return [skipped(KEY, LABEL, f"robotControl.py wrote no frame (exit {proc.poll()}): {tail}")]
                    time.sleep(0.01)
                appeared: list[float] = []
                present = True
                end = time.monotonic() + window
                while time.monotonic() < end and proc.poll() is None:
                    now_present = os.path.exists(frame)
                    if now_present and not present:
                        appeared.append(time.monotonic())
                    present = now_present
                    time.sleep(0.002)
            finally:
                if proc.poll() is None:
                    proc.kill()  # by PID: only the process started here
                proc.wait(timeout=10)
    finally:
        srv.stop()
    intervals = [b - a for a, b in zip(appeared, appeared[1:])]
    fps = (len(appeared) - 1) / (appeared[-1] - appeared[0]) if len(appeared) > 1 else float("nan")
    return [Figure(KEY, LABEL, "1/s", rate_summary(intervals),
                   note=f"{len(appeared)} frames in {window:.0f} s ({fps:.2f}/s counted); reference only",
                   extra={"frames": len(appeared), "fps_count": fps})]
