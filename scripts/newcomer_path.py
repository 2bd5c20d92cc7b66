"""A newcomer's path through simx, timed: what a new user does on a fresh clone, step by step,
each step checked and its wall time printed (issue 44).

    python3 scripts/newcomer_path.py                 # a fresh clone of this checkout in a temp folder
    python3 scripts/newcomer_path.py --training      # and examples/train_ddpg.py --quick, twice
    python3 scripts/newcomer_path.py --here          # this checkout as it is (its .venv, if made)

Steps: ``scripts/serve.sh`` until its ready line (installing on a fresh clone), the README's first
program, the tutorial's ``robotControl.py`` under ``xvfb-run`` (needs ``../shared/legacy`` beside
the checkout: its first frame saved), a V-REP scene (``--list-objects`` of the tutorial's
``scene.ttt`` from ``../shared/ttt-corpus``), the README's ZMQ example, ``simx-dataset --count 5``,
and with ``--training`` ``--quick`` twice, comparing the two episode files. Each step prints one
line: ``ok`` or ``FAILED``, its seconds, and what it showed. Ports: the defaults (19997, 19999,
23000), as a user has them; the script stops every process it started, by PID.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
TUTORIAL_SCENE = SHARED / "ttt-corpus" / "Ianlande+Vrep_yolov3_ddpg_pytorch__scenes_scene.ttt"
READY = "simx-server ready"


def readme_block(checkout: Path, after: str) -> str:
    """The first Python code block of README.md after the text ``after``."""
    text = (checkout / "README.md").read_text()
    return re.search(re.escape(after) + r".*?```python\n(.*?)```", text, re.S).group(1)


class Walk:
    """Runs the steps in ``checkout`` and records each one's outcome."""

    def __init__(self, checkout: Path, work: Path):
        self.checkout, self.work = checkout, work
        self.python = checkout / ".venv" / "bin" / "python"
        self.env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "SDL_AUDIODRIVER": "dummy",
                    "PYTHONUNBUFFERED": "1"}
        self.rows: list[tuple[str, bool, float, str]] = []

    def step(self, name: str, fn) -> None:
        start = time.monotonic()
        try:
            ok, said = fn()
        except Exception as exc:  # a step that breaks is a failed step; the others still run
            ok, said = False, f"{type(exc).__name__}: {exc}"
        seconds = time.monotonic() - start
        self.rows.append((name, ok, seconds, said))
        print(f"[newcomer] {'ok' if ok else 'FAILED'}  {seconds:6.1f} s  {name}: {said}", flush=True)

    def serve(self, *args: str) -> subprocess.Popen:
        log = open(self.work / f"serve{len(self.rows)}.log", "w")
        proc = subprocess.Popen(["bash", str(self.checkout / "scripts" / "serve.sh"), *args], cwd=self.work,
                                stdout=log, stderr=subprocess.STDOUT, env=self.env, start_new_session=True)
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline:
            text = Path(log.name).read_text()
            if READY in text:
                return proc
            if proc.poll() is not None:
                raise RuntimeError(f"serve.sh exited with status {proc.returncode}: {text[-500:]}")
            time.sleep(0.2)
        raise RuntimeError("no ready line within 600 s")

    @staticmethod
    def stop(proc: subprocess.Popen) -> None:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()

    def run_program(self, code: str, name: str, timeout: float = 120) -> str:
        (self.work / name).write_text(code)
        out = subprocess.run([str(self.python), name], cwd=self.work, env=self.env, capture_output=True, text=True,
                             timeout=timeout)
        if out.returncode:
            raise RuntimeError(f"{name} exited with status {out.returncode}: {out.stderr[-500:]}")
        return out.stdout.strip().splitlines()[-1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--here", action="store_true", help="use this checkout as it is, not a fresh clone")
    parser.add_argument("--training", action="store_true", help="also train_ddpg.py --quick, twice")
    args = parser.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="simx-newcomer-"))
    checkout = ROOT
    if not args.here:
        checkout = work / "simx"
        subprocess.run(["git", "clone", "--quiet", str(ROOT), str(checkout)], check=True)
    p = Walk(checkout, work)
    print(f"[newcomer] checkout {checkout}; programs run in {work}", flush=True)

    server: list[subprocess.Popen] = []

    def serve_default():
        server.append(p.serve())
        return True, "ready line seen (first run: installing included)"

    p.step("scripts/serve.sh (install and start the bundled scene)", serve_default)

    def first_program():
        line = p.run_program(readme_block(checkout, "Your first program"), "first.py")
        return "UR5_joint1 at 1.00 rad; kinect_rgb sees 640x480 pixels" in line, line

    p.step("README's first program", first_program)

    def robot_control():
        program = SHARED / "legacy" / "robotControl.py"
        if not program.exists():
            return False, f"{program} is not there (../shared beside the checkout)"
        if shutil.which("xvfb-run") is None:
            return False, "xvfb-run is not installed (scripts/system-deps.sh --with-x)"
        subprocess.run([str(p.python), "-m", "pip", "install", "--quiet", "pygame"], check=True, env=p.env)
        proc = subprocess.Popen(["xvfb-run", "-a", str(p.python), str(program)], cwd=work, env=p.env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
        frame = work / "imgTemp\\frame.jpg"
        try:
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline and not frame.exists() and proc.poll() is None:
                time.sleep(0.2)
            return frame.exists(), f"first Kinect frame saved as {frame.name!r}" if frame.exists() else "no frame"
        finally:
            p.stop(proc)

    p.step("robotControl.py under xvfb-run", robot_control)
    for proc in server:
        p.stop(proc)

    def vrep_scene():
        if not TUTORIAL_SCENE.exists():
            return False, f"{TUTORIAL_SCENE} is not there"
        out = subprocess.run([str(checkout / ".venv" / "bin" / "simx-server"), "--list-objects", str(TUTORIAL_SCENE)],
                             cwd=work, env=p.env, capture_output=True, text=True, timeout=600)
        lines = out.stdout.splitlines()
        return out.returncode == 0 and any("kinect_depth" in line for line in lines), \
            (lines[0] if lines else out.stderr[-300:])

    p.step("a .ttt scene (--list-objects of the tutorial's scene.ttt, converted on first use)", vrep_scene)

    def zmq_example():
        subprocess.run([str(p.python), "-m", "pip", "install", "--quiet", "coppeliasim-zmqremoteapi-client"],
                       check=True, env=p.env)  # the README's install line for the official client
        proc = p.serve("--stopped")
        try:
            line = p.run_program(readme_block(checkout, "Save this as `zmq_first.py`"), "zmq_first.py")
            return line.startswith("after 1.00 s: UR5_joint1 at"), line
        finally:
            p.stop(proc)

    p.step("README's ZMQ example", zmq_example)

    def dataset():
        proc = p.serve()
        try:
            out = subprocess.run([str(checkout / ".venv" / "bin" / "simx-dataset"), "--port", "19999", "--class",
                                  "ball=Sphere", "--pose", "90,-45,90,0,-100,0", "--place", "Sphere", "--surface",
                                  "Table", "--count", "5", "--seed", "1", "--out", str(work / "ball_ds")],
                                 cwd=work, env=p.env, capture_output=True, text=True, timeout=600)
            labels = list((work / "ball_ds").rglob("*.txt"))
            return out.returncode == 0 and len(labels) >= 5, f"{len(labels)} label files; {out.stdout.strip()[-120:]}"
        finally:
            p.stop(proc)

    p.step("simx-dataset --count 5", dataset)

    if args.training:
        def train_twice():
            subprocess.run(["bash", str(checkout / "scripts" / "install-train.sh")], check=True, env=p.env)
            files = []
            for run in (1, 2):
                out_dir = work / f"quick{run}"
                subprocess.run([str(p.python), str(checkout / "examples" / "train_ddpg.py"), "--quick", "--out",
                                str(out_dir)], cwd=work, env=p.env, check=True, stdout=subprocess.DEVNULL)
                files.append((out_dir / "episodes.csv").read_text())
            rows = [f.splitlines()[1:] for f in files]  # the episodes, without the header
            same = [a.split(",")[:5] == b.split(",")[:5] for a, b in zip(*rows)]
            return all(same) and len(rows[0]) == len(rows[1]), \
                f"{sum(same)} of {max(len(r) for r in rows)} episode rows the same (wall time aside)"

        p.step("train_ddpg.py --quick, twice", train_twice)

    failed = [name for name, ok, _, _ in p.rows if not ok]
    print(f"[newcomer] {len(p.rows) - len(failed)} passed, {len(failed)} failed; files in {work}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
