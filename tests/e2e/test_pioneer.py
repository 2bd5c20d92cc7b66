"""The bundled Pioneer P3-DX scene driven by a Braitenberg program in the style of V-REP's
mobile-robot tutorials (tests/e2e/pioneer_braitenberg.py: sonars streamed and read from the
buffer, wheel velocities streamed in a loop, no sleep), as a subprocess against a real server
running ten times faster than real time: 40 s of simulated time without touching the room."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT, ServerProcess

PROGRAM = Path(__file__).resolve().parent / "pioneer_braitenberg.py"


def test_braitenberg_program_drives_40_s_without_touching_a_wall():
    server = ServerProcess(str(ROOT / "scenes" / "pioneer_p3dx.xml"), "--speed", "10", renderers="on-demand")
    try:
        try:
            run = subprocess.run([sys.executable, str(PROGRAM), str(server.port), "40"],
                                 capture_output=True, text=True, timeout=240, check=False)
        except subprocess.TimeoutExpired as exc:  # the server stopped answering: show where it is
            err = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else exc.stderr or ""
            pytest.fail(f"the program did not finish within 240 s; its stderr ends:\n{err[-2000:]}\n"
                        f"the server's log and threads:\n{server.thread_dump()[-12000:]}")
        assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-4000:]
        result = json.loads(run.stdout.strip().splitlines()[-1])
    finally:
        log = server.stop()
    assert result["simulated_s"] >= 40
    assert result["steps_touching"] == 0, result  # simxReadCollision: the robot's parts against the room
    # it roams (a robot stopped in front of a wall touches nothing either) ...
    assert result["travelled_m"] > 4, result  # 4.4 m in 30 s, 8.7 m in 60 s on an idle machine
    # ... and the sonars steered it: obstacles heard inside noDetectionDist
    assert result["loops_with_obstacle"] > 0 and result["closest_m"] < 0.5, result
    assert "Traceback" not in log
