"""CoppeliaSim's own binary format of a packed table: what ``sim.packTable(t)`` (scheme 0, the
default of CoppeliaSim 4.x) writes and scenes saved by CoppeliaSim keep in their custom data
(a model-library conveyor's ``__config__``, ``__fingerPrint__``...), read as coppeliaSimLib's
``CInterfaceStack::pushTableFromBuffer`` reads it.

The buffer is a version byte (0-5: 0 from Lua 5.1, whose numbers were all doubles; never a
byte that can start CBOR), the table, then one byte per string (its text/buffer flags, in the
order the strings were written) and 255. A table (``CInterfaceStackTable::getObjectData``) is
a flags byte (1 an array, 2 a circular reference), a uint32 count of objects (a map's keys and
values both count) and the objects, each a type byte (``sim_stackitem_*``) and its data: null
nothing, double 8 bytes, bool 1, string a uint32 length and the bytes, table as above,
integer 8 bytes; all little-endian as CoppeliaSim's platforms write them.
"""

from __future__ import annotations

import struct
from typing import Any

from simx_wire.protocol import ArgumentError

__all__ = ["is_stack_buffer", "unpack_stack_table"]

#: ``sim_stackitem_null``, ``_double``, ``_bool``, ``_string``, ``_table``, ``_integer``.
NULL, DOUBLE, BOOL, STRING, TABLE, INTEGER = 0, 1, 2, 3, 4, 9
#: The newest version byte CoppeliaSim writes (``CInterfaceStack::getBufferFromTable``).
MAX_VERSION = 5
_MAX_DEPTH = 64


def is_stack_buffer(raw: bytes) -> bool:
    """Whether ``raw`` starts as CoppeliaSim's binary packed table (a version byte, then a table's
    flags byte), not as CBOR.

    Args:
        raw: a buffer.

    Returns:
        True for a version byte 0-5 followed by a flags byte 0-3.
    """
    return len(raw) >= 6 and raw[0] <= MAX_VERSION and raw[1] <= 3


class _String:
    """A string read, converted once the flags after the table are known."""

    __slots__ = ("index", "raw")

    def __init__(self, raw: bytes, index: int):
        self.raw, self.index = raw, index


class _Reader:
    def __init__(self, raw: bytes, version: int):
        self.raw, self.at, self.version = raw, 1, version
        self.strings = 0

    def take(self, n: int) -> bytes:
        if self.at + n > len(self.raw):
            raise ArgumentError("unpackTable: the buffer ends inside a packed table (CoppeliaSim's binary format)")
        chunk = self.raw[self.at:self.at + n]
        self.at += n
        return chunk

    def table(self, depth: int) -> list | dict:
        if depth > _MAX_DEPTH:
            raise ArgumentError(f"unpackTable: a packed table nested more than {_MAX_DEPTH} levels")
        flags = self.take(1)[0]
        (count,) = struct.unpack("<I", self.take(4))
        if count > len(self.raw) - self.at:  # every object takes a byte at least
            raise ArgumentError(f"unpackTable: a packed table of {count:,} objects in a {len(self.raw):,}-byte buffer")
        if flags & 1:
            return [self.item(depth) for _ in range(count)]
        if count % 2:
            raise ArgumentError("unpackTable: a packed map with a key and no value")
        out: dict[Any, Any] = {}
        for _ in range(count // 2):
            key = self.item(depth)
            if isinstance(key, (list, dict)):
                raise ArgumentError("unpackTable: a table as a key of a packed map")
            out[key] = self.item(depth)
        return out

    def item(self, depth: int) -> Any:
        kind = self.take(1)[0]
        if kind == NULL:
            return None
        if kind == DOUBLE:
            (v,) = struct.unpack("<d", self.take(8))
            return int(v) if self.version == 0 and v.is_integer() and abs(v) < 2**63 else v
        if kind == INTEGER:
            return struct.unpack("<q", self.take(8))[0]
        if kind == BOOL:
            return self.take(1)[0] != 0
        if kind == STRING:
            (n,) = struct.unpack("<I", self.take(4))
            self.strings += 1
            return _String(self.take(n), self.strings - 1)
        if kind == TABLE:
            return self.table(depth + 1)
        raise ArgumentError(f"unpackTable: item type {kind} of CoppeliaSim's binary packed tables is not supported "
                            "(null, numbers, booleans, strings and tables are)")


def unpack_stack_table(raw: bytes) -> list | dict:
    """The table of a buffer in CoppeliaSim's binary format (module docstring), as
    ``sim.unpackTable`` gives it: an array as a list, a map as a dict; strings as text, bytes
    for those flagged as buffers and for those that are not UTF-8.

    Args:
        raw: the buffer (:func:`is_stack_buffer`).

    Returns:
        The list or dict.

    Raises:
        ArgumentError: a malformed buffer, nested more than 64 levels, or an item type other
            than null, number, boolean, string and table.
    """
    reader = _Reader(raw, raw[0])
    table = reader.table(0)
    aux = raw[reader.at:]
    flags = aux[:-1] if aux.endswith(b"\xff") and len(aux) - 1 == reader.strings else b""

    def plain(value: Any) -> Any:
        if isinstance(value, list):
            return [plain(v) for v in value]
        if isinstance(value, dict):
            return {plain(k): plain(v) for k, v in value.items()}
        if isinstance(value, _String):
            if flags and flags[value.index] & 1:  # a buffer
                return value.raw
            try:
                return value.raw.decode("utf-8")
            except UnicodeDecodeError:
                return value.raw
        return value

    return plain(table)
