"""Helpers shared by the benchmark suites: clients, the Zenoh floor, interleaved timing."""

from __future__ import annotations

import dataclasses
import os
import random
import time
from pathlib import Path
from typing import Callable

import zenoh

from benchmarks.zenoh_echo import KEY_CODEC, KEY_DESIGN, KEY_DIRECT, KEY_QUEUE, make_request
from simx_client import api
from simx_client import protocol as P
from simx_client.connection import Connection, client_config

perf = time.perf_counter


@dataclasses.dataclass
class Settings:
    """What one run of the suites may spend."""

    quick: bool
    log_dir: Path
    #: ``--baseline DIR``: another source tree of simx (an older commit, ``git archive`` or
    #: ``git worktree``) whose server the suites that support it (``sync``, ``envstep``) time
    #: side by side with this tree's, in the same run; None: not measured.
    baseline: Path | None = None
    #: ``--smoke``: every suite in its tiniest form (CI runs it: ``scripts/bench-smoke.sh``), to
    #: show that it runs; none of its figures means anything. Implies ``quick``.
    smoke: bool = False

    def n(self, full: int, quick: int, smoke: int | None = None) -> int:
        """A count: ``full``, ``quick`` with ``--quick``, ``smoke`` (default a tenth of
        ``quick``, at least 1) with ``--smoke``."""
        if self.smoke:
            return smoke if smoke is not None else max(1, quick // 10)
        return quick if self.quick else full

    def t(self, full: float, quick: float, smoke: float | None = None) -> float:
        """A duration in s: ``full``, ``quick`` with ``--quick``, ``smoke`` (default a fifth of
        ``quick``) with ``--smoke``."""
        if self.smoke:
            return smoke if smoke is not None else quick / 5
        return quick if self.quick else full

    def pick(self, full, quick, smoke=None):
        """Any setting (e.g. which client counts): ``full``, ``quick``, or ``smoke`` (default
        ``quick``) with ``--smoke``."""
        if self.smoke and smoke is not None:
            return smoke
        return quick if self.quick else full


def connect(port: int) -> int:
    """A legacy client id connected to the simx server on ``port`` (raises if it cannot)."""
    cid = api.simxStart("127.0.0.1", port, True, True, 10000, 5)
    if cid < 0:
        raise RuntimeError(f"simxStart to 127.0.0.1:{port} failed")
    return cid


def connection(cid: int) -> Connection:
    """The client's Connection object behind a legacy client id."""
    return api._connections[cid]


def client_as_before_issue44(cid: int) -> None:
    """Make the connection ``cid`` behave as the client did before issue 44's throughput work
    (with ``--baseline`` a tree from before it, the old client and server): its outbox leaves
    in requests of its own before a trigger (``OutboxSender._carry``, the client's only change)."""
    conn = connection(cid)
    conn._carry = lambda commands: None  # type: ignore[method-assign]


def wire_sizes(cid: int, commands: list[list]) -> tuple[int, int]:
    """(request bytes, reply bytes) of one simx request carrying ``commands``, measured on
    the wire by sending it once."""
    conn = connection(cid)
    payload = P.request(conn.client, commands)
    for reply in conn.session.get(P.call_key(conn.prefix, conn.client), payload=payload, timeout=10):
        if reply.ok is not None:
            return len(payload), len(reply.ok.payload.to_bytes())
    raise RuntimeError(f"no reply to {commands!r}")


class Floor:
    """Client side of the bare Zenoh floor: the same ``client_config`` as simx's client, to the
    echo process's own loopback port."""

    def __init__(self, port: int):
        self.session = zenoh.open(client_config("127.0.0.1", port))
        self._payloads: dict[tuple[int, int], bytes] = {}
        # Declared queriers, as simx's client uses: the fastest bare way to query a key.
        self._queriers = {k: self.session.declare_querier(k, timeout=5.0) for k in (KEY_DIRECT, KEY_QUEUE, KEY_CODEC, KEY_DESIGN)}
        self._encoder = P.RequestEncoder("bench-floor-client")
        # The first query also sets up routing; do it before anything is timed.
        deadline = time.monotonic() + 10
        while True:
            try:
                self.call(8, 8, timeout=1.0)
                break
            except TimeoutError:
                if time.monotonic() > deadline:
                    raise

    def call(self, reply_size: int, request_size: int, hop: bool = False, timeout: float = 5.0) -> int:
        """One query/reply; returns the reply size. ``hop``: the queryable that replies from
        the echo's main thread (same thread hop as simx-server)."""
        key = (reply_size, request_size)
        payload = self._payloads.get(key)
        if payload is None:
            payload = self._payloads[key] = make_request(reply_size, request_size)
        key = KEY_QUEUE if hop else KEY_DIRECT
        replies = (self._queriers[key].get(payload=payload) if timeout == 5.0
                   else self.session.get(key, payload=payload, timeout=timeout))
        for reply in replies:
            if reply.ok is not None:
                return len(reply.ok.payload.to_bytes())
        raise TimeoutError("no reply from the echo")

    def codec_call(self, commands: list[list], hop: bool = False) -> float:
        """One query/reply carrying a real simx request and response, encoded and decoded with
        simx's protocol functions on both ends, and nothing else; returns the reply's value.
        ``hop``: answered from a thread fed through a queue, as simx-server answers."""
        for reply in self._queriers[KEY_DESIGN if hop else KEY_CODEC].get(payload=self._encoder.encode(commands)):
            if reply.ok is not None:
                return P.unpack_response(reply.ok.payload.to_bytes())[5][0][1]
        raise TimeoutError("no reply from the echo")

    def close(self) -> None:
        self.session.close()


def time_calls(fn: Callable[[], object], n: int, clock: Callable[[], float] = perf) -> list[float]:
    """Durations in s of ``n`` calls of ``fn`` by ``clock`` (the wall clock by default). A ``fn``
    that returns a float has timed itself (to leave out its untimed set-up) and that value is used."""
    out = []
    for _ in range(n):
        t0 = clock()
        got = fn()
        dt = clock() - t0
        out.append(got if isinstance(got, float) else dt)
    return out


def interleaved(rounds: int, block: int, cases: dict[str, Callable[[], object]],
                warmup: int = 5, budget_s: float = 120.0, clock: Callable[[], float] = perf) -> dict[str, list[float]]:
    """Time every case side by side: ``rounds`` rounds, each running ``block`` calls of every
    case in turn, so that the machine's load changes hit all cases alike. The order is shuffled
    every round (seeded): a rotation would keep each case behind the same neighbour, and the
    case before leaves the processes and caches in a state of its own (seen as a 5 % bias of
    one floor). Stops early (keeping what it has) if ``budget_s`` runs out. ``clock`` times the
    calls (:func:`time_calls`)."""
    names = list(cases)
    for name in names:
        for _ in range(warmup):
            cases[name]()
    times: dict[str, list[float]] = {name: [] for name in names}
    deadline = time.monotonic() + budget_s
    shuffle = random.Random(20261121).shuffle
    for r in range(rounds):
        order = names[:]
        shuffle(order)
        for name in order:
            times[name].extend(time_calls(cases[name], block, clock))
        if time.monotonic() > deadline:
            break
    return times


def loadavg() -> list[float]:
    try:
        return list(os.getloadavg())
    except OSError:
        return []


def floor_pipelined(floor: Floor, first: tuple[int, int], second: tuple[int, int]) -> None:
    """Two queries as a pipelined oneshot batch + blocking ping travel: the first sent without
    waiting, then the second waited for. Sizes are (request bytes, reply bytes)."""
    req, rep = first
    floor.session.get(KEY_DIRECT, lambda reply: None, payload=make_request(rep, req), timeout=5.0)
    floor.call(second[1], second[0])
