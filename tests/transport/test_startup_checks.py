"""Start-up refusals said before the scene loads, in one form (issue 33 item 6): a port in use,
and a scene path that names no file (the same line for serving and for ``--list-objects``, not
MuJoCo's "ParseXML: Error opening file")."""

from __future__ import annotations

import socket
import subprocess
import sys

SERVER = [sys.executable, "-m", "simx_server"]


def run(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([*SERVER, "--no-zmq", *args], capture_output=True, text=True, timeout=60, cwd=cwd)


def test_a_port_in_use_is_refused_before_the_scene_loads(tmp_path):
    # a scene that would fail to load: the port's message comes first, alone
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><geom type='nonsense'/></worldbody></mujoco>")
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = run(str(broken), "--port", str(port))
    assert out.returncode == 2
    assert out.stderr.strip() == (
        f"simx-server: cannot listen on tcp/127.0.0.1:{port}: the port is already in use (another simx-server, "
        "or another program, listens there); stop it, or choose a free port with --port N (the client's "
        "simxStart must use the same port)"), out.stderr


def test_a_scene_path_typo_is_one_line_for_serving_and_listing(tmp_path):
    served, listed = run("scens/ur5.xml", cwd=tmp_path), run("--list-objects", "scens/ur5.xml", cwd=tmp_path)
    tail = (f"no scene file 'scens/ur5.xml' (relative paths start in {tmp_path}): give the path of an MJCF (.xml), "
            "URDF (.urdf) or V-REP / CoppeliaSim (.ttt, .ttm) file, or none for the bundled scene")
    assert (served.returncode, listed.returncode) == (2, 2)
    assert served.stderr.strip() == f"simx-server: {tail}", served.stderr
    assert listed.stderr.strip() == f"simx-server: --list-objects: {tail}", listed.stderr
    assert "ParseXML" not in served.stderr + listed.stderr
