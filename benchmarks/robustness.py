"""8. Robustness (issue 11): what bad or greedy clients cost the server and the others.

Figures, not pass/fail. Each part runs against a simx server of its own (real time, dt 50 ms,
the bundled scene), so that what one part leaves behind (a backlog, memory) does not colour
the next:

a. **malformed requests**: 10,000 (quick 2,000) seeded bad requests from a raw Zenoh session,
   8 in flight: random bytes, requests cut short, wrong types at each position of the request
   array, unknown commands, real commands with arguments of wrong types in every operation
   mode (dict, None, nan, bytes, huge ints), ids that are not their key's, 1 % nested 1,000
   deep. Answered per second (per 0.5 s bin), how many got no reply, server RSS before/after.
b. **mixed load**: 16 client processes (benchmarks/robustness_worker.py ``mixed``) x 2,000 calls
   (quick 500): blocking ``simxGetObjectHandle`` (every handle checked), oneshot
   ``simxSetJointTargetPosition`` and ``buffer`` reads of a streamed joint. Lost, mismatched,
   oneshot errors, blocking p50/p99, buffer reads without a value.
c. **the flood**: one client sends oneshot ``simxSetJointTargetPosition`` as fast as it can for
   20 s (quick 5 s; at most 1,000,000 calls): c1 a legacy client (``flood``), c2 a raw Zenoh
   client with the request pre-encoded (``flood-raw``). Meanwhile this process makes blocking
   ``simxGetJointPosition`` calls; their p99 per 1 s bin against the same calls' p99 unloaded,
   measured just before in the same run. Server RSS sampled every 0.25 s; above 3 GB the
   flood is killed (a bound, not a figure). After the flood: how long from its end until a
   blocking call is again answered within 10x the unloaded p99 (at most 60 s).
d. **image soak**: one client streams ``kinect_rgb`` 640x480 RGB and ``kinect_depth``'s depth
   buffer for 180 s (quick 30 s), reading them in a legacy ``buffer`` loop; server RSS and
   thread count every 10 s (quick 5 s), frames read per second.

Every process is started here and stopped by its own PID; all traffic is on 127.0.0.1 with
multicast scouting off (``client_config``).
"""

from __future__ import annotations

import json
import math
import random
import sys
import threading
import time
import traceback

import msgpack
import numpy as np
import zenoh

from benchmarks import robustness_peers as peers
from benchmarks.common import Settings, connect
from benchmarks.procs import Proc, Server, child_env, proc_status
from benchmarks.stats import Figure, scaled, skipped, summary
from simx_client import api
from simx_client import constants as C
from simx_client import protocol as P
from simx_client.connection import client_config

B, ONESHOT, STREAM, BUFFER = (C.simx_opmode_blocking, C.simx_opmode_oneshot, C.simx_opmode_streaming,
                              C.simx_opmode_buffer)
RSS_ABORT_MB = 3 * 1024
NAMES = ["UR5", "UR5_joint1", "UR5_joint2", "UR5_joint3", "UR5_joint4", "UR5_joint5", "UR5_joint6",
         "RG2", "RG2_openCloseJoint", "kinect_rgb", "kinect_depth", "Table", "Sphere"]


def _one(value: float) -> dict[str, float]:
    return summary([value])


# ------------------------------------------------------------------ a. malformed requests
def malformed_requests(n: int, seed: int = 20261122) -> list[tuple[str, bytes]]:
    """``n`` seeded bad requests as ``(key id, payload)``: the classes in the module docstring."""
    rng = random.Random(seed)
    ids = [f"bad{i}" for i in range(8)]
    names = list(P.COMMANDS)
    junk = [None, {}, {"a": 1}, math.nan, math.inf, 2**64 - 1, -(2**63), b"\x00\x01", [[1, [2]]], "", "x" * 300,
            True, 2.5, -1, 0, 7]
    modes = [ONESHOT, B, STREAM, STREAM + 50, P.MODE_DISCONTINUE, P.MODE_BUFFER, -1, 2**63 - 1]
    out = []
    for _ in range(n):
        cid = rng.choice(ids)
        cmds = [[rng.choice(names), rng.choice(modes), [rng.choice(junk) for _ in range(rng.randint(0, 3))]]
                for _ in range(rng.choice([1, 1, 2, 4]))]
        kind = rng.random()
        if kind < 0.10:
            payload = rng.randbytes(rng.choice([0, 3, 40, 300]))
        elif kind < 0.22:
            full = P.request(cid, cmds)
            payload = full[:rng.randrange(len(full))]
        elif kind < 0.37:
            where = rng.randrange(4)
            message: list = [P.PROTOCOL_VERSION, cid, cmds]
            if where == 3:
                message[2][0][rng.randrange(3)] = rng.choice(junk[:9])
            else:
                message[where] = rng.choice(junk[:9])
            payload = msgpack.packb(message, use_bin_type=True)
        elif kind < 0.45:
            payload = P.request(cid, [["".join(rng.choices("abcXYZ_%", k=12)), B, []]])
        elif kind < 0.50:
            payload = P.request(rng.choice([i for i in ids if i != cid]), cmds)
        elif kind < 0.51:
            name = rng.choice(["GetJointPosition", "SetStringSignal", "GetObjectHandle"])
            payload = (b"\x93" + msgpack.packb(P.PROTOCOL_VERSION) + msgpack.packb(cid) + b"\x91\x93"
                       + msgpack.packb(name) + msgpack.packb(rng.choice(modes[:5])) + b"\x91" * 997 + b"\xc0")
        else:
            payload = P.request(cid, cmds)
        out.append((cid, payload))
    return out


def _malformed(s: Settings) -> list[Figure]:
    n = s.n(10_000, 2_000)
    requests = malformed_requests(n)
    in_flight = 8
    with Server(s.log_dir, "--pacing", "immediate", name="robustness-malformed") as srv:
        session = zenoh.open(client_config("127.0.0.1", srv.port))
        try:
            list(session.get(P.call_key("simx", "warm"), payload=P.request("warm", [["GetPingTime", B, []]]),
                             timeout=10))
            before = proc_status(srv.pid)
            slots = threading.BoundedSemaphore(in_flight)
            replies = [0] * n
            done = [math.nan] * n
            t0 = time.monotonic()
            for i, (cid, payload) in enumerate(requests):
                if not slots.acquire(timeout=60):
                    raise RuntimeError("a malformed request was never answered nor timed out")

                def on_reply(reply, i=i) -> None:
                    replies[i] += 1

                def on_end(i=i) -> None:
                    done[i] = time.monotonic() - t0
                    slots.release()

                session.get(P.call_key("simx", cid), zenoh.handlers.Callback(on_reply, on_end, indirect=False),
                            payload=payload, timeout=30)
            for _ in range(in_flight):
                slots.acquire(timeout=60)
            elapsed = time.monotonic() - t0
            after = proc_status(srv.pid)
        finally:
            session.close()
        alive = srv.proc.poll() is None
    ends = np.asarray(done)
    ends = ends[np.isfinite(ends)]
    bins = np.bincount((ends / 0.5).astype(int))[:-1] / 0.5 if ends.size else []  # the last bin is partial
    unanswered = sum(1 for r in replies if r != 1)
    return [
        Figure("robustness.malformed.rate", f"a. malformed requests answered/s ({n:,}, 8 in flight)", "1/s",
               summary(bins if len(bins) else [n / elapsed]),
               note=f"{n:,} in {elapsed:.1f} s ({n / elapsed:,.0f}/s overall); {unanswered} without exactly one "
                    f"reply; server {'alive' if alive else 'DEAD'} after",
               extra={"requests": n, "seconds": elapsed, "unanswered": unanswered, "server_alive": alive}),
        Figure("robustness.malformed.unanswered", "  malformed requests without exactly one reply", "count",
               _one(unanswered)),
        Figure("robustness.malformed.rss", f"  server RSS after {n:,} malformed requests", "MB",
               _one(after["rss_mb"]), floor={"label": "RSS before", **_one(before["rss_mb"])},
               note=f"RSS {before['rss_mb']:.0f} -> {after['rss_mb']:.0f} MB, threads {before['threads']} -> "
                    f"{after['threads']}", extra={"before": before, "after": after}),
    ]


# ------------------------------------------------------------------ b. mixed load
def _mixed(s: Settings) -> list[Figure]:
    count, calls = s.pick(16, 16, smoke=2), s.n(2000, 500)
    with Server(s.log_dir, "--pacing", "immediate", name="robustness-mixed") as srv:
        cid = connect(srv.port)
        try:
            names = [[n, api.simxGetObjectHandle(cid, n, B)[1]] for n in NAMES]
            joints = [api.simxGetObjectHandle(cid, f"UR5_joint{i}", B)[1] for i in range(1, 7)]
        finally:
            api.simxFinish(cid)
        outs = [s.log_dir / f"robustness-mixed-{i}.json" for i in range(count)]
        workers: list[Proc] = []
        try:
            for i in range(count):
                cmd = [sys.executable, "-m", "benchmarks.robustness_worker", "mixed", "--port", str(srv.port),
                       "--index", str(i), "--calls", str(calls), "--names", json.dumps(names),
                       "--joints", json.dumps(joints), "--out", str(outs[i])]
                workers.append(Proc(f"robustness-mixed-{i}", cmd, s.log_dir, timeout=120, env=child_env(),
                                    stdin_pipe=True))
            start = time.monotonic() + 0.3
            for w in workers:
                w.proc.stdin.write(f"{start!r}\n")
                w.proc.stdin.flush()
            for w in workers:
                w.proc.wait(timeout=300)
            status = proc_status(srv.pid)
        finally:
            for w in workers:
                w.stop()
    results = [json.loads(p.read_text()) for p in outs]
    lat = np.concatenate([r["lat"] for r in results]) * 1e3
    total = {k: sum(r[k] for r in results) for k in ("lost", "mismatched", "oneshot_errors", "buffer_ok", "buffer_empty")}
    wall = max(r["elapsed"] for r in results)
    p50, p99 = (float(np.percentile(lat, q)) for q in (50, 99))
    note = (f"{count} x {calls} calls in {wall:.1f} s ({count * calls / wall:,.0f} calls/s); blocking p50 {p50:.2f} ms, "
            f"p99 {p99:.2f} ms; lost {total['lost']}, mismatched {total['mismatched']}, oneshot errors "
            f"{total['oneshot_errors']}, buffer reads without a value {total['buffer_empty']} of "
            f"{total['buffer_ok'] + total['buffer_empty']}; server RSS {status['rss_mb']:.0f} MB after")
    return [
        Figure("robustness.mixed.latency", f"b. {count} clients x {calls:,} mixed calls: blocking latency", "ms",
               scaled(summary(lat / 1e3), 1e3), note=note, extra={**total, "p50_ms": p50, "p99_ms": p99, "wall_s": wall,
                                                                    "server": status}),
        Figure("robustness.mixed.p99", "  blocking p99 (all calls)", "ms", _one(p99)),
        Figure("robustness.mixed.errors", "  lost + mismatched blocking replies", "count",
               _one(total["lost"] + total["mismatched"]),
               note=f"lost {total['lost']}, mismatched {total['mismatched']} of {len(lat):,}"),
        Figure("robustness.mixed.oneshot_errors", "  oneshot calls answered with an error", "count",
               _one(total["oneshot_errors"])),
    ]


# ------------------------------------------------------------------ c. the flood
def _blocking_window(cid: int, joint: int, seconds: float, stop: threading.Event | None = None) -> list[tuple[float, float, int]]:
    """Blocking ``simxGetJointPosition`` calls for ``seconds`` (or until ``stop``), every ~5 ms:
    ``(start s, latency s, return code)`` each."""
    out = []
    t_end = time.monotonic() + seconds
    t0 = time.monotonic()
    while time.monotonic() < t_end and not (stop and stop.is_set()):
        a = time.perf_counter()
        rc, _ = api.simxGetJointPosition(cid, joint, B)
        out.append((time.monotonic() - t0, time.perf_counter() - a, rc))
        time.sleep(0.005)
    return out


def _binned_p99(calls: list[tuple[float, float, int]], width: float) -> list[float]:
    bins: dict[int, list[float]] = {}
    for t, lat, _ in calls:
        bins.setdefault(int(t / width), []).append(lat)
    return [float(np.percentile(v, 99)) * 1e3 for _, v in sorted(bins.items())]


def _flood(s: Settings, kind: str = "flood") -> list[Figure]:
    raw = kind == "flood-raw"
    tag, who = ("c2", "raw Zenoh") if raw else ("c1", "legacy client")
    seconds, unloaded_s = s.t(20.0, 5.0), s.t(6.0, 3.0)
    max_calls = 1_000_000
    out = s.log_dir / f"robustness-{kind}.json"
    samples: list[tuple[float, float]] = []  # (s since the flood's start, server RSS MB)
    aborted = threading.Event()
    stop_sampling = threading.Event()
    with Server(s.log_dir, "--pacing", "immediate", name=f"robustness-{kind}") as srv:
        cid = connect(srv.port)
        try:
            joint = api.simxGetObjectHandle(cid, "UR5_joint3", B)[1]
            flooded = api.simxGetObjectHandle(cid, "UR5_joint1", B)[1]
            _blocking_window(cid, joint, 0.5)  # warm-up
            unloaded = _blocking_window(cid, joint, unloaded_s)
            rss_before = proc_status(srv.pid)["rss_mb"]
            flood = Proc(f"robustness-{kind}-client",
                         [sys.executable, "-m", "benchmarks.robustness_worker", kind, "--port", str(srv.port),
                          "--joint", str(flooded), "--seconds", str(seconds), "--max-calls", str(max_calls),
                          "--out", str(out)], s.log_dir, timeout=60, env=child_env(), stdin_pipe=True)
            t_flood = time.monotonic() + 0.2

            def sample() -> None:
                while not stop_sampling.is_set():
                    try:
                        rss = proc_status(srv.pid)["rss_mb"]
                    except (OSError, KeyError):
                        return
                    samples.append((time.monotonic() - t_flood, rss))
                    if rss > RSS_ABORT_MB and not aborted.is_set():
                        aborted.set()
                        flood.proc.kill()  # the flood worker, by its own PID
                    stop_sampling.wait(0.25)

            sampler = threading.Thread(target=sample, daemon=True)
            try:
                flood.proc.stdin.write(f"{t_flood!r}\n")
                flood.proc.stdin.flush()
                sampler.start()
                while time.monotonic() < t_flood:
                    time.sleep(0.001)
                loaded = _blocking_window(cid, joint, seconds, stop=aborted)  # calls started during the flood
                flood.proc.wait(timeout=60)
            finally:
                flood.stop()
            sent = json.loads(out.read_text()) if out.exists() else {"sent": None, "seconds": None}
            flood_end = sent.get("ended") or time.monotonic()  # killed: about now
            # Recovery: the first blocking call after the flood answered within 10x the unloaded
            # p99 again (the backlog it left behind is served first), in s after the flood ended.
            limit = 10 * float(np.percentile([c[1] for c in unloaded], 99))
            recovered = None
            while time.monotonic() - flood_end < 60:
                a = time.perf_counter()
                rc, _ = api.simxGetJointPosition(cid, joint, B)
                if rc == 0 and time.perf_counter() - a <= limit:
                    recovered = time.monotonic() - flood_end
                    break
                time.sleep(0.01)
            rss_after = proc_status(srv.pid)["rss_mb"]
        finally:
            stop_sampling.set()
            api.simxFinish(cid)
        alive = srv.proc.poll() is None
    un_p99 = _binned_p99(unloaded, 1.0)
    lo_p99 = _binned_p99(loaded, 1.0)
    lost = sum(1 for c in loaded if c[2] != 0)
    peak = max((r for _, r in samples), default=math.nan)
    rate = f"{sent['sent'] / sent['seconds']:,.0f}/s" if sent.get("sent") else "unknown rate (killed)"
    note = (f"flood: {sent.get('sent')} oneshot calls sent ({rate}){', ABORTED above 3 GB' if aborted.is_set() else ''}; "
            f"blocking calls during it: {len(loaded)}, {lost} lost, overall p99 "
            f"{np.percentile([c[1] for c in loaded], 99) * 1e3:.1f} ms (unloaded "
            f"{np.percentile([c[1] for c in unloaded], 99) * 1e3:.2f} ms); server RSS {rss_before:.0f} -> peak "
            f"{peak:.0f} -> {rss_after:.0f} MB; back within 10x unloaded p99 "
            f"{'after %.1f s' % recovered if recovered is not None else 'NOT within 60 s'}; server "
            f"{'alive' if alive else 'DEAD'}")
    extra = {"sent": sent, "aborted": aborted.is_set(), "lost": lost, "rss_samples": samples,
             "recovery_s": recovered, "server_alive": alive, "unloaded_p99_bins_ms": un_p99, "loaded_p99_bins_ms": lo_p99}
    return [
        Figure(f"robustness.{kind}.p99", f"{tag}. blocking p99 per 1 s, {who} oneshot flood", "ms",
               summary(lo_p99),
               floor={"label": "unloaded p99, same run", **summary(un_p99)}, note=note, extra=extra),
        Figure(f"robustness.{kind}.lost", "  blocking calls lost during the flood", "count", _one(lost)),
        Figure(f"robustness.{kind}.rss_peak", "  server RSS peak during the flood", "MB", _one(peak),
               floor={"label": "RSS before", **_one(rss_before)}),
        Figure(f"robustness.{kind}.recovery", "  after the flood: back within 10x unloaded p99", "s",
               _one(recovered if recovered is not None else math.nan),
               note="" if recovered is not None else "not within 60 s"),
    ]


# ------------------------------------------------------------------ d. image soak
def _soak(s: Settings) -> list[Figure]:
    seconds, every = s.t(180.0, 30.0, smoke=2.0), s.t(10.0, 5.0, smoke=0.5)
    samples: list[dict] = []
    frames = depth_frames = 0
    with Server(s.log_dir, "--pacing", "immediate", name="robustness-soak") as srv:
        cid = connect(srv.port)
        try:
            rgb = api.simxGetObjectHandle(cid, "kinect_rgb", B)[1]
            depth = api.simxGetObjectHandle(cid, "kinect_depth", B)[1]
            api.simxGetVisionSensorImage(cid, rgb, 0, STREAM)
            api.simxGetVisionSensorDepthBuffer(cid, depth, STREAM)
            deadline = time.monotonic() + 20
            while api.simxGetVisionSensorImage(cid, rgb, 0, BUFFER)[0] != 0 and time.monotonic() < deadline:
                time.sleep(0.005)
            t0 = time.monotonic()
            next_sample = t0
            last_rgb = last_depth = None
            while True:
                now = time.monotonic()
                if now >= next_sample:
                    samples.append({"t": now - t0, **proc_status(srv.pid)})
                    next_sample += every
                    if now - t0 >= seconds:
                        break
                rc, res, image = api.simxGetVisionSensorImage(cid, rgb, 0, BUFFER)
                t = api.simxGetLastCmdTime(cid)
                if rc == 0 and t != last_rgb:
                    frames, last_rgb = frames + 1, t
                rc, res, buf = api.simxGetVisionSensorDepthBuffer(cid, depth, BUFFER)
                t = api.simxGetLastCmdTime(cid)
                if rc == 0 and t != last_depth:
                    depth_frames, last_depth = depth_frames + 1, t
                time.sleep(0.005)
            elapsed = time.monotonic() - t0
        finally:
            api.simxFinish(cid)
        alive = srv.proc.poll() is None
    rss = [x["rss_mb"] for x in samples]
    threads = [x["threads"] for x in samples]
    slope = float(np.polyfit([x["t"] for x in samples], rss, 1)[0]) * 60 if len(samples) > 2 else math.nan
    note = (f"{elapsed:.0f} s, {len(samples)} samples: RSS {rss[0]:.0f} -> {rss[-1]:.0f} MB (max {max(rss):.0f}, "
            f"slope {slope:+.1f} MB/min), threads {threads[0]} -> {threads[-1]} (max {max(threads)}); "
            f"{frames / elapsed:.1f} RGB and {depth_frames / elapsed:.1f} depth frames/s read; server "
            f"{'alive' if alive else 'DEAD'}")
    extra = {"samples": samples, "frames": frames, "depth_frames": depth_frames, "seconds": elapsed}
    return [
        Figure("robustness.soak.rss", f"d. image soak {seconds:.0f} s: server RSS (every {every:.0f} s)", "MB",
               summary(rss), floor={"label": "RSS at the start", **_one(rss[0])}, note=note, extra=extra),
        Figure("robustness.soak.rss_slope", "  server RSS growth over the soak", "MB/min", _one(slope)),
        Figure("robustness.soak.threads", "  server threads", "count", summary(threads),
               floor={"label": "threads at the start", **_one(threads[0])}),
        Figure("robustness.soak.fps", "  frames read per second (RGB; depth in the note)", "1/s",
               _one(frames / elapsed), note=f"depth {depth_frames / elapsed:.1f}/s"),
    ]


def run(s: Settings) -> list[Figure]:
    figures: list[Figure] = []
    parts = [("malformed", _malformed), ("mixed", _mixed), ("flood", _flood),
             ("flood-raw", lambda s: _flood(s, "flood-raw")), ("soak", _soak),
             ("viewer-flood", peers.viewer_flood), ("stuck", peers.stuck_consumer),
             ("big-streams", peers.big_image_streams), ("reconnect", peers.reconnect_soak)]
    for name, part in parts:  # one failing part must not hide the others
        print(f"   robustness: {name} ...", file=sys.stderr, flush=True)
        t0 = time.monotonic()
        try:
            figures += part(s)
        except Exception as exc:
            traceback.print_exc()
            figures.append(skipped(f"robustness.{name}.error", f"robustness {name}", f"{type(exc).__name__}: {exc}"))
        print(f"   robustness: {name}: {time.monotonic() - t0:.1f} s", file=sys.stderr, flush=True)
    return figures
