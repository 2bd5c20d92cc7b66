"""The legacy door's intake: every request read, checked and queued in its client's queue, on
Zenoh's threads, and large requests read on a thread of their own, round robin by client, so that
Zenoh's threads stay free for every client's small requests.

Zenoh runs the query callback (:meth:`Intake.on_query`) on its few receiving threads. Reading a
request there (:meth:`Intake.read`: its payload copied out of Zenoh with ``ZBytes.to_bytes``,
decoded by msgpack, its proof checked) takes about 60 ms of CPU for 32 MiB, most of it holding
the GIL. Sixteen clients sending two 32 MiB files each kept both of Zenoh's receiving threads
reading them for 10 s, and another client's small blocking call waited for a free one (p50
0.2 s, p99 1.1-1.5 s, against 2.7 ms unloaded; issue 48 measured 1.7 s while the files were
still written on the simulation thread).

Here a request of :data:`~simx_server.base.limits.LARGE_REQUEST_BYTES` or more is only counted
on Zenoh's thread (its size is known without a copy) and queued, in its client's queue, for one
reading thread that takes the clients' queues round robin; a client's later requests follow it
there while any of its requests waits or is being read, so that its requests keep their order.
The queries waiting hold their payloads (in Zenoh's memory): at most
:data:`~simx_server.base.limits.MAX_INTAKE_BYTES` bytes of a client (its requests beyond are
answered "server busy", as its full queue would answer them) and
:data:`~simx_server.base.limits.MAX_INTAKE_BYTES_TOTAL` of all (a large request beyond, of a
client with none waiting, is read by Zenoh's thread itself, as before: the rest waits in the
network). A request larger than :data:`~simx_server.base.limits.MAX_REQUEST_BYTES` is refused
before its copy (the server's Zenoh does not even reassemble one past
:data:`~simx_server.base.limits.MAX_ZENOH_MESSAGE_BYTES`).
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict, deque
from typing import Any

import msgpack
import zenoh

from simx_wire import proof as PR
from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.base.arguments import quote
from simx_server.base.resources import trim_soon
from simx_server.legacy.replies import send_refusal
from simx_server.legacy.sessions import keep_thread_state, zenoh_thread

log = logging.getLogger("simx.server")

__all__ = ["Intake"]


class Intake:
    """Reads the legacy door's requests (:meth:`on_query`, Zenoh's callback) and queues them.

    Args:
        door: the :class:`~simx_server.legacy.server.LegacyDoor` (its ``sessions``, ``sim``,
            ``loop``, ``courier`` and ``_call_prefix``).
        large: requests of at least this many bytes are read on the intake's thread
            (limits.LARGE_REQUEST_BYTES).
        per_client, total: bytes of requests that may wait for that thread, of one client and
            of all (limits.MAX_INTAKE_BYTES, MAX_INTAKE_BYTES_TOTAL).
    """

    def __init__(self, door: Any, large: int = limits.LARGE_REQUEST_BYTES,
                 per_client: int = limits.MAX_INTAKE_BYTES, total: int = limits.MAX_INTAKE_BYTES_TOTAL):
        self.door = door
        self.large, self.per_client, self.total = large, per_client, total
        self._cond = threading.Condition()
        # client -> its requests (query, key, bytes) in their order; clients in turn order
        self._waiting: OrderedDict[str, deque[tuple[Any, str, int]]] = OrderedDict()
        self._bytes: dict[str, int] = {}  # client -> bytes waiting or being read
        self._in_work: dict[str, int] = {}  # client -> requests waiting or being read
        self._total = 0
        self._thread: threading.Thread | None = None
        self._closed = False

    # ------------------------------------------------------------ Zenoh's threads
    def on_query(self, query: zenoh.Query) -> None:
        """Zenoh's callback: read the request now, or count and queue it for the intake's thread."""
        key = str(query.key_expr)
        payload = query.payload
        size = len(payload) if payload is not None else 0  # no copy
        busy = None if size > limits.MAX_REQUEST_BYTES else self.offer(key[self.door._call_prefix:], query, key, size)
        if busy != "":
            self.read(query, key, busy)

    def offer(self, client: str, query: Any, key: str, size: int) -> str | None:
        """Take ``query`` (``size`` payload bytes, of ``client``) for the intake's thread when it is
        large or its client has requests there. Returns ``""`` when taken; None when the caller
        reads it now itself (a small request of a client with nothing there; a large one of such
        a client while the others' fill ``total``: Zenoh's thread is then held as before, which
        keeps the excess waiting in the network); else the reason it is refused: the caller
        reads it and answers each command with that (a client's requests past its
        ``per_client`` bytes, as its full queue would)."""
        with self._cond:
            pending = self._in_work.get(client, 0)
            if size < self.large and not pending:
                return None
            mine = self._bytes.get(client, 0)
            if pending and mine + size > self.per_client:
                return (f"{P.BUSY}: {mine:,} bytes of this client's requests wait to be read "
                        f"(limits.MAX_INTAKE_BYTES = {self.per_client:,}); send it again")
            if (not pending and self._total + size > self.total) or self._closed:
                return None
            self._waiting.setdefault(client, deque()).append((query, key, size))
            self._bytes[client] = mine + size
            self._in_work[client] = pending + 1
            self._total += size
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="simx-intake", daemon=True)
                self._thread.start()
            self._cond.notify()
            return ""

    def read(self, query: zenoh.Query, key: str, busy: str | None = None) -> None:
        """Read a request and queue it in its client's queue, or answer at once what cannot be
        queued (``busy``: each command is answered with it). Every query gets a reply."""
        if not getattr(zenoh_thread, "kept", False):
            keep_thread_state()
        payload = query.payload
        large = payload is not None and len(payload) >= self.large
        del payload
        try:
            self._read(query, key, busy)
        finally:
            if large:
                trim_soon()  # its buffers, Zenoh's included, given back once it is answered

    def _read(self, query: zenoh.Query, key: str, busy: str | None) -> None:
        door = self.door
        try:
            payload = query.payload
            size = len(payload) if payload is not None else 0
            if size > limits.MAX_REQUEST_BYTES:  # before its copy
                raise P.ProtocolError(f"request of {size} bytes refused: at most "
                                      f"{limits.MAX_REQUEST_BYTES} (limits.MAX_REQUEST_BYTES)")
            data = payload.to_bytes() if payload is not None else b""
            if busy and len(data) >= self.large:  # refused unread: its headers give the reply's shape
                client, count = request_head(data)
                del data, payload  # nothing of it is kept
                if client != key[door._call_prefix:]:
                    raise P.ProtocolError("the request's client id is not the one of its key (<prefix>/call/<client>)")
                t, state, scene = door.sim.stamp()
                reply = P.response(t, state, [[False, busy]] * min(count, limits.MAX_COMMANDS_PER_REQUEST),
                                   int((time.monotonic() - door.loop.started) * 1000), scene)
                log.warning("client %s: request of %d command(s) not queued: %s", client, count, busy)
                door.courier.send(key, lambda: send_refusal(query, key, reply))
                return
            client, commands, size = P.read_request(data, limits.MAX_COMMANDS_PER_REQUEST)  # size: decoded
            if client != key[door._call_prefix:]:
                raise P.ProtocolError("the request's client id is not the one of its key (<prefix>/call/<client>)")
            if door.sessions.get(client) is None and not P.valid_client_id(client):  # once per client
                raise P.ProtocolError("invalid client id: 1 to 128 characters without / * $ ? #")
            attachment = query.attachment  # the proof that the id is the sender's (simx_wire.proof)
            refused = busy or door.sessions.admit(client, (query, commands), size, data,
                                                  attachment.to_bytes() if attachment is not None else None,
                                                  any(c[0] == "Hello" for c in commands))
            if refused is None:
                return  # the simulation thread replies
            if refused.startswith((PR.UNKNOWN, PR.NOT_YOURS)):
                raise P.ProtocolError(refused)
            t, state, scene = door.sim.stamp()
            reply = P.response(t, state, [[False, refused]] * len(commands),
                               int((time.monotonic() - door.loop.started) * 1000), scene)
            log.warning("client %s: request of %d command(s) not queued: %s", client, len(commands), refused)
        except P.ProtocolError as exc:
            log.warning("malformed request on %s refused: %s", quote(key), exc)
            reply = P.error_response(str(exc))
        except Exception as exc:  # the server never dies from a client, and always answers
            log.exception("reading a request on %s", quote(key))
            reply = P.error_response(f"internal error while reading the request: {type(exc).__name__}")
        door.courier.send(key, lambda: send_refusal(query, key, reply))  # Zenoh's thread never waits on a link

    # ------------------------------------------------------------ the intake's thread
    def _next(self) -> tuple[str, Any, str, int] | None:
        """The next request to read, round robin by client (lock held); None once closed and empty."""
        while not self._waiting:
            if self._closed:
                return None
            self._cond.wait()
        client, queue = next(iter(self._waiting.items()))
        query, key, size = queue.popleft()
        del self._waiting[client]
        if queue:  # its next request waits for the other clients' turns
            self._waiting[client] = queue
        return client, query, key, size

    def _run(self) -> None:
        while True:
            with self._cond:
                item = self._next()
            if item is None:
                return
            client, query, key, size = item
            try:
                self.read(query, key)
            finally:
                with self._cond:
                    self._total -= size
                    count = self._in_work[client] - 1
                    if count:
                        self._bytes[client] -= size
                        self._in_work[client] = count
                    else:
                        del self._bytes[client], self._in_work[client]

    def close(self) -> None:
        """The server stops: the thread ends once the requests it took are read."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()


#: Bytes of a request's start that :func:`request_head` reads (its headers and a client id).
MAX_HEAD_BYTES = 4096


def request_head(payload: bytes) -> tuple[str, int]:
    """``(client, number of commands)`` of a legacy request (docs/PROTOCOL.md), read from its
    first bytes only (msgpack's headers: no command is decoded), for a request refused unread
    ("server busy": its reply needs one result per command).

    Raises:
        ProtocolError: not a request of this protocol version.
    """
    unpacker = msgpack.Unpacker()
    unpacker.feed(memoryview(payload)[:MAX_HEAD_BYTES])
    try:
        if unpacker.read_array_header() != 3 or unpacker.unpack() != P.PROTOCOL_VERSION:
            raise P.ProtocolError(f"not a simx request of version {P.PROTOCOL_VERSION}")
        client = unpacker.unpack()
        count = unpacker.read_array_header()
    except (ValueError, msgpack.OutOfData, msgpack.ExtraData, msgpack.FormatError, msgpack.StackError) as exc:
        raise P.ProtocolError(f"not a simx request: {type(exc).__name__}") from None
    if type(client) is not str:
        raise P.ProtocolError("request needs a client id (str)")
    return client, count
