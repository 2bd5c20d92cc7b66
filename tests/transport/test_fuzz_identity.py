"""Issue 48: the legacy door's msgpack requests fuzzed with their new part, the proof a request
carries as its Zenoh attachment (simx_wire.proof), against a real server (bounded: 400 requests,
seeded, 8 in flight).

A legacy client (the victim) holds an id and a file. A raw session sends the fuzzer of
tests/transport/test_fuzz.py's request classes (malformed msgpack, wrong shapes, deep values,
wrong-typed arguments...) under the victim's id, under ids the server does not know, and under
ids that never handshook, each with an attachment drawn from: none, random bytes of every length
near the proof's, a proof of the right length with random bytes, the victim's own proof seen
going by (replayed, or on another payload), a proof sealed with a guessed secret, a sequence
number of 0 or 2**64 - 1. Checked: every request gets exactly one reply, a refusal or a
response, never an internal error; nothing under the victim's id is executed (each is a
refusal); a proven request under an unknown id is refused as unknown; the server logs no
traceback; and afterwards the victim's file is there, the victim is served, and a new legacy
client connects and is served.
"""

from __future__ import annotations

import queue
import random
import tempfile
from pathlib import Path

import msgpack
import pytest
import zenoh

import vrep
from conftest import ServerProcess, free_port, wait_until
from simx_client import api
from simx_client.connection import client_config
from simx_wire import proof as PR
from simx_wire import protocol as P
from test_fuzz import IN_FLIGHT, REPLY_TIMEOUT, Fuzzer, _check_reply, _summary

pytestmark = pytest.mark.renderers_on_demand
SEED = 20261125
N = 400
B = P.MODE_BLOCKING


def _retarget(payload: bytes, client: str) -> bytes:
    """The fuzzed request under ``client``'s id where it names one (a readable request array),
    else as it is."""
    try:
        message = msgpack.unpackb(payload, raw=False, strict_map_key=False)
    except Exception:
        return payload
    if type(message) is list and len(message) == 3 and type(message[1]) is str:
        return msgpack.packb([message[0], client, message[2]], use_bin_type=True)
    return payload


def _files(srv: ServerProcess) -> list[str]:
    return sorted(p.name for p in Path(tempfile.gettempdir()).glob(f"simx-{srv.proc.pid}-*/.simx-clients/*/*"))


class Attachments:
    """The attachment of a fuzzed request, drawn from the kinds the module's text lists."""

    def __init__(self, rng: random.Random, seen: tuple[bytes, bytes]):
        self.rng, (self.payload, self.proof) = rng, seen

    def draw(self, payload: bytes) -> tuple[str, bytes | None]:
        r = self.rng
        kind = r.choice(["none", "bytes", "random proof", "replayed", "seen proof", "guessed", "seq 0", "seq max"])
        if kind == "none":
            return kind, None
        if kind == "bytes":
            return kind, r.randbytes(r.choice([0, 1, 8, PR.PROOF_BYTES - 1, PR.PROOF_BYTES + 1, 64, 4096]))
        if kind == "random proof":
            return kind, r.randbytes(PR.PROOF_BYTES)
        if kind in ("replayed", "seen proof"):
            return kind, self.proof
        secret = r.randbytes(PR.SECRET_BYTES)
        seq = {"guessed": r.randrange(1, 1 << 40), "seq 0": 0, "seq max": (1 << 64) - 1}[kind]
        return kind, PR.seal(secret, seq, payload)


def test_fuzzed_requests_with_fuzzed_proofs_never_act_as_a_client():
    srv = ServerProcess("--stopped", "--log-level", "INFO", ports=[free_port(), free_port()], renderers="on-demand")
    victim_cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    problems: list[str] = []
    try:
        assert victim_cid >= 0
        victim = api._connections[victim_cid].client
        conn = api._connections[victim_cid]
        assert conn.request([["TransferFile", B, ["keep.txt", b"the victim's"]]]) == [[True, None]]
        handles = conn.request([["GetObjects", B, [vrep.sim_handle_all]]])[0][1]
        with zenoh.open(client_config("127.0.0.1", srv.port)) as raw:
            seen: queue.SimpleQueue = queue.SimpleQueue()

            def snoop(query: zenoh.Query) -> None:
                if str(query.key_expr).endswith(victim) and query.attachment is not None:
                    seen.put((query.payload.to_bytes(), query.attachment.to_bytes()))

            with raw.declare_queryable(P.call_keys(), snoop):
                wait_until(lambda: vrep.simxGetPingTime(victim_cid)[0] == 0 and not seen.empty(),
                           what="a request of the victim seen")
            rng = random.Random(SEED)
            fuzzer, attachments = Fuzzer(SEED, handles), Attachments(rng, seen.get())
            cases = []  # (label, kind, n, key id, payload, attachment)
            for i in range(N):
                name, kind, key_id, payload, n = fuzzer.draw()
                target = rng.choice(["victim", "unknown", "unbound"])  # unbound: the fuzzer's own ids
                if target != "unbound":
                    key_id = victim if target == "victim" else f"gone{i}"
                    payload = _retarget(payload, key_id)
                how, attachment = attachments.draw(payload)
                if how == "replayed":
                    payload, key_id, target = attachments.payload, victim, "victim"
                cases.append((f"{name} to {target} with {how} #{i}", kind, n, key_id, payload, attachment, target))
            replies: list[list] = [[] for _ in cases]
            slots = queue.Queue(IN_FLIGHT)
            for i, (_, _, _, key_id, payload, attachment, _) in enumerate(cases):
                slots.put(i, timeout=REPLY_TIMEOUT + 10)

                def on_reply(reply: zenoh.Reply, i=i) -> None:
                    replies[i].append(reply.ok.payload.to_bytes() if reply.ok is not None
                                      else ("zenoh error", reply.err.payload.to_string()[:200]))

                raw.get(P.call_key("simx", key_id), zenoh.handlers.Callback(on_reply, slots.get, indirect=False),
                        payload=payload, attachment=attachment, timeout=REPLY_TIMEOUT)
            for _ in range(IN_FLIGHT):
                slots.put(None, timeout=REPLY_TIMEOUT + 10)
        counts: dict[str, int] = {}
        for (label, kind, n, key_id, payload, attachment, target), got in zip(cases, replies):
            counts[target] = counts.get(target, 0) + 1
            if key_id == victim or attachment is not None:
                kind = "refusal"  # never executed: not the sender's to make, a client never handshaken, or none
            problems += _check_reply(label, kind, n, got)
        assert counts["victim"] > 100 and counts["unknown"] > 100 and counts["unbound"] > 100, counts
        # the victim is untouched: its file, its session; a newcomer is served.
        if _files(srv) != ["keep.txt"]:
            problems.append(f"the victim's files: {_files(srv)}")
        if vrep.simxGetPingTime(victim_cid)[0] != 0:
            problems.append("the victim is no longer served")
        other = vrep.simxStart("127.0.0.1", srv.ports[1], True, True, 5000, 5)  # vrep.py: one client a port
        if other < 0 or vrep.simxGetPingTime(other)[0] != 0:
            problems.append("a new client is not served after the fuzz")
        if other >= 0:
            vrep.simxFinish(other)
    finally:
        vrep.simxFinish(victim_cid)
        log = srv.stop()
    if "Traceback" in log:
        at = log.index("Traceback")
        problems.append(f"the server logged {log.count('Traceback')} tracebacks; the first:\n{log[at - 300:at + 900]}")
    if f"client {victim} disconnected" not in log or log.count(f"client {victim} disconnected") != 1:
        problems.append("the victim was disconnected other than by its own simxFinish")
    assert not problems, _summary(problems)
