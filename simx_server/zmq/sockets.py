"""libzmq's own bounds on the ZMQ remote API's sockets: what one connection may make libzmq hold
before the server sees any of it, and how many connections are served at once.

libzmq reassembles a message whole before the socket thread can read it, so the server can
neither count nor refuse the bytes of a message still arriving. What bounds them:

* ``ZMQ_MAXMSGSIZE`` (:data:`MAX_MESSAGE_BYTES`): a message declaring more closes its connection
  on its header, before any of it is kept. A request just over ``codec.MAX_REQUEST_BYTES`` is
  still read and answered with an error; the step counter's subscribers send only
  subscriptions (:data:`MAX_COUNTER_MESSAGE_BYTES`).
* ZMTP heartbeats (RFC 37: ``ZMQ_HEARTBEAT_IVL``, ``ZMQ_HEARTBEAT_TIMEOUT``): the server sends a
  PING every ``limits.ZMQ_HEARTBEAT_SECONDS``, and a connection from which no whole message
  (a PONG, a request) has come ``limits.ZMQ_HEARTBEAT_TIMEOUT_SECONDS`` after a PING is closed,
  its half-received message freed: libzmq cancels that timer only when it decodes a message,
  so a peer stalled inside a frame, or trickling one, is closed, while a client's libzmq
  answers PINGs by itself however long its program waits between calls.
* the connections served at once (:func:`max_connections`): at most
  ``limits.ZMQ_RECEIVING_MEMORY_SHARE`` of the machine's memory in messages of the largest size
  being received, besides ``limits.MAX_ZMQ_CONNECTIONS`` and half the open-files limit.
"""

from __future__ import annotations

import os
from pathlib import Path

import zmq

from simx_server.base import limits
from simx_server.zmq import codec

#: Messages libzmq reads at all; a larger one closes its connection unanswered before any of it
#: is buffered (room for a request just over codec.MAX_REQUEST_BYTES, answered with an error).
MAX_MESSAGE_BYTES = codec.MAX_REQUEST_BYTES + (1 << 20)
#: The same for the step counter's PUB socket, which reads only its subscribers' subscriptions
#: (CoppeliaSim 4.3-4.5's client subscribes to everything: one empty topic).
MAX_COUNTER_MESSAGE_BYTES = 256
#: Replies libzmq queues per connection (ZMQ_SNDHWM): a REQ client has one reply in flight; beyond,
#: replies to a peer that does not read are dropped.
ZMQ_QUEUED_MESSAGES = 16
#: Requests libzmq queues per connection for the socket thread (ZMQ_RCVHWM), besides the one it is
#: receiving: a REQ client has one in flight; while the queue is full libzmq reads no more of that
#: connection (its kernel buffers fill, then its sender waits). With 16, 8 connections pipelining
#: 60 MiB requests took the server to 3.7 GB.
ZMQ_QUEUED_REQUESTS = 1
_CGROUP_LIMIT = Path("/sys/fs/cgroup/memory.max")  # cgroup v2: the memory this process may use


def bound(sock: zmq.Socket, max_message: int) -> None:
    """Set the bounds every socket of the door has: no linger, ``max_message`` bytes a message,
    ZMTP's handshake within ``limits.ZMQ_HANDSHAKE_SECONDS``, heartbeats, the ZAP domain."""
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.MAXMSGSIZE, max_message)
    sock.setsockopt(zmq.HANDSHAKE_IVL, int(limits.ZMQ_HANDSHAKE_SECONDS * 1000))
    sock.setsockopt(zmq.HEARTBEAT_IVL, int(limits.ZMQ_HEARTBEAT_SECONDS * 1000))
    sock.setsockopt(zmq.HEARTBEAT_TIMEOUT, int(limits.ZMQ_HEARTBEAT_TIMEOUT_SECONDS * 1000))
    sock.setsockopt(zmq.ZAP_DOMAIN, b"simx")


def physical_memory() -> int:
    """Bytes of memory this process may use: the machine's, or its cgroup's limit when lower."""
    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    try:
        text = _CGROUP_LIMIT.read_text().strip()
    except OSError:
        return int(total)
    return int(min(total, int(text))) if text.isdigit() else int(total)


def max_connections(files: int, memory: int | None = None) -> int:
    """ZMQ connections served at once: ``limits.MAX_ZMQ_CONNECTIONS``, at most half of ``files``
    (the open-files limit: Zenoh's clients need descriptors too) and at most as many messages of
    :data:`MAX_MESSAGE_BYTES` as ``limits.ZMQ_RECEIVING_MEMORY_SHARE`` of ``memory`` (bytes,
    default :func:`physical_memory`) holds; never fewer than 16."""
    memory = physical_memory() if memory is None else memory
    receiving = int(limits.ZMQ_RECEIVING_MEMORY_SHARE * memory) // MAX_MESSAGE_BYTES
    return max(16, min(limits.MAX_ZMQ_CONNECTIONS, files // 2, receiving))
