"""The typed interface between the simulation loop and its front doors.

A *front door* reads one API's requests on a thread of its own (a Zenoh callback, a ZMQ socket
thread, an in-process queue in the tests), bounds them, and hands each to the loop as a
``(kind, item)`` tuple through :attr:`LoopAccess.deliver`: ``kind`` names the door's kind of
item (one of :attr:`FrontDoor.kinds`), ``item`` is the decoded request with its client's
identity. The loop's one simulation thread gives each item back to the door's
:meth:`FrontDoor.handle`, between two physics steps; there the door executes the request on the
simulation (its handlers, under the loop's budgets) and hands the encoded reply to its sending
side (:attr:`LoopAccess.courier`, or its own socket thread). After every step, and after every
pass of the loop without one, :meth:`FrontDoor.after_step` answers what waited for that step.

Nothing here imports a front door: the loop sees doors only through :class:`FrontDoor`, and a
door sees the loop only through :class:`LoopAccess`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from simx_server.loop.courier import Courier

#: What a front door's thread hands the loop: ``(kind, item)``, ``kind`` one of its ``kinds``.
Delivery = tuple[str, Any]


@runtime_checkable
class FrontDoor(Protocol):
    """A front door served by the loop (:meth:`~simx_server.loop.core.Loop.attach`).

    Every method but the thread that reads requests runs on the simulation thread.
    """

    #: The kinds of the ``(kind, item)`` tuples the door's thread delivers to the loop.
    kinds: tuple[str, ...]

    def handle(self, kind: str, item: Any) -> None:
        """Serve one delivered item: execute its request on the simulation and hand the reply
        over for sending. Must not raise for anything a client sent (the loop logs what does)."""

    def after_step(self) -> None:
        """After each simulation step, and each loop pass without one: answer what waited for it."""

    def housekeeping(self, now: float) -> None:
        """A few times a second (``now``: ``time.monotonic()``, s): expire silent clients."""

    def client_count(self) -> int:
        """Clients the door holds state for (an idle ``--speed 0`` loop steps while any)."""

    def close(self) -> None:
        """Stop the door's threads and sockets (once, when the loop ends)."""


class LoopAccess(Protocol):
    """What a front door may use of the loop."""

    #: The simulation (:class:`simx_server.scene.simulation.Simulation`); touch it only on the
    #: simulation thread.
    sim: Any
    #: Thread-safe: put a ``(kind, item)`` delivery in the loop's ready ring.
    deliver: Callable[[Any], None]
    #: The sending thread: replies go out in order per lane, after their renders.
    courier: Courier
    #: s a client may stay silent before a door drops its state (limits.CLIENT_EXPIRY).
    client_expiry: float

    def step_now(self) -> bool:
        """One step now (the door's stepped client completed the synchronous barrier); False
        when it failed (every client is told, as for any failed step)."""

    def leave_sync(self, client: str, how: str) -> None:
        """``client`` leaves the synchronous barrier (``how``: for the log); the step the others
        all triggered runs now."""
