"""Decoder for the Huffman body of a ``.ttt``/``.ttm`` file (Marcus Geelnard's Basic
Compression Library coder: the code tree in pre-order, MSB first, bit 1 + 8-bit symbol = leaf,
bit 0 = inner node followed by its "0" then its "1" subtree; then the codes).

Table-driven and vectorised: the bitstream is cut into chunks and one walker per chunk decodes
every chunk in lock step (one numpy gather into a code table per symbol, not per bit). A walker
that started mid-code re-synchronises with the true path (Huffman codes self-synchronise); the
true path enters a chunk where the previous chunk's (correct) walker meets that chunk's walker.
A chunk whose walker is not met within the overlap is walked again from its true entry. Chunks
go in groups so that memory stays bounded (about 20 MB per group) whatever the body's size.
"""

from __future__ import annotations

import numpy as np

from simx_server.scene.ttt.errors import SceneFileError

_CHUNK_BITS = 4096      # bits per walker
_OVERLAP_BITS = 3072    # how far a walker goes into the next chunk to be met there
_GROUP_CHUNKS = 4096    # walkers decoded together
_TABLE_BITS_MAX = 20    # lookup-table window; codes longer than this walk the tree


class _Table:
    """The code tree read from the front of the stream, and its lookup table."""

    def __init__(self, raw: np.ndarray, file: str):
        self.file = file
        self.zero: list[int] = []
        self.one: list[int] = []
        self.symbol: list[int] = []
        bits = np.unpackbits(raw[:400]).tolist()  # a full tree takes at most 2815 bits
        self._pos = 0

        def read(depth: int) -> int:
            if depth > 256 or len(self.symbol) >= 511:
                raise SceneFileError(file, "body", "Huffman code tree malformed (too deep or too many nodes)")
            if self._pos >= len(bits):
                raise SceneFileError(file, "body", "Huffman code tree truncated")
            node = len(self.symbol)
            self.zero.append(-1)
            self.one.append(-1)
            self.symbol.append(-1)
            leaf = bits[self._pos]
            self._pos += 1
            if leaf:
                if self._pos + 8 > len(bits):
                    raise SceneFileError(file, "body", "Huffman code tree truncated")
                value = 0
                for b in bits[self._pos:self._pos + 8]:
                    value = (value << 1) | b
                self.symbol[node] = value
                self._pos += 8
            else:
                self.zero[node] = read(depth + 1)
                self.one[node] = read(depth + 1)
            return node

        read(0)
        self.start = self._pos
        codes, todo = [], [(0, 0, 0)]
        while todo:
            node, code, length = todo.pop()
            if self.symbol[node] >= 0:
                codes.append((self.symbol[node], code, length))
            else:
                todo.append((self.zero[node], code << 1, length + 1))
                todo.append((self.one[node], (code << 1) | 1, length + 1))
        self.k = k = max(1, min(max(length for _, _, length in codes), _TABLE_BITS_MAX))
        # window of k bits -> length << 8 | symbol (length 0: a code longer than k bits)
        self.table = np.zeros(1 << k, dtype=np.int64)
        self.has_long = any(length > k for _, _, length in codes)
        for symbol, code, length in codes:
            if 0 < length <= k:
                lo = code << (k - length)
                self.table[lo:lo + (1 << (k - length))] = (length << 8) | symbol
        self.shift = np.int64(32 - k)
        self.mask = np.uint32((1 << k) - 1)
        padded = np.concatenate([raw, np.zeros(8, dtype=np.uint8)]).astype(np.uint32)
        # every byte index -> the big-endian 32-bit word starting there
        self.words = (padded[:-3] << 24) | (padded[1:-2] << 16) | (padded[2:-1] << 8) | padded[3:]
        self.end = len(raw) * 8
        self._table_list: list[int] | None = None

    def lookup(self, p: np.ndarray) -> np.ndarray:
        """``length << 8 | symbol`` of the codes starting at bit positions ``p`` (int64)."""
        w = (self.words[p >> 3] >> (self.shift - (p & 7)).astype(np.uint32)) & self.mask
        code = self.table[w]
        if self.has_long:
            for i in np.flatnonzero(code < 256):  # codes longer than the table: walk the tree
                node, q = 0, int(p[i])
                while self.symbol[node] < 0:
                    bit = (int(self.words[q >> 3]) >> (31 - (q & 7))) & 1 if q < self.end else 0
                    node = self.one[node] if bit else self.zero[node]
                    q += 1
                code[i] = ((q - int(p[i])) << 8) | self.symbol[node]
        return code

    def walk_one(self, p: int, limit: int) -> tuple[np.ndarray, np.ndarray]:
        """One walker from ``p`` (a true code start) to its first code start at or past
        ``limit``, in plain Python (cheaper than numpy for a single walker)."""
        if self._table_list is None:
            self._table_list = self.table.tolist()
        first = p >> 3
        words = self.words[first:min((limit >> 3) + 64, len(self.words))].tolist()
        table, shift, mask = self._table_list, 32 - self.k, (1 << self.k) - 1
        positions, symbols = [], []
        while True:
            positions.append(p)
            i = (p >> 3) - first
            if p >= limit or i >= len(words):
                symbols.append(0)
                break
            code = table[(words[i] >> (shift - (p & 7))) & mask]
            if code < 256:  # a code longer than the table
                code = int(self.lookup(np.array([p], np.int64))[0])
            symbols.append(code & 0xFF)
            p = min(p + (code >> 8), self.end)
        return np.array(positions, np.int64), np.array(symbols, np.uint8)

    def walk(self, p: np.ndarray, limits: np.ndarray, max_steps: int):
        """Advance each walker until it reaches its limit (it may go a few codes further).
        Returns positions (walker x step, int64) and symbols (uint8)."""
        end = self.end
        pos_steps, code_steps = [], []
        while len(pos_steps) < max_steps and not (p >= limits).all():
            for _ in range(32):
                code = self.lookup(p)
                pos_steps.append(p)
                code_steps.append(code)
                p = np.minimum(p + (code >> 8), end)
        pos_steps.append(p)  # where each walker stopped (at or past its limit)
        code_steps.append(self.lookup(p))
        return np.stack(pos_steps, axis=1), (np.stack(code_steps, axis=1) & 0xFF).astype(np.uint8)


def decode(data: bytes | memoryview, size: int, file: str = "<bytes>") -> bytes:
    """Decode a Huffman body into exactly ``size`` bytes.

    Args:
        data: the compressed body (the file from byte 1021 on).
        size: the uncompressed size the header declares (the caller bounds it).
        file: the file's name, for errors.

    Raises:
        SceneFileError: a malformed code tree, or a stream that ends before ``size`` bytes.
    """
    if size <= 0:
        return b""
    raw = np.frombuffer(data, dtype=np.uint8)
    table = _Table(raw, file)
    if table.symbol[0] >= 0:  # a single symbol: its code has no bits
        return bytes([table.symbol[0]]) * size
    parts, produced, entry, end = [], 0, table.start, table.end
    group_bits = _GROUP_CHUNKS * _CHUNK_BITS
    while produced < size and entry < end:
        group_end = min(entry + group_bits, end)
        out, entry = _decode_group(table, entry, group_end, size - produced)
        parts.append(out)
        produced += out.size
    if produced < size:
        raise SceneFileError(file, "body", f"Huffman stream ends after {produced:,} of {size:,} bytes")
    return np.concatenate(parts)[:size].tobytes()


def _decode_group(table: _Table, entry: int, group_end: int, wanted: int):
    """Symbols of the true path from ``entry`` (a true code start) up to the first code start
    at or past ``group_end``; returns them and that code start."""
    end = table.end
    n = max(1, (group_end - entry) // _CHUNK_BITS)
    bounds = entry + np.arange(n + 1, dtype=np.int64) * _CHUNK_BITS
    bounds[n] = group_end
    limits = np.minimum(bounds[1:] + _OVERLAP_BITS, end)
    limits[-1] = group_end
    pos, sym = table.walk(bounds[:-1].copy(), limits, wanted + 64)
    sync = np.empty(n + 1, dtype=np.int64)
    sync[0] = entry
    sync[n] = group_end
    redone: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    if n > 1:
        span = int(limits.max()) - entry + 1  # marks are indexed from the group's entry
        marks = [np.zeros(span + 1, dtype=bool), np.zeros(span + 1, dtype=bool)]
        valid = pos < limits[:, None]
        for parity in (0, 1):  # the code starts each walker visited before its limit
            marks[parity][pos[parity::2][valid[parity::2]] - entry] = True
        for j in range(1, n):
            prev = redone[j - 1][0] if j - 1 in redone else pos[j - 1]
            cand = prev[(prev >= bounds[j]) & (prev < limits[j - 1])]
            hit = cand[marks[j % 2][cand - entry]]
            if hit.size:
                sync[j] = hit[0]
                continue
            # not met within the overlap (periodic data keeps a walker out of phase):
            # walk chunk j again from its true entry, one code at a time
            sync[j] = start = int(cand[0]) if cand.size else int(bounds[j])
            row = pos[j]
            marks[j % 2][row[row < limits[j]] - entry] = False
            redone[j] = table.walk_one(start, int(limits[j]))
            marks[j % 2][redone[j][0][redone[j][0] < limits[j]] - entry] = True
            pos[j] = end  # the re-walked row is assembled from ``redone``
    last = redone[n - 1][0] if n - 1 in redone else pos[n - 1]
    after = last[last >= group_end]
    nxt = int(after[0]) if after.size else end
    keep = (pos >= sync[:-1, None]) & (pos < sync[1:, None])
    flat = sym[keep]
    if redone:
        pieces = np.split(flat, np.cumsum(keep.sum(axis=1))[:-1])
        for j, (p_j, s_j) in redone.items():
            pieces[j] = s_j[(p_j >= sync[j]) & (p_j < sync[j + 1])]
        flat = np.concatenate(pieces)
    return flat[:wanted], nxt
