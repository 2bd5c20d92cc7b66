"""The ZMQ door's large requests, decoded on a thread of their own (issue 57).

A request of :data:`~simx_server.base.limits.LARGE_REQUEST_BYTES` or more is not decoded on the
socket thread: decoding 60 MiB took it 0.1-0.5 s, during which it read no other connection's
request (8 connections pipelining 60 MiB requests kept another client waiting 9 s). The socket
thread counts it as pending (its connection's one request in work, and its bytes against
``limits.MAX_QUEUED_BYTES_TOTAL``) and hands it here; this thread decodes the requests one after
the other (:func:`~simx_server.zmq.codec.read_request`, whose large strings are copied with the
GIL released) and hands each to the simulation thread, or its refusal back to the socket thread.
Once a request's message is released, glibc's free memory is given back
(:func:`~simx_server.base.resources.trim_soon`).
"""

from __future__ import annotations

import logging
import queue
import threading
from typing import Callable

import zmq

from simx_wire.protocol import ProtocolError
from simx_server.base.resources import trim_soon
from simx_server.zmq import codec

log = logging.getLogger("simx.zmq")


class LargeRequests:
    """The intake thread (``simx-zmq-intake``, made on the first large request).

    Args:
        decoded: called on this thread with ``(envelope, request, fd, size)`` for a request read.
        refused: called on this thread with ``(envelope, message, version)`` for a request refused
            (``version``: its protocol version, None when not known).
    """

    def __init__(self, decoded: Callable[[list, codec.Request, int, int], None],
                 refused: Callable[[list, str, int | None], None]):
        self._decoded, self._refused = decoded, refused
        self._queue: queue.SimpleQueue = queue.SimpleQueue()  # (envelope, frame, fd, size); None: stop
        self._thread: threading.Thread | None = None
        self._closed = False

    def take(self, envelope: list, frame: zmq.Frame, fd: int, size: int) -> None:
        """Queue a large request (its message ``frame``, of ``size`` bytes, already counted as pending)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="simx-zmq-intake", daemon=True)
            self._thread.start()
        self._queue.put((envelope, frame, fd, size))

    def close(self) -> None:
        """The server stops: the thread ends at its next request (those waiting are dropped)."""
        self._closed = True
        self._queue.put(None)

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is None or self._closed:
                return
            envelope, frame, fd, size = item
            try:
                request = codec.read_request(frame.buffer)
            except ProtocolError as exc:
                log.warning("ZMQ request refused: %s", exc)
                self._refused(envelope, str(exc), getattr(exc, "version", None))
                continue
            except Exception as exc:  # the server never dies from a client
                log.exception("reading a ZMQ request")
                self._refused(envelope, f"internal error while reading the request: {type(exc).__name__}", None)
                continue
            finally:
                del frame, item  # the message's buffer goes back to libzmq (and the system) now
                trim_soon()
            self._decoded(envelope, request, fd, size)
