"""The server's C allocator settings (glibc malloc), made once at start by ``simx-server``.

Memory the server frees (a 10 MB request, a 147 MB reply, a connection's buffers) must go back
to the system, or a server that lives for weeks keeps the high-water mark of every burst. Two
glibc defaults keep it:

* the *dynamic mmap threshold*: a block of 128 KiB or more is mapped on its own and unmapped
  when freed, but each time such a block is freed the threshold rises to its size (up to
  32 MiB), so the next blocks of that size come from a heap, where a block still in use above
  them keeps the freed ones from being returned;
* one *arena* (heap) per thread up to 8 per core, each keeping its own free memory: Zenoh's
  threads, the simulation, render and sending threads each fill and keep theirs.

Measured on a server with the fuzz test's large requests: 1-10 MB strings in three
requests left it 71-75 MB larger, after the client closed too; with a fixed threshold and
:data:`ARENA_MAX` arenas, +0 MB.

A fixed mmap threshold also fixes glibc's *trim threshold* at its default, 128 KiB: every free
that leaves more than that at the top of a heap gives it back, and the next request faults the
pages in again. A 640x480 image or depth buffer (0.9-1.2 MB, several copies per call) then cost
a blocking call 40-50 % more (depth buffer 36 -> 52 ms median on a slow 2-core VM). So blocks
under :data:`MMAP_THRESHOLD` (4 MiB: the images of common sensors) come from the heaps, which
keep up to :data:`TRIM_THRESHOLD` free at their top for the next call, and larger ones are
mapped and unmapped on their own (an mmap and a munmap: tens of microseconds against the
milliseconds of handling them).

An operator's ``MALLOC_ARENA_MAX`` / ``MALLOC_MMAP_THRESHOLD_`` environment variables (or the
same ``GLIBC_TUNABLES``) are left to win. Other C libraries (musl, macOS) are left alone.
"""

from __future__ import annotations

import ctypes
import logging
import os

log = logging.getLogger("simx.server")

#: glibc's mallopt() parameters (malloc.h).
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
M_ARENA_MAX = -8
#: Blocks of this many bytes or more are mapped on their own, and unmapped when freed.
MMAP_THRESHOLD = 4 << 20
#: Free memory a heap keeps at its top before giving it back (per heap: :data:`ARENA_MAX` of them).
TRIM_THRESHOLD = 16 << 20
#: Heaps of malloc: the main one and three for the other threads.
ARENA_MAX = 4


def tune_malloc() -> dict[str, int]:
    """Set glibc's mmap threshold (:data:`MMAP_THRESHOLD`), trim threshold (:data:`TRIM_THRESHOLD`)
    and arena count (:data:`ARENA_MAX`) unless the environment sets them; returns what was set (empty where malloc is not glibc's).
    Call it early, before the threads that allocate most start (Zenoh's, the render threads)."""
    try:
        libc = ctypes.CDLL(None)
        libc.gnu_get_libc_version  # noqa: B018 (glibc only: raises AttributeError elsewhere)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return {}
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    tunables = os.environ.get("GLIBC_TUNABLES", "")
    done = {}
    for name, env, tunable, param, value in (
            ("mmap_threshold", "MALLOC_MMAP_THRESHOLD_", "glibc.malloc.mmap_threshold", M_MMAP_THRESHOLD,
             MMAP_THRESHOLD),
            ("trim_threshold", "MALLOC_TRIM_THRESHOLD_", "glibc.malloc.trim_threshold", M_TRIM_THRESHOLD,
             TRIM_THRESHOLD),
            ("arena_max", "MALLOC_ARENA_MAX", "glibc.malloc.arena_max", M_ARENA_MAX, ARENA_MAX)):
        if env in os.environ or tunable in tunables:
            continue
        if mallopt(param, value) == 1:
            done[name] = value
    log.debug("malloc: %s", done or "left as the environment sets it")
    return done
