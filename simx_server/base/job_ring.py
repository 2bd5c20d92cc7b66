"""One background thread serving jobs round robin by client: the shape shared by the scene
conversions (:mod:`simx_server.scene.conversions`) and the remote clients' long API calls
(:mod:`simx_server.api.long_calls`).

One job runs at a time; the thread is started when a job comes and ends when none waits. The
clients with jobs waiting take turns, so a client's job waits behind at most one job of each
other client, however many each has queued; a client has at most ``limit`` jobs running or
waiting (one more is refused ``server busy`` with the subclass's message, :meth:`JobRing.busy`).
"""

from __future__ import annotations

import collections
import logging
import threading
import time
import weakref
from collections.abc import Callable
from typing import Any

from simx_wire.protocol import RemoteError


class JobRing:
    """Jobs waiting for one background thread, served round robin by client (a door's caller
    key; None: the operator's).

    Args:
        limit: jobs of one client running or waiting at once.
        thread_name: the serving thread's name.
        log: where a job's unexpected exception is logged (a job reports its own errors).
        what: the job's kind in that log line.
    """

    def __init__(self, limit: int, thread_name: str, log: logging.Logger, what: str) -> None:
        self.limit, self._thread_name, self._log, self._what = limit, thread_name, log, what
        self._lock = threading.Lock()
        self._jobs: dict[Any, collections.deque[Callable[[], None]]] = {}  # client -> its jobs not started
        self._ring: collections.deque[Any] = collections.deque()  # clients with jobs waiting, in turn
        self._pending: dict[Any, int] = {}  # client -> its jobs waiting or running
        self._running = False
        self._thread: threading.Thread | None = None
        _rings.add(self)

    def busy(self, mine: int) -> str:
        """The refusal of a client that has ``mine`` jobs running or waiting already."""
        raise NotImplementedError

    def pending(self, client: Any = ...) -> int:
        """Jobs waiting or running, of ``client`` (default: of all clients); any thread."""
        with self._lock:
            return sum(self._pending.values()) if client is ... else self._pending.get(client, 0)

    def add(self, client: Any, job: Callable[[], None]) -> None:
        """Queue ``job`` of ``client``.

        Raises:
            RemoteError: ``server busy`` (:meth:`busy`): ``limit`` jobs of ``client`` run or
                wait already.
        """
        with self._lock:
            mine = self._pending.get(client, 0)
            if mine >= self.limit:
                raise RemoteError(self.busy(mine))
            self._pending[client] = mine + 1
            jobs = self._jobs.setdefault(client, collections.deque())
            if not jobs:
                self._ring.append(client)
            jobs.append(job)
            if self._running:
                return
            self._running = True
            self._thread = threading.Thread(target=self._serve, name=self._thread_name, daemon=True)
            self._thread.start()

    def settle(self, timeout: float) -> bool:
        """Wait (at most ``timeout`` s) until the serving thread has ended; any thread but it.

        A daemon thread still alive at interpreter exit keeps what its frame holds (a planner's
        OMPL objects) forever, and OMPL's bindings print "leaked" lines for them.

        Returns:
            Whether no thread serves this ring now.
        """
        with self._lock:
            thread = self._thread
        if thread is not None:
            thread.join(timeout)
        return thread is None or not thread.is_alive()

    def _serve(self) -> None:
        while True:
            with self._lock:
                if not self._ring:
                    self._running = False
                    return
                client = self._ring.popleft()
                jobs = self._jobs[client]
                job = jobs.popleft()
                if jobs:
                    self._ring.append(client)  # its next job after every other client's
                else:
                    del self._jobs[client]
            try:
                job()
            except Exception:  # a job reports its own errors; the queue must outlive it
                self._log.exception("a %s", self._what)
            finally:
                job = None  # type: ignore[assignment]  # what it closes over goes now
                with self._lock:
                    left = self._pending[client] - 1
                    if left:
                        self._pending[client] = left
                    else:
                        del self._pending[client]


#: Every ring made (the module-level ones: scene conversions, long API calls).
_rings: weakref.WeakSet[JobRing] = weakref.WeakSet()


def settle_all(timeout: float) -> bool:
    """:meth:`JobRing.settle` every ring, ``timeout`` s at most in all (a server that closes).

    Returns:
        Whether no ring's thread serves now (False: a job still runs, e.g. a planner's maxTime).
    """
    end = time.monotonic() + timeout
    return all([ring.settle(max(0.0, end - time.monotonic())) for ring in list(_rings)])
