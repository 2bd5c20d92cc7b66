"""Who may connect to the ZMQ remote API: the ZAP handler (ZeroMQ's authentication protocol,
RFC 27) that the frontend's socket thread answers for every new connection (a bound on their
number; CURVE keys when the server has them)."""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable

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
        max_connections: connections served at once; a new one beyond is refused (ZAP status
            400; its descriptor is closed at once and the refusal logged). A connection counts once
            the handler let it through, or once it has been open longer than a handshake may last
            (``limits.ZMQ_HANDSHAKE_SECONDS``: libzmq closes the others), until it closes: a TCP
            connection that never starts ZMTP's handshake holds no slot (:meth:`held`).
    """

    def __init__(self, curve: tuple[bytes, bytes, frozenset] | None = None,
                 max_connections: int = limits.MAX_ZMQ_CONNECTIONS):
        self.curve = curve
        self.max_connections = max_connections
        # the open connections (their descriptors, from the socket monitors' ACCEPTED and
        # DISCONNECTED) and when each was accepted
        self.open: dict[int, float] = {}
        # when the handler let a connection through, for the last handshake window: libzmq's
        # HANDSHAKE_SUCCEEDED names no descriptor, so which open connections succeeded is not known
        self._passed: deque[float] = deque()
        self.refused = 0

    def accepted(self, fd: int) -> None:
        """A connection was accepted on descriptor ``fd`` (a socket monitor's ACCEPTED event)."""
        self.open[fd] = time.monotonic()

    def closed(self, fd: int) -> None:
        """The connection on ``fd`` closed (DISCONNECTED), whether its handshake succeeded or not."""
        self.open.pop(fd, None)

    def held(self) -> int:
        """The connections that hold a slot: those open longer than a handshake may last (libzmq
        closed the rest, so theirs succeeded), and of the younger ones as many as the handler let
        through within that time (a young one that never reached the handler holds none)."""
        window = limits.ZMQ_HANDSHAKE_SECONDS + 1.0  # 1 s for the monitor's events to arrive
        start = time.monotonic() - window
        while self._passed and self._passed[0] < start:
            self._passed.popleft()
        young = sum(1 for t in self.open.values() if t >= start)
        return len(self.open) - young + min(young, len(self._passed))

    def configure(self, router: zmq.Socket) -> None:
        if self.curve is not None:
            secret, public, _ = self.curve
            router.setsockopt(zmq.CURVE_SERVER, 1)
            router.setsockopt(zmq.CURVE_SECRETKEY, secret)
            router.setsockopt(zmq.CURVE_PUBLICKEY, public)

    def answer(self, zap: zmq.Socket, events: Callable[[], None] | None = None) -> None:
        """Answer the ZAP requests waiting on ``zap``; ``events`` reads the socket monitors' events
        after each request is read (a connection's ACCEPTED is reported before its request, so
        :meth:`held` then counts it)."""
        while True:
            try:
                frames = zap.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            if events is not None:
                events()
            version, request_id = (frames + [b"", b""])[:2]
            status, text = self._decide(frames)
            zap.send_multipart([version, request_id, status, text, b"", b""])

    def _decide(self, frames: list[bytes]) -> tuple[bytes, bytes]:
        """ZAP's status and text for one request (RFC 27); a connection let through is recorded."""
        status, text = self._judge(frames)
        if status == b"200":
            self._passed.append(time.monotonic())
        return status, text

    def _judge(self, frames: list[bytes]) -> tuple[bytes, bytes]:
        if len(frames) < 6 or frames[0] != b"1.0":
            return b"500", b"bad ZAP request"
        address, mechanism = frames[3].decode(errors="replace"), frames[5]
        held = self.held()
        if held >= self.max_connections:
            self.refused += 1
            log.warning("ZMQ connection from %s refused: %d connections already (limits.MAX_ZMQ_CONNECTIONS, "
                        "at most %d here; the open-files limit)", address, held, self.max_connections)
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
