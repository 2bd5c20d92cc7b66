"""Who may connect to the ZMQ remote API: the ZAP handler (ZeroMQ's authentication protocol,
RFC 27) that the frontend's socket thread answers for every new connection (a bound on their
number; CURVE keys when the server has them)."""

from __future__ import annotations

import logging
import time
from collections import deque

import zmq
import zmq.utils.z85

from simx_server.base import limits

log = logging.getLogger("simx.zmq")


class Gate:
    """The ZAP handler (ZeroMQ's authentication protocol, RFC 27) of the ZMQ remote API: every
    new connection is asked about once, on the socket thread.

    Args:
        curve: ``(server_secret_key, server_public_key, client_public_keys)`` (Z85 bytes) to
            require CURVE (encryption and client authentication: a connection passes only with
            one of ``client_public_keys``), or None (no authentication: ZMQ's NULL mechanism).
        max_connections: connections served at once (those whose handshake succeeded: the
            frontend's socket monitor calls :meth:`admitted`); a new one beyond is refused (ZAP
            status 400; its descriptor is closed at once and the refusal logged). Connections
            still in their handshake hold no slot (libzmq closes them after
            ``limits.ZMQ_HANDSHAKE_SECONDS``).
    """

    def __init__(self, curve: tuple[bytes, bytes, frozenset] | None = None,
                 max_connections: int = limits.MAX_ZMQ_CONNECTIONS):
        self.curve = curve
        self.max_connections = max_connections
        self.connections: set[int] = set()  # descriptors of the connections whose handshake succeeded
        # when the handler let through connections whose handshake has not succeeded yet: each
        # holds a slot until it does, or for limits.ZMQ_HANDSHAKE_SECONDS (libzmq then closed it)
        self._passed: deque[float] = deque()
        self.refused = 0

    @property
    def passed(self) -> int:
        """Connections let through whose handshake has not succeeded yet (nor run out of time)."""
        end = time.monotonic() - limits.ZMQ_HANDSHAKE_SECONDS
        while self._passed and self._passed[0] < end:
            self._passed.popleft()
        return len(self._passed)

    def admitted(self, fd: int) -> None:
        """A connection's handshake succeeded (the socket monitor's event): it holds a slot until it
        closes (``connections.discard``)."""
        self.connections.add(fd)
        if self._passed:
            self._passed.popleft()

    def configure(self, router: zmq.Socket) -> None:
        if self.curve is not None:
            secret, public, _ = self.curve
            router.setsockopt(zmq.CURVE_SERVER, 1)
            router.setsockopt(zmq.CURVE_SECRETKEY, secret)
            router.setsockopt(zmq.CURVE_PUBLICKEY, public)

    def answer(self, zap: zmq.Socket) -> None:
        """Answer the ZAP requests waiting on ``zap``."""
        while True:
            try:
                frames = zap.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            version, request_id = (frames + [b"", b""])[:2]
            status, text = self._decide(frames)
            if status == b"200":
                self._passed.append(time.monotonic())
            zap.send_multipart([version, request_id, status, text, b"", b""])

    def _decide(self, frames: list[bytes]) -> tuple[bytes, bytes]:
        if len(frames) < 6 or frames[0] != b"1.0":
            return b"500", b"bad ZAP request"
        address, mechanism = frames[3].decode(errors="replace"), frames[5]
        # those let through whose handshake is not over yet count too (their success comes later)
        if len(self.connections) + self.passed >= self.max_connections:
            self.refused += 1
            log.warning("ZMQ connection from %s refused: %d connections already (limits.MAX_ZMQ_CONNECTIONS, "
                        "at most %d here; the open-files limit)", address, len(self.connections) + self.passed,
                        self.max_connections)
            return b"400", b"server busy: too many ZMQ connections"
        if self.curve is None:
            return (b"200", b"OK") if mechanism == b"NULL" else (b"400", b"unexpected mechanism")
        if mechanism != b"CURVE" or len(frames) < 7:
            return b"400", b"CURVE required"
        key = zmq.utils.z85.encode(frames[6]) if len(frames[6]) == 32 else b""
        if key not in self.curve[2]:
            log.warning("ZMQ connection from %s refused: its CURVE key is not an authorised client's "
                        "(--zmq-curve)", address)
            return b"400", b"unknown client key"
        return b"200", b"OK"
