"""The command line's first-day messages: arguments checked before the scene loads, a folder
given as the scene, ``--list-objects | head`` ending quietly, MuJoCo's deprecation warnings as one
log line."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from conftest import SCENE

SERVER = [sys.executable, "-m", "simx_server"]


def run(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([*SERVER, *args], capture_output=True, text=True, timeout=timeout)


@pytest.mark.parametrize("port", ["99999", "-1", "0"])
def test_a_bad_port_is_refused_before_the_scene_loads(tmp_path, port):
    # a scene that would fail to load: the port's message must come first, alone
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><geom type='nonsense'/></worldbody></mujoco>")
    out = run(str(broken), "--port", port)
    assert out.returncode == 2
    assert out.stderr.strip() == (f"simx-server: --port {port}: a TCP port is a number from 1 to 65535"), out.stderr


def test_a_folder_given_as_the_scene_says_so(tmp_path):
    out = run(str(tmp_path))
    assert out.returncode == 2
    assert out.stderr.strip() == (f"simx-server: {tmp_path} is a folder, not a scene file: give an MJCF (.xml), "
                                  "URDF (.urdf) or V-REP / CoppeliaSim (.ttt, .ttm) file"), out.stderr


@pytest.mark.parametrize("suffix", [".ttt", ".xml"])
def test_a_fifo_given_as_the_scene_is_refused_in_one_line_before_it_is_read(tmp_path, suffix):
    """``mkfifo x.ttt; simx-server x.ttt`` waited for a writer for good (issue 48)."""
    fifo = tmp_path / f"x{suffix}"
    os.mkfifo(fifo)
    out = run(str(fifo))
    assert out.returncode == 2
    assert out.stderr.strip() == (f"simx-server: {fifo} is not a regular file (a FIFO, socket or device): give an MJCF "
                                  "(.xml), URDF (.urdf) or V-REP / CoppeliaSim (.ttt, .ttm) file"), out.stderr


def test_list_objects_into_a_closed_pipe_ends_quietly():
    proc = subprocess.Popen([*SERVER, "--list-objects", str(SCENE)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()  # like `| head -1`: read a line, then close the pipe
    proc.stdout.close()
    err = proc.stderr.read()
    assert proc.wait(timeout=60) == 0, err
    assert first.strip() and "Traceback" not in err and "BrokenPipe" not in err, err


def test_mujoco_deprecation_is_one_log_line(tmp_path):
    scene = tmp_path / "mass.xml"
    scene.write_text('<mujoco><compiler settotalmass="14"/><worldbody><body name="b"><freejoint/>'
                     '<geom size="0.1"/></body></worldbody></mujoco>')
    out = run("--list-objects", str(scene))
    assert out.returncode == 0, out.stderr
    lines = [line for line in out.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "settotalmass" in lines[0] and "compile()" not in lines[0], out.stderr
