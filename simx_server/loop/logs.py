"""Rate limiting of repeated log lines: the first few, then one summary line per interval.

A client that repeats a failing call makes the server log one line per call (one program
produced 9,320 warning lines in 20 s). :class:`RepeatFilter`, installed on the log handlers by
``simx-server`` (:func:`install`), counts records in windows of
:data:`~simx_server.base.limits.LOG_REPEAT_INTERVAL` s, two ways:

* identical lines (same logger, level and text): the first
  :data:`~simx_server.base.limits.LOG_REPEAT_BURST` of a window pass;
* lines of one kind (same logger, level and message template, whatever its arguments): the
  first :data:`~simx_server.base.limits.LOG_TEMPLATE_BURST` pass, so that a client cannot get past
  the limit by varying what it sends, while a program's distinct errors all show.

The others are held back; when the window ends, one line gives their count and the last of
them. Summary lines come out at the next record of any kind or at :func:`flush`, which the
server's loop calls a few times a second, so they are written even when the repetition stops.
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from typing import Any

from simx_server.base import limits

_filters: list[RepeatFilter] = []
#: The logger of what clients print (simxAddStatusbarMessage, auxiliary consoles).
CONSOLE_LOGGER = "simx.console"


class _Window:
    __slots__ = ("count", "held", "last", "start")

    def __init__(self, start: float):
        self.start, self.count, self.held = start, 0, 0
        self.last: logging.LogRecord | None = None


#: A window whose interval ended with records held: (its key, the window).
_Due = tuple[tuple[Any, ...], _Window]


class RepeatFilter(logging.Filter):
    """Let through ``burst`` identical records and ``template_burst`` records of one template
    per ``interval`` s; summarise the others at the end of the interval.

    Args:
        handler: the handler this filter is installed on (summaries are written to it).
        burst: identical records let through per interval.
        template_burst: records of one message template let through per interval.
        interval: s; at its end one summary line counts the records held back.
        max_keys: windows tracked at once (the least recently seen are dropped first).
    """

    def __init__(
        self,
        handler: logging.Handler,
        burst: int = limits.LOG_REPEAT_BURST,
        interval: float = limits.LOG_REPEAT_INTERVAL,
        max_keys: int = limits.LOG_REPEAT_KEYS,
        template_burst: int = limits.LOG_TEMPLATE_BURST,
    ):
        super().__init__()
        self.handler, self.burst, self.interval, self.max_keys = handler, burst, interval, max_keys
        self.template_burst = template_burst
        self._lock = threading.Lock()
        self._windows: collections.OrderedDict[tuple[Any, ...], _Window] = collections.OrderedDict()
        self._next_flush = 0.0

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, "simx_summary", False):
            return True
        now = time.monotonic()
        template = record.msg if isinstance(record.msg, str) else type(record.msg).__name__
        try:
            text = record.getMessage()
        except Exception:  # arguments that do not format: the handler reports it
            return True
        with self._lock:
            due = self._due(now)
            same = self._window(("=", record.name, record.levelno, text), now, due)
            kind = self._window(("~", record.name, record.levelno, template), now, due)
            same.count += 1
            kind.count += 1
            if same.count > self.burst:
                held = same
            elif kind.count > self.template_burst:
                held = kind
            else:
                held = None
            if held is not None:
                held.held += 1
                held.last = record
        self._emit(due)
        return held is None

    def _window(self, key: tuple[Any, ...], now: float, due: list[_Due]) -> _Window:
        w = self._windows.get(key)
        if w is None:
            w = self._windows[key] = _Window(now)
            if len(self._windows) > self.max_keys:
                old_key, old = self._windows.popitem(last=False)
                if old.held:
                    due.append((old_key, old))
        else:
            self._windows.move_to_end(key)
        return w

    def flush(self) -> None:
        """Write the summary of every interval that has ended."""
        with self._lock:
            due = self._due(time.monotonic())
        self._emit(due)

    def _due(self, now: float) -> list[_Due]:
        """Windows whose interval ended (lock held): removed, those with held records returned."""
        if now < self._next_flush:
            return []
        self._next_flush = now + min(1.0, self.interval / 4)
        due: list[_Due] = []
        for key in [k for k, w in self._windows.items() if now - w.start >= self.interval]:
            w = self._windows.pop(key)
            if w.held:
                due.append((key, w))
        return due

    def _emit(self, due: list[_Due]) -> None:
        for key, w in due:
            last = w.last
            if last is None:  # held > 0: a record was kept
                continue
            try:
                text = last.getMessage()
            except Exception:
                text = str(last.msg)
            how = "identical" if key[0] == "=" else "similar"
            summary = logging.LogRecord(
                last.name,
                last.levelno,
                last.pathname,
                last.lineno,
                "%d %s line(s) held back in %g s; the last: %s",
                (w.held, how, self.interval, text),
                None,
            )
            summary.simx_summary = True
            self.handler.handle(summary)


def install(interval: float = limits.LOG_REPEAT_INTERVAL, burst: int = limits.LOG_REPEAT_BURST) -> None:
    """Put a :class:`RepeatFilter` on every handler of the root logger (call after
    ``logging.basicConfig``); every logger's records pass through them."""
    for handler in logging.getLogger().handlers:
        if any(isinstance(f, RepeatFilter) for f in handler.filters):
            continue  # installed already (main() called again in one process)
        f = RepeatFilter(handler, burst=burst, interval=interval)
        handler.addFilter(f)
        _filters.append(f)


def flush() -> None:
    """Write the summaries that are due (the server's loop calls this at every tick; cheap)."""
    for f in _filters:
        f.flush()
