"""One client process of the many-clients benchmark (benchmarks/clients.py starts them).

``python -m benchmarks.client_worker --port P --index I --names JSON --window S --max-calls N --out FILE``
``python -m benchmarks.client_worker --echo-port P --sizes REQ,REPLY ...`` (the bare floor)

Connects with the legacy API, prints ``ready``, then waits for one line on stdin: the
CLOCK_MONOTONIC time to start at (shared by all workers). From then on it makes blocking
``simxGetObjectHandle`` calls on the names it was given, in a rotation offset by its index, and
checks each returned handle against the expected one (a reply meant for another call or
another client would carry another handle). It stops at start + window or after N calls
(bounded in time and count), and writes JSON to FILE: calls, lost (return code != 0),
mismatched (wrong handle), the process's CPU time (all its threads, Zenoh's included) spent in
the window, and per call the completion time (s after start) and latency (s).

With ``--echo-port`` it is a bare Zenoh client instead (benchmarks/common.Floor, same
``client_config``) making query/replies of the given sizes to benchmarks/zenoh_echo.py: the
same load pattern with no simx code, for the floor (no handle to check there).
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time

from simx_client import api
from simx_client import constants as C


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--port", type=int)
    p.add_argument("--echo-port", type=int)
    p.add_argument("--sizes", default="80,18", help="bare floor: request,reply bytes")
    p.add_argument("--index", type=int, required=True)
    p.add_argument("--names", required=True, help='JSON [["name", handle], ...]')
    p.add_argument("--window", type=float, required=True)
    p.add_argument("--max-calls", type=int, default=100_000)
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    names = json.loads(args.names)
    if args.echo_port:
        from benchmarks.common import Floor

        floor = Floor(args.echo_port)
        request_size, reply_size = (int(x) for x in args.sizes.split(","))

        def call(name: str) -> tuple[int, int]:
            floor.call(reply_size, request_size)
            return 0, dict(names)[name]

        finish = floor.close
    else:
        cid = api.simxStart("127.0.0.1", args.port, True, True, 10000, 5)
        if cid < 0:
            print("connect failed", flush=True)
            return 1

        def call(name: str) -> tuple[int, int]:
            return api.simxGetObjectHandle(cid, name, C.simx_opmode_blocking)

        def finish() -> None:
            api.simxFinish(cid)
    try:
        # Warm up this client's route before the clock starts.
        for name, _ in names[:3]:
            call(name)
        print("ready", flush=True)
        line = sys.stdin.readline()
        if not line.strip():
            return 1
        start = float(line)
        end = start + args.window
        while time.monotonic() < start:
            time.sleep(0.0005)
        done, lat = [], []
        lost = mismatched = 0
        cpu0 = resource.getrusage(resource.RUSAGE_SELF)
        k, offset, n = 0, args.index * 7, len(names)
        perf, mono = time.perf_counter, time.monotonic
        while k < args.max_calls:
            name, expected = names[(offset + k) % n]
            t0 = perf()
            rc, handle = call(name)
            t1 = perf()
            now = mono()
            k += 1
            if rc != 0:
                lost += 1
            elif handle != expected:
                mismatched += 1
            done.append(now - start)
            lat.append(t1 - t0)
            if now >= end:
                break
        cpu1 = resource.getrusage(resource.RUSAGE_SELF)
        cpu = cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime
        with open(args.out, "w") as f:
            json.dump({"index": args.index, "calls": k, "lost": lost, "mismatched": mismatched,
                       "cpu_s": cpu, "done": done, "lat": lat}, f)
    finally:
        finish()
    return 0


if __name__ == "__main__":
    sys.exit(main())
