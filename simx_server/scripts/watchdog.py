"""Time bounds of Python script calls: a watchdog thread that interrupts a call overrunning its
deadline (used by :class:`simx_server.scripts.child.PythonScript`; Lua scripts are bounded by
an instruction-count hook in :mod:`simx_server.scripts.lua`)."""

from __future__ import annotations

import ctypes
import threading
import time
import traceback
from typing import Any, Callable

__all__ = ["WATCHDOG", "Watchdog"]


def _cpu_clock(thread_id: int) -> int | None:
    """The CPU-time clock of thread ``thread_id`` (POSIX), or None where there is none."""
    try:
        return time.pthread_getcpuclockid(thread_id)
    except (AttributeError, OSError):
        return None


def _cpu(clock: int) -> float:
    """Seconds of CPU time on ``clock``; +inf once it is gone (its thread ended)."""
    try:
        return time.clock_gettime(clock)
    except OSError:
        return float("inf")


class _Interrupt(BaseException):
    """Raised asynchronously inside a Python script that overran its time bound."""


class Watchdog:
    """Interrupts a Python script call that overruns its deadline.

    One daemon thread; :meth:`bounded` arms it around a call. The deadline is in the calling
    thread's CPU time (as Lua scripts' bound: the script's own work, which a loaded machine does
    not shorten), with a backstop of WALL_FACTOR times as much wall time for a script that
    waits (sleeps, I/O, a render it asked for). Past either it raises :class:`_Interrupt` in the
    calling thread (``PyThreadState_SetAsyncExc``), again every 50 ms in case the script
    swallows it, until the call returns. A script blocked inside C (``time.sleep``, I/O) is
    interrupted only when that returns.
    """

    REPEAT = 0.05
    #: Wall time a call may take, in multiples of its CPU-time bound.
    WALL_FACTOR = 10.0

    def __init__(self) -> None:
        self._cond = threading.Condition()
        # (CPU clock of the thread or None, CPU deadline, wall deadline, thread id)
        self._armed: tuple[int | None, float, float, int] | None = None
        self._fired = False
        self._thread: threading.Thread | None = None

    @staticmethod
    def _raise_in(thread_id: int, exc: type[BaseException] | None) -> None:
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(thread_id),
                                                   ctypes.py_object(exc) if exc else None)

    def _run(self) -> None:
        with self._cond:
            while True:
                if self._armed is None:
                    self._cond.wait()
                    continue
                clock, cpu_deadline, wall_deadline, thread_id = self._armed
                wall_left = wall_deadline - time.monotonic()
                cpu_left = wall_left if clock is None else cpu_deadline - _cpu(clock)
                if cpu_left > 0 and wall_left > 0:  # CPU time runs no faster than wall time
                    self._cond.wait(min(cpu_left, wall_left))
                    continue
                self._raise_in(thread_id, _Interrupt)
                self._fired = True
                self._cond.wait(self.REPEAT)

    def _disarm(self, outer: tuple[int | None, float, float, int] | None) -> bool:
        with self._cond:
            self._armed = outer
            fired, self._fired = self._fired, False
            if fired:  # an interruption may still be pending: drop it
                self._raise_in(threading.get_ident(), None)
            self._cond.notify()
            return fired

    def _disarm_until_done(self, outer: tuple[int | None, float, float, int] | None) -> bool:
        while True:  # an interruption may arrive while disarming: disarm again
            try:
                return self._disarm(outer)
            except _Interrupt:
                continue

    def bounded(self, fn: Callable[[], Any], seconds: float) -> tuple[Any, traceback.StackSummary | None]:
        """Run ``fn()`` for at most about ``seconds`` of the calling thread's CPU time (and
        WALL_FACTOR times as much wall time); returns ``(result, None)``, or
        ``(None, where)`` when it overran, ``where`` being the stack it was interrupted in
        (empty when the script swallowed the interruption). Exceptions of ``fn`` propagate.
        Called inside a bounded call of the same thread (a script calling another script's
        function), it ends no later than that call, whose bound holds again once it returns
        (before, the inner call disarmed it: the outer call ran unbounded).

        No exception is kept in a local of this frame: that would be a reference cycle
        (exception -> traceback -> frame -> exception) keeping every caller's frame alive, and
        with them the server's pending Zenoh query, whose final reply waits for it to go."""
        with self._cond:
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="simx-script-watchdog", daemon=True)
                self._thread.start()
            thread_id = threading.get_ident()
            clock = _cpu_clock(thread_id)
            if clock is None:  # no per-thread CPU clock here: wall time
                armed = (None, 0.0, time.monotonic() + seconds, thread_id)
            else:
                armed = (clock, _cpu(clock) + seconds, time.monotonic() + self.WALL_FACTOR * seconds, thread_id)
            # A call made inside a bounded call (a script calling another's function) ends no
            # later than the call it is part of, which is armed again once it returns.
            outer = self._armed
            if outer is not None and outer[3] == thread_id:
                armed = (armed[0], min(armed[1], outer[1]) if outer[0] == armed[0] else armed[1],
                         min(armed[2], outer[2]), thread_id)
            else:
                outer = None
            self._armed = armed
            self._fired = False
            self._cond.notify()
        result, fired, where = None, False, None
        try:
            try:
                result = fn()
            finally:
                fired = self._disarm_until_done(outer)
        except _Interrupt as exc:  # arrived before disarming; none can arrive after
            fired, where = True, traceback.extract_tb(exc.__traceback__)
        except Exception:
            if not fired:
                raise
        if fired:
            return None, where if where is not None else traceback.StackSummary()
        return result, None


#: The one watchdog of the process (its thread starts on first use).
WATCHDOG = Watchdog()
