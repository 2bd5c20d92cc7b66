"""One background thread serving jobs round robin by client: the shape shared by the scene
conversions (:mod:`simx_server.scene.conversions`) and the remote clients' long API calls
(:mod:`simx_server.api.long_calls`).

One job runs at a time; the thread is started when a job comes and ends when none waits. The
clients with jobs waiting take turns, so a client's job waits behind at most one job of each
other client, however many each has queued; a client has at most ``limit`` jobs running or
waiting (one more is refused ``server busy`` with the subclass's message, :meth:`JobRing.busy`).
A job may do its work in slices: one that returns True has more to do, and goes on in its
client's next turn, after every other client's job (or slice): a client's short job then waits
behind one slice of each other client's, not their whole work.

A turn belongs to what the client cannot multiply at will: a front door that knows the
connection a request came on names it while it serves the request (:func:`serving`), and the
job takes that connection's turn and counts toward its ``limit`` (a ZMQ client may claim a new
uuid at every call; fresh uuids on one connection once queued 12 x 2 planning calls before
another client's). A job also belongs to its owner (the client it works for, the door's caller
key): when the client leaves, :func:`cancel_all` drops its jobs not started (their ``cancelled``
callbacks answer their callers) and asks the one running to stop (:func:`stop_requested`, which
a job's work reads where it can stop: a planner's validity check, the wait for a worker process).
"""

from __future__ import annotations

import collections
import contextlib
import logging
import threading
import time
import weakref
from collections.abc import Callable, Iterator
from typing import Any

from simx_wire.protocol import RemoteError

_local = threading.local()  # the serving thread's running job's stop event (``stop``)
_serving: list[tuple[Any, Any] | None] = [None]  # (turn, owner) of the request a door serves now


@contextlib.contextmanager
def serving(turn: Any, owner: Any) -> Iterator[None]:
    """While a door serves a request of ``owner`` (its caller key) that came on the connection
    ``turn``, the jobs ``owner`` adds take ``turn``'s turn (simulation thread)."""
    previous = _serving[0]
    _serving[0] = (turn, owner)
    try:
        yield
    finally:
        _serving[0] = previous


def stop_requested() -> bool:
    """Whether the job running on this thread was asked to stop (its client left), or the work
    of :func:`bounded` on this thread is past its time; False otherwise."""
    stop, until = getattr(_local, "stop", None), getattr(_local, "until", None)
    return (stop is not None and stop.is_set()) or (until is not None and time.monotonic() > until)


def stop_reason() -> str:
    """Why :func:`stop_requested` is true: "its client left", or the reason given to :func:`bounded`."""
    stop = getattr(_local, "stop", None)
    return "its client left" if stop is not None and stop.is_set() else getattr(_local, "reason", "")


@contextlib.contextmanager
def bounded(seconds: float, reason: str) -> Iterator[None]:
    """Work done at once on this thread that stops (:func:`stop_requested`) after ``seconds``
    (s of wall time), ``reason`` saying why (a script's call: what its pass has left)."""
    previous = getattr(_local, "until", None), getattr(_local, "reason", "")
    _local.until, _local.reason = time.monotonic() + seconds, reason
    try:
        yield
    finally:
        _local.until, _local.reason = previous


class _Job:
    __slots__ = ("cancelled", "owner", "run", "stop", "turn")

    def __init__(self, run: Callable[[], bool | None], turn: Any, owner: Any,
                 cancelled: Callable[[], None] | None) -> None:
        self.run, self.turn, self.owner, self.cancelled = run, turn, owner, cancelled
        self.stop = threading.Event()

    def of(self, key: Any) -> bool:
        return key == self.turn or key == self.owner


class JobRing:
    """Jobs waiting for one background thread, served round robin by turn (a door's connection,
    else the caller key; None: the operator's).

    Args:
        limit: jobs of one turn running or waiting at once.
        thread_name: the serving thread's name.
        log: where a job's unexpected exception is logged (a job reports its own errors).
        what: the job's kind in that log line.
    """

    def __init__(self, limit: int, thread_name: str, log: logging.Logger, what: str) -> None:
        self.limit, self._thread_name, self._log, self._what = limit, thread_name, log, what
        self._lock = threading.Lock()
        self._jobs: dict[Any, collections.deque[_Job]] = {}  # turn -> its jobs not started
        self._ring: collections.deque[Any] = collections.deque()  # turns with jobs waiting, in turn
        self._pending: dict[Any, int] = {}  # turn -> its jobs waiting or running
        self._current: _Job | None = None  # the job running
        self._running = False
        self._thread: threading.Thread | None = None
        _rings.add(self)

    def busy(self, mine: int) -> str:
        """The refusal of a client that has ``mine`` jobs running or waiting already."""
        raise NotImplementedError

    def pending(self, client: Any = ...) -> int:
        """Jobs waiting or running, of the turn ``client`` (default: of all); any thread."""
        with self._lock:
            return sum(self._pending.values()) if client is ... else self._pending.get(client, 0)

    def add(self, client: Any, job: Callable[[], bool | None], cancelled: Callable[[], None] | None = None) -> None:
        """Queue ``job`` of ``client`` (its owner), in the turn of the connection a door serves it
        on (:func:`serving`), else in ``client``'s own.

        Args:
            client: the caller key the job works for.
            job: the work; it reports its own errors, and returns True when it has more to do
                (run again in the client's next turn).
            cancelled: called instead of ``job`` when the job is dropped before it ran
                (:meth:`cancel`: its client left), on the thread that cancels it.

        Raises:
            RemoteError: ``server busy`` (:meth:`busy`): ``limit`` jobs of the turn run or
                wait already.
        """
        serving_now = _serving[0]
        turn = serving_now[0] if serving_now is not None and serving_now[1] == client else client
        with self._lock:
            mine = self._pending.get(turn, 0)
            if mine >= self.limit:
                raise RemoteError(self.busy(mine))
            self._pending[turn] = mine + 1
            jobs = self._jobs.setdefault(turn, collections.deque())
            if not jobs:
                self._ring.append(turn)
            jobs.append(_Job(job, turn, client, cancelled))
            if self._running:
                return
            self._running = True
            self._thread = threading.Thread(target=self._serve, name=self._thread_name, daemon=True)
            self._thread.start()

    def cancel(self, key: Any) -> int:
        """Drop the jobs not started whose turn or owner is ``key`` (their ``cancelled``
        callbacks run here, outside the lock), and ask such a job running to stop
        (:func:`stop_requested`); any thread.

        Returns:
            How many jobs were dropped.
        """
        dropped: list[_Job] = []
        with self._lock:
            for turn, jobs in list(self._jobs.items()):
                gone = [j for j in jobs if j.of(key)]
                if not gone:
                    continue
                dropped += gone
                kept = collections.deque(j for j in jobs if not j.of(key))
                if kept:
                    self._jobs[turn] = kept
                else:
                    del self._jobs[turn]
                    self._ring.remove(turn)
                left = self._pending[turn] - len(gone)
                if left:
                    self._pending[turn] = left
                else:
                    del self._pending[turn]
            current = self._current
            if current is not None and current.of(key):
                current.stop.set()
        for job in dropped:
            if job.cancelled is not None:
                try:
                    job.cancelled()
                except Exception:  # the others are dropped all the same
                    self._log.exception("cancelling a %s", self._what)
        return len(dropped)

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
                turn = self._ring.popleft()
                jobs = self._jobs[turn]
                job = self._current = jobs.popleft()
                if jobs:
                    self._ring.append(turn)  # its next job after every other turn's
                else:
                    del self._jobs[turn]
            _local.stop = job.stop
            again = False
            try:
                again = job.run() is True
            except Exception:  # a job reports its own errors; the queue must outlive it
                self._log.exception("a %s", self._what)
            finally:
                _local.stop = None
                with self._lock:
                    self._current = None
                    if again:  # its next slice in its next turn (one asked to stop sees it there)
                        waiting = self._jobs.setdefault(turn, collections.deque())
                        if not waiting:
                            self._ring.append(turn)
                        waiting.appendleft(job)
                    else:
                        left = self._pending[turn] - 1
                        if left:
                            self._pending[turn] = left
                        else:
                            del self._pending[turn]
                job = None  # type: ignore[assignment]  # what it closes over goes now


#: Every ring made (the module-level ones: scene conversions, long API calls).
_rings: weakref.WeakSet[JobRing] = weakref.WeakSet()


def cancel_all(key: Any) -> int:
    """:meth:`JobRing.cancel` ``key`` in every ring (a client, or a door's connection, left).

    Returns:
        How many jobs were dropped in all.
    """
    return sum(ring.cancel(key) for ring in list(_rings))


def settle_all(timeout: float) -> bool:
    """:meth:`JobRing.settle` every ring, ``timeout`` s at most in all (a server that closes).

    Returns:
        Whether no ring's thread serves now (False: a job still runs, e.g. a planner's maxTime).
    """
    end = time.monotonic() + timeout
    return all([ring.settle(max(0.0, end - time.monotonic())) for ring in list(_rings)])
