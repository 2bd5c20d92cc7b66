"""The ZMQ socket thread: CoppeliaSim's ZMQ remote API on a ROUTER socket, nothing of MuJoCo.

A client's ``REQ`` socket sends one request and waits for its reply. simx binds a ``ROUTER``
socket (the REQ's peer that may answer out of order), so that a request waiting for a simulation
step holds only its own client. One thread, ``simx-zmq``, owns the socket (ZMQ sockets belong to
one thread); it reads each request, checks it (:func:`~simx_server.zmq.codec.read_request`: size,
nesting, shape), answers at once what it refuses, and hands the rest to the simulation thread
through the server's ready ring, as Zenoh's threads do (docs/ARCHITECTURE.md). Replies come back
from the simulation thread through :meth:`Frontend.send`: a queue and a wake-up pipe, so that any
thread may reply without touching the socket.

Bounds (clients are untrusted): messages over ``sockets.MAX_MESSAGE_BYTES`` are dropped by libzmq
with their connection, and a connection that sends no whole message within the ZMTP heartbeat's
timeout is closed (:mod:`simx_server.zmq.sockets`); requests over ``codec.MAX_REQUEST_BYTES`` are
answered with an error;
one request at a time per connection (a REQ socket never sends two); at most
``limits.MAX_CLIENTS`` requests and ``limits.MAX_QUEUED_BYTES_TOTAL`` bytes waiting for the
simulation thread, beyond which a request is answered "server busy". A socket monitor tells
which connection closed (its file descriptor), so the simulation thread can forget its client.

Per connection (issue 29): replies not yet taken by the kernel are counted by their bytes
(libzmq's message trackers), and a connection past ``limits.MAX_ZMQ_UNSENT_BYTES`` (or any
connection with unsent replies while all together pass ``MAX_ZMQ_UNSENT_BYTES_TOTAL``) gets
"server busy" for its next request instead of another large reply (a reply still rendering
counts from its call on: :meth:`Frontend.reserve`); libzmq queues at most
``ZMQ_QUEUED_MESSAGES`` replies and ``ZMQ_QUEUED_REQUESTS`` request per connection, and large
requests are decoded on a thread of their own (:mod:`simx_server.zmq.intake`). Every new connection passes the ZAP
handler (:class:`Gate`) on this thread: beyond ``max_connections`` connections let through (or
open longer than a handshake lasts) it is refused (its descriptor closed at once), and with CURVE
keys only the authorised clients' public keys pass. A connection that does not finish its
handshake within ``limits.ZMQ_HANDSHAKE_SECONDS`` is closed by libzmq and never held a slot.

Protocol version 1 (CoppeliaSim 4.3-4.5's client, issue 43) is served beside version 2: the
frontend tells each request's version (:func:`~simx_server.zmq.codec.read_request`), names a
version-1 client by its connection (its requests carry no uuid), and sends it its replies in
version 1's shape (:func:`~simx_server.zmq.codec.to_version_1`). That client's ``client.step()``
then waits for a message on a second socket, a PUB on the port after the main one (CoppeliaSim's
``cntPort``): the reply to its step is preceded by one (:meth:`Frontend.send`, ``publish``).
"""

from __future__ import annotations

import logging
import os
import queue
import struct
import threading
from typing import Any, Callable

import zmq
import zmq.utils.monitor

from simx_wire.protocol import ProtocolError
from simx_server.base import job_ring, limits
from simx_server.zmq import codec
from simx_server.zmq.gate import Gate
from simx_server.zmq.intake import LargeRequests
from simx_server.zmq.sockets import (MAX_COUNTER_MESSAGE_BYTES, MAX_MESSAGE_BYTES, ZMQ_QUEUED_MESSAGES,
                                     ZMQ_QUEUED_REQUESTS, bound)

log = logging.getLogger("simx.zmq")

#: Replies of at least this many bytes are sent with a tracker, so their bytes count until the
#: kernel has them; smaller ones are bounded by ZMQ_QUEUED_MESSAGES.
TRACKED_BYTES = 64 * 1024
_ZAP_ENDPOINT = "inproc://zeromq.zap.01"
#: What the socket monitors report: which connections are open (their descriptors), for the
#: gate's bound (Gate.held) and to forget the clients of a closed one. libzmq's HANDSHAKE_SUCCEEDED
#: carries no descriptor (its value is 0), so it cannot say which connection succeeded.
_COUNTED_EVENTS = zmq.EVENT_ACCEPTED | zmq.EVENT_DISCONNECTED
#: The uuid of a version-1 client (which sends none) is this and its connection's routing id in hex.
VERSION_1_PREFIX = codec.VERSION_1_UUID_PREFIX
#: Where clients connect unless told otherwise (CoppeliaSim's default port).
DEFAULT_PORT = 23000
_POLL_MS = 200  # the thread checks for close() at least this often
_AWAIT_REPLY_S = 0.001  # s the socket thread waits on the reply queue after handing a request over
# pyzmq's flags and options as plain ints: each operation on its enum.Flag members costs
# microseconds on the per-request path (two or three per request).
_NOBLOCK, _SNDMORE_NOBLOCK = int(zmq.NOBLOCK), int(zmq.SNDMORE | zmq.NOBLOCK)
_RCVMORE, _EVENTS, _POLLIN, _SRCFD = int(zmq.RCVMORE), int(zmq.EVENTS), int(zmq.POLLIN), int(zmq.SRCFD)


def _recv_frames(router: zmq.Socket) -> list[zmq.Frame]:
    """The parts of one message, without waiting (raises zmq.Again when none is there):
    ``recv_multipart`` with plain-int flags."""
    frames = [router.recv(_NOBLOCK, copy=False)]
    while router.getsockopt(_RCVMORE):
        frames.append(router.recv(_NOBLOCK, copy=False))
    return frames


def _send_small(router: zmq.Socket, envelope: list, payload: bytes) -> None:
    """``send_multipart(envelope + [payload], NOBLOCK)``, copied, with plain-int flags."""
    for part in envelope:
        router.send(part, _SNDMORE_NOBLOCK)
    router.send(payload, _NOBLOCK)


class Incoming:
    """A request handed to the simulation thread: reply to ``envelope``; ``fd`` is its
    connection's file descriptor, ``size`` its bytes."""

    __slots__ = ("envelope", "request", "fd", "size")

    def __init__(self, envelope: list, request: codec.Request, fd: int, size: int):
        self.envelope, self.request, self.fd, self.size = envelope, request, fd, size


class Frontend:
    """The ROUTER socket and its thread.

    Args:
        endpoints: ZMQ endpoints to bind (``tcp://127.0.0.1:23000``).
        deliver: called on the socket thread with ``("zmq", Incoming)`` or ``("zmq-gone", fd)``
            (the server's ready ring's ``put``); must not block.
        serve: called on the socket thread with ``("zmq", Incoming)`` for a request that
            ``in_place`` accepts: the loop serves it on this thread when the simulation thread
            waits for work, else puts it in the ring (``Loop.serve_or_deliver``); its reply is
            sent at once, without a wake-up of this thread. None: ``deliver``.
        in_place: which requests ``serve`` gets (quick calls: not a scene load or edit, which
            would hold the socket thread as long as they take).

    Raises (from :meth:`open`): zmq.ZMQError when an endpoint cannot be bound.
    """

    def __init__(self, endpoints: list[str], deliver: Callable[[Any], None], gate: Gate | None = None,
                 serve: Callable[[Any], None] | None = None,
                 in_place: Callable[[codec.Request], bool] = lambda request: True,
                 counter_endpoints: list[str] | tuple[str, ...] = ()):
        self.endpoints = list(endpoints)
        #: Where the step counter of version-1 clients is published (the main port + 1); those
        #: bound (:meth:`open`; one that cannot be bound is logged and left out).
        self.counter_endpoints, self.counter_bound = list(counter_endpoints), []
        self._counter: zmq.Socket | None = None
        self._counter_monitor: zmq.Socket | None = None  # its connections count toward the gate's bound
        self._versions: dict[bytes, tuple[int, int]] = {}  # identity -> (fd, protocol version) of its requests
        self._deliver = deliver
        self._serve = serve if serve is not None else deliver
        self._in_place = in_place
        self.gate = gate if gate is not None else Gate()
        self._unsent: dict[bytes, int] = {}  # identity -> bytes of its tracked replies not sent yet
        self._unsent_total = 0
        # identity -> bytes held for replies still rendering (reserve, sent or release); any thread
        self._rendering: dict[bytes, int] = {}
        self._rendering_total = 0
        self._rendering_lock = threading.Lock()
        self._trackers: list[tuple[zmq.MessageTracker, bytes, int]] = []
        self._ctx: zmq.Context | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._replies: queue.SimpleQueue = queue.SimpleQueue()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_r, False)
        os.set_blocking(self._wake_w, False)
        self._large = LargeRequests(self._decoded, self._refuse_large)  # decoded on a thread of its own
        self._pending: dict[bytes, tuple[int, int]] = {}  # identity -> (fd, bytes) of its request in work
        self._pending_bytes = 0
        # True while the socket thread waits on the reply queue (see _await_reply): replies then
        # need no wake-up through the pipe
        self._awaiting = False
        self.bound: list[str] = []

    # ----------------------------------------------------------------- any thread
    def open(self) -> None:
        """Bind the socket and start the thread."""
        ctx = self._ctx = zmq.Context()
        zap = ctx.socket(zmq.REP)  # the ZAP handler of this context: bound before any listener
        zap.setsockopt(zmq.LINGER, 0)
        zap.bind(_ZAP_ENDPOINT)
        router = ctx.socket(zmq.ROUTER)
        bound(router, MAX_MESSAGE_BYTES)  # heartbeats, the handshake's time, the largest message
        router.setsockopt(zmq.SNDHWM, ZMQ_QUEUED_MESSAGES)
        router.setsockopt(zmq.RCVHWM, ZMQ_QUEUED_REQUESTS)
        self.gate.configure(router)
        monitor = router.get_monitor_socket(_COUNTED_EVENTS)
        try:
            for endpoint in self.endpoints:
                router.bind(endpoint)
                self.bound.append(router.getsockopt(zmq.LAST_ENDPOINT).decode())
        except zmq.ZMQError:
            monitor.close(0)
            router.close(0)
            zap.close(0)
            ctx.term()
            self._ctx = None
            raise
        self._open_counter(ctx)
        self._thread = threading.Thread(target=self._run, args=(router, monitor, zap), name="simx-zmq", daemon=True)
        self._thread.start()

    def _open_counter(self, ctx: zmq.Context) -> None:
        """Bind the PUB socket of version 1's step counter (CoppeliaSim 4.3-4.5's add-on: ``cntSocket``,
        conflated); an endpoint in use is logged, and version-1 clients cannot step without one."""
        if not self.counter_endpoints:
            return
        pub = self._counter = ctx.socket(zmq.PUB)
        bound(pub, MAX_COUNTER_MESSAGE_BYTES)  # it reads only subscriptions
        pub.setsockopt(zmq.CONFLATE, 1)
        self.gate.configure(pub)
        self._counter_monitor = pub.get_monitor_socket(_COUNTED_EVENTS)
        for endpoint in self.counter_endpoints:
            try:
                pub.bind(endpoint)
                self.counter_bound.append(pub.getsockopt(zmq.LAST_ENDPOINT).decode())
            except zmq.ZMQError as exc:
                log.warning("ZMQ step counter of CoppeliaSim 4.3-4.5's clients not served on %s (%s): their "
                            "client.step() cannot be served (the port after --zmq-port must be free)", endpoint,
                            exc.strerror)

    def send(self, envelope: list, payload: bytes, held: int = 0, publish: int | None = None) -> None:
        """Reply ``payload`` to the request of ``envelope`` (thread-safe; never blocks); ``held``:
        the bytes :meth:`reserve` held for it, given back once the reply is counted as unsent;
        ``publish``: a step count to publish on the counter socket first (a version-1 step's reply)."""
        self._replies.put((envelope, payload, held, publish))
        if self._awaiting:  # the socket thread waits on the queue itself: the put woke it
            return
        try:
            os.write(self._wake_w, b"\0")
        except BlockingIOError:  # the pipe is full of wake-ups already: the thread is awake
            pass
        except OSError:  # closed: the server stops, replies are dropped
            pass

    def reserve(self, identity: bytes, size: int) -> str | None:
        """Hold ``size`` bytes for a reply that renders (thread-safe): it counts toward the
        unread-reply bounds of its connection (``limits.MAX_ZMQ_UNSENT_BYTES``) and of all
        (``limits.MAX_ZMQ_UNSENT_BYTES_TOTAL``) until it is sent (:meth:`send` with ``held``) or given
        back (:meth:`release`). Why it is refused ("server busy: ..."), or None when held."""
        if not size:
            return None
        with self._rendering_lock:
            own = self._unsent.get(identity, 0) + self._rendering.get(identity, 0)
            total = self._unsent_total + self._rendering_total
            if own + size > limits.MAX_ZMQ_UNSENT_BYTES or total + size > limits.MAX_ZMQ_UNSENT_BYTES_TOTAL:
                return (f"server busy: not executed: its reply of about {size} bytes would pass the bytes of replies "
                        f"not read yet ({own} of this connection's, {total} of all connections' rendering or "
                        f"unsent; limits.MAX_ZMQ_UNSENT_BYTES {limits.MAX_ZMQ_UNSENT_BYTES}, "
                        f"MAX_ZMQ_UNSENT_BYTES_TOTAL {limits.MAX_ZMQ_UNSENT_BYTES_TOTAL}); try again later")
            self._rendering[identity] = self._rendering.get(identity, 0) + size
            self._rendering_total += size
        return None

    def release(self, identity: bytes, size: int) -> None:
        """Give back bytes :meth:`reserve` held (thread-safe)."""
        if not size:
            return
        with self._rendering_lock:
            left = self._rendering.get(identity, 0) - size
            if left > 0:
                self._rendering[identity] = left
            else:
                self._rendering.pop(identity, None)
            self._rendering_total -= size

    def expects(self, identity: bytes) -> bool:
        """Whether the connection of ``identity`` still waits for the reply to its request (it
        has not closed meanwhile); any thread."""
        return identity in self._pending

    def close(self) -> None:
        """Stop the thread and close the socket (replies not yet sent are dropped); idempotent."""
        self._stop.set()
        self.send([], b"")  # wake the thread
        self._large.close()
        if self._thread is not None:
            self._thread.join(5)
            self._thread = None
        if self._ctx is not None:
            self._ctx.term()
            self._ctx = None
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass
        self._wake_r = self._wake_w = -1

    # --------------------------------------------------------------- socket thread
    def _run(self, router: zmq.Socket, monitor: zmq.Socket, zap: zmq.Socket) -> None:
        poller = zmq.Poller()
        poller.register(monitor, zmq.POLLIN)  # first: a closed connection is seen before a new one's request
        poller.register(zap, zmq.POLLIN)
        poller.register(router, zmq.POLLIN)
        poller.register(self._wake_r, zmq.POLLIN)
        counted = self._counter_monitor
        if counted is not None:
            poller.register(counted, zmq.POLLIN)
        try:
            while not self._stop.is_set():
                events = dict(poller.poll(_POLL_MS))
                if monitor in events:
                    self._on_monitor(monitor)
                if counted is not None and counted in events:
                    self._on_monitor(counted, counter=True)
                if zap in events:
                    self.gate.answer(zap, lambda: self._on_monitor(monitor, others=counted))
                if self._trackers:
                    self._count_sent()
                if self._wake_r in events:
                    self._flush_replies(router)
                if router in events:
                    for _ in range(64):  # then look at the replies again
                        try:
                            frames = _recv_frames(router)
                        except zmq.Again:
                            break
                        self._on_message(router, frames)
                        if not router.getsockopt(_EVENTS) & _POLLIN:
                            break  # nothing more to read: no zmq.Again raised (a few µs a call)
                    if self._pending and not router.getsockopt(_EVENTS) & _POLLIN:
                        self._await_reply(router)
        except Exception:  # never reached by a client's input; log it, the server goes on without ZMQ
            log.exception("the ZMQ remote API thread failed; ZMQ clients are no longer served")
        finally:
            monitor.close(0)
            router.close(0)
            zap.close(0)
            for sock in (self._counter_monitor, self._counter):
                if sock is not None:
                    sock.close(0)

    def _on_monitor(self, monitor: zmq.Socket, counter: bool = False, others: zmq.Socket | None = None) -> None:
        """Tell the gate which connections opened and closed (``counter``: the step counter's;
        ``others``: the step counter's monitor, read first), and the simulation thread which
        request connection closed."""
        if others is not None:
            self._on_monitor(others, counter=True)
        while True:
            try:
                event = zmq.utils.monitor.recv_monitor_message(monitor, zmq.NOBLOCK)
            except zmq.Again:
                return
            if event["event"] == zmq.EVENT_ACCEPTED:
                self.gate.accepted(int(event["value"]))
            elif event["event"] == zmq.EVENT_DISCONNECTED:
                fd = int(event["value"])
                self.gate.closed(fd)
                if counter:  # a subscriber of the step counter: no request, no client
                    continue
                for identity in [i for i, (f, _) in self._pending.items() if f == fd]:
                    self._done(identity)
                for identity in [i for i, (f, _) in list(self._versions.items()) if f == fd]:  # (the intake thread adds)
                    self._versions.pop(identity, None)
                    job_ring.cancel_all(identity)  # its long calls not started: nobody reads their replies
                self._deliver(("zmq-gone", fd))

    def _await_reply(self, router: zmq.Socket) -> None:
        """Wait up to :data:`_AWAIT_REPLY_S` on the reply queue itself for the reply of a request
        just handed over, and send it: most calls are answered within it, and a reply put on the
        queue wakes this thread at once, where the pipe and the poller take another wake-up of
        each thread (about 0.1 ms a call on 2 loaded cores). Requests arriving meanwhile wait at
        most that long."""
        self._awaiting = True
        try:
            item = self._replies.get(timeout=_AWAIT_REPLY_S)
        except queue.Empty:
            item = None
        finally:
            self._awaiting = False  # from here on a reply writes the pipe again
        if item is not None:
            self._replies.put(item)  # sent in order with any others below
        self._flush_replies(router)

    def _flush_replies(self, router: zmq.Socket) -> None:
        try:
            os.read(self._wake_r, 65536)
        except BlockingIOError:
            pass
        self._send_replies(router)

    def _send_replies(self, router: zmq.Socket) -> None:
        while True:
            try:
                envelope, payload, held, publish = self._replies.get_nowait()
            except queue.Empty:
                return
            if not envelope:
                continue
            self._done(envelope[0])
            self.release(envelope[0], held)  # counted as unsent below, if the kernel does not take it at once
            if self._versions.get(envelope[0], (0, 0))[1] == codec.VERSION_1:
                payload = codec.to_version_1(payload)
                if publish is not None and self._counter is not None:  # before the reply: client.step() reads it after
                    try:
                        self._counter.send(struct.pack("<I", publish & 0xFFFFFFFF), _NOBLOCK)
                    except zmq.ZMQError as exc:
                        log.debug("ZMQ step count not published: %s", exc)
            try:
                if len(payload) < TRACKED_BYTES:  # copied: cheaper than a zero-copy Frame per part
                    _send_small(router, envelope, payload)
                    continue
                tracker = router.send_multipart([*envelope, payload], zmq.NOBLOCK, copy=False, track=True)
            except zmq.ZMQError as exc:  # the peer went, or its queue is full: its reply is lost
                log.debug("ZMQ reply not sent: %s", exc)
                continue
            if tracker is not None and not tracker.done:
                identity, size = envelope[0], len(payload)
                self._trackers.append((tracker, identity, size))
                self._unsent[identity] = self._unsent.get(identity, 0) + size
                self._unsent_total += size

    def _count_sent(self) -> None:
        """Forget the tracked replies the kernel has taken (libzmq released their buffers)."""
        kept = []
        for entry in self._trackers:
            tracker, identity, size = entry
            if not tracker.done:
                kept.append(entry)
                continue
            self._unsent_total -= size
            left = self._unsent.get(identity, 0) - size
            if left > 0:
                self._unsent[identity] = left
            else:
                self._unsent.pop(identity, None)
        self._trackers = kept

    def _done(self, identity: bytes) -> None:
        entry = self._pending.pop(identity, None)
        if entry is not None:
            self._pending_bytes -= entry[1]

    def _answer(self, router: zmq.Socket, envelope: list, message: str, version: int | None) -> None:
        """Send the error ``message`` in the shape of protocol ``version`` (None: unknown, both)."""
        payload = codec.encode_error(message, version)
        try:
            _send_small(router, envelope, payload)
        except zmq.ZMQError as exc:
            log.debug("ZMQ reply not sent: %s", exc)

    def _on_message(self, router: zmq.Socket, frames: list) -> None:
        """Read one request: refuse it at once, or hand it to the simulation thread."""
        if len(frames) < 2:
            return  # not a request (no identity frame): nothing to answer to
        envelope = [f.bytes for f in frames[:-1]]
        data = frames[-1].buffer
        identity = envelope[0]
        try:
            fd = int(frames[-1].get(_SRCFD))
        except (zmq.ZMQError, ValueError, TypeError):
            fd = -1
        size = len(data)
        try:
            if identity in self._pending:
                raise ProtocolError("one request at a time: a request of this connection is still waiting for "
                                    "its reply (a REQ socket sends the next after the reply)")
            if len(self._pending) >= limits.MAX_CLIENTS:
                raise ProtocolError(f"server busy: {len(self._pending)} requests are waiting (limits.MAX_CLIENTS); "
                                    "try again later")
            unsent = self._unsent.get(identity, 0) if self._unsent else 0
            if unsent and self._trackers:
                self._count_sent()
                unsent = self._unsent.get(identity, 0)
            over_total = unsent and self._unsent_total + self._rendering_total > limits.MAX_ZMQ_UNSENT_BYTES_TOTAL
            if unsent > limits.MAX_ZMQ_UNSENT_BYTES or over_total:
                raise ProtocolError(f"server busy: {unsent} bytes of this connection's earlier replies are not read "
                                    f"yet ({self._unsent_total} of all connections; limits.MAX_ZMQ_UNSENT_BYTES "
                                    f"{limits.MAX_ZMQ_UNSENT_BYTES}, MAX_ZMQ_UNSENT_BYTES_TOTAL "
                                    f"{limits.MAX_ZMQ_UNSENT_BYTES_TOTAL}); read them first")
            if self._pending_bytes + size > limits.MAX_QUEUED_BYTES_TOTAL:
                raise ProtocolError(f"server busy: {self._pending_bytes} bytes of requests are waiting "
                                    "(limits.MAX_QUEUED_BYTES_TOTAL); try again later")
            if size >= limits.LARGE_REQUEST_BYTES:  # decoded on the intake thread: this one keeps reading
                self._pending[identity] = (fd, size)
                self._pending_bytes += size
                self._large.take(envelope, frames[-1], fd, size)
                return
            request = codec.read_request(bytes(data) if size <= 4096 else data)
        except ProtocolError as exc:  # in the shape of its version, else its connection's last one
            log.warning("ZMQ request refused: %s", exc)
            version = getattr(exc, "version", None) or self._versions.get(identity, (0, None))[1]
            self._answer(router, envelope, str(exc), version)
            return
        except Exception as exc:  # the server never dies from a client
            log.exception("reading a ZMQ request")
            self._answer(router, envelope, f"internal error while reading the request: {type(exc).__name__}",
                         self._versions.get(identity, (0, None))[1])
            return
        self._versions[identity] = (fd, request.version)
        if request.version == codec.VERSION_1:  # no uuid: the client is its connection
            request.uuid = f"{VERSION_1_PREFIX}{identity.hex()}"
        self._pending[identity] = (fd, size)
        self._pending_bytes += size
        if not self._in_place(request):
            self._deliver(("zmq", Incoming(envelope, request, fd, size)))
            return
        # Served here when the simulation thread waits for work: its reply, put on the queue
        # meanwhile, is sent below without a wake-up through the pipe (as while awaiting).
        self._awaiting = True
        try:
            self._serve(("zmq", Incoming(envelope, request, fd, size)))
        finally:
            self._awaiting = False
        if not self._replies.empty():
            self._send_replies(router)

    # ----------------------------------------------------------------- intake thread
    def _decoded(self, envelope: list, request: codec.Request, fd: int, size: int) -> None:
        """A large request decoded (:class:`LargeRequests`' thread): hand it to the simulation thread."""
        identity = envelope[0]
        self._versions[identity] = (fd, request.version)
        if request.version == codec.VERSION_1:
            request.uuid = f"{VERSION_1_PREFIX}{identity.hex()}"
        self._deliver(("zmq", Incoming(envelope, request, fd, size)))

    def _refuse_large(self, envelope: list, message: str, version: int | None) -> None:
        """A large request refused (:class:`LargeRequests`' thread): the socket thread sends it."""
        version = version or self._versions.get(envelope[0], (0, None))[1]
        self.send(envelope, codec.encode_error(message, version))
