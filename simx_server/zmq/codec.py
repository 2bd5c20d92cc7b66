"""The messages of CoppeliaSim's ZMQ remote API, protocol versions 2 and 1: CBOR maps read under bounds.

A request of protocol version 2 (CoppeliaSim 4.6+, ``coppeliasim-zmqremoteapi-client`` 2.x) is a
CBOR map ``{func, args, uuid [, ver, lang, timeout, argsL]}``; its reply a map ``{ret: [values]}``,
``{err: text}`` or ``{func: "_*wait*_", args: []}``. A request of version 1 (CoppeliaSim 4.3-4.5's
client, the ``zmqRemoteApi`` package) is ``{func, args}`` with no uuid; its reply ``{success: true,
ret: [values]}`` or ``{success: false, error: text}`` (:func:`to_version_1`). Each request's
version is told by its uuid (docs/PROTOCOL.md, part 2). Clients are untrusted: before cbor2 builds any object, :func:`scan` walks the
message's item heads without recursion and refuses what the protocol never sends and what
would cost more than its size suggests (tags, indefinite lengths, simple values other than
false/true/null, a length beyond the message, more than :data:`MAX_ITEMS` items, containers
nested deeper than :data:`MAX_DEPTH`, map keys that are not strings). Every refusal is a
:class:`~simx_wire.protocol.ProtocolError` whose text the reply carries.

No MuJoCo and no sockets in here.
"""

from __future__ import annotations

import ctypes
import math
from typing import Any

import cbor2
import numpy as np

from simx_wire import decoded_size as D
from simx_wire.protocol import MAX_REQUEST_DECODED_BYTES, ProtocolError

#: The protocol version simx speaks (CoppeliaSim 4.6 and later; ``ver`` of a client's first request).
PROTOCOL_VERSION = 2
#: The version before it (CoppeliaSim 4.3-4.5's client: requests without uuid, ``{success}`` replies),
#: served beside version 2 on the same port.
VERSION_1 = 1
#: Largest request in bytes: a 16 MiB string signal or script argument (limits.MAX_SIGNAL_BYTES,
#: MAX_SCRIPT_CALL_BYTES) and the rest of its request; a 200,000-face sim.createShape (about 5 MiB);
#: a 2048x2048 RGB image for sim.setVisionSensorImg (12 MiB). libzmq holds a message whole before
#: the server sees it, so this bounds what each connection can make it hold (zmq/sockets.py).
MAX_REQUEST_BYTES = 17 * 1024 * 1024
#: Deepest nesting of containers in a request (the request map is level 1, its args level 2).
MAX_DEPTH = 32
#: Most CBOR items in one request (each number, string, array or map counts one).
MAX_ITEMS = 1 << 20
#: Most arrays and maps in one request: each becomes a Python list or dict (and, passed to a
#: script, a Lua table: limits.MAX_SCRIPT_CALL_TABLES), so a 1 MiB request of a million empty
#: arrays is refused on its item heads instead of being built (13 s of the simulation thread).
MAX_CONTAINERS = (1 << 16) + 64
#: The uuid of a version-1 client (which sends none) is this and its connection's routing id in
#: hex (frontend): a version-2 request may not name one, or it would act as that client (libzmq's
#: routing ids count up from a random start, one per connection).
VERSION_1_UUID_PREFIX = "zmq43-"
#: Longest function name and client id (uuid) in characters.
MAX_NAME = 200
#: Bounds of the client's ``timeout`` (s): how long its state is kept without a request.
MIN_TIMEOUT, MAX_TIMEOUT, DEFAULT_TIMEOUT = 1.0, 24 * 3600.0, 600.0

WAIT = "_*wait*_"  # the server asks the client to send _*executed*_ back (sim.step)
EXECUTED = "_*executed*_"  # the client's answer to _*wait*_
END = "_*end*_"  # a client leaving
NIL = "_*NIL*_"  # an argument that stands for nil (Lua drops nils from argument lists)

_FLOAT_SIZES = {25: 2, 26: 4, 27: 8}


_new_bytes = ctypes.pythonapi.PyBytes_FromStringAndSize
_new_bytes.restype, _new_bytes.argtypes = ctypes.py_object, (ctypes.c_void_p, ctypes.c_ssize_t)
_bytes_at = ctypes.pythonapi.PyBytes_AsString
_bytes_at.restype, _bytes_at.argtypes = ctypes.c_void_p, (ctypes.py_object,)


def copy_out(view: memoryview) -> bytes:
    """``bytes(view)`` (a contiguous buffer), copied with the GIL released: ctypes' ``memmove``
    lets the other threads run while it copies and faults in the new pages (60 MiB took 0.12-0.19 s
    on a loaded machine, every other thread of the server waiting)."""
    n = len(view)
    out = _new_bytes(None, n)  # not initialised: filled below, before anyone sees it
    if n:
        ctypes.memmove(_bytes_at(out), np.frombuffer(view, np.uint8).ctypes.data, n)
    return out


#: Strings this long or longer are copied out of a request without cbor2 (:func:`_decode`).
LARGE_STRING = 64 * 1024
_TAG = 0x5A17  # an unassigned CBOR tag, standing for a large string in what cbor2 decodes
_TAG_HEAD = bytes([0xD9]) + _TAG.to_bytes(2, "big")


def scan(data: bytes, max_depth: int = MAX_DEPTH, max_items: int = MAX_ITEMS,
         max_decoded: int = MAX_REQUEST_DECODED_BYTES, max_containers: int = MAX_CONTAINERS,
         spans: list[tuple[int, int, int, int]] | None = None) -> int:
    """Check the item heads of a CBOR message without building it; raises ProtocolError.
    Returns the memory its decoded value takes (bytes, about: CPython's costs of
    :mod:`simx_wire.decoded_size`), refused past ``max_decoded`` (the legacy door's
    ``MAX_REQUEST_DECODED_BYTES``: a 1-byte empty map decodes to 240 bytes).

    Accepts what protocol version 2 uses: unsigned and negative integers up to 64 bits, byte
    and text strings, arrays, maps with string keys, false, true, null and floats; all of
    definite length, one top-level item, no byte after it.

    ``spans``: when given, each byte or text string of :data:`LARGE_STRING` bytes or more that is
    not a map key is listed there as ``(head, start, end, major)`` (its head's offset, its bytes'
    offsets, 2 or 3), for :func:`_decode`."""
    n = len(data)
    pos = 0
    stack = [1]  # items still to read at each open level
    keys = [False]  # whether the next item of that level is a map key
    items = decoded = containers = 0
    while stack:
        if stack[-1] == 0:
            stack.pop()
            keys.pop()
            continue
        stack[-1] -= 1
        is_key = keys[-1] and stack[-1] % 2 == 1  # a map's count is doubled: keys are the odd ones left
        if pos >= n:
            raise ProtocolError("not CBOR: the message ends inside an item")
        head_at, head = pos, data[pos]
        pos += 1
        major, info = head >> 5, head & 31
        items += 1
        if items > max_items:
            raise ProtocolError(f"request refused: more than {max_items} CBOR items (codec.MAX_ITEMS)")
        if major == 7:
            if is_key:
                raise ProtocolError("request refused: map keys must be strings")
            if 20 <= info <= 22:  # false, true, null
                decoded += D.REF
                continue
            size = _FLOAT_SIZES.get(info)
            if size is None:
                raise ProtocolError("request refused: CBOR simple values other than false, true and null, "
                                    "and indefinite lengths, are not used by the protocol")
            pos += size
            if pos > n:
                raise ProtocolError("not CBOR: the message ends inside a float")
            decoded += D.REF + D._FLOAT
            continue
        if info < 24:
            arg = info
        elif info <= 27:
            size = 1 << (info - 24)
            if pos + size > n:
                raise ProtocolError("not CBOR: the message ends inside an item's head")
            arg = int.from_bytes(data[pos:pos + size], "big")
            pos += size
        else:
            raise ProtocolError("request refused: indefinite lengths are not used by the protocol")
        if major <= 1:
            if is_key:
                raise ProtocolError("request refused: map keys must be strings")
            decoded += D.REF + (D._INT if arg > 256 else 0)
            continue
        if major <= 3:  # byte and text strings
            if arg > n - pos:
                raise ProtocolError("not CBOR: a string is longer than the message")
            if spans is not None and arg >= LARGE_STRING and not is_key:
                spans.append((head_at, pos, pos + arg, major))
            pos += arg
            decoded += D.REF + (D._BIN if major == 2 else D._STR) + arg
            continue
        if major == 6:
            raise ProtocolError("request refused: CBOR tags are not used by the protocol")
        if is_key:
            raise ProtocolError("request refused: map keys must be strings")
        count = arg * 2 if major == 5 else arg
        containers += 1
        if containers > max_containers:
            raise ProtocolError(f"request refused: more than {max_containers} arrays and maps (codec.MAX_CONTAINERS)")
        decoded += D.REF + (D._MAP + D._PAIR * arg if major == 5 else D._ARRAY)
        if decoded > max_decoded:
            raise ProtocolError(f"request refused: it would take more than {max_decoded} bytes once decoded "
                                "(protocol.MAX_REQUEST_DECODED_BYTES)")
        if count > n - pos:  # every item takes at least one byte
            raise ProtocolError("not CBOR: a container holds more items than the message has bytes")
        if len(stack) > max_depth:
            raise ProtocolError(f"request refused: containers nested deeper than {max_depth} (codec.MAX_DEPTH)")
        stack.append(count)
        keys.append(major == 5)
    if pos != n:
        raise ProtocolError(f"not CBOR: {n - pos} bytes after the message's item")
    if decoded > max_decoded:
        raise ProtocolError(f"request refused: it would take more than {max_decoded} bytes once decoded "
                            "(protocol.MAX_REQUEST_DECODED_BYTES)")
    return decoded


class Request:
    """One request: ``func`` (str), ``args`` (list), ``uuid`` (str; for version 1, which has none,
    the frontend names the client by its connection), the first contact's ``lang`` and
    ``timeout`` (s, None when not given), and its protocol ``version`` (2, or :data:`VERSION_1`)."""

    __slots__ = ("func", "args", "uuid", "lang", "timeout", "version")

    def __init__(self, func: str, args: list, uuid: str, lang: str | None = None, timeout: float | None = None,
                 version: int = PROTOCOL_VERSION):
        self.func, self.args, self.uuid, self.lang, self.timeout = func, args, uuid, lang, timeout
        self.version = version

    def __repr__(self) -> str:
        return f"Request({self.func!r}, {len(self.args)} args, uuid={self.uuid!r})"


class RequestError(ProtocolError):
    """A request refused before it is served; ``version``: its protocol version (which reply
    shape the client reads), None when the message is not a request map at all."""

    def __init__(self, message: str, version: int | None = None):
        super().__init__(message)
        self.version = version


def read_request(data: bytes) -> Request:
    """The request in ``data``; raises :class:`RequestError` naming what is wrong.

    ``args`` may be absent (no arguments); the string ``"_*NIL*_"`` among them stands for nil
    (None). A map with a ``uuid`` is protocol version 2's (a ``ver`` other than 2 is refused);
    one without is version 1's (CoppeliaSim 4.3-4.5's client: ``{func, args}``; its ``eval``
    requests, Lua code to run, are refused)."""
    try:
        msg = _decode(data)
    except ProtocolError as exc:
        raise RequestError(str(exc)) from None
    version = PROTOCOL_VERSION if "uuid" in msg else VERSION_1
    try:
        return _request(msg) if version == PROTOCOL_VERSION else _request_1(msg)
    except ProtocolError as exc:
        raise RequestError(str(exc), version) from None


def _decode(data: bytes) -> dict:
    """The CBOR map in ``data``, read under the bounds of :func:`scan`.

    Strings of :data:`LARGE_STRING` bytes or more are copied out of ``data`` directly (a slice of
    a memoryview: a memcpy), and cbor2 decodes the rest with a small tag in their place: cbor2
    reads a large string in 64 KiB pieces, holding the GIL, 0.17 s for 60 MiB (0.5 s from a
    memoryview) during which no other thread of the server ran."""
    if len(data) > MAX_REQUEST_BYTES:
        raise ProtocolError(f"request of {len(data)} bytes refused: at most {MAX_REQUEST_BYTES} (codec.MAX_REQUEST_BYTES)")
    spans: list[tuple[int, int, int, int]] = []
    scan(data, spans=spans)
    hook = None
    if spans:
        view = memoryview(data)
        parts, values, at = [], [], 0
        try:
            for i, (head, start, end, major) in enumerate(spans):
                parts += [view[at:head], _TAG_HEAD, cbor2.dumps(i)]
                values.append(copy_out(view[start:end]) if major == 2 else str(view[start:end], "utf-8"))
                at = end
        except UnicodeDecodeError:
            raise ProtocolError("not CBOR: a text string is not UTF-8") from None
        parts.append(view[at:])
        data = b"".join(parts)

        def hook(tag, *_):  # only the tags put above: scan refuses any other (cbor2 6: (tag, immutable))
            return values[tag.value] if tag.tag == _TAG else tag
    try:
        msg = cbor2.loads(data, max_depth=MAX_DEPTH + 1, allow_indefinite=False, strict_hashable_types=True,
                          tag_hook=hook)
    except (cbor2.CBORDecodeError, ValueError, RecursionError, MemoryError) as exc:
        raise ProtocolError(f"not CBOR: {str(exc)[:200]}") from None
    if not isinstance(msg, dict):
        raise ProtocolError(f"a request is a CBOR map {{func, args, uuid}}, got {type(msg).__name__}")
    return msg


def _request(msg: dict) -> Request:
    uuid = msg.get("uuid")
    ver = msg.get("ver")
    if ver is not None and ver != PROTOCOL_VERSION:
        raise ProtocolError(f"protocol version {_short(ver)} refused: this server speaks version {PROTOCOL_VERSION} "
                            "(coppeliasim-zmqremoteapi-client 2.x)")
    if not isinstance(uuid, str) or not 0 < len(uuid) <= MAX_NAME:
        raise ProtocolError(f"uuid must be a string of 1 to {MAX_NAME} characters")
    if uuid.startswith(VERSION_1_UUID_PREFIX):  # a version-1 client's: its connection's, no one else's
        raise ProtocolError(f"uuids starting with {VERSION_1_UUID_PREFIX!r} are the server's own (version-1 clients')")
    func, args = _func_args(msg)
    lang = msg.get("lang")
    timeout = msg.get("timeout")
    if timeout is not None:
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or not math.isfinite(timeout):
            raise ProtocolError("timeout must be a number of seconds")
        timeout = min(max(float(timeout), MIN_TIMEOUT), MAX_TIMEOUT)
    return Request(func, args, uuid, lang if isinstance(lang, str) else None, timeout)


def _func_args(msg: dict) -> tuple[str, list]:
    func = msg.get("func")
    if not isinstance(func, str) or not 0 < len(func) <= MAX_NAME:
        raise ProtocolError(f"func must be a function name, a string of 1 to {MAX_NAME} characters")
    args = msg.get("args", [])
    if args is None:
        args = []
    if not isinstance(args, list):
        raise ProtocolError(f"args must be an array, got {type(args).__name__}")
    return func, [None if a == NIL else a for a in args]


def _request_1(msg: dict) -> Request:
    """A request of CoppeliaSim 4.3-4.5's client (its add-on's ``zmqRemoteApi.handleRequest``):
    ``{func, args}``; ``uuid`` is left empty for the frontend to fill."""
    if "func" not in msg and "eval" in msg:
        raise ProtocolError("eval requests are refused: simx runs no code a client sends (call functions by name; "
                            "docs/SECURITY.md)")
    if "ver" in msg:
        raise ProtocolError(f"a request with ver {_short(msg['ver'])} needs a uuid (protocol version "
                            f"{PROTOCOL_VERSION}: coppeliasim-zmqremoteapi-client 2.x)")
    func, args = _func_args(msg)
    if func.startswith("_*"):
        raise ProtocolError(f"{_short(func)} is a message of protocol version {PROTOCOL_VERSION} (requests with a uuid)")
    return Request(func, args, "", version=VERSION_1)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _plain(value: Any) -> Any:
    """cbor2's fallback for values it does not know: numpy scalars and arrays, tuples."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, (set, frozenset)):
        return list(value)
    raise TypeError(f"{type(value).__name__} cannot be sent")


def _default(encoder: cbor2.CBOREncoder, value: Any) -> None:
    encoder.encode(_plain(value))


def encode_reply(values: list | tuple) -> bytes:
    """``{ret: values}``: a function's return values (one per returned value; none: empty)."""
    return cbor2.dumps({"ret": list(values)}, default=_default)


def encode_error(message: str, version: int | None = PROTOCOL_VERSION) -> bytes:
    """The reply of a failed request, whose text the client raises: ``{err: message}`` (version
    2), ``{success: false, error: message}`` (version 1), or both in one map for a message
    whose version is not known (not a request map): each client version reads its keys."""
    if version == PROTOCOL_VERSION:
        return cbor2.dumps({"err": message})
    if version == VERSION_1:
        return cbor2.dumps({"success": False, "error": message})
    return cbor2.dumps({"err": message, "success": False, "error": message})


# The heads of version 2's {ret: ...} and {err: ...} maps (a 1-pair map, a 3-letter key), and
# of version 1's two-pair maps that replace them, {success: true, ret: ...} / {success: false, error: ...}.
_RET_2, _ERR_2 = b"\xa1\x63ret", b"\xa1\x63err"
_RET_1 = b"\xa2" + cbor2.dumps("success") + cbor2.dumps(True) + cbor2.dumps("ret")
_ERR_1 = b"\xa2" + cbor2.dumps("success") + cbor2.dumps(False) + cbor2.dumps("error")


def to_version_1(payload: bytes) -> bytes:
    """A version-2 reply (:func:`encode_reply`, :func:`encode_error`) as version 1's client reads
    it (CoppeliaSim 4.3-4.5's add-on, ``zmqRemoteApi.handleRequest``): ``{success: true, ret}``
    or ``{success: false, error}``. The value is kept as encoded (an image is not copied twice);
    another reply (``_*wait*_``, a callback, ``{}``), which version 1 has no use for, becomes an error."""
    head = payload[:5]
    if head == _RET_2:
        return _RET_1 + payload[5:]
    if head == _ERR_2:
        return _ERR_1 + payload[5:]
    if payload == cbor2.dumps({}):
        return _RET_1 + cbor2.dumps([])
    return encode_error("this reply has no form in protocol version 1 (CoppeliaSim 4.3-4.5's client); "
                        "use coppeliasim-zmqremoteapi-client 2.x", VERSION_1)


def encode_wait() -> bytes:
    """``{func: "_*wait*_", args: []}``: the client answers with ``_*executed*_``."""
    return cbor2.dumps({"func": WAIT, "args": []})


def encode_callback(name: str, args: list) -> bytes:
    """``{func: name, args}``: the client runs its function ``name`` (the one it passed as
    ``"name@func"``) with ``args`` and answers ``_*executed*_`` with its return values."""
    return cbor2.dumps({"func": name, "args": list(args)}, default=_default)


def encode_request(func: str, args: list, uuid: str, first: bool = False) -> bytes:
    """A request as a client sends it (tests and benchmarks; the official client builds its own)."""
    msg: dict[str, Any] = {"func": func, "args": list(args), "uuid": uuid}
    if first:
        msg.update(ver=PROTOCOL_VERSION, lang="python", timeout=int(DEFAULT_TIMEOUT))
    msg["argsL"] = len(args)
    return cbor2.dumps(msg, default=_default)
