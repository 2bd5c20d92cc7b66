"""Issue 29 item 7: a simx server's memory over many reconnecting clients.

``python -m benchmarks.reconnect_soak [--mode MODE] [-n N] [--requests R] [--bytes B] [SERVER ARGS...]``
starts a simx server (the bundled scene, ``--pacing immediate``, its own loopback port) and makes
``N`` connections one after the other; each opens a fresh Zenoh session, sends ``R`` small
requests and closes:

* ``raw`` (default): ``zenoh.open`` in this process, a fresh client id, ``R`` blocking
  ``GetPingTime``/``GetObjectHandle``/``SetStringSignal`` requests (each ``B`` bytes of signal
  value), ``session.close()``;
* ``legacy``: ``simxStart`` / ``R`` blocking calls / ``simxFinish`` in this process (a liveliness
  token, the peer check and the Bye each time);
* ``proc``: one Python process per connection doing what ``legacy`` does (each with its own
  Zenoh runtime and shared-memory pool).

The server's RSS (and its anonymous / shared-memory parts, ``/proc/PID/status``) is printed after
every tenth of the connections; the last line gives the MB per connection over the first and
the second half (a warm-up step followed by a flat line reads as ~0 in the second half).
Bounded by ``N`` and by each call's timeout; loopback only, multicast scouting off.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
import uuid
from pathlib import Path

import zenoh

from benchmarks.procs import Server, child_env
from simx_client import protocol as P
from simx_client.connection import client_config

ROOT = Path(__file__).resolve().parents[1]
B = P.MODE_BLOCKING

def legacy_calls(port: int, n: int, size: int) -> None:
    """``simxStart``, ``n`` blocking calls (ping, handle, string signal of ``size`` bytes), ``simxFinish``."""
    import vrep

    cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
    assert cid >= 0, "simxStart failed"
    for i in range(n):
        if i % 3 == 0:
            rc = vrep.simxGetPingTime(cid)[0]
        elif i % 3 == 1:
            rc = vrep.simxGetObjectHandle(cid, "UR5_joint1", vrep.simx_opmode_blocking)[0]
        else:
            rc = vrep.simxSetStringSignal(cid, "soak", b"x" * size, vrep.simx_opmode_blocking)
        assert rc == 0, f"call {i}: rc {rc}"
    vrep.simxFinish(cid)


def status(pid: int) -> dict[str, float]:
    """``VmRSS``, ``RssAnon``, ``RssShmem`` (MB) and ``Threads`` of a process."""
    out = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "RssAnon", "RssShmem"):
                out[key] = int(value.split()[0]) / 1024
            elif key == "Threads":
                out[key] = int(value)
    return out


def raw_connection(port: int, requests: int, size: int) -> None:
    """One fresh Zenoh session: ``requests`` blocking requests under a fresh client id, close."""
    session = zenoh.open(client_config("127.0.0.1", port))
    client = uuid.uuid4().hex
    key = P.call_key(P.DEFAULT_PREFIX, client)
    commands = [[["GetPingTime", B, []]], [["GetObjectHandle", B, ["UR5_joint1"]]],
                [["SetStringSignal", B, ["soak", b"x" * size]]]]
    try:
        for i in range(requests):
            replies = list(session.get(key, payload=P.request(client, commands[i % 3]), timeout=10))
            assert len(replies) == 1 and replies[0].ok is not None, "no reply"
    finally:
        session.close()


def legacy_connection(port: int, requests: int, size: int, own_process: bool) -> None:
    """``simxStart``, ``requests`` blocking calls, ``simxFinish``: here or in a process of its own."""
    if own_process:
        code = f"from benchmarks.reconnect_soak import legacy_calls; legacy_calls({port}, {requests}, {size})"
        subprocess.run([sys.executable, "-c", code], check=True, env=child_env(), cwd=ROOT, timeout=60)
    else:
        legacy_calls(port, requests, size)


def soak(port: int, pid: int, mode: str, n: int, requests: int, size: int, marks: int = 10) -> list[tuple]:
    """Make ``n`` connections; returns ``(connections, seconds, status)`` at the start and after
    every ``n / marks`` connections."""
    t0 = time.monotonic()
    samples = [(0, 0.0, status(pid))]
    for i in range(n):
        if mode == "raw":
            raw_connection(port, requests, size)
        else:
            legacy_connection(port, requests, size, own_process=mode == "proc")
        if (i + 1) % max(1, n // marks) == 0 or i + 1 == n:
            time.sleep(0.2)  # the Bye and the token's DELETE reach the server
            samples.append((i + 1, time.monotonic() - t0, status(pid)))
    return samples


def per_connection(samples: list[tuple]) -> tuple[float, float]:
    """MB of RSS per connection over the first and over the second half of the samples."""
    mid = samples[len(samples) // 2]
    first, last = samples[0], samples[-1]
    a = (mid[2]["VmRSS"] - first[2]["VmRSS"]) / max(1, mid[0] - first[0])
    b = (last[2]["VmRSS"] - mid[2]["VmRSS"]) / max(1, last[0] - mid[0])
    return a, b


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mode", choices=("raw", "legacy", "proc"), default="raw")
    parser.add_argument("-n", type=int, default=200, help="connections (at most 2,000)")
    parser.add_argument("--requests", type=int, default=30)
    parser.add_argument("--bytes", type=int, default=100, help="bytes of each SetStringSignal value")
    args, server_args = parser.parse_known_args(argv)
    n = min(args.n, 2000)
    log_dir = ROOT / "benchmarks" / "results" / "logs" / "reconnect"
    log_dir.mkdir(parents=True, exist_ok=True)
    with Server(log_dir, "--pacing", "immediate", *server_args, name="reconnect") as srv:
        time.sleep(1.0)
        samples = soak(srv.port, srv.pid, args.mode, n, args.requests, args.bytes)
    for done, seconds, st in samples:
        print(f"{done:5d} connections {seconds:6.1f} s: RSS {st['VmRSS']:7.1f} MB (anon {st['RssAnon']:.1f}, "
              f"shmem {st['RssShmem']:.1f}), {st['Threads']} threads")
    a, b = per_connection(samples)
    print(f"{args.mode}, {n} connections x {args.requests} requests: {samples[0][2]['VmRSS']:.0f} -> "
          f"{samples[-1][2]['VmRSS']:.0f} MB; {a:.2f} MB/connection over the first half, {b:.2f} over the second")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
