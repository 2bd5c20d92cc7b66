"""The process's own resources: the open-files limit, raised once at start."""

from __future__ import annotations

import logging

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
