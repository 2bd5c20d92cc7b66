"""Several servers behind one Zenoh router: each has its own --prefix, clients pick one with
$SIMX_PREFIX and all connect to the router's address and port."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port

ROUTER = textwrap.dedent("""
    import sys, time, zenoh
    c = zenoh.Config()
    c.insert_json5("mode", '"router"')
    c.insert_json5("listen/endpoints", '["tcp/127.0.0.1:%s"]' % sys.argv[1])
    c.insert_json5("scouting/multicast/enabled", "false")
    s = zenoh.open(c)
    print("router ready", flush=True)
    sys.stdin.read()   # until the test closes our stdin
""")


@pytest.fixture
def router():
    """A Zenoh router (a Python session in router mode, as zenohd) on a free loopback port."""
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-c", ROUTER, str(port)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    try:
        assert "router ready" in proc.stdout.readline()
        yield port
    finally:
        proc.stdin.close()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def test_two_servers_behind_one_router(router, tmp_path, monkeypatch):
    config = tmp_path / "server.json5"
    config.write_text('{ mode: "peer", connect: { endpoints: ["tcp/127.0.0.1:%d"] }, '
                      'scouting: { multicast: { enabled: false } } }' % router)
    servers = [ServerProcess(str(SCENE), "--zenoh-config", str(config), "--prefix", f"simx{i}", "--stopped",
                             "--pacing", "immediate", renderers="on-demand") for i in range(2)]
    cids = []
    try:
        for i in range(2):
            monkeypatch.setenv("SIMX_PREFIX", f"simx{i}")
            cid = vrep.simxStart("127.0.0.1", router, True, True, 5000, 5)  # the router, not the server
            assert cid >= 0
            cids.append(cid)
        joints = [vrep.simxGetObjectHandle(cid, "UR5_joint1", vrep.simx_opmode_blocking) for cid in cids]
        assert all(rc == 0 for rc, _ in joints)
        assert vrep.simxSetJointPosition(cids[0], joints[0][1], 0.5, vrep.simx_opmode_blocking) == 0
        assert abs(vrep.simxGetJointPosition(cids[0], joints[0][1], vrep.simx_opmode_blocking)[1] - 0.5) < 1e-6
        assert vrep.simxGetJointPosition(cids[1], joints[1][1], vrep.simx_opmode_blocking)[1] == 0.0
    finally:
        for cid in cids:
            vrep.simxFinish(cid)
        for srv in servers:
            srv.stop()
