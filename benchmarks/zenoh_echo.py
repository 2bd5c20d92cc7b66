"""The bare Zenoh floor: a queryable that answers a payload of a requested size, nothing else.

``python -m benchmarks.zenoh_echo --port N`` listens on ``tcp/127.0.0.1:N`` with the same
Zenoh config as simx-server (``simx_server.legacy.zenoh_config.zenoh_config``: peer mode, multicast
scouting off) and declares four queryables:

* ``bench/echo/direct`` answers with a plain Python callback, Zenoh's default: Zenoh runs it in
  a Python thread of its own, fed through a channel (``Callback(indirect=True)``). This is the
  bare query/reply floor.
* ``bench/echo/queue``: Zenoh's network thread puts the query on a ``queue.SimpleQueue``
  (``indirect=False``) and the main thread replies, exactly as simx-server hands queries to
  its simulation thread: the thread hop the server's design needs, instead of Zenoh's own.
* ``bench/echo/codec`` answers like ``direct`` but decodes the request as a simx request and
  encodes a simx response carrying one float, with simx's own protocol functions: the floor
  plus the msgpack work any msgpack protocol over Zenoh does (no simx logic).
* ``bench/echo/design`` does what ``codec`` does, from a thread of its own fed through a
  ``queue.SimpleQueue`` like ``queue``: the least that DESIGN.md's architecture (one thread
  owns the simulation and replies; msgpack on the wire) costs, before any simx logic.

A request's first 4 bytes (little-endian uint32) are the size of the reply wanted; the rest
is padding, so requests and replies can have exactly the sizes simx's own messages have.
Prints one ``echo ready`` line; SIGTERM stops it.
"""

from __future__ import annotations

import argparse
import queue
import signal
import struct
import threading

import zenoh

from simx_client import protocol as P

KEY_DIRECT = "bench/echo/direct"
KEY_QUEUE = "bench/echo/queue"
KEY_CODEC = "bench/echo/codec"
KEY_DESIGN = "bench/echo/design"


def make_request(reply_size: int, request_size: int) -> bytes:
    """A request of ``request_size`` bytes asking for a reply of ``reply_size`` bytes."""
    head = struct.pack("<I", reply_size)
    return head + bytes(max(0, request_size - len(head)))


class Echo:
    def __init__(self) -> None:
        self._replies: dict[int, bytes] = {}
        self.queue: queue.SimpleQueue = queue.SimpleQueue()

    def reply(self, query: zenoh.Query) -> None:
        payload = query.payload.to_bytes() if query.payload is not None else b""
        size = struct.unpack_from("<I", payload)[0] if len(payload) >= 4 else 0
        body = self._replies.get(size)
        if body is None:
            body = self._replies[size] = bytes(size)
        query.reply(query.key_expr, body)

    @staticmethod
    def codec_reply(query: zenoh.Query) -> None:
        payload = query.payload.to_bytes() if query.payload is not None else b""
        client, commands = P.parse_request(payload)
        query.reply(query.key_expr, P.response(1234, 5, [[True, 0.5 + len(commands)]], 5678, 4321))


def _serve_queue(queries: queue.SimpleQueue, reply, stop: threading.Event) -> None:
    """Answer the queries handed over through ``queries`` until ``stop`` is set."""
    while not stop.is_set():
        try:
            query = queries.get(timeout=0.2)
        except queue.Empty:
            continue
        reply(query)
        query.drop()


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--port", type=int, required=True)
    args = p.parse_args(argv)
    from simx_server.legacy.zenoh_config import zenoh_config  # here: clients import this module too

    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    echo = Echo()
    session = zenoh.open(zenoh_config([f"tcp/127.0.0.1:{args.port}"]))
    try:
        direct = session.declare_queryable(KEY_DIRECT, echo.reply)  # noqa: F841
        # As simx-server does: Zenoh's network thread puts the query on the queue itself
        # (indirect=False); a plain callable would add a Python thread of Zenoh's in between.
        hop = session.declare_queryable(KEY_QUEUE, zenoh.handlers.Callback(echo.queue.put, indirect=False))  # noqa: F841
        codec = session.declare_queryable(KEY_CODEC, echo.codec_reply)  # noqa: F841
        design_queue: queue.SimpleQueue = queue.SimpleQueue()
        design = session.declare_queryable(KEY_DESIGN, zenoh.handlers.Callback(design_queue.put, indirect=False))  # noqa: F841
        threading.Thread(target=_serve_queue, args=(design_queue, echo.codec_reply, stop), daemon=True).start()
        print(f"echo ready on tcp/127.0.0.1:{args.port}", flush=True)
        _serve_queue(echo.queue, echo.reply, stop)
    finally:
        session.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
