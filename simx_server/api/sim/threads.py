"""Python scripts' threads: :class:`PythonThread` runs a script's ``sysCall_thread`` as a
coroutine on its own OS thread, and the ``sim`` functions here give such a script the thread
functions (``sim.switchThread``, ``sim.step``, ``sim.wait``, ``sim.waitForSignal``).

Lua scripts get their own thread functions from :mod:`simx_server.scripts.threads`.
"""

from __future__ import annotations

import time
from typing import Any, Generator

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.signals import Signals
from simx_server.api.sim.stepped import MAX_MOTION_STEPS, Stepped, strings_as_text
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_number as _num, as_text as _text

class ThreadEnd(BaseException):
    """Raised inside a Python script's thread to end it (the simulation stopped, or it overran
    its time bound); not an ``Exception``, so ``except Exception`` does not swallow it."""


class PythonThread:
    """A Python script's ``sysCall_thread`` / ``sysCall_threadmain`` run as a coroutine: its own
    OS thread, but only ever running while the simulation thread waits for it (a hand-off in
    both directions), so the script sees the simulation as from the simulation thread.

    :meth:`resume` runs it until it yields (``sim.switchThread()``, ``sim.step()``,
    ``sim.wait``, ``sim.waitForSignal``) or ends, for at most ``timeout`` s: past that the thread
    is interrupted (an asynchronous :class:`ThreadEnd`, repeated every 50 ms until it lets go)
    and ended. :meth:`end` ends it at the simulation's stop.
    """

    def __init__(self, fn: Any, name: str):
        import threading

        self._go, self._back = threading.Semaphore(0), threading.Semaphore(0)
        self._ending = False
        self.alive = True
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(fn,), name=f"simx-script-thread {name}", daemon=True)
        self._thread.start()

    def _run(self, fn: Any) -> None:
        self._go.acquire()
        try:
            if not self._ending:
                fn()
        except ThreadEnd:
            pass
        except BaseException as exc:  # reported by resume() on the simulation thread
            self.error = exc
        finally:
            self.alive = False
            self._back.release()

    def in_thread(self) -> bool:
        """Whether the caller runs on this script's thread.

        Returns:
            True inside the thread.

        """
        import threading

        return threading.current_thread() is self._thread

    def switch(self) -> None:
        """In the thread: give the step back; returns when resumed (raises ThreadEnd at the end)."""
        self._back.release()
        self._go.acquire()
        if self._ending:
            raise ThreadEnd

    def resume(self, timeout: float) -> bool:
        """Run the thread until it yields or ends; True when it yielded in time, False when it
        overran ``timeout`` (it is then ended). Its error, if it raised one, is in :attr:`error`.

        Args:
            timeout: s of wall time.

        Returns:
            True when it yielded or ended in time.
        """
        import ctypes

        if not self.alive:
            return True
        self._go.release()
        if self._back.acquire(timeout=timeout):
            return True
        self._ending = True
        ident = self._thread.ident
        for _ in range(40):  # interrupt it until it lets go (at most ~2 s)
            ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(ident), ctypes.py_object(ThreadEnd))
            if self._back.acquire(timeout=0.05):
                break
        self.alive = False
        return False

    def end(self) -> None:
        """End the thread (the simulation stops): it raises ThreadEnd where it waits."""
        if self.alive:
            self._ending = True
            self._go.release()
            self._back.acquire(timeout=1.0)
        self.alive = False


# The thread functions of ``sim`` for Python scripts (Lua scripts get their own from
# :data:`simx_server.scripts.threads.THREADS_LUA`).

def py_thread(ctx: CallContext, what: str) -> PythonThread:
    script = ctx.script
    thread = getattr(script, "py_thread", None)
    if thread is None or not thread.in_thread():
        raise ArgumentError(f"sim.{what} can only be called in a threaded script (sysCall_thread)")
    return thread


@sim_function("switchThread")
def switchThread(ctx: CallContext) -> int:  # noqa: N802
    """Give the rest of this step back; the thread resumes at the next step.

    ``sim.switchThread``.

    Returns:
        1.

    Raises:
        ArgumentError: not called in a threaded Python script.
    """
    py_thread(ctx, "switchThread").switch()
    return 1


@sim_function("step")
def step(ctx: CallContext) -> None:
    """CoppeliaSim 4.6's name of :func:`switchThread` in threads."""
    py_thread(ctx, "step").switch()


@sim_function("wait")
def wait(ctx: CallContext, dt: Any, simulationTime: Any = True) -> float:  # noqa: N803
    """Yield until ``dt`` s of simulation time (``simulationTime`` false: wall time) passed.

    ``sim.wait``.

    Args:
        dt: s to wait.
        simulationTime: False: wall time.

    Returns:
        0.0 (CoppeliaSim's time left over).

    Raises:
        ArgumentError: not called in a threaded Python script, or ``dt`` not a number.
    """
    if ctx.remote:
        return _client_wait(ctx, dt, simulationTime)
    thread = py_thread(ctx, "wait")
    dt = _num(dt, "dt")
    if simulationTime is False:
        end = time.monotonic() + dt
        while time.monotonic() < end:
            thread.switch()
    else:
        end = ctx.sim.getSimulationTime() + dt
        while ctx.sim.getSimulationTime() < end - 1e-9:
            thread.switch()
    return 0.0


@sim_function("waitForSignal")
def waitForSignal(ctx: CallContext, name: Any) -> Any:  # noqa: N802
    """Yield until an integer, float or string signal ``name`` exists; returns its value.

    ``sim.waitForSignal``.

    Args:
        name: the signal's name.

    Returns:
        The signal's value (int, float or bytes).

    Raises:
        ArgumentError: not called in a threaded Python script, or ``name`` not a string.
    """
    if ctx.remote:
        return _client_wait_for_signal(ctx, name)
    thread = py_thread(ctx, "waitForSignal")
    while True:
        for kind in ("int", "float", "string"):
            value = ctx.signals.get(kind, _text(name, "signal name"))
            if value is not None:
                return value
        thread.switch()


@sim_function("setThreadAutomaticSwitch")
def setThreadAutomaticSwitch(ctx: CallContext, allow: Any) -> int:  # noqa: N802
    """Python threads switch only where they call the functions above: accepted, returns 0.

    ``sim.setThreadAutomaticSwitch``.

    Args:
        allow: ignored.

    Returns:
        0.
    """
    return 0


def _client_wait(ctx: CallContext, dt: Any, simulationTime: Any = True) -> Stepped:  # noqa: N803
    """Let ``dt`` s of simulation time pass (one step at least); returns the time left over
    (0 or negative: the steps' overshoot). Only simulation time (``simulationTime`` true)."""
    span = _num(dt, "dt")
    if not simulationTime:
        raise UnsupportedError("sim.wait with system time is not supported: give simulation time")
    world = ctx.world

    def waiting() -> Generator[None, None, list]:
        end = world.time + span
        for _ in range(MAX_MOTION_STEPS):
            yield
            if world.time >= end - 1e-9:
                break
        return [end - world.time]

    return Stepped(waiting())


def _client_wait_for_signal(ctx: CallContext, sigName: Any) -> Stepped:  # noqa: N802, N803
    """Wait, step after step, until signal ``sigName`` (of any kind) is set; its value. A
    call that lasts several steps (docs/ZMQ.md), at most MAX_MOTION_STEPS; the coroutine
    form inside scripts is the scripts' own."""
    name, signals = _text(sigName, "sigName"), ctx.signals

    def waiting():
        for _ in range(MAX_MOTION_STEPS):
            for kind in Signals.KINDS:
                value = signals.get(kind, name)
                if value is not None:
                    return [strings_as_text(value)]
            yield
        raise ArgumentError(f"signal {name!r} not set within {MAX_MOTION_STEPS} steps")

    return Stepped(waiting())
