"""Issue 23 part 3: the memory one request can cost once decoded, and what a server keeps per
connection.

* A request is measured on its bytes before it is decoded (:mod:`simx_client.decoded_size`):
  at most ``protocol.MAX_REQUEST_ITEMS`` values and ``MAX_REQUEST_DECODED_BYTES`` of Python
  objects, refused with the bound's name before msgpack builds anything. The estimate is an
  upper bound of what decoding takes (sys.getsizeof of every object) and not far above it.
* The bombs that beat a container count (uncached small integers, two-letter strings and empty
  maps, flat or spread over nested arrays) are refused on a real server whose peak RSS stays
  small while another client goes on.
* Connections that come and go leave no state behind (tests/transport/test_memory_budgets.py's
  last test: sessions, streams, errors, liveliness tokens and Zenoh transports are freed).
"""

from __future__ import annotations

import random
import struct
import sys
import uuid

import msgpack
import pytest
import zenoh

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client import decoded_size
from simx_client import protocol as P
from simx_client.connection import client_config
from simx_server.base import limits as L

B = vrep.simx_opmode_blocking
BOUNDS = "MAX_REQUEST_(ITEMS|DECODED_BYTES)"


# ------------------------------------------------------------------ the estimate
def _value(rng: random.Random, depth: int = 0):
    r = rng.random()
    if depth < 4 and r < 0.15:
        return [_value(rng, depth + 1) for _ in range(rng.randrange(0, 40))]
    if depth < 4 and r < 0.2:
        return {rng.choice(["a", "bc", "x" * rng.randrange(50), rng.randrange(-100, 100_000)]): _value(rng, depth + 1)
                for _ in range(rng.randrange(0, 10))}
    if depth < 4 and r < 0.25:  # a run of one scalar, measured without a step per item
        return [rng.choice([1.5, -7, 3, 300, 2 ** 40, None, True, -2])] * rng.randrange(0, 100)
    # One of 27 scalars, with the draws of a list of them built whole (its three lengths, then
    # the choice: rng.choice(seq) is seq[rng.randrange(len(seq))]), only the one chosen made:
    # the same payloads, without a list and two ExtTypes made for each of a million values.
    x, ab, ext = rng.randrange(300), rng.randrange(100), rng.randrange(40)
    k = rng.randrange(len(_SCALARS) + 6)
    if k < len(_SCALARS):
        return _SCALARS[k]
    return ("x" * x, b"", b"a", b"ab" * ab, msgpack.ExtType(3, b"abc"), msgpack.ExtType(3, b"a" * ext))[k - len(_SCALARS)]


_SCALARS = (None, True, False, 0, 5, -3, -6, -33, 200, 300, -300, 70_000, -70_000, 2 ** 40, -2 ** 40, 2 ** 63, 1.5,
            "", "a", "ab", "\u4e2d\u6587")


def _decoded_bytes(data: bytes) -> int:
    """The memory the decoded value of ``data`` takes: every distinct object's sys.getsizeof (a
    list's and a dict's include their references and GC header). It agrees with tracemalloc
    within 10 % on these values, and unlike tracemalloc it does not count what other threads
    of the test process allocate meanwhile."""
    seen, total, todo = set(), 0, [msgpack.unpackb(data, raw=False, strict_map_key=False)]
    while todo:
        value = todo.pop()
        if id(value) not in seen:
            seen.add(id(value))
            total += sys.getsizeof(value)
            if type(value) is list:
                todo.extend(value)
            elif type(value) is dict:
                todo.extend(value)
                todo.extend(value.values())
    return total


def test_the_estimate_bounds_what_decoding_takes_and_is_close_to_it():
    rng = random.Random(20261123)
    ratios = []
    for _ in range(40):  # 40 seeded payloads (150 took 45 s of a loaded 2-core machine)
        data = msgpack.packb([_value(rng) for _ in range(rng.randrange(50, 300))], use_bin_type=True)
        items, estimate = decoded_size.measure(data, 10 ** 9, 10 ** 12)
        real = _decoded_bytes(data)
        assert real <= estimate, (real, estimate)
        ratios.append(real / estimate)
        assert items == _count(msgpack.unpackb(data, raw=False, strict_map_key=False))
    assert min(ratios) > 0.5, "the estimate is an upper bound, but not a loose one"


def _count(value) -> int:
    if isinstance(value, list):
        return 1 + sum(_count(v) for v in value)
    if isinstance(value, dict):
        return 1 + sum(_count(k) + _count(v) for k, v in value.items())
    return 1


def _flat(n: int, item: bytes) -> bytes:
    return b"\xdd" + struct.pack(">I", n) + item * n


def _request(args: bytes) -> bytes:
    """A request whose one command's argument list is ``args`` (msgpack bytes)."""
    return (b"\x93" + msgpack.packb(P.PROTOCOL_VERSION) + msgpack.packb("bomber")
            + b"\x91\x93" + msgpack.packb("GetPingTime") + msgpack.packb(B) + args)


def _nested(levels: int, per_level: int, item: bytes) -> bytes:
    """Arrays nested ``levels`` deep, each holding ``per_level`` items before the next level:
    a container count sees nothing until the innermost array ends."""
    return (b"\xdd" + struct.pack(">I", per_level + 1) + item * per_level) * levels + b"\x90"


#: Bombs of a few MiB each (the issue's was 60 MiB: 62.9 M empty arrays, 4.7 GB of server).
BOMBS = {
    "empty arrays": _flat(3_000_000, b"\x90"),
    "empty maps": _flat(3_000_000, b"\x80"),
    "uncached fixints (-6)": _flat(8_000_000, b"\xfa"),
    "two-letter strings": _flat(3_000_000, b"\xa2ab"),
    "mixed fixints and nil": _flat(4_000_000, b"\xfa\xc0"),  # no run of one width and cost
    "nested levels of fixints": _nested(16, 500_000, b"\xfa"),
    "a map of many pairs": b"\xdf" + struct.pack(">I", 2_000_000) + b"\x01\x90" * 2_000_000,
}


@pytest.mark.parametrize("kind", sorted(BOMBS))
def test_a_bomb_is_refused_with_the_bound_before_anything_is_decoded(kind, monkeypatch):
    payload = _request(BOMBS[kind])
    assert len(payload) <= L.MAX_REQUEST_BYTES
    monkeypatch.setattr(P.msgpack, "unpackb", lambda *a, **k: pytest.fail("decoded before it was measured"))
    with pytest.raises(P.ProtocolError, match=BOUNDS):
        P.read_request(payload, L.MAX_COMMANDS_PER_REQUEST)


def test_real_requests_pass_and_count_their_decoded_size():
    file = P.request("c", [["TransferFile", B, ["mesh.stl", b"\x00" * (60 << 20)]]])  # 60 MiB of bin
    client, cmds, size = P.read_request(file)
    assert client == "c" and (60 << 20) < size < (61 << 20)
    floats = P.request("c", [["CallScriptFunction", B, ["s", 1, "f", [], [0.5] * 1_000_000, [], b""]]])
    _, _, size = P.read_request(floats)  # a run: measured with a few byte counts
    assert 32e6 < size < 50e6
    small = P.request("c", [["GetJointPosition", B, [17]]])
    assert len(small) <= P.MEASURE_ABOVE and P.read_request(small)[2] == decoded_size.RATIO * len(small)
    assert L.MAX_QUEUED_BYTES >= L.MAX_REQUEST_DECODED_BYTES  # one largest request always fits its queue


def test_bytes_that_are_not_msgpack_are_refused_as_undecodable():
    for data in (b"\xc1" * 2000, _flat(5000, b"\xcb")[:3000], b"\xdb\xff\xff\xff\xff" + b"x" * 2000):
        with pytest.raises(P.ProtocolError, match="undecodable"):
            P.read_request(data)


# ------------------------------------------------------------------ on a real server
def _vm(pid: int, field: str) -> float:
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(field + ":")) / 1024


@pytest.fixture(scope="module")
def server():
    srv = ServerProcess(str(SCENE), "--pacing", "immediate", ports=[free_port()], renderers="on-demand")
    yield srv
    srv.stop()


def test_bombs_cost_the_server_no_memory_and_another_client_goes_on(server):
    cid = vrep.simxStart("127.0.0.1", server.port, True, True, 5000, 5)
    assert cid >= 0
    session = zenoh.open(client_config("127.0.0.1", server.port))
    try:
        assert vrep.simxGetPingTime(cid)[0] == 0
        peak = _vm(server.proc.pid, "VmHWM")
        for kind, args in BOMBS.items():
            client = f"bomber{uuid.uuid4().hex[:8]}"
            payload = _request(args).replace(b"\xa6bomber", msgpack.packb(client), 1)
            reply = None
            for r in session.get(P.call_key("simx", client), payload=payload, timeout=30):
                if r.ok is not None:
                    reply = msgpack.unpackb(r.ok.payload.to_bytes(), raw=False)
            assert isinstance(reply, dict) and reply.get("err"), (kind, reply)
            assert "MAX_REQUEST_ITEMS" in reply["err"] or "MAX_REQUEST_DECODED_BYTES" in reply["err"], (kind, reply)
            assert vrep.simxGetPingTime(cid)[0] == 0
        grown = _vm(server.proc.pid, "VmHWM") - peak
        # The payloads themselves pass through Zenoh (about 3-8 MiB each); decoded, the first
        # would have cost 190 MB and the fixints 380 MB (the hooks of a container count let
        # those through), the 60 MiB bomb 4.4 GB.
        assert grown < 120, f"server peak RSS grew by {grown:.0f} MB"
        assert vrep.simxGetObjectHandle(cid, "UR5", B)[0] == 0 and server.proc.poll() is None
    finally:
        session.close()
        vrep.simxFinish(cid)
