"""V-REP 3.x's tubes: in-process message pipes between scripts (``simTubeOpen``,
``simTubeWrite``, ``simTubeRead``, ``simTubeStatus``, ``simTubeClose``).

A tube is V-REP's full-duplex pipe between two scripts of the same simulator: two
``simTubeOpen(dataHeader, dataName, readBufferSize)`` calls with the same header and name open
the two ends of one tube (a third opens a new, unconnected tube). Each end has its own handle
and its own read buffer of at most ``readBufferSize`` packets (the oldest is dropped when it is
full); ``simTubeWrite`` on one end puts a packet into the other end's read buffer when the tube
is connected (the packet is lost otherwise, and the call answers -1), ``simTubeRead`` takes the
oldest packet of its own buffer (nil when there is none; ``blockingOperation`` true in a
threaded script: yields until one arrives). Tubes opened by scripts during a simulation close
when it stops, as V-REP's do.

The ``sim.tube*`` functions here open and use them; :class:`Tubes` is the registry, one per
scene's scripts (kept in their shared dictionary).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_text as _text

__all__ = ["Tubes"]

#: Packets one end may buffer at most, whatever ``readBufferSize`` asks (bounds the server's memory).
MAX_BUFFERED = 10_000
#: Bytes one packet may hold at most.
MAX_PACKET = 1 << 20


@dataclass
class _End:
    key: tuple[int, str]
    size: int
    buffer: deque = field(default_factory=deque)
    peer: int = -1  # handle of the other end, -1 while unconnected


class Tubes:
    """The open tubes of one scene's scripts: handles -> ends."""

    def __init__(self) -> None:
        self.ends: dict[int, _End] = {}
        self._next = 1

    def open(self, header: int, name: str, size: int) -> int:
        key = (header, name)
        waiting = next((h for h, e in self.ends.items() if e.key == key and e.peer == -1), None)
        handle, self._next = self._next, self._next + 1
        self.ends[handle] = _End(key, size)
        if waiting is not None:
            self.ends[handle].peer, self.ends[waiting].peer = waiting, handle
        return handle

    def close(self, handle: int) -> None:
        e = self.ends.pop(handle)
        if e.peer in self.ends:
            self.ends[e.peer].peer = -1

    def clear(self) -> None:
        self.ends.clear()


# ``sim.tubeOpen`` & co. (V-REP 3.x's ``simTube*``), for Lua and Python scripts.

def _tubes(ctx: CallContext) -> Tubes:
    me = ctx.script
    shared = me.shared if me is not None else ctx.state.own_shared
    return shared.setdefault("tubes", Tubes())


@sim_function("tubeOpen")
def tubeOpen(ctx: CallContext, dataHeader: Any, dataName: Any, readBufferSize: Any) -> int:  # noqa: N802, N803
    """Open one end of the tube ``(dataHeader, dataName)``: connected to an end already
    opened with the same header and name that has no partner yet, else waiting for one.
    ``readBufferSize``: packets this end keeps unread (at least 1, at most MAX_BUFFERED).
    Returns the end's handle."""
    header, name = _int(dataHeader, "dataHeader"), _text(dataName, "dataName")
    size = min(max(1, _int(readBufferSize, "readBufferSize")), MAX_BUFFERED)
    return _tubes(ctx).open(header, name, size)


@sim_function("tubeClose")
def tubeClose(ctx: CallContext, tubeHandle: Any) -> int:  # noqa: N802, N803
    """Close an end (its unread packets go; the other end becomes unconnected). Returns 1,
    or -1 for a tube that does not exist (V-REP's answer)."""
    tubes = _tubes(ctx)
    h = _int(tubeHandle, "tubeHandle")
    if h not in tubes.ends:
        return -1
    tubes.close(h)
    return 1


@sim_function("tubeWrite")
def tubeWrite(ctx: CallContext, tubeHandle: Any, data: Any) -> int:  # noqa: N802, N803
    """Send ``data`` (bytes) to the other end's read buffer; returns 1, or -1 when the tube
    is not connected (the packet is lost, as in V-REP) or does not exist."""
    tubes = _tubes(ctx)
    e = tubes.ends.get(_int(tubeHandle, "tubeHandle"))
    raw = _bytes(data, "data")
    if len(raw) > MAX_PACKET:
        raise ArgumentError(f"tubeWrite: a packet of {len(raw)} bytes; at most {MAX_PACKET}")
    peer = tubes.ends.get(e.peer) if e is not None else None
    if peer is None:
        return -1
    peer.buffer.append(raw)
    while len(peer.buffer) > peer.size:
        peer.buffer.popleft()
    return 1


@sim_function("tubeRead")
def tubeRead(ctx: CallContext, tubeHandle: Any, blockingOperation: Any = False) -> bytes | None:  # noqa: N802, N803
    """The oldest unread packet of this end, nil when there is none or the tube does not
    exist (V-REP's answers). With ``blockingOperation`` in a threaded script, yields until a
    packet arrives (Lua threads: :data:`~simx_server.scripts.threads.THREADS_LUA`; Python
    threads here)."""
    e = _tubes(ctx).ends.get(_int(tubeHandle, "tubeHandle"))
    if e is None:
        return None
    if blockingOperation and not e.buffer:
        thread = getattr(ctx.script, "py_thread", None)
        if thread is not None and thread.in_thread():
            while not e.buffer:
                thread.switch()
    return e.buffer.popleft() if e.buffer else None


@sim_function("tubeStatus")
def tubeStatus(ctx: CallContext, tubeHandle: Any) -> tuple[int, int, int]:  # noqa: N802, N803
    """``(status, readPacketsCount, writePacketsCount)``: status -1 for no such tube, 0 not
    connected, 1 connected; the packets waiting in this end's buffer, and in the other's."""
    tubes = _tubes(ctx)
    e = tubes.ends.get(_int(tubeHandle, "tubeHandle"))
    if e is None:
        return -1, 0, 0
    peer = tubes.ends.get(e.peer)
    return (1 if peer is not None else 0), len(e.buffer), len(peer.buffer) if peer is not None else 0


