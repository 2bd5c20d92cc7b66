"""The container and the tagged records of a ``.ttt``/``.ttm`` file.

A file is a 1021-byte header and one body (Huffman-coded or raw). The body is a list of records:
3 ASCII tag bytes, an i32 byte count, the payload; ``EOO`` ends a list (no count), ``EOF`` the
top level, ``NXT`` separates a scene object's common part from its type part. Payloads that are
lists include their own ``EOO`` in their count, so every record can be skipped by its count.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from simx_server.scene.ttt import errors as E
from simx_server.scene.ttt import huffman
from simx_server.scene.ttt.errors import SceneFileError

HEADER_BYTES = 1021
_ENDS = (b"EOO", b"EOF")


@dataclass(frozen=True)
class Header:
    """The container header (all little-endian).

    Attributes:
        serialization: serialization version (18 = V-REP 3.1.3 ... 24 = CoppeliaSim 4.5.1).
        min_serialization: the oldest version able to read the file.
        compressed: True for a Huffman body.
        body_size: the uncompressed body size, bytes.
        program_version: e.g. 30600 = V-REP 3.6.0, 40501 = CoppeliaSim 4.5.1.
        file_type: 0 (V-REP 3.x), 1 scene, 2 model.
    """

    serialization: int
    min_serialization: int
    compressed: bool
    body_size: int
    program_version: int
    file_type: int


def read_header(data: bytes, file: str) -> Header:
    """Parse and check the header. Raises SceneFileError (not a V-REP file, a version this
    reader does not know, a body size beyond ``MAX_BODY_BYTES``)."""
    if len(data) < HEADER_BYTES or data[:4] != b"VREP":
        raise SceneFileError(file, "header", "not a V-REP/CoppeliaSim file (no 'VREP' header of 1021 bytes)")
    if len(data) > E.MAX_FILE_BYTES:
        raise SceneFileError(file, "header", f"{len(data):,} bytes, more than MAX_FILE_BYTES = {E.MAX_FILE_BYTES:,}")
    ser, min_ser, comp, size = struct.unpack_from("<iiBi", data, 4)
    program, = struct.unpack_from("<H", data, 21)
    file_type = data[28]
    if not 18 <= ser <= 40 or min_ser > 25:
        raise SceneFileError(file, "header", f"serialization version {ser} (minimum {min_ser}) is not 18 to 25")
    if comp not in (0, 1):
        raise SceneFileError(file, "header", f"unknown compression {comp}")
    if not 0 < size <= E.MAX_BODY_BYTES:
        raise SceneFileError(file, "header", f"body size {size:,} is not 1 to MAX_BODY_BYTES = {E.MAX_BODY_BYTES:,}")
    if not comp and size > len(data) - HEADER_BYTES:
        raise SceneFileError(file, "header", f"body size {size:,} beyond the file's {len(data) - HEADER_BYTES:,} bytes")
    return Header(ser, min_ser, bool(comp), size, program, file_type)


def read_body(data: bytes, file: str) -> tuple[Header, bytes]:
    """The header and the decoded body of a whole file's bytes."""
    header = read_header(data, file)
    raw = memoryview(data)[HEADER_BYTES:]
    if header.compressed:
        # a Huffman code is at least 1 bit a byte: a body of N bytes needs at least N / 8 of stream
        if header.body_size > len(raw) * 8 + 8:
            raise SceneFileError(file, "body", f"declared size {header.body_size:,} cannot come from "
                                 f"{len(raw):,} bytes of Huffman stream")
        body = huffman.decode(raw, header.body_size, file)
    else:
        body = bytes(raw[:header.body_size])
    return header, body


class Records:
    """One record list: ``(tag, payload)`` pairs, tags as str; duplicates kept in order.

    Args:
        buf: the bytes holding the list; ``start``/``end`` its span.
        file, path: for errors (``path`` is the tags leading here, e.g. ``"SHP/Ge2"``).
        depth: nesting depth, bounded by ``MAX_NESTING``.
        counter: one-element list counting records read in the file (bounded by ``MAX_RECORDS``).

    After the list's ``EOO``/``EOF``, :attr:`end` is where the list stopped (a mesh record holds
    two lists back to back).
    """

    def __init__(self, buf: bytes | memoryview, file: str, path: str = "", start: int = 0,
                 end: int | None = None, depth: int = 0, counter: list[int] | None = None,
                 stop_at_nxt: bool = False):
        if depth > E.MAX_NESTING:
            raise SceneFileError(file, path, f"records nested deeper than MAX_NESTING = {E.MAX_NESTING}")
        self.file, self.path, self.depth = file, path, depth
        self.counter = counter if counter is not None else [0]
        self.items: list[tuple[str, memoryview]] = []
        mv = memoryview(buf)
        end = len(mv) if end is None else end
        p = start
        while True:
            if p + 3 > end:  # a list ends without its EOO: what the file had, with the path
                self.end = end
                self.terminated = False
                break
            tag = bytes(mv[p:p + 3])
            p += 3
            if tag in _ENDS:
                self.end = p
                self.terminated = True
                break
            if tag == b"NXT":
                if stop_at_nxt:
                    self.end = p
                    self.terminated = True
                    break
                continue
            if p + 4 > end:
                raise SceneFileError(file, f"{path}/{tag.decode('latin-1')}", "record truncated (no byte count)")
            n, = struct.unpack_from("<i", mv, p)
            p += 4
            name = tag.decode("latin-1")
            if n < 0 or p + n > end:
                raise SceneFileError(file, f"{path}/{name}" if path else name,
                                     f"declared size {n:,} beyond its list ({end - p:,} bytes left)")
            self.items.append((name, mv[p:p + n]))
            p += n
            self.counter[0] += 1
            if self.counter[0] > E.MAX_RECORDS:
                raise SceneFileError(file, path or "body", f"more than MAX_RECORDS = {E.MAX_RECORDS:,} records")

    def __iter__(self):
        return iter(self.items)

    def get(self, *tags: str) -> memoryview | None:
        """The payload of the first present tag among ``tags`` (give the newest first)."""
        for tag in tags:
            for name, payload in self.items:
                if name == tag:
                    return payload
        return None

    def sub(self, tag: str, payload: memoryview | None = None, start: int = 0) -> "Records":
        """The record list inside a payload (default: the first ``tag`` record's)."""
        if payload is None:
            payload = self.get(tag)
            if payload is None:
                payload = memoryview(b"EOO")
        return Records(payload, self.file, f"{self.path}/{tag}" if self.path else tag, start, None,
                       self.depth + 1, self.counter)

    def error(self, tag: str, message: str) -> SceneFileError:
        return SceneFileError(self.file, f"{self.path}/{tag}" if self.path else tag, message)

    # ---------------------------------------------------------------- typed values
    def floats(self, new: str | None, old: str | None, count: int) -> np.ndarray | None:
        """``count`` numbers from the first present of ``new`` (f64 twin, 4.5+) or ``old`` (f32);
        None when neither is there."""
        for tag, dtype in ((new, "<f8"), (old, "<f4")):
            if tag is None:
                continue
            payload = self.get(tag)
            if payload is not None:
                size = np.dtype(dtype).itemsize * count
                if len(payload) < size:
                    raise self.error(tag, f"{len(payload)} bytes, expected at least {size}")
                return np.frombuffer(payload[:size], dtype=dtype).astype(np.float64)
        return None

    def ints(self, tag: str, count: int, dtype: str = "<i4") -> np.ndarray | None:
        payload = self.get(tag)
        if payload is None:
            return None
        size = np.dtype(dtype).itemsize * count
        if len(payload) < size:
            raise self.error(tag, f"{len(payload)} bytes, expected at least {size}")
        return np.frombuffer(payload[:size], dtype=dtype).astype(np.int64)

    def int(self, tag: str, default: int = 0) -> int:
        v = self.ints(tag, 1)
        return default if v is None else int(v[0])

    def byte(self, tag: str, default: int = 0) -> int:
        payload = self.get(tag)
        return default if payload is None or len(payload) < 1 else payload[0]

    def string(self, tag: str, default: str = "") -> str:
        payload = self.get(tag)
        if payload is None:
            return default
        return read_string(payload, 0, self, tag)[0]


def read_string(payload: memoryview, p: int, where: Records, tag: str) -> tuple[str, int]:
    """An i32-length-prefixed string at ``p``; returns it and the position after it."""
    if p + 4 > len(payload):
        raise where.error(tag, "string truncated")
    n, = struct.unpack_from("<i", payload, p)
    if n < 0 or n > E.MAX_STRING_BYTES or p + 4 + n > len(payload):
        raise where.error(tag, f"string of declared size {n:,} beyond its record")
    return bytes(payload[p + 4:p + 4 + n]).decode("utf-8", "replace"), p + 4 + n


def light_decode(text: bytes) -> bytes:
    """Undo the light obfuscation of stored script text (``Ste``): each byte but the first and
    last shifted by amounts from its index and those two bytes (signed char arithmetic)."""
    n = len(text)
    if n < 3:
        return text
    buf = np.frombuffer(text, dtype=np.int8).astype(np.int64)
    first, last = int(buf[0]), int(buf[-1])
    start = int(first / 2)  # C integer division truncates toward zero
    end_k = last * 3
    i = np.arange(1, n - 1)
    shift = np.zeros(n - 2, dtype=np.int64)
    shift += np.where(i & 1, i + start + end_k, 0)
    shift -= np.where(i & 2, 3 * i + start, 0)
    shift += np.where(i & 4, i // 2 + end_k, 0)
    out = buf.copy()
    out[1:-1] = buf[1:-1] + shift
    return (out & 0xFF).astype(np.uint8).tobytes()


_PACK_CHUNK = 1024   # bytes walked by one walker of unpack_indices
_PACK_GROUP = 4096   # chunks walked together (their positions: 4 x 4096 x 1024 int32 = 64 MiB at most)


def packed_count(payload: memoryview, where: Records, tag: str) -> int:
    """The declared value count of a packed index array (``In2``), checked against its record
    and ``MAX_MESH_TRIANGLES`` before anything is decoded."""
    if len(payload) < 4:
        raise where.error(tag, "truncated")
    count, = struct.unpack_from("<i", payload, 0)
    if count < 0 or count > 3 * E.MAX_MESH_TRIANGLES or count > len(payload) - 4:
        raise where.error(tag, f"index count {count:,} beyond its record or 3 x MAX_MESH_TRIANGLES = "
                          f"{3 * E.MAX_MESH_TRIANGLES:,}")
    return count


def _value_starts(data: np.ndarray, count: int, where: Records, tag: str) -> np.ndarray:
    """Where each of the first ``count`` packed values starts in ``data`` (its first byte's top
    two bits: how many bytes follow), walked with numpy: the bytes are cut into chunks, and four
    walkers per chunk start at its first four bytes, all chunks in lock step. A value is at most
    4 bytes long, so the true chain enters each chunk at one of those four; which one follows
    from where the previous chunk's true walker left it."""
    n = len(data)
    step = ((data >> 6) + 1).astype(np.int32)
    chunks = -(-n // _PACK_CHUNK)
    out: list[np.ndarray] = []
    found, j = 0, 0
    for c0 in range(0, chunks, _PACK_GROUP):
        c1 = min(chunks, c0 + _PACK_GROUP)
        base = np.arange(c0, c1, dtype=np.int32) * _PACK_CHUNK
        pos = (base[:, None] + np.arange(4, dtype=np.int32)).ravel()  # walker 4c + k starts at k
        limit = np.minimum(np.repeat(base + _PACK_CHUNK, 4), n)
        seen = []
        active = pos < limit
        while active.any():
            seen.append(np.where(active, pos, -1))
            pos = pos + np.where(active, step[np.minimum(pos, n - 1)], 0)
            active = pos < limit
        trail = np.stack(seen) if seen else np.empty((0, len(pos)), np.int32)
        cols = np.empty(c1 - c0, dtype=np.int64)
        for c in range(c1 - c0):  # the true walker of each chunk, from the previous one's exit
            if j > 3:
                break
            cols[c] = 4 * c + j
            j = int(pos[4 * c + j]) - int(base[c]) - _PACK_CHUNK
        else:
            c = c1 - c0
        taken = trail[:, cols[:c]].T.ravel()
        taken = taken[taken >= 0]
        out.append(taken[:count - found])
        found += len(out[-1])
        if found >= count or j > 3:
            break
    starts = np.concatenate(out) if out else np.empty(0, np.int32)
    if len(starts) < count:
        raise where.error(tag, f"packed indices end after {len(starts):,} of {count:,}")
    return starts


def unpack_indices(payload: memoryview, where: Records, tag: str) -> np.ndarray:
    """The packed, delta-coded index array of older files (``In2``): i32 count, then per index
    1-4 bytes (top 2 bits of the first = extra byte count; biased delta to the previous), as
    CoppeliaSim's ``CMeshRoutines``' packed index format; decoded with numpy (no per-value
    Python step), bounded by :func:`packed_count` first.

    Returns:
        The indices, (count,) int64.

    Raises:
        SceneFileError: a count beyond its record or bound, or values that end early.
    """
    count = packed_count(payload, where, tag)
    data = np.frombuffer(payload[4:], dtype=np.uint8)
    if count == 0:
        return np.zeros(0, np.int64)
    starts = _value_starts(data, count, where, tag)
    extra = data[starts] >> 6
    if int(starts[-1] + extra[-1]) >= len(data):
        raise where.error(tag, "packed indices truncated")
    padded = np.concatenate([data, np.zeros(4, np.uint8)])
    # int32 throughout (a value's delta is within +-2**30): a quarter of int64's memory
    diff = (padded[starts] & 0x3F).astype(np.int32)
    for k in (1, 2, 3):
        more = np.flatnonzero(extra >= k)
        diff[more] += padded[starts[more] + k].astype(np.int32) << (8 * k - 2)
    diff -= np.array([31, 8191, 2097151, 536870911], dtype=np.int32)[extra]
    return np.cumsum(diff, dtype=np.int64)
