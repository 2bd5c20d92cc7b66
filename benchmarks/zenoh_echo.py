"""The bare Zenoh floor: a queryable that answers a payload of a requested size, nothing else.

``python -m benchmarks.zenoh_echo --port N`` listens on ``tcp/127.0.0.1:N`` with the same
Zenoh config as simx-server (``simx_server.server.zenoh_config``: peer mode, multicast
scouting off) and declares two queryables:

* ``bench/echo/direct`` answers inside Zenoh's callback thread: the bare query/reply floor.
* ``bench/echo/queue`` hands the query to the main thread through a ``queue.SimpleQueue``,
  which replies, exactly as simx-server hands queries to its simulation thread: the floor
  plus the thread hop the server's design needs.
* ``bench/echo/codec`` answers like ``direct`` but decodes the request as a simx request and
  encodes a simx response carrying one float, with simx's own protocol functions: the floor
  plus the msgpack work any msgpack protocol over Zenoh does (no simx logic).

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

KEY_DIRECT = "bench/echo/direct"
KEY_QUEUE = "bench/echo/queue"
KEY_CODEC = "bench/echo/codec"


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
        from simx_client import protocol as P

        payload = query.payload.to_bytes() if query.payload is not None else b""
        client, commands = P.parse_request(payload)
        query.reply(query.key_expr, P.response(1234, 5, [[True, 0.5 + len(commands)]], 5678, 4321))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--port", type=int, required=True)
    args = p.parse_args(argv)
    from simx_server.server import zenoh_config  # here: clients import this module too

    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    echo = Echo()
    session = zenoh.open(zenoh_config([f"tcp/127.0.0.1:{args.port}"]))
    try:
        direct = session.declare_queryable(KEY_DIRECT, echo.reply)  # noqa: F841
        hop = session.declare_queryable(KEY_QUEUE, echo.queue.put)  # noqa: F841
        codec = session.declare_queryable(KEY_CODEC, echo.codec_reply)  # noqa: F841
        print(f"echo ready on tcp/127.0.0.1:{args.port}", flush=True)
        while not stop.is_set():
            try:
                echo.reply(echo.queue.get(timeout=0.2))
            except queue.Empty:
                pass
    finally:
        session.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
