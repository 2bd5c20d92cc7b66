"""The typed interface between the simulation loop and its front doors.

A *front door* reads one API's requests on a thread of its own (a Zenoh callback, a ZMQ socket
thread, an in-process queue in the tests), bounds them, and hands them to the loop's ready ring
(:attr:`LoopAccess.ring`) one of two ways:

* a ``(kind, item)`` tuple through :attr:`LoopAccess.deliver`: ``kind`` names the door's kind
  of item (one of :attr:`FrontDoor.kinds`), ``item`` the decoded request with its client's
  identity; the loop's one simulation thread gives it back to the door's
  :meth:`FrontDoor.handle`, between two physics steps;
* a *ready client* (:class:`ReadyClient`): a client with requests waiting in the door's own
  bounded queue, put in the ring once; the loop paces it (under ``pacing="legacy"`` a blocking
  request waits for the next step, :meth:`ReadyDoor.blocking`) and has its door serve its next
  request (:meth:`ReadyDoor.serve_ready`).

There the door executes the request on the simulation (its handlers, under the loop's budgets)
and hands the encoded reply to its sending side (:attr:`LoopAccess.courier`, or its own socket
thread). After every step (and every idle pass while the simulation is not running)
:meth:`FrontDoor.publish` sends what streams; after every step and every pass without one
:meth:`FrontDoor.after_step` answers what waited for that step.

Per-client state the loop keeps for every door is in the registry (:attr:`LoopAccess.clients`,
:mod:`simx_server.loop.clients`): a door registers its clients there; the loop's housekeeping
asks it who expired and calls the door's :meth:`FrontDoor.forget`; a failed step marks every
client (:meth:`FrontDoor.fault` lets a door tell what waits at once).

Nothing here imports a front door: the loop sees doors only through :class:`FrontDoor`, and a
door sees the loop only through :class:`LoopAccess`. A door may subclass :class:`FrontDoor` for
its defaults (each hook does nothing); it never subclasses the loop.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from simx_server.loop.clients import Client, Clients
from simx_server.loop.courier import Courier

#: What a front door's thread hands the loop: ``(kind, item)``, ``kind`` one of its ``kinds``.
Delivery = tuple[str, Any]


@runtime_checkable
class FrontDoor(Protocol):
    """A front door served by the loop (:meth:`~simx_server.loop.core.Loop.attach`).

    Every method runs on the simulation thread (the door's own threads only read requests and
    hand them over). The bodies here are the defaults a door that subclasses this class gets.
    """

    #: The kinds of the ``(kind, item)`` tuples the door's thread delivers to the loop.
    kinds: tuple[str, ...]

    def handle(self, kind: str, item: Any) -> None:
        """Serve one delivered item: execute its request on the simulation and hand the reply
        over for sending. Must not raise for anything a client sent (the loop logs what does)."""
        return None

    def publish(self) -> None:
        """After each successful step, and each idle pass while the simulation is not running:
        send the clients' streamed updates."""
        return None

    def after_step(self) -> None:
        """After each simulation step, and each loop pass without one: answer what waited for it."""
        return None

    def housekeeping(self, now: float) -> None:
        """A few times a second (``now``: ``time.monotonic()``, s), after the loop expired the
        registry's silent clients: the door's own periodic work."""
        return None

    def keeps(self, client: Any) -> bool:
        """Whether ``client`` (one of the door's in the registry) stays past its expiry (it holds
        a liveliness token, requests of it wait, a reply of it waits for a step)."""
        return False

    def forget(self, client: Any, how: str) -> None:
        """Drop ``client`` (the loop's housekeeping: it expired; ``how`` says so for the log):
        remove it from the registry (:meth:`Clients.remove`), drop the door's own state of it,
        take it out of the synchronous barrier."""
        return None

    def fault(self, reason: str) -> None:
        """A simulation step failed (the simulation has stopped): every registered client is
        marked already (``Client.fault``, told at its next request); the door tells what waits."""
        return None

    def watched(self) -> bool:
        """Whether someone the registry does not count watches the steps (a viewer, a client
        whose first request waits): a ``--speed 0`` loop keeps stepping for it."""
        return False

    def close(self) -> None:
        """Stop the door's threads and sockets (once, when the loop ends, after the simulation
        and the sending thread have finished what was handed over)."""
        return None


class ReadyDoor(Protocol):
    """A door whose clients sit in the ready ring themselves (:class:`ReadyClient`)."""

    def blocking(self, ready: Any) -> bool:
        """Whether ``ready``'s next request is a blocking call (paced: under ``pacing="legacy"``
        it waits for the next step once its previous blocking call saw the current one)."""
        ...

    def serve_ready(self, ready: Any, step: int | None) -> None:
        """Serve ``ready``'s next request (``step``: the step its blocking call sees, under
        legacy pacing; None otherwise). Puts ``ready`` back in the ring if more requests wait."""
        ...


class ReadyClient(Protocol):
    """A ready-ring item that is a client with requests waiting in its door's queue."""

    #: The door that serves it.
    door: ReadyDoor
    #: ``Simulation.steps`` when its last blocking request was answered (-1: none yet).
    step: int


class LoopAccess(Protocol):
    """What a front door may use of the loop."""

    #: The simulation (:class:`simx_server.scene.simulation.Simulation`); touch it only on the
    #: simulation thread.
    sim: Any
    #: Thread-safe: put a ``(kind, item)`` delivery in the loop's ready ring.
    deliver: Callable[[Any], None]
    #: The ready ring itself (thread-safe): a door puts its ready clients here.
    ring: queue.SimpleQueue[Any]
    #: The sending thread: replies go out in order per lane, after their renders.
    courier: Courier
    #: While an item is served in place: the door's sends to run after the simulation is let
    #: go, on the door's thread; None otherwise.
    in_place: list[Callable[[], None]] | None
    #: s a client may stay silent before it is dropped (limits.CLIENT_EXPIRY; a door may give
    #: its clients their own, as ZMQ clients their ``timeout``).
    client_expiry: float
    #: Every door's clients (simulation thread only).
    clients: Clients
    #: ``time.monotonic()`` when the loop was made (a legacy reply's server time counts from it).
    started: float

    def serve_or_deliver(self, item: Any) -> None:
        """Thread-safe: serve a ready-ring item on the calling thread if the simulation thread
        is waiting for work, else put it in the ready ring (Loop.serve_or_deliver)."""

    def hold_pass(self, client: str, seconds: float) -> None:
        """The door served ``client``; while the simulation runs, the next asynchronous step waits
        until ``seconds`` per client served since the last step have passed since that step,
        requests being served meanwhile (Loop.hold_pass, CoppeliaSim's ZMQ service window)."""

    def step_now(self) -> bool:
        """One step now (the door's stepped client completed the synchronous barrier); False
        when it failed (every client is told, as for any failed step)."""
        ...

    def step_after_reply(self) -> threading.Event:
        """The door's stepped client completed the synchronous barrier: the step runs once the
        request being served has been answered, before anything else is served
        (Loop.step_after_reply); a failure is told to every client at its next request. The
        door sets the event returned once that request's reply is handed to its transport."""
        ...

    def leave_sync(self, client: str, how: str) -> None:
        """``client`` leaves the synchronous barrier (``how``: for the log); the step the others
        all triggered runs now."""
        ...


__all__ = ["Client", "Clients", "Delivery", "FrontDoor", "LoopAccess", "ReadyClient", "ReadyDoor"]
