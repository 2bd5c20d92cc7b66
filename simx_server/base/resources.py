"""The process's own resources: the open-files limit, raised once at start, and memory given back
after large requests."""

from __future__ import annotations

import ctypes
import logging
import threading
import time

try:
    import resource
except ImportError:  # pragma: no cover - not on POSIX
    resource = None

log = logging.getLogger("simx.server")

#: The soft open-files limit is raised to the hard limit, at most to this (select()-free code
#: paths only; libzmq and Zenoh use epoll).
MAX_OPEN_FILES = 65536


def raise_open_files_limit() -> int:
    """Raise the soft RLIMIT_NOFILE to the hard limit (at most MAX_OPEN_FILES); returns the soft
    limit now in force (a large number where there is none). Each ZMQ and Zenoh connection takes a
    descriptor: with the common soft limit of 1,024, idle connections could starve the rest."""
    if resource is None:
        return 1 << 30
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    target = MAX_OPEN_FILES if hard == resource.RLIM_INFINITY else min(hard, MAX_OPEN_FILES)
    if soft != resource.RLIM_INFINITY and soft < target:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
            log.debug("open-files limit raised from %d to %d", soft, target)
            soft = target
        except (ValueError, OSError) as exc:
            log.warning("open-files limit stays %d (could not raise it to %d: %s)", soft, target, exc)
    return soft if soft != resource.RLIM_INFINITY else 1 << 30


#: s after the last large request (:func:`trim_soon`) that glibc's free memory is given back.
TRIM_DELAY = 1.0
_trim = {"due": None, "thread": None, "count": 0}
_trim_wake = threading.Condition()


def trim_soon(delay: float = TRIM_DELAY) -> None:
    """Give glibc's free memory back to the system ``delay`` s after the last call (``malloc_trim(0)``,
    on a thread of its own, the GIL released): after a large request has been answered and its
    buffers freed. Zenoh and libzmq receive a large message in many small blocks (Zenoh's 64 KiB
    batches), which stay in malloc's heaps once freed: 16 Zenoh sessions' 60 MiB requests left a
    server 0.3-0.6 GB larger after they had gone. A no-op where malloc is not glibc's."""
    with _trim_wake:
        _trim["due"] = time.monotonic() + delay
        if _trim["thread"] is None:
            _trim["thread"] = threading.Thread(target=_trimmer, name="simx-trim", daemon=True)
            _trim["thread"].start()
        _trim_wake.notify()


def _trimmer() -> None:
    try:
        libc = ctypes.CDLL(None)
        malloc_trim = libc.malloc_trim
        malloc_trim.argtypes, malloc_trim.restype = (ctypes.c_size_t,), ctypes.c_int
    except (OSError, AttributeError):
        return
    while True:
        with _trim_wake:
            while _trim["due"] is None:
                _trim_wake.wait()
            wait = _trim["due"] - time.monotonic()
            if wait > 0:
                _trim_wake.wait(wait)
                continue
            _trim["due"] = None
        malloc_trim(0)  # a ctypes call: the GIL is released meanwhile
        _trim["count"] += 1
