"""The thread that writes clients' files (``simxTransferFile``), one file at a time, taking the
clients' queues in turn.

:class:`~simx_server.scene.client_files.ClientFiles` counts a transfer against the client's
budgets on the simulation thread and hands the write here, off that thread (sixteen 32 MiB writes
on it pushed other clients' p99 from 5 ms to 1.7 s, issue 48). One thread in arrival order made a
client's 1 kB file wait behind every other client's writes: with eight clients rewriting 32 MiB
files in a loop, up to 256 MiB of them (limits.MAX_UNWRITTEN_BYTES_TOTAL), 1.06 s. Here each
client's writes keep their order, and the clients take turns: a file waits behind at most one
write of each other client.
"""

from __future__ import annotations

import threading
from collections import OrderedDict, deque
from concurrent.futures import Future
from typing import Any, Callable

__all__ = ["FileWriter"]


class FileWriter:
    """One thread running the jobs handed to it, one at a time, round robin by key (a client);
    started at the first job. Thread-safe."""

    def __init__(self, name: str = "simx-files"):
        self._name = name
        self._cond = threading.Condition()
        self._waiting: OrderedDict[str, deque[tuple[Future, Callable[[], Any]]]] = OrderedDict()
        self._thread: threading.Thread | None = None

    def submit(self, key: str, job: Callable[[], Any]) -> Future:
        """Run ``job()`` after the jobs of ``key`` handed over before it, in its turn among the
        keys; returns its Future (its result, or the exception it raised)."""
        future: Future = Future()
        with self._cond:
            self._waiting.setdefault(key, deque()).append((future, job))
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
                self._thread.start()
            self._cond.notify()
        return future

    def _next(self) -> tuple[Future, Callable[[], Any]]:
        """The next job, round robin by key (lock held; waits for one)."""
        while not self._waiting:
            self._cond.wait()
        key, jobs = next(iter(self._waiting.items()))
        item = jobs.popleft()
        del self._waiting[key]
        if jobs:  # its next job waits for the other keys' turns
            self._waiting[key] = jobs
        return item

    def _run(self) -> None:
        while True:
            with self._cond:
                future, job = self._next()
            if not future.set_running_or_notify_cancel():
                continue
            try:
                result = job()
            except BaseException as exc:  # the Future carries it to whoever waits
                future.set_exception(exc)
            else:
                future.set_result(result)
