"""Sending to clients off the simulation and render threads.

Every reply to a request, every stream update and every viewer model leaves the server through
the :class:`Courier`: the simulation thread hands a send over, with the render jobs it waits
for, and goes on. Each client has a *lane*: its sends leave in the order they were handed over
(a reply after the stream update of the same step, as the legacy inbox had them), each once its
images are rendered. One sending thread serves the lanes, a lane whose next send waits for a
render holding it up not at all.

Why: a reply is sent with Zenoh's blocking congestion control, and a client that stops reading
(its socket full of the images it asked for) makes the send wait for room on its link, up to
``limits.MAX_BLOCKED_REPLY_SECONDS`` before Zenoh closes that link. Sent from the simulation
thread, that wait held every client (issue 23: 5.2-5.6 s) and the simulation itself; here the
simulation steps on, requests are executed, and the other clients' sends wait that long once.

Why one thread, not one per client: several threads pushing to the same blocked link (a client
with several ids, its viewer queries, clients behind one Zenoh router) never came back, and
when Zenoh's lease then closed the stuck peer, every other client's queries stopped too
(measured with 17 sends to a stopped peer on 64 threads; Zenoh's own issue #1876 "Blocking push
can block the router indefinitely"). A single sender never pushes concurrently, and Zenoh's
``wait_before_close`` then ends the wait as configured (2.01 s measured).

Large sends go last: a *bulk* send (a stream update or reply with images of
``limits.BULK_SEND_BYTES`` or more) takes the thread for as long as Zenoh needs to push it (a
50 MB update: tens of milliseconds, more to a slow reader), so a lane whose next send is bulk
gives way while other lanes are ready, for at most ``limits.MAX_BULK_DEFER_SECONDS``. Another
client's small reply then waits for at most the one push under way, not for every client's.
And bulk stream updates take at most ``limits.BULK_SHARE`` of the thread's time (:meth:`bulk_allowed`).
"""

from __future__ import annotations

import collections
import logging
import queue
import threading
import time
from collections.abc import Callable, Hashable, Iterable
from concurrent.futures import Future
from typing import Any

from simx_server.base import limits

log = logging.getLogger("simx.server")


class Courier:
    """Per-lane ordered sends on the sending thread."""

    def __init__(self) -> None:
        # Lanes due to be pumped, in order. A plain queue and thread, not an executor: the hop
        # is on every blocking call's path (an executor's future and work item cost more).
        self._ready: queue.SimpleQueue[Hashable] = queue.SimpleQueue()
        self._lock = threading.Lock()
        # lanes with sends waiting or running: lane -> deque of (job, futures it waits for, bulk)
        self._lanes: dict[Hashable, collections.deque[tuple[Callable[[], None], tuple[Future[Any], ...], bool]]] = {}
        self._idle = threading.Condition(self._lock)
        self._closed = False
        # sending thread only: lanes whose next send is bulk and gave way, with when they first did
        self._deferred: collections.deque[tuple[Hashable, float]] = collections.deque()
        self._bulk_debt, self._bulk_since = 0.0, time.monotonic()  # sending thread only: see bulk_allowed
        self._thread = threading.Thread(target=self._serve, name="simx-send", daemon=True)
        self._thread.start()

    def send(
        self, lane: Hashable, job: Callable[[], None], waits: Iterable[Future[Any]] = (), bulk: bool = False
    ) -> None:
        """Run ``job()`` on the sending thread once every future of ``waits`` is done and every
        job handed over earlier on ``lane`` has run; ``bulk`` (a send of
        ``limits.BULK_SEND_BYTES`` or more) gives way to the sends of other lanes (see the
        module's text). Never blocks; an exception of ``job`` is logged. After :meth:`close`,
        ``job`` runs at once on the calling thread."""
        item = (job, tuple(waits), bulk)
        with self._lock:
            if not self._closed:
                lane_jobs = self._lanes.get(lane)
                if lane_jobs is not None:  # a pump is on this lane (running or waiting): it takes it
                    lane_jobs.append(item)
                    return
                self._lanes[lane] = collections.deque([item])
                self._ready.put(lane)
                return
        try:  # closed: the render thread has finished, so these are done
            for f in item[1]:
                f.exception(timeout=limits.MAX_BLOCKED_REPLY_SECONDS)
        except Exception:  # not rendered (a render thread that did not finish): not sent
            log.warning("closing: a send to %s was dropped, its images were not rendered", lane)
            return
        self._run(lane, job)

    def pending(self) -> int:
        """Lanes with sends waiting or running (for tests and benchmarks)."""
        with self._lock:
            return len(self._lanes)

    def _pump(self, lane: Hashable, since: float | None = None) -> None:
        """Run a lane's jobs in order until it is empty, its next job waits for a render, or its
        next job is bulk while other lanes are ready (the lane is then deferred; ``since``: when
        it first gave way, None if it did not)."""
        while True:
            with self._lock:
                lane_jobs = self._lanes[lane]
                if not lane_jobs:
                    del self._lanes[lane]
                    if not self._lanes:
                        self._idle.notify_all()
                    return
                job, waits, bulk = lane_jobs[0]
                waiting = next((f for f in waits if not f.done()), None)
                if waiting is None:
                    if bulk and not self._ready.empty() and not self._closed:
                        now = time.monotonic()
                        since = now if since is None else since
                        if now - since < limits.MAX_BULK_DEFER_SECONDS:  # others first
                            self._deferred.append((lane, since))
                            return
                    lane_jobs.popleft()
            if waiting is not None:  # the lane stays (its head waits): no other pump starts on it
                waiting.add_done_callback(lambda _f: self._resume(lane))
                return
            if bulk:
                started = time.monotonic()
                self._run(lane, job)
                self._bulk_debt = self._bulk_left(started) + time.monotonic() - started
                self._bulk_since = time.monotonic()
            else:
                self._run(lane, job)
            since = None  # a bulk send after this one gives way again

    def _bulk_left(self, now: float) -> float:
        return max(0.0, self._bulk_debt - (now - self._bulk_since) * limits.BULK_SHARE)

    def bulk_allowed(self) -> bool:
        """Whether a bulk stream update may be pushed now (called by the update's job, on the
        sending thread): the time bulk sends took, less ``limits.BULK_SHARE`` s per s since, is
        within ``limits.BULK_DEBT_SECONDS``. An update not pushed is a step its stream skips, as
        V-REP's streams do when the client is slower than the simulation; replies are always sent."""
        return self._bulk_left(time.monotonic()) <= limits.BULK_DEBT_SECONDS

    def _serve(self) -> None:
        """The sending thread: pump each lane put in the ready queue, until None; deferred
        lanes (bulk sends) when no lane is ready."""
        while True:
            if self._deferred and (
                self._ready.empty() or time.monotonic() - self._deferred[0][1] >= limits.MAX_BULK_DEFER_SECONDS
            ):
                self._pump(*self._deferred.popleft())
                continue
            lane = self._ready.get()
            if lane is None:
                return
            self._pump(lane)

    def _resume(self, lane: Hashable) -> None:
        """A render a lane waited for is done (on the render thread): pump the lane again."""
        with self._lock:
            closed = self._closed
        if closed:  # the sending thread has stopped: finish the lane here
            self._pump(lane)
        else:
            self._ready.put(lane)

    @staticmethod
    def _run(lane: Hashable, job: Callable[[], None]) -> None:
        try:
            job()
        except Exception:
            log.exception("sending to %s", lane)

    def close(self, timeout: float = 0.5) -> None:
        """Wait (at most ``timeout`` s) for the sends handed over so far, then stop the thread;
        later sends run on the caller's thread. Idempotent. A send blocked on a client that
        stopped reading is not waited for beyond ``timeout`` (SIGTERM ends the server within
        2 s): the sending thread is a daemon."""
        with self._lock:
            if self._closed:
                return
            self._idle.wait_for(lambda: not self._lanes, timeout)
            self._closed = True
            left = len(self._lanes)
        if left:
            log.warning("closing: sends to %d client(s) or viewer(s) not done (stopped reading?)", left)
        self._ready.put(None)  # the thread ends after what is queued (a stuck send: it is a daemon)
