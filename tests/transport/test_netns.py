"""Servers on another host, as a real network: two network namespaces made by the test.

Namespace A holds the servers, namespace B the clients; a veth pair joins them with addresses
that exist only inside these namespaces (192.0.2.1/24 and 192.0.2.2/24, TEST-NET-1). The servers
listen on A's address only, multicast scouting off, and the clients reach them by address and
port, as programs on another machine would. Needs root (or CAP_NET_ADMIN and CAP_SYS_ADMIN) and
iproute2's ``ip``; skipped with the reason otherwise. The namespaces are removed afterwards.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys

import pytest

from conftest import ROOT, SCENE, network_namespaces, ready_line

ADDR_A, ADDR_B = "192.0.2.1", "192.0.2.2"
ENV = dict(os.environ, MUJOCO_GL="egl", PYTHONUNBUFFERED="1")

CLIENT = """
import sys, vrep
host, ports = sys.argv[1], [int(p) for p in sys.argv[2:]]
for port in ports:
    cid = vrep.simxStart(host, port, True, True, 5000, 5)
    assert cid >= 0, f"no connection to {host}:{port}"
    rc, handle = vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)
    assert rc == vrep.simx_return_ok and handle > 0, (rc, handle)
    print(f"ok {port} UR5={handle}", flush=True)
    vrep.simxFinish(cid)
"""


@pytest.fixture
def namespaces():
    """Two namespaces joined by a veth pair: yields (A, B); removes both afterwards."""
    with network_namespaces(ADDR_A, ADDR_B) as names:
        yield names


#: These servers serve no image: no GL renderer at load (0.25 s of CPU a server).
NO_IMAGES = ("--renderers", "on-demand")


def _start_in(ns: str, *args: str) -> tuple[subprocess.Popen, str]:
    # --no-zmq: these tests count the legacy endpoints a server listens on (ZMQ has its own tests)
    proc = subprocess.Popen(["ip", "netns", "exec", ns, sys.executable, "-m", "simx_server.cli", *args, "--no-zmq"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=ROOT)
    line = ready_line(proc, 90)
    if line is not None:
        return proc, line
    _stop(proc)
    raise AssertionError(f"server in {ns} not ready: {proc.communicate()[1][-3000:]}")


def _stop(proc: subprocess.Popen) -> int:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)  # `ip netns exec` execs the server: this is its PID
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    return proc.returncode


def _client_in(ns: str, host: str, ports: list[int]) -> subprocess.CompletedProcess:
    return subprocess.run(["ip", "netns", "exec", ns, sys.executable, "-c", CLIENT, host, *map(str, ports)],
                          capture_output=True, text=True, timeout=120, env=ENV, cwd=ROOT)


def _listening(ns: str) -> set[str]:
    out = subprocess.run(["ip", "netns", "exec", ns, "ss", "-ltnH"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    return {line.split()[3] for line in out.stdout.splitlines() if line.strip()}


def test_server_in_one_namespace_client_in_another(namespaces):
    a, b = namespaces
    port = 19997
    proc, line = _start_in(a, str(SCENE), "--host", ADDR_A, "--port", str(port), "--pacing", "immediate", *NO_IMAGES)
    try:
        assert f"tcp/{ADDR_A}:{port}" in line
        assert _listening(a) == {f"{ADDR_A}:{port}"}  # the namespace's address only, no loopback
        out = _client_in(b, ADDR_A, [port])
        assert out.returncode == 0, out.stdout + out.stderr
        assert f"ok {port}" in out.stdout
        # From B, nothing answers on B's own loopback: the call really crossed the veth pair.
        out = _client_in(b, "127.0.0.1", [port])
        assert out.returncode != 0
    finally:
        assert _stop(proc) == 0


def test_instances_in_one_namespace_clients_in_another(namespaces):
    a, b = namespaces
    proc, line = _start_in(a, "--instances", "2", "--host", ADDR_A, "--pacing", "immediate", *NO_IMAGES)
    try:
        ports = [int(p) for p in re.findall(rf"tcp/{re.escape(ADDR_A)}:(\d+)", line)]
        assert len(ports) == 2, line
        assert _listening(a) == {f"{ADDR_A}:{p}" for p in ports}
        out = _client_in(b, ADDR_A, ports)
        assert out.returncode == 0, out.stdout + out.stderr
        assert all(f"ok {p}" in out.stdout for p in ports)
    finally:
        assert _stop(proc) == 0


VECTOR = """
import sys
import numpy as np
import gymnasium as gym
sys.path[:0] = [sys.argv[1], sys.argv[1] + "/client"]  # conftest, test_pool_gym
from test_pool_gym import ENV_ID, JointEnv
from simx_server.pool import ServerClaims
host, folder, ports = sys.argv[2], sys.argv[3], [int(p) for p in sys.argv[4:]]
gym.register(ENV_ID, entry_point=JointEnv)
envs = gym.make_vec(ENV_ID, num_envs=len(ports), vectorization_mode="async", vector_kwargs={"context": "spawn"},
                    servers=ServerClaims([(host, p) for p in ports], folder))
try:
    obs, info = envs.reset(seed=0)
    assert sorted(info["port"]) == sorted(ports), info
    obs, _, _, _, info = envs.step(np.array([[0.25], [-0.5]], np.float32))
    assert np.allclose(obs[:, 0], [0.25, -0.5], atol=1e-6), obs
    print("vector ok", flush=True)
finally:
    envs.close()
"""


def test_vector_env_in_one_namespace_servers_in_another(namespaces, tmp_path):
    pytest.importorskip("gymnasium", reason="gymnasium is not installed (pip install gymnasium)")
    a, b = namespaces
    proc, line = _start_in(a, str(SCENE), "--instances", "2", "--host", ADDR_A, "--stopped", "--pacing", "immediate",
                          *NO_IMAGES)
    try:
        ports = [int(p) for p in re.findall(rf"tcp/{re.escape(ADDR_A)}:(\d+)", line)]
        assert len(ports) == 2, line
        out = subprocess.run(["ip", "netns", "exec", b, sys.executable, "-c", VECTOR, str(ROOT / "tests"), ADDR_A,
                              str(tmp_path), *map(str, ports)], capture_output=True, text=True, timeout=120,
                             env=ENV, cwd=ROOT)
        assert out.returncode == 0 and "vector ok" in out.stdout, out.stdout + out.stderr[-3000:]
    finally:
        assert _stop(proc) == 0
