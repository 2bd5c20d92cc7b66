"""The ZMQ door's reply and time budgets: the legacy door's rules, per ZMQ connection.

* **Replies sized before they are built** (:func:`reply_estimate`): a call whose reply is known
  from its arguments (an image from its sensor's resolution, an unpacked table from its buffer's
  length) is refused before it runs when it would pass ``limits.MAX_REPLY_BYTES`` or carry more
  than ``protocol.MAX_REQUEST_ITEMS`` values (the legacy door's image rule,
  :func:`simx_server.commands.sensors.image_pixels`): without it a 100-byte
  ``sim.getVisionSensorImage`` of a 4096x4096 sensor (50 M values) holds the simulation thread
  for seconds and takes gigabytes, as does ``sim.unpackUInt8Table`` of a 60 MiB buffer.
* **The simulation thread's share per connection** (:class:`Connection`, the loop's
  :class:`~simx_server.loop.budgets.Share`): a connection's calls that reached the scene's
  editor (loads, edits, recompiles, whatever their names: the editor counts them,
  ``Editor.edits``) cost their duration, and any other call its time past ``limits.MAX_REQUEST_SECONDS`` (a request's budget
  on the legacy door); the debt falls by ``limits.EDIT_SHARE`` s per s, and while it exceeds
  ``limits.EDIT_DEBT_SECONDS`` the connection's calls wait (deferred: other connections are served meanwhile). Counted per
  connection (its ROUTER routing id), not per uuid: a client may use a new uuid for every call.
"""

from __future__ import annotations

import struct
from typing import Any

from simx_wire.protocol import MAX_REQUEST_ITEMS
from simx_server.base import limits
from simx_server.loop.budgets import Share
from simx_server.api.sim.core import _PACK_FORMATS
from simx_server.api.sim.sensors import HANDLEFLAG_GREYSCALE as _GREYSCALE
from simx_server.commands.sensors import image_pixels

_DEPTH_METRES = 0x800000  # sim.handleflag_depthbuffermeters
_CBOR_FLOAT, _CBOR_INT = 9, 5  # bytes of a float64 and of a 32-bit integer in a CBOR reply


def _image(sim: Any, args: list, floats: bool) -> tuple[int, int]:
    handle = args[0] if args and type(args[0]) is int else -1
    grey = handle >= 0 and bool(handle & _GREYSCALE)
    pixels = image_pixels(sim, [handle & ~_GREYSCALE if grey else handle])
    values = pixels * (1 if grey else 3)
    if floats and not (len(args) > 5 and args[5] == 1):  # returnType 1: a buffer of bytes
        return values * _CBOR_FLOAT, values
    return values, 1


def _unpack(code: str, args: list) -> tuple[int, int]:
    data = args[0] if args else b""
    if not isinstance(data, (bytes, bytearray, str)):
        return 0, 0
    ints = [a if type(a) is int and a > 0 else 0 for a in (args + [0, 0, 0])[1:4]]
    start, count, offset = ints
    items = max(0, (len(data) - offset) // struct.calcsize(code) - start)
    if count:
        items = min(items, count)
    return items * (_CBOR_FLOAT if code in "fd" else _CBOR_INT), items


def _handle(args: list) -> list:
    """The sensor handle argument without the flags added to it (greyscale, depth in metres)."""
    if not args or type(args[0]) is not int:
        return []
    return [args[0] & ~(_GREYSCALE | _DEPTH_METRES) if args[0] >= 0 else args[0]]


def _floats(sim: Any, args: list, per_pixel: int) -> tuple[int, int]:
    values = per_pixel * image_pixels(sim, _handle(args))
    return values * _CBOR_FLOAT, values


_ESTIMATES = {
    "getVisionSensorImage": lambda sim, args: _image(sim, args, floats=True),
    "getVisionSensorImg": lambda sim, args: _image(sim, args, floats=False),
    "getVisionSensorCharImage": lambda sim, args: (3 * image_pixels(sim, args[:1]), 1),
    "getVisionSensorDepth": lambda sim, args: (4 * image_pixels(sim, args[:1]), 1),
    "getVisionSensorDepthBuffer": lambda sim, args: _floats(sim, args, 1),
    "checkVisionSensorEx": lambda sim, args: _floats(sim, args, 3 if len(args) > 2 and args[2] else 1),
    **{f"unpack{kind}Table": (lambda sim, args, code=code: _unpack(code, args))
       for kind, code in _PACK_FORMATS.items()},
}


def reply_estimate(sim: Any, name: str, args: list) -> str | None:
    """Why ``sim.NAME(*args)`` is refused before it runs (its reply would pass a bound), or None."""
    estimate = _ESTIMATES.get(name)
    if estimate is None:
        return None
    size, values = estimate(sim, args)
    if size > limits.MAX_REPLY_BYTES:
        return (f"not executed: the reply would be about {size} bytes, more than {limits.MAX_REPLY_BYTES} "
                "(limits.MAX_REPLY_BYTES); ask for less (a smaller resolution or window, a part of the buffer)")
    if values > MAX_REQUEST_ITEMS:
        return (f"not executed: the reply would hold {values} values, more than {MAX_REQUEST_ITEMS} "
                "(protocol.MAX_REQUEST_ITEMS); ask for less")
    return None


#: Calls that wait for a render: the ZMQ service replies once the render thread is done
#: (:attr:`~simx_server.api.context.CallContext.defer_renders`).
RENDERS = frozenset({"getVisionSensorImg", "getVisionSensorImage", "getVisionSensorCharImage",
                     "getVisionSensorDepth", "getVisionSensorDepthBuffer", "checkVisionSensorEx",
                     "readVisionSensor", "checkVisionSensor", "handleVisionSensor"})
_PACKET_BYTES = 3 + 4  # a vision packet's frames per pixel: RGB bytes and a float32 depth


def held_estimate(sim: Any, name: str, args: list) -> int:
    """Bytes that ``sim.NAME(*args)``, one of :data:`RENDERS`, holds until its reply is read:
    its reply's (:func:`reply_estimate`'s), or for a vision packet its frames (the sum over every
    sensor for ``sim.handle_all``). 0 when the handle is no vision sensor (the call then answers
    its error)."""
    estimate = _ESTIMATES.get(name)
    if estimate is not None:
        return estimate(sim, args)[0]
    handle = args[0] if args and type(args[0]) is int else None
    if name == "handleVisionSensor" and handle is not None and handle < 0:
        return _PACKET_BYTES * sum(spec.pixels for spec in sim.vision.specs.values())
    return _PACKET_BYTES * image_pixels(sim, args[:1])


class Connection(Share):
    """A ZMQ connection (a ROUTER routing id): its clients (uuids) and its share of the
    simulation thread (:class:`~simx_server.loop.budgets.Share`: ``wait(now)`` is how long its
    next call waits)."""

    __slots__ = ("fd", "uuids")

    def __init__(self, fd: int, now: float):
        super().__init__(now)
        self.fd = fd
        self.uuids: set[str] = set()

    def charge_call(self, seconds: float, now: float, edit: bool) -> None:
        """A call of ``seconds`` done at ``now``: an edit costs all of it, another call its time
        past limits.MAX_REQUEST_SECONDS."""
        self.charge(seconds if edit else max(0.0, seconds - limits.MAX_REQUEST_SECONDS), now)
