"""Handshake slots (issue 57): TCP connections that never start their door's handshake must not
lock new clients out. Before: 110 idle connections to the legacy port (reopened as Zenoh closed
them) filled Zenoh's 100 handshake slots (``accept_pending``, each held 10 s), and every new legacy
client was refused; 1,100 stalled ZMQ connections counted toward ``limits.MAX_ZMQ_CONNECTIONS``
(the gate counted accepted connections), and 1 of 8 new ZMQ clients was served. Now Zenoh's
handshakes have limits.ZENOH_ACCEPT_SECONDS and limits.ZENOH_ACCEPT_PENDING slots, and ZMQ's slots
are held only by connections whose handshake succeeded (limits.ZMQ_HANDSHAKE_SECONDS for the rest).

The attacks are the issue's in a bounded form: 110 connections to the legacy door, and 140 to a
ZMQ door whose bound is 128 (a server started with an open-files limit of 256)."""

from __future__ import annotations

import resource
import selectors
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import cbor2
import pytest
import zmq

import vrep
from conftest import ServerProcess, free_port, ready_line
from simx_server.zmq import codec

pytestmark = pytest.mark.renderers_on_demand

SCENE = """<mujoco model="slots">
  <worldbody><body name="Keeper" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body></worldbody>
</mujoco>
"""


class Holder:
    """``n`` TCP connections to ``port`` that never send a byte, each reopened when the server
    closes it, until :meth:`close` (at most 10^6 reopenings, 120 s)."""

    def __init__(self, port: int, n: int):
        self.port, self.sel = port, selectors.DefaultSelector()
        self.reopened = 0
        for _ in range(n):
            self._open()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _open(self) -> None:
        s = socket.create_connection(("127.0.0.1", self.port), timeout=5)
        s.setblocking(False)
        self.sel.register(s, selectors.EVENT_READ)

    def _run(self) -> None:
        end = time.monotonic() + 120
        while not self._stop.is_set() and time.monotonic() < end and self.reopened < 1_000_000:
            for key, _ in self.sel.select(0.05):
                try:
                    data = key.fileobj.recv(4096)
                except OSError:
                    data = b""
                if not data:  # closed by the server: taken again at once
                    self.sel.unregister(key.fileobj)
                    key.fileobj.close()
                    try:
                        self._open()
                    except OSError:
                        pass
                    self.reopened += 1

    def close(self) -> None:
        self._stop.set()
        self._thread.join(10)
        for key in list(self.sel.get_map().values()):
            key.fileobj.close()
        self.sel.close()


def _descriptors(pid: int) -> int:
    return len(list(Path(f"/proc/{pid}/fd").iterdir()))


def _until(condition, polls: int = 400) -> None:
    for _ in range(polls):
        if condition():
            return
        threading.Event().wait(0.05)
    assert condition()


def test_idle_tcp_connections_do_not_lock_legacy_clients_out(tmp_path):
    (tmp_path / "scene.xml").write_text(SCENE)
    server = ServerProcess(str(tmp_path / "scene.xml"), renderers="on-demand")
    try:
        before = _descriptors(server.proc.pid)
        holder = Holder(server.port, 110)
        try:
            _until(lambda: _descriptors(server.proc.pid) >= before + 100)  # Zenoh took them (pending handshakes)
            for _ in range(3):
                cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
                assert cid >= 0, server.log_so_far()[-2000:]
                try:
                    rc, _ = vrep.simxGetObjectHandle(cid, "Keeper", vrep.simx_opmode_blocking)
                    assert rc == vrep.simx_return_ok
                finally:
                    vrep.simxFinish(cid)
        finally:
            holder.close()
    finally:
        server.stop()


def _limited_server(folder: Path, nofile: int, *args: str) -> tuple[subprocess.Popen, list[str]]:
    """A server of SCENE started with an open-files limit of ``nofile`` (soft and hard), and its
    log as it comes."""
    (folder / "scene.xml").write_text(SCENE)

    def low_limit():
        resource.setrlimit(resource.RLIMIT_NOFILE, (nofile, nofile))

    proc = subprocess.Popen([sys.executable, "-m", "simx_server.cli", str(folder / "scene.xml"), "--stopped",
                             "--renderers", "on-demand", *args], preexec_fn=low_limit, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    log: list[str] = []
    threading.Thread(target=lambda: log.extend(proc.stderr), daemon=True).start()
    return proc, log


def _stop(proc: subprocess.Popen) -> None:
    proc.terminate()
    try:
        proc.wait(20)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def test_stalled_zmq_connections_hold_no_slot(tmp_path):
    port = free_port()  # the gate's bound is half the open-files limit: 128 connections
    proc, log = _limited_server(tmp_path, 256, "--port", str(free_port()), "--zmq-port", str(port))
    ctx = zmq.Context()
    try:
        assert ready_line(proc, 60) is not None
        before = _descriptors(proc.pid)
        holder = Holder(port, 140)
        try:
            _until(lambda: _descriptors(proc.pid) >= before + 130)  # libzmq accepted them
            for k in range(8):
                sock = ctx.socket(zmq.REQ)
                sock.setsockopt(zmq.LINGER, 0)
                sock.setsockopt(zmq.RCVTIMEO, 5000)
                sock.connect(f"tcp://127.0.0.1:{port}")
                try:
                    sock.send(codec.encode_request("sim.getSimulationState", [], f"new{k}"))
                    assert "ret" in cbor2.loads(sock.recv()), k
                finally:
                    sock.close(0)
        finally:
            holder.close()
        assert not any("MAX_ZMQ_CONNECTIONS" in line for line in log), "".join(log)[-2000:]
    finally:
        ctx.destroy(0)
        _stop(proc)


def test_zenoh_handshake_bounds_in_the_config_unless_the_operator_sets_them(tmp_path):
    from simx_server.base import limits
    from simx_server.legacy.zenoh_config import zenoh_config

    config = zenoh_config(["tcp/127.0.0.1:19997"])
    assert config.get_json("transport/unicast/accept_timeout") == str(int(limits.ZENOH_ACCEPT_SECONDS * 1000))
    assert 100 <= int(config.get_json("transport/unicast/accept_pending")) <= limits.ZENOH_ACCEPT_PENDING
    own = tmp_path / "zenoh.json5"
    own.write_text('{transport: {unicast: {accept_timeout: 20000, accept_pending: 7}}}')
    config = zenoh_config(["tcp/127.0.0.1:19997"], own)
    assert (config.get_json("transport/unicast/accept_timeout"), config.get_json("transport/unicast/accept_pending")) \
        == ("20000", "7")


def test_more_idle_connections_than_zenohs_slots_do_not_lock_legacy_clients_out(tmp_path):
    """Issue 84: 5,000 idle TCP connections from one process filled Zenoh's 4,096 handshake slots,
    which refuses the newest connection once they are full, and every new legacy client was
    refused (0 of 4 in 30 s). Bounded: a server whose open-files limit is 1,024 (Zenoh's slots were
    a quarter of it, 256; a third now, 341), 300 idle connections, reopened as they are closed:
    3 new clients must each be served."""
    port = free_port()
    proc, log = _limited_server(tmp_path, 1024, "--no-zmq", "--port", str(port))
    try:
        assert ready_line(proc, 60) is not None
        before = _descriptors(proc.pid)
        holder = Holder(port, 300)
        try:
            _until(lambda: holder.reopened > 300)  # closed by Zenoh (slots full) before, by the guard now
            for _ in range(3):
                cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
                assert cid >= 0, "".join(log)[-2000:]
                try:
                    rc, _ = vrep.simxGetObjectHandle(cid, "Keeper", vrep.simx_opmode_blocking)
                    assert rc == vrep.simx_return_ok
                finally:
                    vrep.simxFinish(cid)
            assert _descriptors(proc.pid) < before + 341 + 50  # never more than Zenoh's slots
        finally:
            holder.close()
    finally:
        _stop(proc)


def test_the_guard_closes_the_oldest_connections_that_are_not_sessions():
    """Zenoh refuses the newest connection once its handshake slots (``accept_pending``) are full;
    simx's guard (legacy/handshakes.py) closes the oldest connections that are not a session yet,
    past three quarters of the slots, down to half of them: a session is never closed, and a new
    client finds a slot. In process, Zenoh with 40 slots; sweeps called directly."""
    import zenoh

    from simx_server.legacy.handshakes import HandshakeGuard, connections
    from simx_server.legacy.zenoh_config import zenoh_config

    port = free_port()
    config = zenoh_config([f"tcp/127.0.0.1:{port}"])
    config.insert_json5("transport/unicast/accept_pending", "40")
    server = zenoh.open(config)
    guard = HandshakeGuard.of(server, config)
    assert guard is not None and (guard.high, guard.low) == (30, 20)
    client = zenoh.Config()
    client.insert_json5("mode", '"client"')
    client.insert_json5("connect/endpoints", f'["tcp/127.0.0.1:{port}"]')
    client.insert_json5("scouting/multicast/enabled", "false")
    first = zenoh.open(client)  # a session before the attack
    idle: list[socket.socket] = []
    try:
        idle += [socket.create_connection(("127.0.0.1", port)) for _ in range(30)]
        _until(lambda: len(connections({port})) == 31)
        assert guard.sweep() == 0  # at the trigger, not past it: seen, left to Zenoh
        idle += [socket.create_connection(("127.0.0.1", port)) for _ in range(10)]  # the slots are full
        _until(lambda: len(connections({port})) == 41)
        with pytest.raises(zenoh.ZError):
            zenoh.open(client).close()
        assert guard.sweep() == 20  # 40 waiting: the 20 oldest go
        gone = []
        for k, sock in enumerate(idle):
            sock.settimeout(10)
            try:
                if sock.recv(1) == b"":
                    gone.append(k)
            except OSError:  # reset: closed too
                gone.append(k)
            if len(gone) == 20:
                break
        assert len(gone) == 20 and max(gone) < 30, gone  # among the oldest 30, none of the 10 newest
        late = zenoh.open(client)  # a slot was free
        late.close()
        sessions = {str(r.ok.key_expr).split("/")[5] for r in server.get(
            f"@/{server.info.zid()}/session/transport/unicast/*")}
        assert str(first.info.zid()) in sessions  # the session from before was left alone
    finally:
        for sock in idle:
            sock.close()
        first.close()
        server.close()
