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

Measured on a server with the fuzz test's large requests (issue 29): 1-10 MB strings in three
requests left it 71-75 MB larger, after the client closed too; with a fixed threshold of 1 MiB
and :data:`ARENA_MAX` arenas, +0 MB. Requests of 1 MiB and more then cost an mmap and a munmap
each (tens of microseconds against the milliseconds of handling them).

An operator's ``MALLOC_ARENA_MAX`` / ``MALLOC_MMAP_THRESHOLD_`` environment variables (or the
same ``GLIBC_TUNABLES``) are left to win. Other C libraries (musl, macOS) are left alone.
"""

from __future__ import annotations

import ctypes
import logging
import os

log = logging.getLogger("simx.server")

#: glibc's mallopt() parameters (malloc.h).
M_MMAP_THRESHOLD = -3
M_ARENA_MAX = -8
#: Blocks of this many bytes or more are mapped on their own, and unmapped when freed.
MMAP_THRESHOLD = 1 << 20
#: Heaps of malloc: the main one and three for the other threads.
ARENA_MAX = 4


def tune_malloc() -> dict[str, int]:
    """Set glibc's mmap threshold (:data:`MMAP_THRESHOLD`) and arena count (:data:`ARENA_MAX`)
    unless the environment sets them; returns what was set (empty where malloc is not glibc's).
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
            ("arena_max", "MALLOC_ARENA_MAX", "glibc.malloc.arena_max", M_ARENA_MAX, ARENA_MAX)):
        if env in os.environ or tunable in tunables:
            continue
        if mallopt(param, value) == 1:
            done[name] = value
    log.debug("malloc: %s", done or "left as the environment sets it")
    return done
