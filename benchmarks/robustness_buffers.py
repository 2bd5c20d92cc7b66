"""Buffered request bytes and handshake slots under attack (issue 57): each attack on a server of
its own, on loopback, with raw pyzmq / Zenoh / TCP sockets; figures, not pass/fail (the bounded
forms are tests/transport/test_buffered_requests.py and test_handshake_slots.py).

    MUJOCO_GL=egl python -m benchmarks.robustness_buffers                # this checkout (~2-3 min)
    MUJOCO_GL=egl python -m benchmarks.robustness_buffers --code DIR     # another checkout's simx_server
    MUJOCO_GL=egl python -m benchmarks.robustness_buffers --only zmq     # attacks whose name holds "zmq"

Attacks (the issue's sizes):

* **zmq pipelined**: 8 DEALER connections each send 16 requests of 60 MiB at once (a REQ client
  has one in flight); a probe REQ client calls ``sim.getSimulationTime`` meanwhile.
* **legacy large**: 16 raw Zenoh sessions each send 3 queries of 60 MiB at once; a probe legacy
  client makes blocking calls meanwhile; how many of the 48 queries got a reply.
* **legacy idle TCP**: one process holds 110 TCP connections to the legacy port that never start
  Zenoh's handshake (reopened when the server closes them); then a new legacy client connects.
* **zmq stalled**: 1,100 TCP connections to the ZMQ port that never start ZMTP's handshake; then
  8 new ZMQ clients each make one call.
* **zmq half frames** (issue 84): 40 connections finish ZMTP's handshake, declare a 17 MiB frame,
  send 16 MiB of it and stop; how long until the server has closed them, and its memory.
* **legacy 5,000 idle TCP** (issue 84): one process holds 5,000 TCP connections to the legacy port
  (server and attacker at an open-files limit of 20,000), reopened as they are closed; then 4 new
  legacy clients, one every 3 s.

Each prints: the server's RSS before, at its peak (sampled every 50 ms from /proc) and 10 s after
the attack ended; the probe's slowest answer; what the attacker got.
"""

from __future__ import annotations

import argparse
import os
import resource
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import cbor2
import zmq

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from conftest import free_port, ready_line  # noqa: E402

from simx_server.zmq import codec  # noqa: E402
from simx_wire import protocol as P  # noqa: E402

SCENE = """<mujoco model="attack">
  <worldbody>
    <light name="light" pos="0 0 3"/>
    <body name="Keeper" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body>
  </worldbody>
</mujoco>
"""
MIB = 1 << 20
BIG = 60 * MIB
#: s a legacy attacker waits for each query's reply (Zenoh's default is 10 s)
QUERY_TIMEOUT = float(os.environ.get("SIMX_ATTACK_QUERY_TIMEOUT", "30"))


class Target:
    """A simx-server process of ``code`` (legacy and ZMQ doors) and its RSS sampled meanwhile."""

    def __init__(self, code: Path, folder: Path, nofile: int = 4096, extra: tuple[str, ...] = ()):
        self.zmq_port, self.port = free_port(), free_port()
        env = dict(os.environ, MUJOCO_GL="egl", PYTHONPATH=str(code))

        def limit():  # soft and hard: the server raises its soft limit to the hard one
            resource.setrlimit(resource.RLIMIT_NOFILE, (nofile, nofile))

        self.proc = subprocess.Popen([sys.executable, "-m", "simx_server.cli", str(folder / "scene.xml"),
                                      "--renderers", "on-demand", "--port", str(self.port),
                                      "--zmq-port", str(self.zmq_port), *extra], env=env, cwd=str(code),
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, preexec_fn=limit)
        if ready_line(self.proc, 90) is None:
            raise RuntimeError("the server did not start")
        self.before = self.peak = self.rss()
        self._stop = threading.Event()
        threading.Thread(target=self._sample, daemon=True).start()

    def rss(self) -> float:
        try:
            for line in Path(f"/proc/{self.proc.pid}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
        except OSError:
            pass
        return 0.0

    def _sample(self) -> None:
        while not self._stop.wait(0.05):
            self.peak = max(self.peak, self.rss())

    def socket(self, ctx: zmq.Context, kind: int = zmq.REQ, timeout_ms: int = 60000) -> zmq.Socket:
        sock = ctx.socket(kind)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.RCVTIMEO, timeout_ms)
        sock.setsockopt(zmq.SNDTIMEO, timeout_ms)
        sock.connect(f"tcp://127.0.0.1:{self.zmq_port}")
        return sock

    def stop(self) -> None:
        self._stop.set()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


_PROBE = r"""
import json, sys, threading, time
import cbor2, zmq
from simx_client import api
from simx_server.zmq import codec
kind, port, timeout = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
stop = threading.Event()
threading.Thread(target=lambda: (sys.stdin.read(), stop.set()), daemon=True).start()
times, failed = [], 0
if kind == "zmq":
    ctx = zmq.Context()
    def sock():
        s = ctx.socket(zmq.REQ); s.setsockopt(zmq.LINGER, 0); s.setsockopt(zmq.RCVTIMEO, int(timeout * 1000))
        s.connect(f"tcp://127.0.0.1:{port}"); return s
    s = sock()
    for _ in range(100_000):
        if stop.wait(0.05):
            break
        start = time.monotonic()
        try:
            s.send(codec.encode_request("sim.getSimulationTime", [], "probe")); s.recv()
            times.append(time.monotonic() - start)
        except zmq.Again:
            failed += 1; s.close(0); s = sock()
    s.close(0)
else:
    cid = api.simxStart("127.0.0.1", port, True, True, int(timeout * 1000), 5)
    failed += cid < 0
    for _ in range(100_000 if cid >= 0 else 0):
        if stop.wait(0.05):
            break
        start = time.monotonic()
        if api.simxGetObjectHandle(cid, "Keeper", 0x010000)[0] == 0:
            times.append(time.monotonic() - start)
        else:
            failed += 1
    if cid >= 0:
        api.simxFinish(cid)
print(json.dumps([times, failed]))
"""


class Probe:
    """Another client's calls while an attack runs, in a process of its own (the attacker's
    threads here hold this process's GIL): the slowest answer and the calls without one within
    ``timeout`` s. ``kind``: "zmq" or "legacy"."""

    def __init__(self, t: Target, kind: str, timeout: float = 10.0):
        port = t.zmq_port if kind == "zmq" else t.port
        self.proc = subprocess.Popen([sys.executable, "-c", _PROBE, kind, str(port), str(timeout)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=str(ROOT))

    def result(self) -> str:
        import json

        out, _ = self.proc.communicate("", timeout=120)
        times, failed = json.loads(out.strip().splitlines()[-1])
        worst = max(times) if times else float("nan")
        p99 = sorted(times)[int(0.99 * (len(times) - 1))] if times else float("nan")
        return f"probe: {len(times)} calls, p99 {p99 * 1000:.0f} ms, slowest {worst * 1000:.0f} ms, {failed} unanswered"


def zmq_pipelined(t: Target, ctx: zmq.Context) -> str:
    """8 DEALER connections x 16 pipelined 60 MiB requests."""
    probe = Probe(t, "zmq")
    time.sleep(1.0)
    request = codec.encode_request("sim.setStringSignal", ["big", b"\1" * BIG], "attacker")
    dealers = []
    replies = [0]

    def attack(k: int) -> None:
        d = t.socket(ctx, zmq.DEALER, timeout_ms=60000)
        d.setsockopt(zmq.SNDHWM, 0)
        dealers.append(d)
        for _ in range(16):
            d.send_multipart([b"", request], copy=False)
        end = time.monotonic() + 120
        while time.monotonic() < end and replies[0] < 8 * 16:
            try:
                d.recv_multipart()
                replies[0] += 1
            except zmq.Again:
                break

    threads = [threading.Thread(target=attack, args=(k,), daemon=True) for k in range(8)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(180)
    peak = t.peak
    for d in dealers:
        d.close(0)
    out = probe.result()
    time.sleep(10)
    return f"{replies[0]} of 128 requests answered; peak {peak:.0f} MB; {out}"


def legacy_large(t: Target, ctx: zmq.Context) -> str:
    """16 raw Zenoh sessions x 3 queries of 60 MiB at once."""
    import zenoh

    from simx_client.client_config import client_config

    probe = Probe(t, "legacy")
    time.sleep(1.0)
    got = [0, 0]  # replies, of which errors
    lock = threading.Lock()
    sessions = [zenoh.open(client_config("127.0.0.1", t.port)) for _ in range(16)]

    def attack(k: int) -> None:
        client = f"attacker-{k}"
        payload = P.request(client, [["SetStringSignal", P.MODE_BLOCKING, ["big", b"\1" * BIG]]])
        handlers = [sessions[k].get(P.call_key("simx", client), payload=payload, timeout=QUERY_TIMEOUT) for _ in range(3)]
        for h in handlers:
            for r in h:
                with lock:
                    got[0] += 1
                    got[1] += r.ok is None

    threads = [threading.Thread(target=attack, args=(k,), daemon=True) for k in range(16)]
    for th in threads:
        th.start()
    for th in threads:
        th.join(90)
    peak = t.peak
    for s in sessions:
        s.close()
    out = probe.result()
    time.sleep(10)
    return f"{got[0]} of 48 queries answered ({got[1]} errors); peak {peak:.0f} MB; {out}"


def _hold_tcp(port: int, n: int, stop: threading.Event) -> list[int]:
    """Hold ``n`` idle TCP connections to ``port`` until ``stop``, reopening those the server closes
    (at most 100 rounds); returns [opened, reopened]."""
    import selectors

    sel = selectors.DefaultSelector()
    counts = [0, 0]

    def open_one() -> None:
        s = socket.create_connection(("127.0.0.1", port), timeout=5)
        s.setblocking(False)
        sel.register(s, selectors.EVENT_READ)
        counts[0] += 1

    for _ in range(n):
        open_one()
    rounds = 0
    while not stop.is_set() and rounds < 100_000:
        rounds += 1
        for key, _ in sel.select(0.1):
            s = key.fileobj
            try:
                data = s.recv(4096)
            except OSError:
                data = b""
            if not data:  # closed by the server: reopen it
                sel.unregister(s)
                s.close()
                try:
                    open_one()
                except OSError:  # the listener's backlog is full: the next round tries again
                    continue
                counts[1] += 1
    for key in list(sel.get_map().values()):
        key.fileobj.close()
    return counts


def _idle_then_clients(t: Target, idle: int, clients: int, settle: float) -> str:
    """``idle`` idle TCP connections to the legacy port (this process's open-files limit raised to
    its hard limit meanwhile), then ``clients`` new legacy clients, one every 3 s."""
    from simx_client import api

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    stop = threading.Event()
    counts: list[int] = []
    holder = threading.Thread(target=lambda: counts.extend(_hold_tcp(t.port, idle, stop)), daemon=True)
    holder.start()
    time.sleep(settle)
    results = []
    try:
        for _ in range(clients):
            start = time.monotonic()
            cid = api.simxStart("127.0.0.1", t.port, True, True, 5000, 5)
            ok = cid >= 0 and api.simxGetObjectHandle(cid, "Keeper", P.MODE_BLOCKING)[0] == 0
            results.append(f"{'served' if ok else 'refused'} in {time.monotonic() - start:.2f} s")
            if cid >= 0:
                api.simxFinish(cid)
            time.sleep(3.0)
    finally:
        stop.set()
        holder.join(60)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    return f"new legacy clients: {', '.join(results)}; attacker opened {counts[0]}, reopened {counts[1]}"


def legacy_idle_tcp(t: Target, ctx: zmq.Context) -> str:
    """110 idle TCP connections to the legacy port, then 3 new legacy clients."""
    return _idle_then_clients(t, 110, 3, 2.0)


def _zmtp_half_frame(port: int, declared: int, sent: int) -> socket.socket:
    """A connection that speaks ZMTP 3.0 by hand (RFC 23: greeting, NULL, READY as a DEALER),
    then declares a frame of ``declared`` bytes, sends ``sent`` of them and stops."""
    import struct

    sock = socket.create_connection(("127.0.0.1", port), timeout=30)
    body = b"\x05READY\x0bSocket-Type" + struct.pack(">I", 6) + b"DEALER"
    sock.sendall(b"\xff" + b"\0" * 8 + b"\x7f\x03\x00" + b"NULL".ljust(20, b"\0") + b"\0" * 32
                 + bytes([0x04, len(body)]) + body)
    got = b""
    while len(got) < 66 or len(got) < 66 + got[65]:  # the server's greeting and READY
        data = sock.recv(4096)
        if not data:
            return sock
        got += data
    try:
        sock.sendall(b"\x01\x00\x02" + struct.pack(">Q", declared))
        sock.sendall(b"\0" * sent)
    except OSError:  # closed by the server meanwhile
        pass
    return sock


def zmq_half_frames(t: Target, ctx: zmq.Context) -> str:
    """40 connections stalled inside a 17 MiB frame (16 MiB sent)."""
    import selectors

    probe = Probe(t, "zmq")
    start = time.monotonic()
    socks = [_zmtp_half_frame(t.zmq_port, 17 * MIB, 16 * MIB) for _ in range(40)]
    sent = time.monotonic()
    sel = selectors.DefaultSelector()
    for s in socks:
        s.setblocking(False)
        sel.register(s, selectors.EVENT_READ)
    closed_at: list[float] = []
    while sel.get_map() and time.monotonic() - sent < 60:
        for key, _ in sel.select(0.5):
            try:
                data = key.fileobj.recv(65536)
            except OSError:
                data = b""
            if not data:
                sel.unregister(key.fileobj)
                closed_at.append(time.monotonic() - sent)
    open_left = len(sel.get_map())
    for s in socks:
        s.close()
    time.sleep(10)
    last = f"the last {max(closed_at):.1f} s after" if closed_at else "none"
    return (f"sent in {sent - start:.1f} s; {len(closed_at)} of 40 closed by the server ({last}), {open_left} "
            f"still open after 60 s; {probe.result()}")


def legacy_idle_5000(t: Target, ctx: zmq.Context) -> str:
    """5,000 idle TCP connections to the legacy port, then 4 new legacy clients."""
    return _idle_then_clients(t, 5000, 4, 5.0)


legacy_idle_5000.nofile = 20000  # type: ignore[attr-defined]


def zmq_stalled(t: Target, ctx: zmq.Context) -> str:
    """1,100 TCP connections to the ZMQ port that never handshake, then 8 new ZMQ clients."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, 8192), hard))
    stop = threading.Event()
    counts: list[int] = []
    holder = threading.Thread(target=lambda: counts.extend(_hold_tcp(t.zmq_port, 1100, stop)), daemon=True)
    holder.start()
    time.sleep(3.0)
    served, times = 0, []
    try:
        for k in range(8):
            sock = t.socket(ctx, timeout_ms=2000)
            start = time.monotonic()
            try:
                sock.send(codec.encode_request("sim.getSimulationTime", [], f"new{k}"))
                if "ret" in cbor2.loads(sock.recv()):
                    served += 1
                    times.append(time.monotonic() - start)
            except zmq.Again:
                pass
            finally:
                sock.close(0)
    finally:
        stop.set()
        holder.join(30)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    worst = f", slowest {max(times) * 1000:.0f} ms" if times else ""
    return f"{served} of 8 new ZMQ clients served within 2 s{worst}; attacker opened {counts[0]}, reopened {counts[1]}"


ATTACKS = {"zmq pipelined: 8 connections x 16 x 60 MiB": zmq_pipelined,
           "legacy large: 16 sessions x 3 x 60 MiB": legacy_large,
           "legacy idle TCP: 110 connections, then simxStart": legacy_idle_tcp,
           "zmq stalled: 1,100 connections, then 8 clients": zmq_stalled,
           "zmq half frames: 40 connections stalled inside a 17 MiB frame": zmq_half_frames,
           "legacy 5,000 idle TCP, then 4 x simxStart": legacy_idle_5000}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--code", type=Path, default=ROOT, help="checkout whose simx_server runs (default: this one)")
    p.add_argument("--only", action="append", metavar="WORD", help="attacks whose name holds WORD (repeatable)")
    args = p.parse_args(argv)
    folder = Path(tempfile.mkdtemp(prefix="simx-buffer-attack-"))
    (folder / "scene.xml").write_text(SCENE)
    ctx = zmq.Context()
    print(f"code: {args.code}; load average {os.getloadavg()[0]:.1f}")
    print("| attack | took | server RSS before -> peak -> 10 s after | result |")
    print("|---|---|---|---|")
    for name, attack in ATTACKS.items():
        if args.only and not any(w in name for w in args.only):
            continue
        t = Target(args.code, folder, getattr(attack, "nofile", 4096))
        try:
            start = time.monotonic()
            result = attack(t, ctx)
            took = time.monotonic() - start
            print(f"| {name} | {took:.1f} s | {t.before:.0f} -> {t.peak:.0f} -> {t.rss():.0f} MB | {result} |",
                  flush=True)
        finally:
            t.stop()
    ctx.destroy(0)


if __name__ == "__main__":
    main()
