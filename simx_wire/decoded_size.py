"""What a msgpack message will cost once decoded, measured on its bytes before it is decoded.

A request is bounded by its bytes (the server's ``limits.MAX_REQUEST_BYTES``), but a byte of
msgpack can become a Python object of 60-90 bytes: one 60 MiB request of empty arrays took a
server from 216 MB to 4.7 GB (issue 23). :func:`measure` walks the message's type bytes without
building anything and adds up the memory its decoded value takes (each value's object and its
reference in the list or map that holds it), so that a peer can refuse it first.

Costs are CPython's (64-bit, measured with tracemalloc) rounded up: ``None``, booleans and the
integers CPython caches (-5..256) cost only their reference (8 bytes); another integer 48, a
float 32, a string 88 plus its bytes, a bin 48 plus its bytes, an array 64 plus 8 per item, a map
240 plus 48 per pair, an ext 104 plus its bytes. A run of same-width scalars in one array (a
list of floats, of small integers, of empty arrays) is measured with a few byte counts, not one
step per item.

Pure Python, no dependency beyond the standard library: the client imports it through
:mod:`simx_wire.protocol`.
"""

from __future__ import annotations

#: Bytes of an item's reference in the array or map that holds it, counted for every item.
REF = 8
_INT, _FLOAT = 40, 24  # a new int / float object (beyond its reference)
_STR, _BIN, _EXT = 80, 40, 96  # str, bytes and ExtType objects, beyond their data
_ARRAY = 56  # a list with its GC header; its items' references are counted with the items
_MAP, _PAIR = 232, 40  # a dict, and each entry of its table
#: The worst cost of one byte of msgpack (an empty map: 1 byte, 72 decoded; a map of one small
#: pair: 3 bytes, 232): ``RATIO x len(payload)`` bounds any message's decoded size.
RATIO = 96

# Kinds of type bytes.
_SCALAR, _STRING, _BYTES, _EXTENSION, _ARR, _DICT, _BAD = range(7)


def _table() -> list[tuple[int, int, int, int]]:
    """For each of the 256 type bytes: ``(kind, header bytes, payload or count, cost)``.
    For _SCALAR the third item is the whole width; for the others, with a header of 1 byte it
    is the fixed length or count (fixstr, fixarray, fixmap, fixext), else -1: read from the
    header's next ``header - 1`` bytes."""
    t = [(_BAD, 1, 0, 0)] * 256
    for b in range(0x00, 0x80):
        t[b] = (_SCALAR, 1, 1, 0)  # positive fixint, cached
    for b in range(0x80, 0x90):
        t[b] = (_DICT, 1, b & 0x0F, 0)
    for b in range(0x90, 0xA0):
        t[b] = (_ARR, 1, b & 0x0F, 0)
    # An empty array or map is a value of one byte, like a scalar: runs of them are measured at once.
    t[0x80], t[0x90] = (_SCALAR, 1, 1, _MAP), (_SCALAR, 1, 1, _ARRAY)
    for b in range(0xA0, 0xC0):
        t[b] = (_STRING, 1, b & 0x1F, 0)
    for b in range(0xE0, 0x100):
        t[b] = (_SCALAR, 1, 1, 0 if b >= 0xFB else _INT)  # negative fixint; -5..-1 cached
    t[0xC0] = t[0xC2] = t[0xC3] = (_SCALAR, 1, 1, 0)  # nil, false, true
    t[0xC4], t[0xC5], t[0xC6] = (_BYTES, 2, -1, 0), (_BYTES, 3, -1, 0), (_BYTES, 5, -1, 0)
    t[0xC7], t[0xC8], t[0xC9] = (_EXTENSION, 2, -1, 0), (_EXTENSION, 3, -1, 0), (_EXTENSION, 5, -1, 0)
    t[0xCA], t[0xCB] = (_SCALAR, 1, 5, _FLOAT), (_SCALAR, 1, 9, _FLOAT)
    t[0xCC] = (_SCALAR, 1, 2, 0)  # uint8: 0..255, cached
    t[0xCD], t[0xCE], t[0xCF] = (_SCALAR, 1, 3, _INT), (_SCALAR, 1, 5, _INT), (_SCALAR, 1, 9, _INT)
    t[0xD0], t[0xD1], t[0xD2], t[0xD3] = ((_SCALAR, 1, w, _INT) for w in (2, 3, 5, 9))
    for b, n in zip(range(0xD4, 0xD9), (1, 2, 4, 8, 16), strict=True):
        t[b] = (_EXTENSION, 1, n + 1, 0)  # fixext: a type byte and n bytes
    t[0xD9], t[0xDA], t[0xDB] = (_STRING, 2, -1, 0), (_STRING, 3, -1, 0), (_STRING, 5, -1, 0)
    t[0xDC], t[0xDD] = (_ARR, 3, -1, 0), (_ARR, 5, -1, 0)
    t[0xDE], t[0xDF] = (_DICT, 3, -1, 0), (_DICT, 5, -1, 0)
    return t


_TYPES = _table()
#: Same-width scalar type bytes, by width, each with its cost: the runs measured at once.
_WIDTHS: dict[int, list[tuple[int, int]]] = {}
for _b, (_k, _h, _w, _c) in enumerate(_TYPES):
    if _k == _SCALAR:
        _WIDTHS.setdefault(_w, []).append((_b, _c))
_OF_WIDTH = {w: bytes(b for b, _ in codes) for w, codes in _WIDTHS.items()}
#: Per width, each cost but 0 with the type bytes that are *not* of that cost (deleted to count
#: those that are).
_COSTLY: dict[int, list[tuple[bytes, int]]] = {}
for _w, _codes in _WIDTHS.items():
    for _c in sorted({c for _, c in _codes if c}):
        _COSTLY.setdefault(_w, []).append((bytes(b for b in range(256) if (b, _c) not in _codes), _c))
_RUN = 8  # arrays of at least this many items try the run measure first


class DecodedSizeError(ValueError):
    """A message over a bound (``bound`` names which: ``"items"`` or ``"bytes"``), or one whose
    type bytes cannot be read (``bound`` None); raised before anything is decoded."""

    def __init__(self, message: str, bound: str | None = None):
        super().__init__(message)
        self.bound = bound


def measure(data: bytes, max_items: int, max_bytes: int) -> tuple[int, int]:
    """``(items, decoded bytes)`` of the one msgpack value that ``data`` starts with.

    Items are every value at any depth (containers, map keys and values included); decoded
    bytes are their estimated memory once decoded (see the module's costs; an upper bound).
    Walks at most ``max_items`` values one by one; same-width scalar runs cost a few C calls.

    Raises:
        DecodedSizeError: more than ``max_items`` items or ``max_bytes`` decoded bytes
            (``bound`` says which), or bytes that are not msgpack (truncated, the unused type
            byte 0xc1): the caller refuses the message either way.
    """
    types, end = _TYPES, len(data)
    pos = items = cost = 0
    need = 1  # values still to read
    try:
        while need:
            if items > max_items or cost > max_bytes:
                break
            kind, head, n, c = types[data[pos]]
            need -= 1
            items += 1
            if kind == _SCALAR:
                pos += n
                cost += REF + c
                continue
            if n < 0:
                n = int.from_bytes(data[pos + 1 : pos + head], "big")
            pos += head
            if n > end - pos:  # longer than the rest, or more items than bytes left
                raise DecodedSizeError("truncated msgpack")
            if kind == _STRING:
                pos += n
                cost += REF + _STR + n
            elif kind == _ARR:
                cost += REF + _ARRAY
                if items + n > max_items:  # its items alone are too many: refused unread
                    items += n
                    break
                if n >= _RUN and pos < end:
                    run = _run(data, pos, n)
                    if run is not None:
                        pos, run_cost = run
                        items += n
                        cost += run_cost
                        continue
                need += n
            elif kind == _BYTES:
                pos += n
                cost += REF + _BIN + n
            elif kind == _DICT:
                cost += REF + _MAP + _PAIR * n
                if items + 2 * n > max_items:
                    items += 2 * n
                    break
                need += 2 * n
            elif kind == _EXTENSION:
                pos += n + (head > 1)  # fixext's n counts its type byte; ext 8/16/32 add one
                cost += REF + _EXT + n
            else:
                raise DecodedSizeError(f"byte 0x{data[pos - head]:02x} at {pos - head} is not a msgpack type")
    except IndexError:
        raise DecodedSizeError("truncated msgpack") from None
    if items > max_items:
        raise DecodedSizeError(f"more than {max_items:,} values", "items")
    if cost > max_bytes:
        raise DecodedSizeError(f"more than {max_bytes:,} bytes once decoded", "bytes")
    if need or pos > end:
        raise DecodedSizeError("truncated msgpack")
    return items, cost


def _run(data: bytes, pos: int, n: int) -> tuple[int, int] | None:
    """An array's ``n`` items at ``pos`` when all are scalars of one width: ``(position after
    them, their cost)``; None otherwise (the caller walks them one by one)."""
    kind, _, width, _ = _TYPES[data[pos]]
    if kind != _SCALAR:
        return None
    types = data[pos : pos + width * n : width]  # every item's type byte, if they are all this wide
    if len(types) != n or types.translate(None, _OF_WIDTH[width]):
        return None
    cost = sum(len(types.translate(None, others)) * c for others, c in _COSTLY.get(width, ()))
    return pos + width * n, n * REF + cost
