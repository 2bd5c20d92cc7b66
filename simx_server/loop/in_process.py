"""A front door without sockets: calls from this process's threads, served by the loop.

As ``httpx.MockTransport`` serves httpx's own tests, :class:`InProcessDoor` serves the loop's:
a caller on any thread hands the loop a function of the simulation with a client id
(:meth:`InProcessDoor.call`) and gets a ``concurrent.futures.Future`` of its result. The door
does what every front door does, in a few lines: bound (pending calls), hand over
(:attr:`LoopAccess.deliver`), execute on the simulation thread, and send the reply from the
sending thread (:attr:`LoopAccess.courier`, on the client's lane). Per-client state and expiry,
the synchronous barrier (:meth:`InProcessDoor.stepping`) and calls that wait for the next step
(``after_step=True``) go through the loop as the real doors' do: its clients are in the loop's
registry (:mod:`simx_server.loop.clients`), which expires them (:meth:`InProcessDoor.forget`);
a failed step is told to a client at its next call (:attr:`InProcessDoor.faults`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

from simx_server.loop.clients import Client
from simx_server.loop.front_door import FrontDoor, LoopAccess
from simx_server.sim.state import RunState

#: Calls handed over and not answered yet, over all clients; past it a call is refused at once.
MAX_PENDING = 256


class _Call:
    __slots__ = ("after_step", "client", "fn", "future", "step_at", "value")

    def __init__(self, client: str, fn: Callable[[Any], Any], future: Future[Any], after_step: bool) -> None:
        self.client = client
        self.fn = fn
        self.future = future
        self.after_step = after_step
        self.step_at = -1  # Simulation.steps when it came (after_step: answered once past it)
        self.value: Any = None  # its result, kept while it waits for a step


class InProcessDoor(FrontDoor):
    """Calls from this process served by ``loop`` (see the module docstring).

    Args:
        loop: the loop it is attached to (``loop.attach(door)`` is the caller's).
        max_pending: calls handed over and not answered yet, over all clients.
        kind: the kind of its deliveries (one per door attached to a loop).
    """

    def __init__(self, loop: LoopAccess, max_pending: int = MAX_PENDING, kind: str = "in-process") -> None:
        self.loop = loop
        self.kinds: tuple[str, ...] = (kind,)
        self.max_pending = max_pending
        self.expired: list[str] = []  # clients the loop's housekeeping dropped, oldest first
        #: ``(client, message)`` of each failed step told to a client, at its next call.
        self.faults: list[tuple[str, str]] = []
        self._waiting: list[_Call] = []  # after_step calls executed, answered after the next step
        self._pending = 0
        self._lock = threading.Lock()

    # ---------------------------------------------------------- any thread
    def call(
        self, client: str, fn: Callable[[Any], Any], after_step: bool = False, in_place: bool = False
    ) -> Future[Any]:
        """``fn(sim)`` run on the simulation thread for ``client``; the future holds its result
        or its exception. ``after_step``: the result is sent once a step has run since (at
        once while the simulation is not running), as a ZMQ ``sim.step()`` is answered.
        ``in_place``: run on the calling thread if the simulation thread waits for work
        (:meth:`LoopAccess.serve_or_deliver`, as the Zenoh and ZMQ doors serve quick calls),
        the future then done when this returns.

        The future's exception is ``RuntimeError`` at once when ``max_pending`` calls wait.
        """
        future: Future[Any] = Future()
        with self._lock:
            if self._pending >= self.max_pending:
                future.set_exception(RuntimeError(f"refused: {self._pending} calls pending (max_pending)"))
                return future
            self._pending += 1
        item = (self.kinds[0], _Call(client, fn, future, after_step))
        (self.loop.serve_or_deliver if in_place else self.loop.deliver)(item)
        return future

    def stepping(self, client: str, on: bool) -> Future[Any]:
        """``client`` joins (``on``) or leaves the synchronous barrier."""

        def toggle(sim: Any) -> None:
            if on:
                sim.enable_sync(client, True)
            elif sim.is_synchronous(client):
                self.loop.leave_sync(client, "left stepping mode")

        return self.call(client, toggle)

    def trigger(self, client: str) -> Future[Any]:
        """``client``'s trigger of the barrier; its future is done once the step ran."""

        def step(sim: Any) -> int:
            if sim.state is RunState.RUNNING and sim.trigger(client):
                self.loop.step_now()
            return int(sim.steps)

        return self.call(client, step, after_step=True)

    # ---------------------------------------------------- simulation thread
    def handle(self, kind: str, item: Any) -> None:
        call: _Call = item
        now = time.monotonic()
        registry = self.loop.clients
        client = registry.get(self, call.client)
        if client is None:
            client = Client(call.client, self, now, self.loop.client_expiry)
            registry.add(client)
        client.last_seen = now
        if client.fault is not None:  # a failed step since its last call: told now
            self.faults.append((call.client, client.fault))
            client.fault = None
        sim = self.loop.sim
        call.step_at = sim.steps
        try:
            value = call.fn(sim)
        except Exception as exc:  # the caller's exception goes back to the caller
            self._send(call, None, exc)
            return
        if call.after_step and sim.state is RunState.RUNNING and sim.steps <= call.step_at:
            call.value = value
            self._waiting.append(call)
            return
        self._send(call, value, None)

    def after_step(self) -> None:
        if not self._waiting:
            return
        sim = self.loop.sim
        due = [c for c in self._waiting if sim.state is not RunState.RUNNING or sim.steps > c.step_at]
        if due:
            self._waiting = [c for c in self._waiting if c not in due]
            for call in due:
                self._send(call, call.value, None)

    def keeps(self, client: Any) -> bool:
        """A client with a call waiting for a step stays."""
        return any(c.client == client.id for c in self._waiting)

    def forget(self, client: Any, how: str) -> None:
        """Drop ``client`` (it expired): out of the registry and of the synchronous barrier."""
        if not self.loop.clients.remove(client):
            return
        self.expired.append(client.id)
        if self.loop.sim.is_synchronous(client.id):
            self.loop.leave_sync(client.id, f"{how}: out of synchronous mode")

    def client_count(self) -> int:
        """The door's clients in the loop's registry."""
        return self.loop.clients.count(self)

    def close(self) -> None:
        for call in self._waiting:
            call.future.cancel()
        self._waiting.clear()

    def _send(self, call: _Call, value: Any, exc: BaseException | None) -> None:
        def send() -> None:
            with self._lock:
                self._pending -= 1
            if exc is not None:
                call.future.set_exception(exc)
            else:
                call.future.set_result(value)

        sends = self.loop.in_place
        if sends is not None:  # served in place: answered by the calling thread
            sends.append(send)
            return
        self.loop.courier.send(call.client, send)
