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
_OVERLAP_BITS = 1024    # how far a walker goes into the next chunk to be met there
_GROUP_CHUNKS = 512    # walkers decoded together
_TABLE_BITS_MAX = 20    # lookup-table window; codes longer than this walk the tree
_SLICE_WORDS = 1 << 17  # words turned into per-position codes at a time
_SMALL_TABLE_BITS = 15  # the first-level table (64 KB, in cache) for the per-position pass
_MAX_LONG_CODES = 1_000_000  # bit positions per group where a longer code starts
_MARGIN_BYTES = 32 * 32 // 8 + 16  # room for walkers past their limit within one batch


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
        self.table32 = self.table.astype(np.int32)
        self.k_small = ks = min(k, _SMALL_TABLE_BITS)
        full = self.table32[(np.arange(1 << ks, dtype=np.int64) << (k - ks))]
        self.table_small = np.where((full >> 8) <= ks, full, 0).astype(np.int16)
        self.shift = np.int64(32 - k)
        self.mask = np.uint32((1 << k) - 1)
        padded = np.concatenate([raw, np.zeros(8 + _MARGIN_BYTES, dtype=np.uint8)]).astype(np.uint32)
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
            self._table_list = self.table_small.tolist()
        first = p >> 3
        words = self.words[first:min((limit >> 3) + 64, len(self.words))].tolist()
        table, shift, mask = self._table_list, 32 - self.k_small, (1 << self.k_small) - 1
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

    def codes_at(self, first: int, last: int) -> tuple[np.ndarray, int]:
        """``length << 8 | symbol`` of the code starting at every bit position from ``first`` to
        ``last`` (and a margin for walkers that overshoot), as int32; and the position of its
        element 0. One table gather per bit position, done once, so that a walker's step is
        a single gather."""
        i0 = first >> 3
        i1 = min((last >> 3) + _MARGIN_BYTES, len(self.words))
        w = self.words[i0:i1]
        # first a small table (fits the CPU cache); the few positions that start a longer code
        # look again in the full one. Slices of words bound the temporaries.
        ks = self.k_small
        shifts = (32 - ks - np.arange(8)).astype(np.intp)
        codes = np.empty((i1 - i0) * 8, np.int16)  # length << 8 | symbol (at most 20 << 8 | 255)
        wide = w.astype(np.intp)  # indices of the platform's size: the gather converts none
        for a in range(0, i1 - i0, _SLICE_WORDS):
            window = (wide[a:a + _SLICE_WORDS, None] >> shifts[None, :]) & ((1 << ks) - 1)
            np.take(self.table_small, window.ravel(), out=codes[8 * a:8 * (a + len(window))])
        if ks < self.k:
            more = np.flatnonzero(codes < 256)
            at = more + i0 * 8
            wk = (w[(at >> 3) - i0] >> (32 - self.k - (at & 7)).astype(np.uint32)) & self.mask
            codes[more] = self.table32[wk]
        if self.has_long:
            slow = np.flatnonzero(codes < 256)
            if slow.size > _MAX_LONG_CODES:
                raise SceneFileError(self.file, "body", f"Huffman codes longer than {self.k} bits at "
                                     f"{slow.size:,} positions, more than {_MAX_LONG_CODES:,}")
            if slow.size:
                codes[slow] = self.lookup(slow.astype(np.int64) + i0 * 8)
        return codes, i0 * 8

    def walk(self, p: np.ndarray, limits: np.ndarray, max_steps: int, bits_per_code: float = 1.0,
             codes_origin: tuple[np.ndarray, int] | None = None):
        """Advance each walker until it reaches its limit (it may go a few codes further).
        Returns positions (int32) and symbols (uint8), step-major ``(steps, walkers)``: rows are
        written in place (``bits_per_code``, the stream's average, sizes the arrays).
        ``codes_origin``: :meth:`codes_at` of a span that covers the walk, when the caller has it."""
        n = len(p)
        codes, origin = codes_origin or self.codes_at(int(p.min(initial=0)), int(limits.max(initial=0)))
        top = len(codes) - 1 - 32 * 32  # a batch of 32 steps moves at most 32 x 32 bits
        q = (p - origin).astype(np.intp)
        lim = (limits - origin).astype(np.intp)
        cap = 64 + int(1.25 * int((limits - p).max(initial=0)) / max(bits_per_code, 1.0))
        pos = np.empty((cap, n), np.int32)
        sym = np.empty((cap, n), np.uint8)
        k = 0
        while True:
            if k + 33 > cap:
                cap = cap * 3 // 2 + 64
                pos = np.resize(pos, (cap, n))
                sym = np.resize(sym, (cap, n))
            if k >= max_steps or (q >= lim).all():
                break
            np.minimum(q, top, out=q)
            for _ in range(32):
                code = codes[q]
                pos[k] = q
                sym[k] = code
                q += code >> 8
                k += 1
        np.minimum(q, top, out=q)
        pos[k] = q  # where each walker stopped (at or past its limit)
        sym[k] = codes[q]
        pos = pos[:k + 1]
        pos += origin  # back to bit positions in the stream
        np.minimum(pos, self.end, out=pos)
        return pos, sym[:k + 1]


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
    bits_per_code = (end - entry) / size  # the stream's average code length
    while produced < size and entry < end:
        group_end = min(entry + group_bits, end)
        out, entry = _decode_group(table, entry, group_end, size - produced, bits_per_code)
        parts.append(out)
        produced += out.size
    if produced < size:
        raise SceneFileError(file, "body", f"Huffman stream ends after {produced:,} of {size:,} bytes")
    return np.concatenate(parts)[:size].tobytes()


def _decode_group(table: _Table, entry: int, group_end: int, wanted: int, bits_per_code: float):
    """Symbols of the true path from ``entry`` (a true code start) up to the first code start
    at or past ``group_end``; returns them and that code start."""
    end = table.end
    n = max(1, (group_end - entry) // _CHUNK_BITS)
    bounds = entry + np.arange(n + 1, dtype=np.int64) * _CHUNK_BITS
    bounds[n] = group_end
    limits = np.minimum(bounds[1:] + _OVERLAP_BITS, end)
    limits[-1] = group_end
    span_codes = table.codes_at(entry, int(limits.max()))  # shared with the re-walks below
    pos, sym = table.walk(bounds[:-1].copy(), limits, wanted + 64, bits_per_code, span_codes)  # (steps, walkers)
    cols = np.arange(n)
    sync = np.empty(n + 1, dtype=np.int64)
    sync[0] = entry
    sync[n] = group_end
    redone: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    if n > 1:
        span = int(limits.max()) - entry + 2  # marks are indexed from the group's entry
        marks = np.zeros((2, span), dtype=bool)  # by walker parity: code starts in the overlaps
        # walker j's head, up to the end of the previous walker's overlap
        head = int((pos[:, 1:] < limits[None, :-1]).sum(axis=0).max())
        h = pos[:head, 1:]
        ok = h < limits[None, :-1]
        for parity in (0, 1):  # walker j = column j - 1 of h
            sel = slice(1 - parity, None, 2)
            marks[parity][h[:, sel][ok[:, sel]] - entry] = True
        # walker j-1's tail from bounds[j] to its limit: its first code start that walker j
        # visited too is where the true path (right on walker j-1) enters chunk j
        start = (pos[:, :-1] < bounds[None, 1:n]).sum(axis=0)
        stop = (pos[:, :-1] < limits[None, :-1]).sum(axis=0)
        width = int((stop - start).max(initial=0)) + 1
        rows = np.minimum(start[None, :] + np.arange(width)[:, None], len(pos) - 1)
        tail = pos[rows, cols[None, :-1]].astype(np.int64)
        inside = np.arange(width)[:, None] < (stop - start)[None, :]
        parity = cols[1:] % 2
        idx = np.clip(tail - entry, 0, span - 1)
        hit = inside & np.where(parity[None, :] == 1, marks[1][idx], marks[0][idx])
        first = hit.argmax(axis=0)
        found = hit[first, cols[:-1]]
        sync[1:n] = tail[first, cols[:-1]]
        todo = set((np.flatnonzero(~found) + 1).tolist())

        def row(j: int) -> np.ndarray:
            return redone[j][0] if j in redone else pos[:, j].astype(np.int64)

        # walkers never met within the overlap (periodic data keeps them out of phase): walk
        # those chunks again from their true entries, all whose predecessor is settled at once
        while todo:
            again, starts = [], []
            for j in sorted(todo):
                if j - 1 in todo:
                    continue
                todo.discard(j)
                prev_row = row(j - 1)
                cand = prev_row[(prev_row >= bounds[j]) & (prev_row < limits[j - 1])]
                here = cand[marks[j % 2][cand - entry]]
                if here.size:
                    sync[j] = here[0]
                    continue
                sync[j] = int(cand[0]) if cand.size else int(bounds[j])
                again.append(j)
                starts.append(sync[j])
            if not again:
                continue
            lims = limits[again]
            if len(again) >= 16:  # many: in lock step; a few (a chain, one per round): one by one
                p2, s2 = table.walk(np.array(starts, np.int64), lims, wanted + 64, bits_per_code, span_codes)
            for c, j in enumerate(again):
                old = row(j)
                marks[j % 2][old[(old < limits[j - 1]) & (old >= entry)] - entry] = False
                if len(again) >= 16:
                    col = p2[:, c].astype(np.int64)
                    k = int(np.searchsorted(col, lims[c])) + 1  # up to its first start at/past the limit
                    redone[j] = (col[:k], s2[:k, c])
                else:
                    redone[j] = table.walk_one(int(starts[c]), int(lims[c]))
                new = redone[j][0]
                marks[j % 2][new[(new < limits[j - 1]) & (new >= entry)] - entry] = True
                if j + 1 < n:  # its entry was found on the old row j
                    todo.add(j + 1)
    last = redone[n - 1][0] if n - 1 in redone else pos[:, n - 1]
    after = last[last >= group_end]
    nxt = int(after[0]) if after.size else end
    # each walker's kept codes are one run of steps: [first >= sync_j, first >= sync_j+1)
    lo = (pos < sync[None, :-1]).sum(axis=0)
    hi = (pos < sync[None, 1:]).sum(axis=0)
    pieces = []
    for j in range(n):
        if j in redone:
            p_j, s_j = redone[j]
            pieces.append(s_j[(p_j >= sync[j]) & (p_j < sync[j + 1])])
        else:
            pieces.append(sym[lo[j]:hi[j], j])
    flat = np.concatenate(pieces) if pieces else np.empty(0, np.uint8)
    return flat[:wanted], nxt
