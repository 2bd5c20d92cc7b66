"""One client process of the robustness benchmark (benchmarks/robustness.py starts them).

``python -m benchmarks.robustness_worker mixed --port P --index I --calls N --names JSON --joints JSON --out FILE``
``python -m benchmarks.robustness_worker flood|flood-raw --port P --joint H --seconds S --max-calls N --out FILE``

Both connect with the legacy API, print ``ready``, then wait for one line on stdin: the
CLOCK_MONOTONIC time to start at (shared by all workers).

``mixed`` (one of the 16 mixed-load clients) streams ``simxGetJointPosition`` of one UR5 joint
and then makes ``N`` calls in a fixed rotation: two blocking ``simxGetObjectHandle`` on the
scene's names (offset by its index; each returned handle is checked: a reply meant for another
call or client would carry another handle), one oneshot ``simxSetJointTargetPosition`` of its
joint, one ``buffer`` read of its streamed joint. It writes JSON: blocking latencies (s), lost
(return code not 0: a timeout or an error), mismatched (wrong handle), oneshot errors (return
code 8 or worse: the previous oneshot reply was an error, or the call failed locally), buffer
reads with and without a value, elapsed time and CPU time.

``flood`` sends oneshot ``simxSetJointTargetPosition`` as fast as one Python client can, for
``S`` seconds or ``N`` calls (bounded in both), and writes the count sent, the time taken and the
CLOCK_MONOTONIC time it stopped.
``flood-raw`` does the same without the client library: a raw Zenoh session (``client_config``)
sends the one pre-encoded request ``[[SetJointTargetPosition, oneshot, [H, 0.0]]]`` to its own
call key with a declared querier and ignores the replies, as a hostile client could.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time

from simx_client import api
from simx_client import constants as C

B, ONESHOT = C.simx_opmode_blocking, C.simx_opmode_oneshot
STREAM, BUFFER = C.simx_opmode_streaming, C.simx_opmode_buffer


def _wait_for_start() -> float | None:
    print("ready", flush=True)
    line = sys.stdin.readline()
    if not line.strip():
        return None
    start = float(line)
    while time.monotonic() < start:
        time.sleep(0.0005)
    return start


def mixed(args: argparse.Namespace, cid: int) -> dict:
    names = json.loads(args.names)
    joints = json.loads(args.joints)
    joint = joints[args.index % len(joints)]
    api.simxGetJointPosition(cid, joint, STREAM)
    deadline = time.monotonic() + 10
    while api.simxGetJointPosition(cid, joint, BUFFER)[0] != 0 and time.monotonic() < deadline:
        time.sleep(0.002)
    for name, _ in names[:3]:  # this client's route, before the clock starts
        api.simxGetObjectHandle(cid, name, B)
    if _wait_for_start() is None:
        return {}
    lat: list[float] = []
    lost = mismatched = oneshot_errors = buffer_ok = buffer_empty = 0
    offset, n = args.index * 7, len(names)
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    t_start = time.perf_counter()
    for k in range(args.calls):
        step = k % 4
        if step < 2:
            name, expected = names[(offset + k) % n]
            t0 = time.perf_counter()
            rc, handle = api.simxGetObjectHandle(cid, name, B)
            lat.append(time.perf_counter() - t0)
            if rc != 0:
                lost += 1
            elif handle != expected:
                mismatched += 1
        elif step == 2:
            rc = api.simxSetJointTargetPosition(cid, joint, 0.01 * (k % 8), ONESHOT)
            if rc not in (0, 1):
                oneshot_errors += 1
        else:
            if api.simxGetJointPosition(cid, joint, BUFFER)[0] == 0:
                buffer_ok += 1
            else:
                buffer_empty += 1
    elapsed = time.perf_counter() - t_start
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    return {"index": args.index, "calls": args.calls, "lat": lat, "lost": lost, "mismatched": mismatched,
            "oneshot_errors": oneshot_errors, "buffer_ok": buffer_ok, "buffer_empty": buffer_empty,
            "elapsed": elapsed, "cpu_s": cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime}


def _send_for(args: argparse.Namespace, send) -> dict:
    """``send(k)`` for k = 0, 1, ... until ``args.seconds`` have passed or ``args.max_calls``
    were sent (the clock read every 256 calls); the count, seconds and end time."""
    t0 = time.monotonic()
    end = t0 + args.seconds
    sent = 0
    while sent < args.max_calls:
        send(sent)
        sent += 1
        if not sent % 256 and time.monotonic() >= end:
            break
    ended = time.monotonic()
    return {"sent": sent, "seconds": ended - t0, "ended": ended}


def flood(args: argparse.Namespace, cid: int) -> dict:
    if _wait_for_start() is None:
        return {}
    return _send_for(args, lambda k: api.simxSetJointTargetPosition(cid, args.joint, 0.001 * (k % 100), ONESHOT))


def flood_raw(args: argparse.Namespace) -> dict:
    import uuid

    import zenoh

    from simx_client import protocol as P
    from simx_client.connection import client_config

    client = uuid.uuid4().hex
    session = zenoh.open(client_config("127.0.0.1", args.port))
    try:
        querier = session.declare_querier(P.call_key(P.DEFAULT_PREFIX, client), timeout=5.0)
        payload = P.request(client, [["SetJointTargetPosition", P.MODE_ONESHOT, [args.joint, 0.0]]])
        ignore = zenoh.handlers.Callback(lambda reply: None, indirect=False)
        if _wait_for_start() is None:
            return {}
        result = _send_for(args, lambda k: querier.get(ignore, payload=payload))
        with open(args.out, "w") as f:  # before closing: with thousands of queries pending,
            json.dump(result, f)  # Zenoh's close can time out
        return result
    finally:
        try:
            session.close()
        except zenoh.ZError as exc:
            print(f"closing the session: {exc}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("kind", choices=["mixed", "flood", "flood-raw"])
    p.add_argument("--port", type=int, required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--index", type=int, default=0)
    p.add_argument("--calls", type=int, default=2000)
    p.add_argument("--names", help='mixed: JSON [["name", handle], ...]')
    p.add_argument("--joints", help="mixed: JSON [handle, ...]")
    p.add_argument("--joint", type=int, help="flood: the joint handle")
    p.add_argument("--seconds", type=float, default=20.0)
    p.add_argument("--max-calls", type=int, default=1_000_000)
    args = p.parse_args(argv)
    if args.kind == "flood-raw":
        flood_raw(args)
        return 0
    cid = api.simxStart("127.0.0.1", args.port, True, True, 5000, 5)
    if cid < 0:
        print("connect failed", flush=True)
        return 1
    try:
        result = (mixed if args.kind == "mixed" else flood)(args, cid)
        with open(args.out, "w") as f:
            json.dump(result, f)
    finally:
        api.simxFinish(cid)
    return 0


if __name__ == "__main__":
    sys.exit(main())
