"""A minimal reproduction, for an upstream report to Eclipse Zenoh, of the memory a Zenoh peer
keeps per connection with the shared-memory transport on (Zenoh's default).

No simx: a queryable process (``--serve``) answers every query with an empty reply; this
process opens ``N`` client sessions one after the other, each sends ``R`` queries with a
payload of ``B`` bytes and closes. The queryable's RSS and its shared-memory part
(``RssShmem`` of ``/proc/PID/status``) are printed every tenth of the connections::

    python benchmarks/zenoh_reconnect_repro.py                 # shared memory on (default)
    python benchmarks/zenoh_reconnect_repro.py --no-shm        # off on the queryable's side

Observed with eclipse-zenoh 1.10.2 (Python), Linux, loopback TCP: with payloads over the
transport-optimisation threshold (``message_size_threshold``, 3,072 bytes) each client session
sends them through its own 16 MiB pool (``pool_size``); the queryable maps that pool on the
first such message and keeps it mapped after the session closed: +16 MB of RssShmem per
connection, never returned (80 sessions: 0 -> 513 MB of RssShmem, with a pause between the
17th and the 27th; the same pattern against simx-server: +16.0 MB for each of 50 sessions).
With payloads under the threshold, or shared memory off on either side, RSS stays flat. Expected: a peer's segments are unmapped
when its last session closes.

Loopback only, multicast scouting off, bounded by ``N`` (at most 500).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from importlib import metadata

import zenoh

KEY = "repro/echo"


def config(mode: str, endpoint: str, shm: bool) -> zenoh.Config:
    c = zenoh.Config()
    c.insert_json5("mode", f'"{mode}"')
    c.insert_json5("listen/endpoints" if mode == "peer" else "connect/endpoints", f'["{endpoint}"]')
    c.insert_json5("scouting/multicast/enabled", "false")
    c.insert_json5("transport/shared_memory/enabled", "true" if shm else "false")
    return c


def serve(endpoint: str, shm: bool) -> None:
    """The queryable: answers every query on KEY with an empty reply until stdin closes."""
    session = zenoh.open(config("peer", endpoint, shm))
    queryable = session.declare_queryable(KEY, lambda query: query.reply(KEY, b""))
    print("ready", flush=True)
    sys.stdin.read()
    queryable.undeclare()
    session.close()


def status(pid: int) -> tuple[float, float]:
    """(VmRSS, RssShmem) of a process, MB."""
    values = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "RssShmem"):
                values[key] = int(value.split()[0]) / 1024
    return values["VmRSS"], values["RssShmem"]


def main() -> int:
    parser = argparse.ArgumentParser(description="Zenoh: memory kept per connection with shared memory")
    parser.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--port", type=int, default=47448)
    parser.add_argument("-n", type=int, default=30, help="connections (at most 500)")
    parser.add_argument("--requests", type=int, default=30)
    parser.add_argument("--bytes", type=int, default=5000, help="payload of each query")
    parser.add_argument("--no-shm", action="store_true", help="shared memory off on the queryable's side")
    args = parser.parse_args()
    endpoint = f"tcp/127.0.0.1:{args.port}"
    if args.serve:
        serve(endpoint, not args.no_shm)
        return 0
    server = subprocess.Popen([sys.executable, __file__, "--serve", "--port", str(args.port)]
                              + (["--no-shm"] if args.no_shm else []), stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert server.stdout.readline().strip() == "ready"
        n, payload = min(args.n, 500), b"x" * args.bytes
        print(f"eclipse-zenoh {metadata.version('eclipse-zenoh')}; shared memory "
              f"{'off' if args.no_shm else 'on'} on the queryable; {n} sessions x {args.requests} queries "
              f"of {args.bytes} B")
        print("connections  RSS MB  RssShmem MB")
        print(f"{0:11d}  {status(server.pid)[0]:6.1f}  {status(server.pid)[1]:11.1f}")
        for i in range(n):
            session = zenoh.open(config("client", endpoint, True))
            for _ in range(args.requests):
                for reply in session.get(KEY, payload=payload, timeout=5):
                    assert reply.ok is not None
            session.close()
            if (i + 1) % max(1, n // 10) == 0:
                time.sleep(0.2)
                rss, shm = status(server.pid)
                print(f"{i + 1:11d}  {rss:6.1f}  {shm:11.1f}")
    finally:
        server.stdin.close()
        server.wait(timeout=10)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
