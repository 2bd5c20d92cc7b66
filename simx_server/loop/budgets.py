"""The loop's budgets that every front door applies: a client's share of the simulation thread,
and the length of an error message.

Scene loads and edits recompile the scene; one client's stream of them would take the
simulation thread from every other client. Each client (a legacy client id, a ZMQ connection)
has a :class:`Share`: what it took costs its duration, the debt falls by ``limits.EDIT_SHARE`` s
per s, and while it exceeds ``limits.EDIT_DEBT_SECONDS`` the client is past its share. What a
door does then is the door's API's: the legacy door refuses the call (``BUSY``, V-REP programs
check return codes), the ZMQ door defers it (its official client does not retry).

Error messages (a reply's, ``simxGetLastErrors``', a log line's client text) are cut to
``limits.MAX_ERROR_CHARS`` (at most) by :func:`cut`, which says how long they were.

The limits are read at each call, so that tests may change them.
"""

from __future__ import annotations

from simx_server.base import limits


def cut(text: str, limit: int | None = None) -> str:
    """``text`` cut to at most ``limit`` characters (default ``limits.MAX_ERROR_CHARS``), its end
    saying how long it was: ``"<start>... (N characters)"``."""
    limit = limits.MAX_ERROR_CHARS if limit is None else limit
    if len(text) <= limit:
        return text
    tail = f"... ({len(text)} characters)"
    return (text[: max(0, limit - len(tail))] + tail)[:limit]


class Share:
    """A client's share of the simulation thread: seconds owed, as of when.

    Args:
        now: ``time.monotonic()`` (s) of the client's first call.
    """

    __slots__ = ("debt", "since")

    def __init__(self, now: float) -> None:
        self.debt = 0.0  # s of the simulation thread owed
        self.since = now

    def owed(self, now: float) -> float:
        """The debt at ``now`` (s): it falls by ``limits.EDIT_SHARE`` s per s."""
        self.debt = max(0.0, self.debt - (now - self.since) * limits.EDIT_SHARE)
        self.since = now
        return self.debt

    def over(self, now: float) -> bool:
        """Whether the client is past its share at ``now`` (its debt over ``limits.EDIT_DEBT_SECONDS``)."""
        return self.owed(now) > limits.EDIT_DEBT_SECONDS

    def wait(self, now: float) -> float:
        """s before the client is within its share again (0: now)."""
        return max(0.0, (self.owed(now) - limits.EDIT_DEBT_SECONDS) / limits.EDIT_SHARE)

    def add(self, seconds: float, now: float) -> None:
        """Charge ``seconds`` that ended at ``now`` (the debt as of ``now``, none paid meanwhile)."""
        self.debt += seconds
        self.since = now

    def charge(self, seconds: float, now: float) -> None:
        """Charge ``seconds`` at ``now`` after paying what fell due until then."""
        self.owed(now)
        self.debt += seconds
