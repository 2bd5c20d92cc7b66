"""A new user's first hour (issue 14, parts 5 and 6): a test suite that passes on a plain clone
(the tests that need the tutorial's files from ``../shared/`` skip there, and fail under CI),
``simx-server --version``, ``python -m simx_server``, a clear message for a port in use, and one
start-up warning line for a scene whose elements share names."""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import vrep
from conftest import ROOT, free_port, ready_line

import simx_server

DUPLICATES = ROOT / "tests" / "scenes" / "duplicate_names.xml"
B = vrep.simx_opmode_blocking


# ----------------------------------------------------------------- ../shared on a plain clone
NEEDS_SHARED = '''
from conftest import REFERENCE, require_shared


def test_needs_the_reference():
    assert "simx_" in require_shared(REFERENCE / "constants.txt").read_text()
'''


def _pytest(checkout: Path, ci: str | None) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    if ci is not None:
        env["CI"] = ci
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-rsf", "-p", "no:cacheprovider",
                           str(checkout / "tests")], cwd=checkout, env=env, capture_output=True, text=True,
                          timeout=60)


def test_a_test_needing_shared_skips_on_a_plain_clone_and_fails_under_ci(tmp_path):
    """The project's own conftest in a checkout with no ``../shared`` beside it: the test SKIPS
    with the missing file's absolute path; with ``CI=1`` it FAILS; once the file is there, it runs."""
    checkout = tmp_path / "simx"
    (checkout / "tests").mkdir(parents=True)
    shutil.copy(ROOT / "tests" / "conftest.py", checkout / "tests" / "conftest.py")
    (checkout / "tests" / "test_needs_shared.py").write_text(NEEDS_SHARED)
    expected = tmp_path / "shared" / "reference" / "constants.txt"

    plain = _pytest(checkout, ci=None)
    assert plain.returncode == 0 and "1 skipped" in plain.stdout, plain.stdout + plain.stderr
    assert f"shared/reference/constants.txt (from the tutorial) is missing: expected at {expected}" in plain.stdout

    empty_ci = _pytest(checkout, ci="")  # set but empty: not CI
    assert empty_ci.returncode == 0 and "1 skipped" in empty_ci.stdout, empty_ci.stdout

    ci = _pytest(checkout, ci="1")
    assert ci.returncode == 1 and "1 failed" in ci.stdout and "skipped" not in ci.stdout, ci.stdout
    assert str(expected) in ci.stdout and "CI is set: failing instead of skipping" in ci.stdout

    expected.parent.mkdir(parents=True)
    expected.write_text("simx_return_ok = 0\n")
    present = _pytest(checkout, ci="1")
    assert present.returncode == 0 and "1 passed" in present.stdout, present.stdout


# ----------------------------------------------------------------- --version, python -m
def _version_line() -> re.Pattern:
    return re.compile(rf"^simx-server {re.escape(simx_server.__version__)} "
                      rf"\(MuJoCo {re.escape(metadata.version('mujoco'))}, "
                      rf"Zenoh {re.escape(metadata.version('eclipse-zenoh'))}, Python \d+\.\d+\.\d+\)$")


def test_version_of_the_console_script_and_of_python_m():
    script = Path(sys.executable).with_name("simx-server")
    for cmd in ([str(script), "--version"], [sys.executable, "-m", "simx_server", "--version"]):
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        assert _version_line().match(out.stdout.strip()), out.stdout
    assert simx_server.__version__ == metadata.version("simx")  # pyproject reads it from the package


# ----------------------------------------------------------------- shared names: one warning
def test_python_m_serves_and_a_scene_with_shared_names_logs_one_warning():
    """``python -m simx_server`` is the server (ready line, legacy clients served); the scene's six
    elements renamed NAME#N give one WARNING line (count, the first three) and one DEBUG line each."""
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "simx_server", str(DUPLICATES), "--port", str(port),
                             "--no-zmq",  # its ports (23000, or a free one and the next) may be held by another test
                             "--log-level", "DEBUG"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=dict(os.environ, MUJOCO_GL="egl", PYTHONUNBUFFERED="1"))
    try:
        line = ready_line(proc, timeout=60)
        assert line and f"tcp/127.0.0.1:{port}" in line, proc.stderr.read() if proc.poll() is not None else line
        cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
        assert cid >= 0
        try:
            rc, camera = vrep.simxGetObjectHandle(cid, "torso#1", B)
            assert rc == 0
            rc, res, _ = vrep.simxGetVisionSensorImage(cid, camera, 0, B)
            assert rc == 0 and res == [16, 12]
        finally:
            vrep.simxFinish(cid)
    finally:
        proc.terminate()
        _, log = proc.communicate(timeout=15)
    warnings = [x for x in log.splitlines() if " WARNING " in x]
    assert len(warnings) == 1, log
    assert "6 MJCF element(s) share a name" in warnings[0] and "and 3 more" in warnings[0]
    assert warnings[0].count(" -> ") == 3
    details = [x for x in log.splitlines() if " DEBUG " in x and "is the V-REP object" in x]
    assert len(details) == 6 and any("MJCF camera 'torso' is the V-REP object 'torso#1'" in x for x in details), log


# ----------------------------------------------------------------- port in use
def test_port_in_use_is_one_clean_line_naming_the_port_and_the_way_out():
    """A port another program holds (a socket of ours): exit status 2 and one line that names that
    endpoint (not the free one beside it) and ``--port``, without Zenoh's Rust source paths."""
    with socket.socket() as blocker:
        blocker.bind(("127.0.0.1", 0))
        blocker.listen()
        taken = blocker.getsockname()[1]
        free = free_port()
        out = subprocess.run([sys.executable, "-m", "simx_server", str(DUPLICATES), "--port", str(free),
                              "--port", str(taken), "--log-level", "ERROR"],
                             capture_output=True, text=True, timeout=60, env=dict(os.environ, MUJOCO_GL="egl"))
    assert out.returncode == 2, out.stderr
    lines = [x for x in out.stderr.splitlines() if x.strip()]
    assert len(lines) == 1, out.stderr
    assert lines[0] == (f"simx-server: cannot listen on tcp/127.0.0.1:{taken}: the port is already in use "
                        "(another simx-server, or another program, listens there); stop it, or choose a free "
                        "port with --port N (the client's simxStart must use the same port)")
    assert ".rs" not in out.stderr and str(free) not in out.stderr


def test_an_address_not_of_this_machine_is_one_clean_line_naming_host():
    out = subprocess.run([sys.executable, "-m", "simx_server", str(DUPLICATES), "--host", "192.0.2.1",
                          "--port", str(free_port()), "--log-level", "ERROR"],  # 192.0.2.1: TEST-NET-1
                         capture_output=True, text=True, timeout=60, env=dict(os.environ, MUJOCO_GL="egl"))
    assert out.returncode == 2, out.stderr
    lines = [x for x in out.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("simx-server: cannot listen on tcp/192.0.2.1:"), out.stderr
    assert "not one of this machine's; give --host one of its own addresses" in lines[0] and ".rs" not in lines[0]
