"""One ``World.changed()`` for a block of state writes: :meth:`World.one_change
<simx_server.sim.world.World.one_change>`.

``World.changed()`` runs ``mj_forward`` after each write of the state (a joint placed, an object
moved), so that poses, contacts and sensors read next are current. A caller that writes several
values in a row and reads nothing derived in between (PyRep's ``set_joint_positions``: seven
joints, one API call each) needs the forward once, at the end: ``mj_forward`` is a function of the
state (``mj_step`` alone writes the solver's warm start), so the state after is the same.
"""

from __future__ import annotations

import threading
from contextlib import contextmanager
from typing import Callable, Iterator


class ChangeBatch:
    """The block of one thread whose ``changed()`` calls are held back, if any."""

    def __init__(self) -> None:
        self._owner: int | None = None  # the thread in the block
        self._depth = 0
        self._pending = False

    def holds(self) -> bool:
        """Whether the calling thread is in the block (its change is then noted, to run at its end).

        Returns:
            True when ``changed()`` must return at once.
        """
        if self._owner is None or self._owner != threading.get_ident():
            return False
        self._pending = True
        return True

    @contextmanager
    def block(self, changed: Callable[[], None]) -> Iterator[None]:
        """Hold back the calling thread's changes; at the end, ``changed()`` once if one was held.
        Nests; another thread's changes go through meanwhile, and a block that another thread
        opens while this one is open holds nothing back. ``changed`` runs even when the block
        raises (after what it wrote).

        Args:
            changed: ``World.changed``.

        Yields:
            None, while changes are held back.
        """
        me = threading.get_ident()
        if self._owner is not None:
            if self._owner == me:
                self._depth += 1
            try:
                yield
            finally:
                if self._owner == me:
                    self._depth -= 1
            return
        self._owner, self._depth, self._pending = me, 1, False
        try:
            yield
        finally:
            pending, self._owner, self._pending = self._pending, None, False
            if pending:
                changed()
