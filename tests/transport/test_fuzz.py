"""Issue 11: a seeded fuzz of the wire protocol against a real simx-server.

A server of its own (random commands may change its scene) takes a few thousand malformed or
hostile requests from a raw Zenoh session (``client_config``: loopback, multicast scouting
off), sent with a bounded number in flight: random bytes, valid requests cut short, every
position of the request array with a wrong type or shape, unknown commands, values nested
past msgpack's and Python's depth limits, command names and arguments of 1-10 MB, batches of
thousands of commands, real commands with wrong-typed arguments in every operation mode, an
image batch far above the reply bound, and requests whose id is not their key's.

Checked, all together so that one run lists every problem: the server stays alive; every
request gets a reply (a refusal map or a response with one result per command); a refusal
and an error stay small whatever the input's size; no error is an internal one (a handler
crashed on its input) and the server logs no traceback; its RSS grows by less than
``RSS_GROWTH_MB``; and afterwards a legacy client (``import vrep``) connects, makes a blocking
call and gets a streamed value.
"""

from __future__ import annotations

import math
import random
import re
import threading
import time

import msgpack
import pytest
import zenoh

import vrep
from conftest import ServerProcess, wait_until
from simx_client import protocol as P
from simx_client.connection import client_config
from simx_server.base import limits

SEED = 20261122
N_RANDOM = 3000  # requests drawn at random from the classes below (plus a few fixed large ones)
IN_FLIGHT = 8  # queries outstanding at once
REPLY_TIMEOUT = 30.0  # s a query waits for its reply
MAX_REFUSAL = 64 * 1024  # bytes: a refusal of any input
MAX_ERROR_TEXT = 4 * 1024  # characters: one command's error message
RSS_GROWTH_MB = 40  # MB; issue 29: +134-300 MB before the fix (pack_large's cycle, malloc), +6 MB since
B, ONESHOT, STREAMING, DISCONTINUE = P.MODE_BLOCKING, P.MODE_ONESHOT, P.MODE_STREAMING, P.MODE_DISCONTINUE
MODES = [ONESHOT, B, STREAMING, STREAMING + 100, P.MODE_ONESHOT_SPLIT, P.MODE_STREAMING_SPLIT, DISCONTINUE,
         P.MODE_BUFFER, P.MODE_REMOVE, -1, 0x7FFFFFFF, 2**63 - 1, -(2**63), 2**64 - 1]
IDS = [f"fuzz{i}" for i in range(8)]
#: Legal commands that legitimately change what every client shares (the scene loaded, the
#: objects in it, synchronous mode, files): they are tested elsewhere; here they would only
#: make the final legacy-client check depend on the dice.
SCENE_CHANGING = {"Synchronous", "LoadScene", "CloseScene", "LoadModel", "RemoveObject", "RemoveModel",
                  "TransferFile", "EraseFile", "CopyPasteObjects", "SetObjectParent"}
#: A Hello binds its id to a secret (simx_wire.proof) that this raw fuzzer does not keep: its
#: later requests under the id would be refused. tests/transport/test_fuzz_identity.py fuzzes proofs.
COMMANDS = sorted(set(P.COMMANDS) - SCENE_CHANGING - {"Hello"})


def _nested(depth: int, leaf: bytes = b"\xc0") -> bytes:
    """msgpack bytes of a one-item list nested ``depth`` deep around ``leaf`` (packb stops at
    about 1,000 levels, so deeper values are written by hand)."""
    return b"\x91" * depth + leaf


def _pack(value) -> bytes:
    return msgpack.packb(value, use_bin_type=True)


class Fuzzer:
    """The request generator: one seeded Random; each ``case_*`` returns ``(kind, key_id,
    payload, n_commands)`` where kind is "refusal", "response" or "either" (what a correct
    server must answer) and n_commands the commands a response must carry results for."""

    def __init__(self, seed: int, handles: list[int]):
        self.rng = random.Random(seed)
        self.handles = handles

    def value(self, depth: int = 0):
        """A random argument value, mostly of a type no command expects."""
        r = self.rng
        pick = r.randrange(18)
        if pick == 0:
            return None
        if pick == 1:
            return {r.choice(["a", 1, "handle"]): r.choice([1, None, [1]]), "k": {}}
        if pick == 2:
            return {}
        if pick == 3:
            return r.choice([math.nan, math.inf, -math.inf, 1e308, -0.0, 5e-324])
        if pick == 4:
            return r.choice([2**63 - 1, -(2**63), 2**64 - 1, 2**31, 10**7])
        if pick == 5:
            return r.randbytes(r.choice([0, 1, 17, 4096]))
        if pick == 6 and depth < 3:
            return [self.value(depth + 1) for _ in range(r.randint(0, 4))]
        if pick == 7:
            return list(range(r.choice([0, 3, 4, 1000])))
        if pick == 8:
            return r.choice(["", "x", "UR5", "UR5_joint1", "kinect_rgb", "\u00e9\u4e2d\U0001f600", "a" * 300,
                             "%s%n{0}", "../../etc/passwd", "/UR5/UR5_joint3"])
        if pick == 9:
            return r.choice([True, False])
        if pick in (10, 11, 12, 13):
            return r.choice(self.handles)
        if pick == 14:
            return r.choice([-1, 0, 1, -2, 65535, 2000, 2001])
        if pick == 15:
            return r.uniform(-10, 10)
        return r.randint(-3, 40)

    def command(self) -> list:
        r = self.rng
        return [r.choice(COMMANDS), r.choice(MODES) if r.random() < 0.7 else r.randint(-5, 0x80000),
                [self.value() for _ in range(r.choice([0, 1, 1, 2, 2, 3, 3, 4, 7]))]]

    def request(self, n: int | None = None) -> tuple[str, list]:
        cid = self.rng.choice(IDS)
        return cid, [self.command() for _ in range(n or self.rng.choice([1, 1, 1, 2, 3, 6]))]

    # ------------------------------------------------------------ classes
    def case_random_bytes(self):
        r = self.rng
        return "either", r.choice(IDS), r.randbytes(r.choice([0, 1, 2, 5, 16, 64, 256, 1024])), 0

    def case_truncated(self):
        cid, cmds = self.request()
        full = P.request(cid, cmds)
        return "refusal", cid, full[:self.rng.randrange(len(full))], 0

    def case_wrong_shape(self):
        """A wrong type or size at one position of ``[version, client, [[name, mode, args]]]``."""
        r = self.rng
        cid, cmds = self.request()
        junk = r.choice([None, 1, -1, 2.5, "s", b"\x00", [], {}, {"v": 3}, {"v": 1, "c": 5, "cmds": 7}, [[]], True,
                        2**64 - 1])
        where = r.randrange(9)
        if where == 0:
            message = junk  # not an array at all
        elif where == 1:
            message = [P.PROTOCOL_VERSION, cid, cmds][:r.randrange(3)] + ([] if r.random() < 0.5 else [cid, cmds, junk])
        elif where == 2:
            message = [r.choice([0, 1, 2, 3, -3, "4", None, 2**64 - 1, 3.5]), cid, cmds]  # any but 4
        elif where == 3:
            message = [P.PROTOCOL_VERSION, r.choice([None, 5, ["fuzz0"], {"id": 1}, b"fuzz0"]), cmds]
        elif where == 4:
            message = [P.PROTOCOL_VERSION, cid, r.choice([None, 5, "cmds", {"GetPingTime": 1}, b"\x01"])]
        elif where == 5:
            cmds[0] = r.choice([None, 5, "GetPingTime", {"n": 1}, [], ["GetPingTime"], ["GetPingTime", B],
                                ["GetPingTime", B, [], 7], b"GetPingTime"])
            message = [P.PROTOCOL_VERSION, cid, cmds]
        elif where == 6:
            cmds[0][0] = r.choice([None, 5, b"GetPingTime", ["GetPingTime"], {"n": 1}, 1.5])
            message = [P.PROTOCOL_VERSION, cid, cmds]
        elif where == 7:
            cmds[0][1] = r.choice([None, "0x10000", 65536.0, [B], {"m": 1}, True, b"\x01"])
            message = [P.PROTOCOL_VERSION, cid, cmds]
        else:
            cmds[0][2] = r.choice([None, 5, "args", {"a": 1}, b"\x00", 1.5])
            message = [P.PROTOCOL_VERSION, cid, cmds]
        return "refusal", cid, _pack(message), 0

    def case_unknown_command(self):
        r = self.rng
        cid = r.choice(IDS)
        name = r.choice(["", "simxGetJointPosition", "getjointposition", "__class__", "_bye", "_forget", "GetPingTime ",
                         "serve", "\x00", "\u4e2d\u6587", "Get" * 50, "".join(r.choices("abcXYZ_%{}", k=20))])
        return "response", cid, P.request(cid, [[name, r.choice(MODES), [self.value()]]]), 1

    def case_deep(self):
        """Values nested 1,000-1,024 deep (msgpack decodes them: Python code that recurses
        does not) and 1,025-5,000 deep (msgpack refuses them) at every position."""
        r = self.rng
        cid = r.choice(IDS)
        depth = r.choice([1000, 1010, 1024, 1025, 2000, 5000])
        head = b"\x93" + _pack(P.PROTOCOL_VERSION)
        where = r.randrange(6)
        if where == 0:
            payload = _nested(depth)
        elif where == 1:
            payload = head + _nested(depth - 1) + _pack([])
        elif where == 2:
            payload = head + _pack(cid) + _nested(depth - 1)
        elif where == 3:  # the command itself
            payload = head + _pack(cid) + b"\x91" + _nested(depth - 2)
        elif where == 4:  # the name
            payload = head + _pack(cid) + b"\x91\x93" + _nested(depth - 3) + _pack(B) + _pack([])
        else:  # an argument of a real command, in any mode
            name = r.choice(["GetJointPosition", "GetObjectPosition", "SetStringSignal", "CallScriptFunction",
                             "GetObjectHandle", "SetObjectPosition"])
            payload = (head + _pack(cid) + b"\x91\x93" + _pack(name) + _pack(r.choice(MODES[:9]))
                       + b"\x91" + _nested(depth - 4))
        return "either", cid, payload, (1 if where in (4, 5) else 0)

    def case_mismatched_id(self):
        """A request sent to another client's key (or naming no client, or an invalid id)."""
        cid, cmds = self.request()
        named = self.rng.choice([i for i in IDS if i != cid] + ["", "x" * 200, "a/b", "*"])
        return "refusal", cid, P.request(named, cmds), 0

    def case_valid_wrong_args(self):
        cid, cmds = self.request()
        return "response", cid, P.request(cid, cmds), len(cmds)

    def case_large_batch(self):
        r = self.rng
        cid = r.choice(IDS)
        n = r.choice([limits.MAX_COMMANDS_PER_REQUEST // 2, limits.MAX_COMMANDS_PER_REQUEST,
                      2 * limits.MAX_COMMANDS_PER_REQUEST])
        cmds = [self.command() if r.random() < 0.2 else [r.choice(["GetPingTime", "NoSuchCommand"]), B, []]
                for _ in range(n)]
        expected = "response" if n <= limits.MAX_COMMANDS_PER_REQUEST else "refusal"
        return expected, cid, P.request(cid, cmds), n

    def draw(self):
        """One request of a class drawn with these weights."""
        classes = [(self.case_random_bytes, 8), (self.case_truncated, 10), (self.case_wrong_shape, 14),
                   (self.case_unknown_command, 6), (self.case_deep, 3), (self.case_mismatched_id, 5),
                   (self.case_valid_wrong_args, 53), (self.case_large_batch, 0.3)]
        fn = self.rng.choices([c for c, _ in classes], weights=[w for _, w in classes])[0]
        return fn.__name__[5:], *fn()

    def fixed(self, rgb: int) -> list:
        """The large cases, a few times each: 1-10 MB command names, client ids and string
        arguments (an error that quotes them whole is as large), a batch of 5,000 commands
        (more than ``limits.MAX_COMMANDS_PER_REQUEST``) and 160 RGB images in one request
        (about 147 MB: more than ``limits.MAX_REPLY_BYTES``)."""
        out = []
        for mb in (1, 4, 10):
            cid = self.rng.choice(IDS)
            big = "N" * (mb << 20)
            out.append(("long_name", "either", cid, P.request(cid, [[big, B, []]]), 1))
            out.append(("long_argument", "either", cid,
                        P.request(cid, [["GetObjectHandle", B, [big]], ["GetJointPosition", ONESHOT, [big]]]), 2))
        out.append(("long_client_id", "refusal", "fuzz0", P.request("C" * (1 << 20), [["GetPingTime", B, []]]), 0))
        out.append(("huge_batch", "either", "fuzz1", P.request("fuzz1", [["GetPingTime", B, []]] * 5000), 5000))
        out.append(("image_amplification", "either", "fuzz2",
                    P.request("fuzz2", [["GetVisionSensorImage", B, [rgb, 0]]] * 160), 160))
        return out


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


class Sender:
    """Sends queries with at most ``in_flight`` outstanding; each query's replies are
    collected by Zenoh callbacks, and its end (Zenoh's final reply, or the timeout) recorded."""

    def __init__(self, session: zenoh.Session, in_flight: int):
        self.session = session
        self.slots = threading.BoundedSemaphore(in_flight)
        self.in_flight = in_flight
        self.replies: list[list] = []
        self.seconds: list[float] = []

    def send(self, key_id: str, payload: bytes) -> None:
        i = len(self.replies)
        self.replies.append([])
        self.seconds.append(math.nan)
        assert self.slots.acquire(timeout=REPLY_TIMEOUT + 10), "a query never ended"
        t0 = time.monotonic()

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                self.replies[i].append(reply.ok.payload.to_bytes())
            else:
                self.replies[i].append(("zenoh error", reply.err.payload.to_string()[:200]))

        def on_end() -> None:
            self.seconds[i] = time.monotonic() - t0
            self.slots.release()

        self.session.get(P.call_key("simx", key_id), zenoh.handlers.Callback(on_reply, on_end, indirect=False),
                         payload=payload, timeout=REPLY_TIMEOUT)

    def wait(self) -> None:
        for _ in range(self.in_flight):
            assert self.slots.acquire(timeout=REPLY_TIMEOUT + 10), "a query never ended"
        for _ in range(self.in_flight):
            self.slots.release()


def _check_reply(label: str, kind: str, n: int, replies: list) -> list[str]:
    """What is wrong with one query's replies (an empty list when nothing is)."""
    if len(replies) != 1:
        return [f"{label}: {len(replies)} replies, expected exactly 1"]
    reply = replies[0]
    if isinstance(reply, tuple):
        return [f"{label}: {reply[0]}: {reply[1]}"]
    try:
        message = msgpack.unpackb(reply, raw=False, strict_map_key=False)
    except Exception as exc:
        return [f"{label}: undecodable reply of {len(reply)} bytes: {exc}"]
    if type(message) is dict:
        problems = []
        if kind == "response":
            problems.append(f"{label}: refused ({str(message.get('err'))[:120]!r}), expected a response")
        if message.get("v") != P.PROTOCOL_VERSION or type(message.get("err")) is not str:
            problems.append(f"{label}: a refusal that is not {{'v': {P.PROTOCOL_VERSION}, 'err': str}}: {str(message)[:120]}")
        if len(reply) > MAX_REFUSAL:
            problems.append(f"{label}: refusal of {len(reply):,} bytes (> {MAX_REFUSAL:,})")
        return problems
    if type(message) is not list or len(message) != 6 or type(message[5]) is not list:
        return [f"{label}: neither a refusal nor a response: {str(message)[:120]}"]
    problems = []
    if kind == "refusal":
        problems.append(f"{label}: answered as a valid request, expected a refusal")
    results = message[5]
    if n and len(results) != n:
        problems.append(f"{label}: {len(results)} results for {n} commands")
    for ok, value in results:
        if ok is False:
            if type(value) is not str:
                problems.append(f"{label}: an error that is not a string: {str(value)[:80]}")
            elif len(value) > MAX_ERROR_TEXT:
                problems.append(f"{label}: an error text of {len(value):,} characters (> {MAX_ERROR_TEXT:,}): "
                                f"{value[:80]!r}...")
                break
            elif "internal error" in value:
                problems.append(f"{label}: internal error: {value[:160]!r}")
                break
    if len(reply) > limits.MAX_REPLY_BYTES:
        problems.append(f"{label}: reply of {len(reply):,} bytes (> limits.MAX_REPLY_BYTES)")
    return problems


def test_fuzzed_requests_are_all_answered_and_harm_nothing():
    srv = ServerProcess("--log-level", "INFO")
    session = zenoh.open(client_config("127.0.0.1", srv.port))
    problems: list[str] = []
    log = ""
    try:
        # Warm up (the first render allocates its buffers) and learn the scene's handles.
        setup = list(session.get(P.call_key("simx", "fuzz-setup"), timeout=10, payload=P.request("fuzz-setup", [
            ["GetObjects", B, [vrep.sim_handle_all]], ["GetObjectHandle", B, ["kinect_rgb"]]])))
        (_, handles), (_, rgb) = P.unpack_response(setup[0].ok.payload.to_bytes())[5]
        list(session.get(P.call_key("simx", "fuzz-setup"), timeout=10,
                         payload=P.request("fuzz-setup", [["GetVisionSensorImage", B, [rgb, 0]]])))
        rss_before = _rss_mb(srv.proc.pid)

        fuzzer = Fuzzer(SEED, handles)
        cases = [fuzzer.draw() for _ in range(N_RANDOM)]
        fixed = fuzzer.fixed(rgb)
        for k, case in enumerate(fixed):  # spread the large ones through the run
            cases.insert((k + 1) * len(cases) // (len(fixed) + 1), case)
        sender = Sender(session, IN_FLIGHT)
        t0 = time.monotonic()
        for _, _, key_id, payload, _ in cases:
            sender.send(key_id, payload)
        sender.wait()
        elapsed = time.monotonic() - t0
        rss_after = _rss_mb(srv.proc.pid)

        counts: dict[str, int] = {}
        for (name, kind, _, payload, n), replies in zip(cases, sender.replies):
            counts[name] = counts.get(name, 0) + 1
            label = f"{name} #{counts[name]} ({len(payload):,} bytes)"
            problems += _check_reply(label, kind, n, replies)
        if srv.proc.poll() is not None:
            problems.append(f"the server died (exit status {srv.proc.returncode})")
        if rss_after - rss_before > RSS_GROWTH_MB:
            problems.append(f"server RSS grew {rss_after - rss_before:.0f} MB ({rss_before:.0f} -> "
                            f"{rss_after:.0f} MB), more than {RSS_GROWTH_MB} MB")
        print(f"{len(cases)} requests in {elapsed:.1f} s; slowest answered in {max(sender.seconds):.2f} s; "
              f"server RSS {rss_before:.0f} -> {rss_after:.0f} MB; classes {counts}")

        if srv.proc.poll() is None:  # a legacy program still works: a blocking call and a stream
            cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
            try:
                if cid < 0:
                    problems.append("a legacy client could not connect after the fuzz")
                else:
                    rc, h = vrep.simxGetObjectHandle(cid, "UR5_joint2", B)
                    if rc != 0:
                        problems.append(f"blocking simxGetObjectHandle after the fuzz: rc {rc}")
                    vrep.simxGetJointPosition(cid, h, vrep.simx_opmode_streaming)
                    try:
                        wait_until(lambda: vrep.simxGetJointPosition(cid, h, vrep.simx_opmode_buffer)[0] == 0,
                                   timeout=10, what="a streamed joint position after the fuzz")
                    except pytest.fail.Exception as exc:
                        problems.append(str(exc))
            finally:
                if cid >= 0:
                    vrep.simxFinish(cid)
    finally:
        session.close()
        log = srv.stop()
    tracebacks = log.count("Traceback")
    if tracebacks:
        at = log.index("Traceback")
        start = log.rfind("\n", 0, at - 1) + 1  # the log line before it names the call
        problems.append(f"the server logged {tracebacks} tracebacks; the first:\n{log[start:at + 900]}")
    assert not problems, _summary(problems)


def _summary(problems: list[str]) -> str:
    """Problems grouped by what went wrong (numbers and command names left out), with the
    count of each group and its first three cases."""
    groups: dict[str, list[str]] = {}
    for p in problems:
        what = p.split(";")[0] if p.startswith("the server") else p.split(": ", 1)[-1]
        what = re.sub(r"simx[A-Za-z]+|[0-9][0-9,.]*", "#", what)[:100]
        groups.setdefault(what, []).append(p)
    lines = [f"{len(problems)} problems in {len(groups)} groups:"]
    for what, members in sorted(groups.items(), key=lambda g: -len(g[1])):
        lines.append(f"- {len(members)} x {what}")
        lines += [f"    {m[:1200]}" for m in members[:3]]
    return "\n".join(lines)
