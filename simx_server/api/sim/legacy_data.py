"""V-REP 3.x script calls with no CoppeliaSim 4.x twin, of data rather than scripts: custom data
blocks, 16/32-bit boolean helpers, system time and ``simExtRemoteApiStart``.

:class:`RemoteApiPorts` is what the server's legacy transport reads the ports that scripts ask
for from.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError
from simx_server.base import limits as L
from simx_server.api.sim.objects import HANDLE_SCENE
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_text as _text

log = logging.getLogger("simx.scripts")

_MAX_CUSTOM_DATA = 1 << 20  # bytes of one custom data block (limits of the scene's own store)


class RemoteApiPorts:
    """Ports scripts asked the legacy remote API to serve (``simExtRemoteApiStart(port)``).

    ``sim.remoteApiStart`` & co. record requests (:meth:`request`); the transport takes them
    (:meth:`take`) on its own thread and says which ports it serves (:attr:`served`)."""

    def __init__(self) -> None:
        self.pending: list[int] = []
        self.served: set[int] = set()

    def request(self, port: int) -> None:
        """Ask for ``port`` to be served (ignored when it is served or asked for already); at
        most limits.MAX_SCRIPT_PORTS ports in all (those the server listens on already count
        once asked for). The port listens on the server's own hosts (loopback unless the
        operator's configuration says otherwise, :mod:`simx_server.legacy.script_hooks`).

        Args:
            port: TCP port, 1..65535 (checked by the caller).

        Raises:
            ArgumentError: a new port past limits.MAX_SCRIPT_PORTS.
        """
        if port in self.served or port in self.pending:
            return
        if len(self.served) + len(self.pending) >= L.MAX_SCRIPT_PORTS:
            raise ArgumentError(f"remoteApiStart({port}): scripts may ask for at most {L.MAX_SCRIPT_PORTS} ports "
                                f"(limits.MAX_SCRIPT_PORTS); asked already: "
                                f"{', '.join(map(str, sorted(self.served | set(self.pending))))}")
        self.pending.append(port)

    def take(self) -> list[int]:
        """The ports requested since the last call (in order), emptied.

        Returns:
            The port numbers, oldest first.
        """
        out, self.pending = self.pending, []
        return out


# Custom data blocks, boolean helpers, system time, remote API ports.

def _blocks(ctx: CallContext, handle: Any) -> dict:
    h = ctx.h(handle)
    if h not in (HANDLE_SCENE, -1):
        ctx.world.get(h)
    me = ctx.script
    store = me.shared.setdefault("custom_data", {}) if me is not None else {}
    return store.setdefault(h, {})


@sim_function("writeCustomDataBlock")
def writeCustomDataBlock(ctx: CallContext, objectHandle: Any, tagName: Any, data: Any) -> int:  # noqa: N802, N803
    """Store ``data`` (bytes) under ``tagName`` on an object (``sim.handle_scene``: the scene);
    empty data or nil removes the tag. Blocks live as long as the loaded scene.

    ``simWriteCustomDataBlock``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.
        data: bytes (or a string) of at most 1 MiB; None or empty: remove the tag.

    Returns:
        1.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: data over 1 MiB, or a bad argument.
    """
    blocks, tag = _blocks(ctx, objectHandle), _text(tagName, "tagName")
    if data is None or data == b"" or data == "":
        blocks.pop(tag, None)
        return 1
    raw = _bytes(data, "data")
    if len(raw) > _MAX_CUSTOM_DATA:
        raise ArgumentError(f"custom data block {tag!r} of {len(raw)} bytes: at most {_MAX_CUSTOM_DATA}")
    blocks[tag] = raw
    return 1


@sim_function("readCustomDataBlock")
def readCustomDataBlock(ctx: CallContext, objectHandle: Any, tagName: Any) -> bytes | None:  # noqa: N802, N803
    """The block stored under ``tagName``, nil when there is none.

    ``simReadCustomDataBlock``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.

    Returns:
        The bytes, or None.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a bad argument.
    """
    return _blocks(ctx, objectHandle).get(_text(tagName, "tagName"))


@sim_function("readCustomDataBlockTags")
def readCustomDataBlockTags(ctx: CallContext, objectHandle: Any) -> list[str]:  # noqa: N802, N803
    """The tags of the object's custom data blocks.

    ``simReadCustomDataBlockTags``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.

    Returns:
        The tags, sorted.

    Raises:
        UnknownObjectError: no such object.
    """
    return sorted(_blocks(ctx, objectHandle))


@sim_function("boolOr32")
def boolOr32(ctx: CallContext, a: Any, b: Any) -> int:  # noqa: N802
    """``a | b`` on 32-bit unsigned values (3.x ``simBoolOr16`` too).

    Args:
        a: an integer.
        b: an integer.

    Returns:
        The result, 0..2**32-1.

    Raises:
        ArgumentError: not an integer.
    """
    return (_int(a, "value1") | _int(b, "value2")) & 0xFFFFFFFF


@sim_function("boolAnd32")
def boolAnd32(ctx: CallContext, a: Any, b: Any) -> int:  # noqa: N802
    """``a & b`` on 32-bit unsigned values (3.x ``simBoolAnd16`` too).

    Args:
        a: an integer.
        b: an integer.

    Returns:
        The result, 0..2**32-1.

    Raises:
        ArgumentError: not an integer.
    """
    return (_int(a, "value1") & _int(b, "value2")) & 0xFFFFFFFF


@sim_function("boolXor32")
def boolXor32(ctx: CallContext, a: Any, b: Any) -> int:  # noqa: N802
    """``a ^ b`` on 32-bit unsigned values (3.x ``simBoolXor16`` too).

    Args:
        a: an integer.
        b: an integer.

    Returns:
        The result, 0..2**32-1.

    Raises:
        ArgumentError: not an integer.
    """
    return (_int(a, "value1") ^ _int(b, "value2")) & 0xFFFFFFFF


@sim_function("getSystemTimeInMs")
def getSystemTimeInMs(ctx: CallContext, previousTime: Any = -1) -> int:  # noqa: N802, N803
    """Milliseconds of a monotonic clock (``previousTime`` -1), or elapsed since ``previousTime``.

    ``simGetSystemTimeInMs``.

    Args:
        previousTime: ms from an earlier call, or -1.

    Returns:
        ms (wrapping at 2**31).

    Raises:
        ArgumentError: ``previousTime`` is not an integer.
    """
    now = int(time.monotonic() * 1000) & 0x7FFFFFFF
    prev = _int(previousTime, "previousTime")
    return now if prev == -1 else (now - prev) & 0x7FFFFFFF


def _ports(ctx: CallContext) -> RemoteApiPorts:
    sim = ctx.simulation("remoteApiStart")
    ports = getattr(sim, "remote_api", None)
    if ports is None:
        raise ArgumentError("remoteApiStart needs a server (this simulation serves no remote API)")
    return ports


@sim_function("remoteApiStart")
def remoteApiStart(ctx: CallContext, port: Any, maxPacketSize: Any = 1300, debug: Any = False,  # noqa: N802, N803
                   preEnableTrigger: Any = False) -> int:  # noqa: N803
    """``simExtRemoteApiStart(port)`` / ``simRemoteApi.start(port)``: serve the legacy remote
    API on ``port`` too (a no-op when it is served already: 19997/19999 by default); the
    server opens it on its own thread, under the same host and security configuration.
    Returns 1 (the port is served or will be).

    Args:
        port: TCP port, 1..65535.
        maxPacketSize: ignored (Zenoh frames the messages).
        debug: ignored.
        preEnableTrigger: ignored.

    Returns:
        1.

    Raises:
        ArgumentError: a port out of range, a new port past limits.MAX_SCRIPT_PORTS, or a
            simulation that serves no remote API.
        UnsupportedError: no simulation behind the script.
    """
    p = _int(port, "port")
    if not 1 <= p <= 65535:
        raise ArgumentError(f"port must be 1..65535, got {p}")
    _ports(ctx).request(p)
    return 1


@sim_function("remoteApiStatus")
def remoteApiStatus(ctx: CallContext, port: Any) -> int:  # noqa: N802
    """1 when the legacy remote API is served on ``port`` (or about to be), else -1.

    ``simExtRemoteApiStatus`` / ``simRemoteApi.status``.

    Args:
        port: TCP port.

    Returns:
        1 or -1.

    Raises:
        ArgumentError: not an integer, or a simulation that serves no remote API.
        UnsupportedError: no simulation behind the script.
    """
    ports = _ports(ctx)
    p = _int(port, "port")
    return 1 if p in ports.served or p in ports.pending else -1


@sim_function("remoteApiStop")
def remoteApiStop(ctx: CallContext, port: Any) -> int:  # noqa: N802
    """Ports opened for the scene stay open while the server runs: logged, returns 0.

    ``simExtRemoteApiStop`` / ``simRemoteApi.stop``.

    Args:
        port: TCP port.

    Returns:
        0.
    """
    log.info("[%s] simRemoteApi.stop(%s): simx keeps serving the port", ctx.label, port)
    return 0


@sim_function("remoteApiReset")
def remoteApiReset(ctx: CallContext) -> int:  # noqa: N802
    """Nothing to reset: returns 0.

    ``simRemoteApi.reset``.

    Returns:
        0.
    """
    return 0


