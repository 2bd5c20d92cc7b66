"""The ZMQ door under attack (issue 29): short attacks, each on a server of its own, with raw
pyzmq sockets; figures, not pass/fail (tests/zmq/ has the pass/fail side).

    MUJOCO_GL=egl python -m benchmarks.robustness_zmq                 # this checkout (~1-2 min)
    MUJOCO_GL=egl python -m benchmarks.robustness_zmq --code DIR      # another checkout's simx_server

Each attack prints: the attacker's call time, the server's RSS before and at its peak (sampled
every 50 ms from /proc), whether the server still answers afterwards (and its exit code if not).
"""

from __future__ import annotations

import argparse
import os
import resource
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

SCENE = """<mujoco model="attack">
  <worldbody>
    <light name="light" pos="0 0 3"/>
    <body name="Keeper" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body>
    <body name="Camera" pos="0 0 1"><camera name="cam" fovy="45" resolution="32 24"/></body>
  </worldbody>
  <custom><text name="simx:Keeper" data="child_script=keeper.lua"/></custom>
</mujoco>
"""
KEEPER = "kept = {}\nfunction store(...) kept[#kept + 1] = {...} return #kept end\n"


class Target:
    """A simx-server process of ``code`` with the ZMQ API, and its RSS sampled meanwhile."""

    def __init__(self, code: Path, folder: Path):
        self.zmq_port, self.port = free_port(), free_port()
        env = dict(os.environ, MUJOCO_GL="egl", PYTHONPATH=str(code))

        def common_limit():  # the open-files limit of many systems, soft and hard (Zenoh raises the soft one)
            resource.setrlimit(resource.RLIMIT_NOFILE, (1024, 1024))

        self.proc = subprocess.Popen([sys.executable, "-m", "simx_server.cli", str(folder / "scene.xml"),
                                      "--port", str(self.port), "--zmq-port", str(self.zmq_port)], env=env,
                                     cwd=str(code), stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                                     preexec_fn=common_limit)
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
        sock.connect(f"tcp://127.0.0.1:{self.zmq_port}")
        return sock

    def alive(self, ctx: zmq.Context) -> str:
        if self.proc.poll() is not None:
            return f"died (exit {self.proc.returncode})"
        sock = self.socket(ctx, timeout_ms=30000)
        try:
            return "answers" if "ret" in call(sock, "sim.getSimulationTime", uuid="probe") else "errors"
        except zmq.Again:
            return "no answer in 30 s"
        finally:
            sock.close(0)

    def stop(self) -> None:
        self._stop.set()
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def call(sock: zmq.Socket, func: str, *args, uuid: str = "attacker") -> dict:
    sock.send(codec.encode_request(func, list(args), uuid))
    return cbor2.loads(sock.recv())


def _short(reply: dict) -> str:
    text = reply.get("err") or f"ret ({len(cbor2.dumps(reply))} bytes)"
    return text if len(text) < 110 else text[:107] + "..."


def crash(t: Target, ctx: zmq.Context) -> str:
    sock = t.socket(ctx)
    out = []
    for _ in range(5):
        try:
            out.append(_short(call(sock, "sim.callScriptFunction", "store@/Keeper", 1, b"\0" * (60 << 20))))
        except zmq.Again:
            out.append("no reply")
            break
    sock.close(0)
    return "; ".join(out[-2:])


def empty_tables(t: Target, ctx: zmq.Context) -> str:
    head = cbor2.dumps({"func": "sim.callScriptFunction", "uuid": "attacker"})[1:]
    n = 1_000_000
    payload = (b"\xa3" + head + cbor2.dumps("args") + b"\x83" + cbor2.dumps("store@/Keeper") + b"\x01"
               + b"\x9a" + n.to_bytes(4, "big") + b"\x80" * n)
    sock = t.socket(ctx)
    sock.send(payload)
    reply = cbor2.loads(sock.recv())
    sock.close(0)
    return _short(reply)


def unpack(t: Target, ctx: zmq.Context) -> str:
    sock = t.socket(ctx)
    reply = call(sock, "sim.unpackUInt8Table", b"\1" * (20 << 20))
    sock.close(0)
    return _short(reply)


def unread(t: Target, ctx: zmq.Context) -> str:
    sock = t.socket(ctx)
    call(sock, "sim.setStringSignal", "big", b"\1" * (16 << 20))
    sock.close(0)
    dealer = t.socket(ctx, zmq.DEALER)
    dealer.setsockopt(zmq.RCVHWM, 1)
    request = codec.encode_request("sim.getStringSignal", ["big"], "never-reads")
    end = time.monotonic() + 5
    sent = 0
    while time.monotonic() < end:
        dealer.send_multipart([b"", request])
        sent += 1
        time.sleep(0.02)
    dealer.close(0)
    return f"{sent} requests in 5 s, none read"


def uuids(t: Target, ctx: zmq.Context) -> str:
    sock = t.socket(ctx)
    refused = sum("err" in call(sock, "sim.setStepping", True, uuid=f"u{i}") for i in range(1100))
    sock.close(0)
    other = t.socket(ctx)
    reply = call(other, "sim.getSimulationTime", uuid="newcomer")
    other.close(0)
    return f"{refused} of 1,100 uuids refused; a new client: {_short(reply)}"


def long_path(t: Target, ctx: zmq.Context) -> str:
    sock = t.socket(ctx)
    reply = call(sock, "sim.loadScene", "a" * 5000 + ".ttt")
    sock.close(0)
    return _short(reply)


def sigterm(t: Target, ctx: zmq.Context) -> str:
    """SIGTERM while the server makes a 4096x4096 image for a ZMQ client: s until it exits."""
    sock = t.socket(ctx)
    cam = call(sock, "sim.getObject", "/cam")["ret"][0]
    call(sock, "sim.setObjectInt32Param", cam, 1002, 4096)
    call(sock, "sim.setObjectInt32Param", cam, 1003, 4096)
    sock.send(codec.encode_request("sim.getVisionSensorImage", [cam], "attacker"))
    time.sleep(0.3)
    start = time.monotonic()
    t.proc.terminate()
    try:
        t.proc.wait(30)
    except subprocess.TimeoutExpired:
        return "still running 30 s after SIGTERM"
    finally:
        sock.close(0)
    return f"exited {time.monotonic() - start:.2f} s after SIGTERM (exit {t.proc.returncode})"


def idle_connections(t: Target, ctx: zmq.Context) -> str:
    """1,000 idle ZMQ connections (the server started with an open-files limit of 1,024, soft
    and hard), then a legacy client's simxStart (5 s timeout)."""
    from simx_client import api

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, 8192), hard))  # this process's own sockets
    socks = [t.socket(ctx) for _ in range(1000)]
    time.sleep(3)
    try:
        start = time.monotonic()
        cid = api.simxStart("127.0.0.1", t.port, True, True, 5000, 5)
        took = time.monotonic() - start
        if cid >= 0:
            api.simxFinish(cid)
        fds = len(os.listdir(f"/proc/{t.proc.pid}/fd"))
        return f"server descriptors {fds}; legacy simxStart {cid} after {took:.1f} s"
    finally:
        for sock in socks:
            sock.close(0)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


def _legacy_calls(port: int, seconds: float) -> list[float]:
    """A legacy client's blocking simxGetObjectHandle calls for ``seconds``: their times in ms."""
    from simx_client import api

    cid = api.simxStart("127.0.0.1", port, True, True, 30000, 5)
    out, end = [], time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            start = time.perf_counter()
            api.simxGetObjectHandle(cid, "Keeper", 0x010000)  # simx_opmode_blocking
            out.append((time.perf_counter() - start) * 1e3)
    finally:
        api.simxFinish(cid)
    return out


def big_images_beside_legacy(t: Target, ctx: zmq.Context) -> str:
    """Four ZMQ connections loop ``sim.getVisionSensorImg`` of a 4096x4096 sensor for 20 s while a
    legacy client makes blocking calls: its p99 against its own unloaded p99 (issue 29 item 5,
    before: 14 s)."""
    import numpy as np

    unloaded = _legacy_calls(t.port, 3.0)
    setup = t.socket(ctx)
    cam = call(setup, "sim.getObject", "/cam")["ret"][0]
    call(setup, "sim.setObjectInt32Param", cam, 1002, 4096)
    call(setup, "sim.setObjectInt32Param", cam, 1003, 4096)
    setup.close(0)
    stop, images, errors = threading.Event(), [0], []

    def loop(k: int) -> None:
        sock = t.socket(ctx)
        while not stop.is_set():
            try:
                reply = call(sock, "sim.getVisionSensorImg", cam, uuid=f"images{k}")
                if "ret" in reply:
                    images[0] += 1
                elif not images[0]:
                    errors.append(_short(reply))
            except zmq.Again:
                break
        sock.close(0)

    threads = [threading.Thread(target=loop, args=(k,), daemon=True) for k in range(4)]
    for th in threads:
        th.start()
    time.sleep(1.0)
    loaded = _legacy_calls(t.port, 20.0)
    stop.set()
    for th in threads:
        th.join(60)
    p99, p99u = np.percentile(loaded, 99), np.percentile(unloaded, 99)
    return (f"legacy p99 {p99:.1f} ms against {p99u:.1f} ms unloaded ({p99 / p99u:.1f}x; median "
            f"{np.median(loaded):.2f} / {np.median(unloaded):.2f} ms), {len(loaded)} calls; {images[0]} images"
            + (f" ({errors[0]})" if errors else ""))


ATTACKS = {"crash: 5 x store(60 MiB)": crash, "1 M empty tables into a script": empty_tables,
           "unpackUInt8Table(20 MiB)": unpack, "16 MiB signal every 20 ms, unread, 5 s": unread,
           "1,100 stepping uuids, one connection": uuids, "loadScene of a 5,000-char path": long_path,
           "SIGTERM during a 4096x4096 image": sigterm, "1,000 idle ZMQ connections, then simxStart": idle_connections,
           "4 connections looping 4096x4096 images beside a legacy client": big_images_beside_legacy}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--code", type=Path, default=ROOT, help="checkout whose simx_server runs (default: this one)")
    p.add_argument("--only", action="append", metavar="WORD", help="attacks whose name holds WORD (repeatable)")
    args = p.parse_args(argv)
    folder = Path(tempfile.mkdtemp(prefix="simx-zmq-attack-"))
    (folder / "scene.xml").write_text(SCENE)
    (folder / "keeper.lua").write_text(KEEPER)
    ctx = zmq.Context()
    print(f"code: {args.code}; load average {os.getloadavg()[0]:.1f}")
    print("| attack | attacker's time | server RSS before -> peak | afterwards | reply |")
    print("|---|---|---|---|---|")
    for name, attack in ATTACKS.items():
        if args.only and not any(w in name for w in args.only):
            continue
        t = Target(args.code, folder)
        try:
            start = time.monotonic()
            try:
                reply = attack(t, ctx)
            except zmq.Again:
                reply = "no reply"
            took = time.monotonic() - start
            time.sleep(0.5)
            after = t.alive(ctx) if attack is not sigterm else "-"
            print(f"| {name} | {took:.1f} s | {t.before:.0f} -> {t.peak:.0f} MB | {after} | {reply} |", flush=True)
        finally:
            t.stop()
    ctx.destroy(0)


if __name__ == "__main__":
    main()
