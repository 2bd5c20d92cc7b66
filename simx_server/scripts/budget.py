"""The budget of all of a scene's scripts together: their time per simulation pass, their share of
the server's time over a window, and their total memory, so that no number of scripts starves the
clients (30 scripts, each within its own 1 s and 256 MiB, made one step take 30 s and 2 GB; four
scripts at 0.6 s each, within the pass's bound, made every step take 2 s for as long as the scene
ran).

:class:`ScriptBudget` is one per :class:`~simx_server.scripts.scene_scripts.Scripts`. The manager
opens a pass (:meth:`ScriptBudget.pass_of`: a simulation start, a step's actuation, dynamics-step
callbacks and sensing together, an idle pass of the customization scripts, a stop) and every
callback into a script within it (life-cycle functions, thread resumes, ``sysCall_dynCallback``,
``sysCall_jointCallback``, ``sysCall_contactCallback``, messages; child and customization
scripts alike) is charged and bounded by the earliest of

* its own ``script_timeout``;
* the pass's end: :data:`~simx_server.base.limits.MAX_SCRIPTS_STEP_TIME` of the simulation thread's
  CPU time from the pass's start;
* the scripts' share: in each pass the scripts may take
  :data:`~simx_server.base.limits.SCRIPTS_PASS_ALLOWANCE` (not charged), and beyond it what is left
  of :data:`~simx_server.base.limits.SCRIPTS_SHARE` x
  :data:`~simx_server.base.limits.SCRIPTS_SHARE_WINDOW` after what they took beyond their
  allowances in the last ``SCRIPTS_SHARE_WINDOW`` s of the server's CPU time (``time.process_time``:
  a busy machine, which deschedules the server, does not change the outcome). Short passes are
  never charged; passes long enough to keep the clients waiting are, and once the scripts have
  taken their share of the window each pass gets its allowance only.

A script interrupted by the pass's end or by the share is the one that overran: the error names
it and the bound, and it is treated as CoppeliaSim treats a script error (``CDetachedScript::
_announceErrorWasRaisedAndPossiblyPauseSimulation``: logged with the script's name; simx does not
pause the simulation, which its clients drive, but skips every callback of the script, its
``sysCall_cleanup`` excepted, until the next start). The callbacks after it in that pass are
skipped for that pass only. Between two passes the server loop serves the clients' requests
(simx_server/loop/core.py), so what the bounds cut goes to them. Remote calls
(``simxCallScriptFunction``, a client's messages) run outside passes, under the script's own bound,
on the calling client's time.

Memory: the Lua states of the scene's scripts together hold at most
:data:`~simx_server.base.limits.MAX_SCRIPTS_MEMORY`; before each call, a Lua script's cap is
what the others leave (:meth:`ScriptBudget.memory_cap`), at most its own
:data:`~simx_server.base.limits.MAX_SCRIPT_MEMORY`. Python scripts are the operator's trusted
code (``--allow-python-scripts``); their memory is the server's.
"""

from __future__ import annotations

import math
import time
from collections import deque
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator

from simx_server.base import limits as L

__all__ = ["PASS", "SHARE", "ScriptBudget", "ScriptPass"]

#: Why a call's bound is shorter than the script's own: the pass's end, or the scripts' share.
PASS, SHARE = "pass", "share"


class ScriptPass:
    """One pass of the simulation thread as the scripts see it.

    Attributes:
        deadline: its end, in the simulation thread's CPU time (s).
        allowance: the scripts' time (s) it may hold: the per-pass allowance and what is left of
            the share when it opened.
        used: the scripts' time (s) in it so far (callbacks that returned).
        charged: what of ``used`` was charged to the share already (s).
    """

    __slots__ = ("allowance", "charged", "deadline", "used")

    def __init__(self, deadline: float, allowance: float):
        self.deadline = deadline
        self.allowance = allowance
        self.used = 0.0
        self.charged = 0.0


class ScriptBudget:
    """Time per pass, share over a window, and total memory of a scene's scripts.

    Args:
        seconds: CPU seconds of one pass for all scripts together (limits.MAX_SCRIPTS_STEP_TIME).
        memory: bytes all Lua states may hold together (limits.MAX_SCRIPTS_MEMORY).
        states: returns the scripts whose memory counts (objects with ``memory_used()``, bytes).
        share: the fraction of the window the scripts may take beyond their allowances
            (limits.SCRIPTS_SHARE).
        window: s of ``clock`` over which the share is counted (limits.SCRIPTS_SHARE_WINDOW).
        allowance: s of scripts' time per pass never charged (limits.SCRIPTS_PASS_ALLOWANCE).
        clock: the window's clock (s; the server's CPU time).

    The attributes of the same names may be changed between passes (tests shrink them).
    """

    def __init__(self, seconds: float = L.MAX_SCRIPTS_STEP_TIME, memory: int = L.MAX_SCRIPTS_MEMORY,
                 states: Callable[[], Iterable[Any]] = tuple, *, share: float = L.SCRIPTS_SHARE,
                 window: float = L.SCRIPTS_SHARE_WINDOW, allowance: float = L.SCRIPTS_PASS_ALLOWANCE,
                 clock: Callable[[], float] = time.process_time):
        self.seconds = float(seconds)
        self.memory = int(memory)
        self.share = float(share)
        self.window = float(window)
        self.allowance = float(allowance)
        self.clock = clock
        self._states = states
        #: The pass open now (None outside passes).
        self.current: ScriptPass | None = None
        self.skipped = 0  # calls skipped in the current pass, its time being spent
        self._charges: deque[tuple[float, float]] = deque()  # (clock, s beyond a pass's allowance)
        self._depth = 0  # callbacks running (a script's callback may call into another script)
        self._call_start = 0.0  # thread CPU time when the outermost one began

    @property
    def deadline(self) -> float:
        """End of the current pass in the simulation thread's CPU time (+inf outside passes)."""
        return math.inf if self.current is None else self.current.deadline

    @contextmanager
    def pass_of(self, what: str, resume: ScriptPass | None = None) -> Iterator[ScriptPass]:
        """A pass (``what``: "open", "start", "step", "idle", "stop") during which the scripts'
        callbacks share :attr:`seconds` and what is left of their share; ``resume`` goes on with
        an earlier pass (a step's dynamics callbacks and sensing go on with the pass its actuation
        opened). Nested passes share the outer one. What the scripts took beyond the allowance
        is charged to the share when the pass (or its part) ends."""
        if self.current is not None:
            yield self.current
            return
        step = resume if resume is not None else ScriptPass(
            time.thread_time() + self.seconds, self.allowance + max(0.0, self.share * self.window - self.taken()))
        if resume is None:
            self.skipped = 0
        self.current = step
        try:
            yield step
        finally:
            self.current = None
            self._charge(step)

    def taken(self) -> float:
        """s the scripts took beyond their allowances in the last :attr:`window` s of the clock."""
        horizon = self.clock() - self.window
        charges = self._charges
        while charges and charges[0][0] <= horizon:
            charges.popleft()
        return sum(s for _, s in charges)

    def _charge(self, step: ScriptPass) -> None:
        excess = max(0.0, step.used - self.allowance) - step.charged
        if excess > 0:
            self._charges.append((self.clock(), excess))
            step.charged += excess

    @contextmanager
    def callback(self) -> Iterator[None]:
        """A callback into a script: its time counts toward the current pass (a callback inside
        another, or outside passes, is not counted again)."""
        step = self.current
        if step is None or self._depth:
            yield
            return
        self._depth = 1
        self._call_start = start = time.thread_time()
        try:
            yield
        finally:
            self._depth = 0
            step.used += time.thread_time() - start

    def _used(self, step: ScriptPass, now: float) -> float:
        return step.used + (now - self._call_start if self._depth else 0.0)

    def spent(self) -> bool:
        """True when the current pass has no time left for scripts, its own or the share's (then
        the next call is skipped)."""
        step = self.current
        if step is None:
            return False
        now = time.thread_time()
        if now >= step.deadline or self._used(step, now) >= step.allowance:
            self.skipped += 1
            return True
        return False

    def bound(self, own: float) -> tuple[float, str | None]:
        """``(seconds, why)``: how long the next call may run, at most ``own`` (the script's
        ``script_timeout``); ``why`` is :data:`PASS` or :data:`SHARE` when the pass's end or the
        scripts' share comes first, None when ``own`` does."""
        step = self.current
        if step is None:
            return own, None
        now = time.thread_time()
        to_end, to_share = step.deadline - now, step.allowance - self._used(step, now)
        left, why = (to_end, PASS) if to_end <= to_share else (to_share, SHARE)
        if left < own:
            return max(left, 0.0), why
        return own, None

    def holders(self) -> list[Any]:
        """What holds the scripts' memory (objects with ``memory_used()``, bytes): the Lua states
        and the scene's parameters."""
        return list(self._states())

    def memory_cap(self, script: Any, own_cap: int) -> int:
        """The memory cap (bytes) of ``script``'s Lua state for its next call: at most
        ``own_cap``, and no more than the others leave of :attr:`memory`."""
        others = sum(s.memory_used() for s in self._states() if s is not script)
        return max(0, min(own_cap, self.memory - others))
