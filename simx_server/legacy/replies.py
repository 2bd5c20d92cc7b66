"""The reply budget: what a command's result will cost in a reply, before and after it runs.

A request's reply (and a stream update) carries at most ``limits.MAX_REPLY_BYTES``: the server
counts each result against that budget and answers an error instead of the results past it.
An image's size is known before it is rendered (resolution x channels), so an image that
would not fit is not rendered at all; other results are sized as they come, cheaply for the
small results of most calls.
"""

from __future__ import annotations

import logging
import struct
from typing import Any

import msgpack
import zenoh

from simx_wire import protocol as P
from simx_server.base.arguments import quote
from simx_server.commands.sensors import IMAGES, image_pixels, image_size  # noqa: F401  (re-exported)
from simx_server.sim.vision import Deferred

log = logging.getLogger("simx.server")

SMALL = frozenset({type(None), bool, int, float})  # results that cost nothing in a reply


def reply_size(value: Any, depth: int = 0) -> int:
    """Bytes ``value`` takes in a reply, about (msgpack: 9 per number, the length of bytes and
    strings); cheap for the small results of most calls."""
    t = type(value)
    if t in SMALL:
        return 9
    if t is bytes or t is str or t is bytearray:
        return len(value) + 5
    if (t is list or t is tuple) and depth < 8:
        return 5 + sum(reply_size(v, depth + 1) for v in value)
    if t is dict and depth < 8:
        return 5 + sum(reply_size(k, depth + 1) + reply_size(v, depth + 1) for k, v in value.items())
    return 64


#: Binaries of at least this many bytes are copied by ``bytes.join`` (see :func:`pack_large`),
#: which CPython does without the GIL from 1 MiB on.
LARGE_BINARY = 1 << 20


def pack_large(message: Any) -> bytes:
    """``P.pack(message)``, the same bytes, for messages with large images (stream updates and
    replies of 1024x1024 frames and more): each ``bytes`` value of ``LARGE_BINARY`` bytes or
    more is copied once, by ``bytes.join``, which lets the other threads run meanwhile.

    Why: msgpack's Packer copies a whole message holding the GIL. A 4096x4096 sensor's image and
    depth buffer (117 MB) held it 170 ms in one piece, on a render thread, and another client's
    request (its command, its small frame's reply) waited that long."""
    packer = msgpack.Packer(use_bin_type=True)
    pieces: list[bytes] = []
    small = bytearray()  # the msgpack bytes since the last large binary
    _walk(message, packer, pieces, small)
    pieces.append(bytes(small))
    return b"".join(pieces)


def _walk(value: Any, packer: msgpack.Packer, pieces: list[bytes], small: bytearray) -> None:
    """:func:`pack_large`'s walk: msgpack bytes of ``value`` into ``small``, each large binary
    as a piece of its own. A function of the module, not a closure: a nested function that
    calls itself is a reference cycle (function -> cell -> function), which kept ``pieces``
    (every image of the message) until the cyclic collector ran."""
    t = type(value)
    if t is bytes and len(value) >= LARGE_BINARY:
        small.extend(struct.pack(">BI", 0xC6, len(value)))  # msgpack bin 32
        pieces.append(bytes(small))
        small.clear()
        pieces.append(value)
    elif t is list or t is tuple:
        small.extend(packer.pack_array_header(len(value)))
        for item in value:
            _walk(item, packer, pieces, small)
    elif t is dict:
        small.extend(packer.pack_map_header(len(value)))
        for key, item in value.items():
            _walk(key, packer, pieces, small)
            _walk(item, packer, pieces, small)
    else:
        small.extend(packer.pack(value))


def resolve(results: list, client: str) -> list:
    """``[ok, value]`` results with every Deferred replaced by its value (called on the render
    thread); a failed render becomes an error result."""
    out = []
    for ok, value in results:
        if isinstance(value, Deferred):
            try:
                value = value.future.result()
            except P.RemoteError as exc:  # a deferred scene load that failed (scene.conversions)
                ok, value = False, str(exc)
            except Exception as exc:
                log.exception("client %s: rendering failed", client)
                ok, value = False, f"internal error while rendering: {type(exc).__name__}: {exc}"
        out.append([ok, value])
    return out


def encode_response(t: int, state: int, results: list, server_time: int, scene: int, client: str,
                    large: bool = False) -> bytes:
    """The encoded response (``large``: with :func:`pack_large`, for replies with images), or a
    short refusal when it cannot be encoded."""
    try:
        return P.response(t, state, results, server_time, scene, pack_large if large else P.pack)
    except Exception as exc:
        log.exception("client %s: encoding a reply", client)
        return P.error_response(f"internal error while encoding the reply: {type(exc).__name__}")


def answer(query: zenoh.Query, payload: bytes | zenoh.ZBytes) -> None:
    """Reply to ``query`` and send Zenoh's final reply (on the sending thread); raises what the
    reply raises, the final reply sent all the same."""
    try:
        query.reply(query.key_expr, payload)
    finally:
        query.drop()


def send_refusal(query: zenoh.Query, key: str, reply: bytes) -> None:
    """:func:`answer` with a refusal; a failure is one warning naming the key."""
    try:
        answer(query, reply)
    except Exception as exc:
        log.warning("replying on %s: %s", quote(key), exc)


def tell_secret(commands: list, results: list, secret: bytes) -> None:
    """A ``Hello``'s result carries its client's secret (``"secret"``, simx_wire.proof): the reply
    goes to the querier alone, which proves every later request with it."""
    for (name, _mode, _args), result in zip(commands, results):
        if name == "Hello" and result[0] is True and type(result[1]) is dict:
            result[1] = {**result[1], "secret": secret}
