"""Many servers on one machine: ServerPool and ``simx-server --instances N``."""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys

import pytest

import vrep
from conftest import ROOT, SCENE, ready_line, wait_until
from simx_server.pool import PoolError, ServerPool

ENV = dict(os.environ, MUJOCO_GL="egl", PYTHONUNBUFFERED="1")
#: These servers serve no image: no GL renderer at load (0.25 s of CPU a server).
NO_IMAGES = ("--renderers", "on-demand")


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie (a child this test did not reap)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


def _connect(host: str, port: int) -> int:
    cid = vrep.simxStart(host, port, True, True, 5000, 5)
    assert cid >= 0, f"no connection to {host}:{port}"
    return cid


def test_pool_of_two_serves_separate_simulations_and_close_stops_them():
    lines: list[str] = []
    pool = ServerPool(2, SCENE, "--pacing", "immediate", "--stopped", *NO_IMAGES, progress=lines.append)
    try:
        ports = sorted(port for _, port in pool.addresses)
        assert [line.split(" ready")[0] for line in lines] == ["simx-server 1 of 2", "simx-server 2 of 2"]
        assert sorted(int(line.split("port ")[1].split()[0]) for line in lines) == ports
        assert len(pool.addresses) == 2 and len(set(pool.addresses)) == 2
        assert all(host == "127.0.0.1" for host, _ in pool.addresses)
        pids = pool.pids
        assert all(_alive(pid) for pid in pids)
        cids = [_connect(host, port) for host, port in pool.addresses]
        for cid in cids:
            rc, handle = vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)
            assert rc == vrep.simx_return_ok and handle > 0
        joints = [vrep.simxGetObjectHandle(cid, "UR5_joint1", vrep.simx_opmode_blocking)[1] for cid in cids]
        assert vrep.simxSetJointPosition(cids[0], joints[0], 0.7, vrep.simx_opmode_blocking) == 0
        first = vrep.simxGetJointPosition(cids[0], joints[0], vrep.simx_opmode_blocking)
        second = vrep.simxGetJointPosition(cids[1], joints[1], vrep.simx_opmode_blocking)
        assert first[0] == 0 and abs(first[1] - 0.7) < 1e-6
        assert second[0] == 0 and abs(second[1]) < 1e-6  # its own simulation: unchanged
        for cid in cids:
            vrep.simxFinish(cid)
        logs = pool.log_paths
        assert all(path.exists() and "simx-server ready" in path.read_text() for path in logs)
    finally:
        pool.close()
    assert not any(_alive(pid) for pid in pids)
    assert pool.poll() == [0, 0]  # stopped by SIGTERM, cleanly
    assert not logs[0].parent.exists()  # its temporary log folder is gone
    pool.close()  # again: nothing to do


def test_pool_context_manager_and_kept_log_dir(tmp_path):
    with ServerPool(1, None, "--pacing", "immediate", *NO_IMAGES, log_dir=tmp_path) as pool:
        (host, port), = pool.addresses
        cid = _connect(host, port)
        assert vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)[0] == 0
        vrep.simxFinish(cid)
        pids = pool.pids
    assert not any(_alive(pid) for pid in pids)
    assert "simx-server ready" in (tmp_path / "server-0.log").read_text()


def test_pool_takes_another_port_when_one_is_taken(monkeypatch):
    """A lost race for a port (another program listens on it first) starts that server again on
    another free port."""
    import simx_server.pool as pool_module

    blocker = socket.socket()
    blocker.bind(("127.0.0.1", 0))
    blocker.listen()
    taken = blocker.getsockname()[1]
    real = pool_module.free_port
    answers = iter([taken])
    monkeypatch.setattr(pool_module, "free_port", lambda host="127.0.0.1": next(answers, None) or real(host))
    try:
        with ServerPool(1, None, "--pacing", "immediate", *NO_IMAGES) as pool:
            (_, port), = pool.addresses
            assert port != taken
            cid = _connect("127.0.0.1", port)
            assert vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)[0] == 0
            vrep.simxFinish(cid)
            assert "cannot listen" in pool.logs()[0]  # the first try, on the taken port
    finally:
        blocker.close()


def test_pool_reports_a_server_that_cannot_start(tmp_path):
    bad = tmp_path / "broken.xml"
    bad.write_text("<mujoco><worldbody>")
    with pytest.raises(PoolError, match="broken.xml"):
        ServerPool(2, bad)


def test_pool_refuses_host_and_port_arguments():
    with pytest.raises(ValueError, match="--port"):
        ServerPool(1, None, "--port", "1234")
    with pytest.raises(ValueError):
        ServerPool(0)


def _children(pid: int) -> list[int]:
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    if int(f.read().rsplit(")", 1)[1].split()[1]) == pid:
                        out.append(int(entry))
            except (OSError, ValueError, IndexError):
                pass
    return out


def _start_instances(*args: str) -> tuple[subprocess.Popen, str]:
    proc = subprocess.Popen([sys.executable, "-m", "simx_server.cli", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV, cwd=ROOT)
    line = ready_line(proc, 90)
    if line is not None:
        return proc, line
    proc.kill()
    raise AssertionError(f"simx-server --instances not ready: {proc.communicate()[1]}")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_instances_end_to_end(sig):
    proc, line = _start_instances(str(SCENE), "--instances", "2", "--pacing", "immediate", *NO_IMAGES)
    try:
        ports = [int(p) for p in re.findall(r"tcp/127\.0\.0\.1:(\d+)", line)]
        assert len(ports) == 2 and ports[0] != ports[1], line
        assert line.startswith("simx-server ready: 2 instances")
        children = _children(proc.pid)
        assert len(children) == 2
        for port in ports:
            cid = _connect("127.0.0.1", port)
            assert vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)[0] == 0
            vrep.simxFinish(cid)
        proc.send_signal(sig)
        assert proc.wait(timeout=15) == 0
        wait_until(lambda: not any(_alive(pid) for pid in children), timeout=5, what="every server gone")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _free_run(n: int) -> int:
    """The first of ``n`` consecutive ports nothing listens on now (loopback)."""
    for _ in range(50):
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            first = min(s.getsockname()[1], 65000)
        try:
            for port in range(first, first + n):
                with socket.socket() as s:
                    s.bind(("127.0.0.1", port))
            return first
        except OSError:
            continue
    pytest.fail(f"no run of {n} free ports found")


def test_instances_with_port_uses_consecutive_ports():
    first = _free_run(3)
    proc, line = _start_instances("--instances", "3", "--port", str(first), "--pacing", "immediate", *NO_IMAGES)
    try:
        assert re.findall(r"tcp/127\.0\.0\.1:(\d+)", line) == [str(first + i) for i in range(3)]
        cid = _connect("127.0.0.1", first + 2)
        assert vrep.simxGetObjectHandle(cid, "UR5", vrep.simx_opmode_blocking)[0] == 0
        vrep.simxFinish(cid)
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=15) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.parametrize("args", [["--port", "1", "--port", "2"], ["--host", "127.0.0.1", "--host", "::1"],
                                  ["--port", "65535"], []])
def test_instances_refusals(args):
    instances = ["--instances", "0"] if not args else ["--instances", "2"]
    out = subprocess.run([sys.executable, "-m", "simx_server.cli", *instances, *args], capture_output=True,
                         text=True, timeout=60, env=ENV)
    assert out.returncode == 2 and ("--instances" in out.stderr or "--port" in out.stderr), out.stderr


def test_instances_one_failing_stops_the_other(tmp_path):
    """A server that exits after the pool started takes the others down with it (status 1)."""
    proc, line = _start_instances("--instances", "2", "--pacing", "immediate", *NO_IMAGES, "--log-dir", str(tmp_path))
    try:
        children = _children(proc.pid)
        assert len(children) == 2
        os.kill(children[0], signal.SIGKILL)
        assert proc.wait(timeout=15) == 1
        wait_until(lambda: not any(_alive(pid) for pid in children), timeout=5, what="every server gone")
        assert (tmp_path / "server-1.log").exists()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_servers_stop_when_the_pool_owner_is_killed(tmp_path):
    """PR_SET_PDEATHSIG: a training script killed with SIGKILL leaves no server behind."""
    code = ("import sys; from simx_server.pool import ServerPool\n"
            "p = ServerPool(2, None, '--pacing', 'immediate', '--renderers', 'on-demand', log_dir=sys.argv[1])\n"
            "print(*p.pids, flush=True)\n"
            "sys.stdin.read()\n")
    owner = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             text=True, env=ENV, cwd=ROOT)
    try:
        pids = [int(p) for p in owner.stdout.readline().split()]
        assert len(pids) == 2 and all(_alive(pid) for pid in pids)
        owner.kill()
        owner.wait()
        wait_until(lambda: not any(_alive(pid) for pid in pids), timeout=10, what="servers gone after SIGKILL")
    finally:
        if owner.poll() is None:
            owner.kill()
            owner.wait()
