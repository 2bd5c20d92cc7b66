"""Start-up refusals said before the scene loads, in one form (issue 33 item 6): a port in use,
and a scene path that names no file (the same line for serving and for ``--list-objects``, not
MuJoCo's "ParseXML: Error opening file"). A taken port is said before MuJoCo, OpenCV and the API
table are even imported (issue 60: it came after 1.4-1.7 s of imports; benchmarks/startup.py
times it)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys

import pytest

from conftest import free_port

SERVER = [sys.executable, "-m", "simx_server"]
#: Modules a refusal must come before: each, imported, ends the server with its own message.
HEAVY = ("mujoco", "cv2", "lupa", "zmq")


def run(*args: str, cwd=None, env=None) -> subprocess.CompletedProcess:
    zmq = [] if "--zmq-port" in args else ["--no-zmq"]
    return subprocess.run([*SERVER, *zmq, *args], capture_output=True, text=True, timeout=60, cwd=cwd, env=env)


def without_heavy_modules(tmp_path) -> dict[str, str]:
    """An environment whose MuJoCo, OpenCV, Lua and ZMQ cannot be imported: a package of each
    name first on the path raises at import."""
    poisoned = tmp_path / "poisoned"
    for name in HEAVY:
        (poisoned / name).mkdir(parents=True)
        (poisoned / name / "__init__.py").write_text(f"raise ImportError('{name} imported before the refusal')\n")
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(poisoned), os.environ.get("PYTHONPATH", "")]))


@pytest.fixture
def taken():
    """A loopback TCP port something listens on."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen()
        yield sock.getsockname()[1]


def test_a_port_in_use_is_refused_before_the_scene_and_mujoco_load(tmp_path, taken):
    # a scene that would fail to load, and no MuJoCo: the port's message comes first, alone
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><geom type='nonsense'/></worldbody></mujoco>")
    out = run(str(broken), "--port", str(taken), env=without_heavy_modules(tmp_path))
    assert out.returncode == 2
    assert out.stderr.strip() == (
        f"simx-server: cannot listen on tcp/127.0.0.1:{taken}: the port is already in use (another simx-server, "
        "or another program, listens there); stop it, or choose a free port with --port N (the client's "
        "simxStart must use the same port)"), out.stderr


def test_a_zmq_port_in_use_is_refused_before_mujoco_loads(tmp_path, taken):
    out = run("--port", str(free_port()), "--zmq-port", str(taken), env=without_heavy_modules(tmp_path))
    assert out.returncode == 2
    assert out.stderr.strip() == (
        f"simx-server: cannot listen on tcp://127.0.0.1:{taken} (ZMQ remote API): Address already in use; choose a "
        "free port with --zmq-port N, or --no-zmq"), out.stderr


def test_the_poisoned_environment_does_stop_a_server_that_imports_mujoco(tmp_path):
    """The check above cannot pass by accident: with the ports free, the same environment ends
    the server at MuJoCo's import."""
    out = run("--port", str(free_port()), env=without_heavy_modules(tmp_path))
    assert out.returncode != 0 and "imported before the refusal" in out.stderr, out.stderr


def test_a_scene_path_typo_is_one_line_for_serving_and_listing(tmp_path):
    served, listed = run("scens/ur5.xml", cwd=tmp_path), run("--list-objects", "scens/ur5.xml", cwd=tmp_path)
    tail = (f"no scene file 'scens/ur5.xml' (relative paths start in {tmp_path}): give the path of an MJCF (.xml), "
            "URDF (.urdf) or V-REP / CoppeliaSim (.ttt, .ttm) file, or none for the bundled scene")
    assert (served.returncode, listed.returncode) == (2, 2)
    assert served.stderr.strip() == f"simx-server: {tail}", served.stderr
    assert listed.stderr.strip() == f"simx-server: --list-objects: {tail}", listed.stderr
    assert "ParseXML" not in served.stderr + listed.stderr
