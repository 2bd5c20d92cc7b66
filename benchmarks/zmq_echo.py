"""The bare ZMQ floor: a REP socket answering each request with a reply of the size it asks for.

A request's first 4 bytes (little endian) are the size of the reply wanted; the rest is padding,
so the client sends exactly the request size it measures against. The main thread receives and
replies, nothing else: what a ZMQ REQ/REP round trip of those sizes costs on this machine.

    python -m benchmarks.zmq_echo --port N      # prints "ready" once bound
"""

from __future__ import annotations

import argparse
import signal
import sys

import zmq


def request(reply_size: int, request_size: int) -> bytes:
    """A request of ``request_size`` bytes asking for ``reply_size`` bytes back."""
    return reply_size.to_bytes(4, "little") + b"\0" * max(0, request_size - 4)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--port", type=int, required=True)
    args = p.parse_args(argv)
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REP)
    sock.setsockopt(zmq.LINGER, 0)
    sock.bind(f"tcp://127.0.0.1:{args.port}")
    replies: dict[int, bytes] = {}
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    print("ready", flush=True)
    try:
        while True:
            data = sock.recv()
            size = int.from_bytes(data[:4], "little")
            reply = replies.get(size)
            if reply is None:
                reply = replies[size] = b"\1" * size
            sock.send(reply, copy=False)
    finally:
        sock.close(0)
        ctx.term()


if __name__ == "__main__":
    sys.exit(main())
