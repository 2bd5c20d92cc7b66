"""The budget of all of a scene's scripts together: their total time per simulation pass and their
total memory, so that no number of scripts starves the clients (30 scripts, each within its own
1 s and 256 MiB, made one step take 30 s and 2 GB).

:class:`ScriptBudget` is one per :class:`~simx_server.scripts.scene_scripts.Scripts`. The manager
opens a pass (:meth:`ScriptBudget.pass_of`: a simulation start, a step's actuation and sensing
together, an idle pass of the customization scripts) and every call into a script within it is
bounded by the earlier of its own ``script_timeout`` and the pass's end, in the simulation
thread's CPU time (the scripts' own work, as each script's bound). A script interrupted by the
pass's end is the one that overran: the error names it and :data:`~simx_server.base.limits.MAX_SCRIPTS_STEP_TIME`,
and it is treated as CoppeliaSim treats a script error (``CDetachedScript::
_announceErrorWasRaisedAndPossiblyPauseSimulation``: logged with the script's name; simx does
not pause the simulation, which its clients drive, but skips the script's step functions until
the next start, as for any overrun). The scripts after it in that pass are skipped for that pass
only. Remote calls (``simxCallScriptFunction``) run outside passes, under their own bound.

Memory: the Lua states of the scene's scripts together hold at most
:data:`~simx_server.base.limits.MAX_SCRIPTS_MEMORY`; before each call, a Lua script's cap is
what the others leave (:meth:`ScriptBudget.memory_cap`), at most its own
:data:`~simx_server.base.limits.MAX_SCRIPT_MEMORY`. Python scripts are the operator's trusted
code (``--allow-python-scripts``); their memory is the server's.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator

from simx_server.base import limits as L

__all__ = ["ScriptBudget"]


class ScriptBudget:
    """Total time per pass and total memory of a scene's scripts.

    Args:
        seconds: CPU seconds of one pass for all scripts together (limits.MAX_SCRIPTS_STEP_TIME).
        memory: bytes all Lua states may hold together (limits.MAX_SCRIPTS_MEMORY).
        states: returns the scripts whose memory counts (objects with ``memory_used()``, bytes).
    """

    def __init__(self, seconds: float = L.MAX_SCRIPTS_STEP_TIME, memory: int = L.MAX_SCRIPTS_MEMORY,
                 states: Callable[[], Iterable[Any]] = tuple):
        self.seconds = float(seconds)
        self.memory = int(memory)
        self._states = states
        #: End of the current pass in the simulation thread's CPU time (+inf outside passes).
        self.deadline = math.inf
        self.skipped = 0  # calls skipped in the current pass, the pass's time being spent

    @contextmanager
    def pass_of(self, what: str, until: float | None = None) -> Iterator[None]:
        """A pass (``what``: "open", "start", "step", "idle", "stop") during which the scripts'
        calls share :attr:`seconds`, or end at ``until`` (CPU time: a step's sensing ends with
        the pass its actuation opened); nested passes share the outer one."""
        if self.deadline != math.inf:
            yield
            return
        self.deadline = time.thread_time() + self.seconds if until is None else until
        self.skipped = 0
        try:
            yield
        finally:
            self.deadline = math.inf

    def spent(self) -> bool:
        """True when the current pass has no time left (then the next call is skipped)."""
        if time.thread_time() >= self.deadline:
            self.skipped += 1
            return True
        return False

    def bound(self, own: float) -> tuple[float, bool]:
        """``(seconds, by_pass)``: how long the next call may run, at most ``own`` (the script's
        ``script_timeout``); ``by_pass`` when the pass's end comes first."""
        left = self.deadline - time.thread_time()
        if left < own:
            return max(left, 0.0), True
        return own, False

    def memory_cap(self, script: Any, own_cap: int) -> int:
        """The memory cap (bytes) of ``script``'s Lua state for its next call: at most
        ``own_cap``, and no more than the others leave of :attr:`memory`."""
        others = sum(s.memory_used() for s in self._states() if s is not script)
        return max(0, min(own_cap, self.memory - others))
