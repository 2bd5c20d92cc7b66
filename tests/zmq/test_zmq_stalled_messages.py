"""Half-received ZMQ messages (issue 84): 40 connections each stalled inside a 60 MiB frame held
+2.4 GB for as long as the attacker liked (libzmq reassembles a message whole before the server
sees any of it; no ZMTP heartbeat; 66 MiB a message, 1,000 connections: 66 GB). Now ZMTP
heartbeats close a peer that sends no whole message within ``limits.ZMQ_HEARTBEAT_*``, a message
is at most ``sockets.MAX_MESSAGE_BYTES`` (the step counter's subscriptions far less), and the
connections served at once are bounded by the memory their messages may hold.

In process: the frontend's socket thread on loopback, raw ZMTP peers (the attacker's bytes as a
program would write them), heartbeats shortened for the test."""

from __future__ import annotations

import socket
import struct
import threading

import cbor2
import pytest
import zmq

from conftest import free_port
from simx_server.base import limits
from simx_server.zmq import codec, sockets
from simx_server.zmq.frontend import Frontend


PING = b"\x04PING"  # the heartbeat's command (RFC 37), as it appears in the server's bytes


def _greeting() -> bytes:
    """ZMTP 3.0's greeting with the NULL mechanism, as a client (RFC 23)."""
    return b"\xff" + b"\0" * 8 + b"\x7f" + bytes([3, 0]) + b"NULL".ljust(20, b"\0") + b"\0" + b"\0" * 31


def _ready(socket_type: bytes) -> bytes:
    """ZMTP's READY command naming ``socket_type``."""
    body = b"\x05READY" + b"\x0bSocket-Type" + struct.pack(">I", len(socket_type)) + socket_type
    return bytes([0x04, len(body)]) + body


class RawPeer:
    """A TCP connection speaking ZMTP by hand: it can stop in the middle of a frame."""

    def __init__(self, port: int, socket_type: bytes = b"DEALER"):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=30)
        self.sock.sendall(_greeting() + _ready(socket_type))
        # the server's greeting and READY (sent once the ZAP handler let it in): a frame sent
        # before the handshake is done would be a protocol error
        self.received = b""
        while len(self.received) < 66 or len(self.received) < 66 + self.received[65]:
            data = self.sock.recv(4096)
            assert data, "the server closed the connection during the handshake"
            self.received += data

    def start_frame(self, size: int, sent: int) -> None:
        """A long frame (RFC 23) declaring ``size`` bytes, of which ``sent`` are sent (fewer if
        the server closes the connection meanwhile)."""
        try:
            self.sock.sendall(b"\x01\x00" + bytes([0x02]) + struct.pack(">Q", size))  # an empty delimiter, MORE
            self.sock.sendall(b"\0" * sent)
        except OSError:  # closed by the server already
            pass

    def closed_by_server(self, seconds: float) -> bytes | None:
        """What the server sent (its greeting, READY, PINGs) until it closed the connection, or
        None when it did not close it within ``seconds``."""
        self.sock.settimeout(seconds)
        received = self.received
        try:
            while data := self.sock.recv(65536):
                received += data
        except (TimeoutError, socket.timeout):
            return None
        except OSError:  # reset
            pass
        return received

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def frontend(monkeypatch):
    monkeypatch.setattr(limits, "ZMQ_HEARTBEAT_SECONDS", 0.3)
    monkeypatch.setattr(limits, "ZMQ_HEARTBEAT_TIMEOUT_SECONDS", 1.0)
    port = free_port()
    delivered: list = []
    front = Frontend([f"tcp://127.0.0.1:{port}"], delivered.append)
    front.open()
    front.port, front.delivered = port, delivered
    yield front
    front.close()


def test_a_peer_stalled_inside_a_frame_is_closed(frontend):
    """Before: the connection and its half-received frame stayed for good."""
    peer = RawPeer(frontend.port)
    try:
        peer.start_frame(8 << 20, 256 << 10)  # 256 KiB of a declared 8 MiB, then nothing
        received = peer.closed_by_server(30)
        assert received is not None and PING in received  # the heartbeat's PING went unanswered
    finally:
        peer.close()
    assert not [d for d in frontend.delivered if d[0] == "zmq"]  # nothing of it reached the simulation


def test_an_idle_client_answering_pings_is_kept(frontend):
    """libzmq answers the heartbeat's PINGs by itself: a client between two calls is not closed."""
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, 30000)
    monitor = sock.get_monitor_socket(zmq.EVENT_DISCONNECTED)
    sock.connect(f"tcp://127.0.0.1:{frontend.port}")
    try:
        sock.send(codec.encode_request("sim.getSimulationTime", [], "idle"))
        for _ in range(100):
            if frontend.delivered:
                break
            threading.Event().wait(0.05)
        envelope = frontend.delivered[0][1].envelope
        frontend.send(envelope, codec.encode_reply([0.0]))
        assert cbor2.loads(sock.recv()) == {"ret": [0.0]}
        # three heartbeat timeouts without a call: the connection stays
        assert not monitor.poll(int(3 * limits.ZMQ_HEARTBEAT_TIMEOUT_SECONDS * 1000))
    finally:
        monitor.close(0)
        sock.close(0)
        ctx.term()


def test_a_message_past_the_smaller_bound_closes_its_connection(frontend):
    """A message of 3 x the request bound (which the old bound, 66 MiB, read whole and
    answered) closes its connection on its header; a 16 MiB signal and a 200,000-face
    createShape, the largest calls programs make, fit the request bound."""
    ctx = zmq.Context()
    dealer = ctx.socket(zmq.DEALER)
    dealer.setsockopt(zmq.LINGER, 0)
    monitor = dealer.get_monitor_socket(zmq.EVENT_DISCONNECTED)
    dealer.connect(f"tcp://127.0.0.1:{frontend.port}")
    try:
        dealer.send_multipart([b"", b"\0" * (3 * codec.MAX_REQUEST_BYTES)], copy=False)
        assert monitor.poll(30000)  # disconnected by the server: nothing was answered, nothing kept
        assert not dealer.poll(0)
    finally:
        monitor.close(0)
        dealer.close(0)
        ctx.term()
    assert 3 * codec.MAX_REQUEST_BYTES < 66 << 20
    signal = codec.encode_request("sim.setStringSignal", ["big", b"\1" * limits.MAX_SIGNAL_BYTES], "c")
    faces = 200_000
    shape = codec.encode_request("sim.createShape", [0, 0.0, [0.5] * (3 * faces // 2), list(range(3 * faces))],
                                 "c")
    assert len(signal) <= codec.MAX_REQUEST_BYTES and len(shape) <= codec.MAX_REQUEST_BYTES


def test_the_step_counters_subscriptions_are_bounded():
    """The step counter (a PUB socket) read its subscribers' messages without a bound, and kept
    each as a subscription. Its heartbeat as served (no PING before the refusal: the bound, not
    the heartbeat, closes it)."""
    port, counter = free_port(), free_port()
    front = Frontend([f"tcp://127.0.0.1:{port}"], lambda item: None, counter_endpoints=[f"tcp://127.0.0.1:{counter}"])
    front.open()
    peer = RawPeer(counter, b"SUB")
    try:
        peer.start_frame(1 << 20, 1 << 20)  # a whole subscription of 1 MiB
        received = peer.closed_by_server(30)
        assert received is not None and PING not in received
    finally:
        peer.close()
        front.close()


def test_connections_are_bounded_by_the_memory_their_messages_may_hold():
    """1,000 connections x 66 MiB could hold 66 GB of half-received messages: the bound is what
    ZMQ_RECEIVING_MEMORY_SHARE of the memory holds in messages of the largest size."""
    gib = 1 << 30
    budget = int(limits.ZMQ_RECEIVING_MEMORY_SHARE * 8 * gib)
    assert sockets.max_connections(files=65536, memory=8 * gib) == budget // sockets.MAX_MESSAGE_BYTES
    assert sockets.max_connections(files=256, memory=512 * gib) == 128  # half the open-files limit
    assert sockets.max_connections(files=65536, memory=512 * gib) == limits.MAX_ZMQ_CONNECTIONS
    assert sockets.max_connections(files=65536, memory=gib // 4) == 16  # never fewer
    assert 0 < sockets.physical_memory() < 1 << 50
