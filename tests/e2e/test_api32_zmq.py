"""Issue 32's CoppeliaSim 4.x programs over ZMQ with the official client, as a user runs them: a
subprocess (tests/e2e/zmq_programs/arm32.py) against a real simx-server on the api32 arm scene.
The same programs run as child scripts in tests/scripts/test_api32_scripts.py."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT, ServerProcess, free_port

pytest.importorskip("coppeliasim_zmqremoteapi_client")

PROGRAM = Path(__file__).resolve().parent / "zmq_programs" / "arm32.py"


def test_ik_pick_and_place_reach_and_line_follower_over_zmq(tmp_path):
    port = free_port()
    server = ServerProcess(str(ROOT / "tests" / "scenes" / "api32" / "arm.xml"), "--stopped", "--zmq-port", str(port),
                           renderers="on-demand")
    try:
        env = dict(os.environ, SIMX_ZMQ_PORT=str(port))
        run = subprocess.run([sys.executable, str(PROGRAM)], env=env, capture_output=True, text=True, timeout=300,
                             cwd=tmp_path)
    finally:
        log = server.stop()
    assert run.returncode == 0, f"{run.stdout}\n{run.stderr}\n--- server log ---\n{log[-3000:]}"
    for text in ("pick reached", "place reached", "reach stopped", "line centred", "OK arm32"):
        assert text in run.stdout, run.stdout
    assert "Traceback" not in log, log[-3000:]


BREADTH = Path(__file__).resolve().parent / "zmq_programs" / "breadth32.py"


def test_second_round_functions_over_zmq(tmp_path):
    port = free_port()
    server = ServerProcess(str(ROOT / "tests" / "scenes" / "api32" / "arm.xml"), "--stopped", "--zmq-port", str(port),
                           renderers="on-demand")
    try:
        env = dict(os.environ, SIMX_ZMQ_PORT=str(port))
        run = subprocess.run([sys.executable, str(BREADTH)], env=env, capture_output=True, text=True, timeout=300,
                             cwd=tmp_path)
    finally:
        log = server.stop()
    assert run.returncode == 0, f"{run.stdout}\n{run.stderr}\n--- server log ---\n{log[-3000:]}"
    for text in ("cloud", "octree occupied", "graph recorded", "sensors created", "trajectory", "pose reached",
                 "OK breadth32"):
        assert text in run.stdout, run.stdout
    assert "Traceback" not in log, log[-3000:]
