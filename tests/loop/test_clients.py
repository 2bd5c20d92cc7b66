"""The loop's client registry (simx_server/loop/clients.py), alone and through a serving loop:
expiry asks the door which clients it keeps and calls its ``forget``; a ready client of a door
is paced (two blocking calls see distinct steps); a failed step is told to every door's clients.
Real :class:`~simx_server.loop.core.Loop` and simulation, in-process doors, no sockets."""

from __future__ import annotations

import collections
import time
from typing import Any

import loop_fixtures
import pytest
from loop_fixtures import WAIT, LoopThread

from simx_server.loop.clients import Client, Clients
from simx_server.loop.core import Loop
from simx_server.loop.front_door import FrontDoor, LoopAccess, ReadyClient, ReadyDoor
from simx_server.loop.in_process import InProcessDoor
from simx_server.scene.simulation import Simulation
from simx_server.sim.state import RunState

sim = loop_fixtures.sim  # the shared fixture


class Door(FrontDoor):
    """A door that keeps the clients named in ``kept`` and records what it is told to forget."""

    kinds: tuple[str, ...] = ()

    def __init__(self, registry: Clients, kept: set[str] | None = None) -> None:
        self.registry = registry
        self.kept = kept or set()
        self.forgotten: list[tuple[str, str]] = []

    def keeps(self, client: Any) -> bool:
        return client.id in self.kept

    def forget(self, client: Any, how: str) -> None:
        self.registry.remove(client)
        self.forgotten.append((client.id, how))


def test_the_registry_counts_expires_and_marks_each_doors_clients() -> None:
    registry = Clients()
    a, b = Door(registry, kept={"held"}), Door(registry)
    for name, door, seen in (("old", a, 0.0), ("held", a, 0.0), ("new", a, 9.0), ("other", b, 1.0)):
        registry.add(Client(name, door, seen, expiry=5.0))
    assert registry.count() == 4 and registry.count(a) == 3 and registry.count(b) == 1
    assert set(registry.of(a)) == {"old", "held", "new"} and registry.get(b, "other") is not None
    expired = registry.expired(now=10.0)  # "held" is kept by its door, "new" is recent
    assert [c.id for c in expired] == ["old", "other"]  # oldest first, whatever the door
    assert expired[0].expired_how() == "expired (no request for 5 s)"
    assert registry.oldest(a, lambda c: c.id != "old").id == "held"
    registry.fault_all("the step failed")
    assert all(c.fault == "the step failed" for c in registry)
    assert registry.remove(expired[0]) and not registry.remove(expired[0])  # once
    assert registry.count(a) == 2 and registry.get(a, "old") is None


Served = LoopThread  # a loop serving on a thread, no door but the test's


def wait_for(condition: Any, what: str) -> None:
    deadline = time.monotonic() + WAIT
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.01)


def test_expiry_asks_the_door_and_calls_its_forget(sim: Simulation) -> None:
    """The loop's housekeeping drops a silent client through its door's ``forget``, not one the
    door keeps; the in-process door's client leaves the synchronous barrier as it goes."""
    s = Served(sim, speed=0, client_expiry=0.2)
    door = InProcessDoor(s.loop)
    s.loop.attach(door)
    keeping = Door(s.loop.clients, kept={"kept"})
    s.loop.attach(keeping)
    now = time.monotonic()
    for name in ("kept", "quiet"):
        s.loop.clients.add(Client(name, keeping, now, expiry=0.2))
    s.thread.start()
    try:
        door.stepping("stepped", True).result(WAIT)
        wait_for(lambda: door.expired and keeping.forgotten, "the silent clients dropped")
        assert door.expired == ["stepped"] and door.client_count() == 0
        assert keeping.forgotten == [("quiet", "expired (no request for 0.2 s)")]
        assert [c.id for c in s.loop.clients] == ["kept"]
        assert not door.call("other", lambda sim: sim.is_synchronous("stepped")).result(WAIT)
    finally:
        s.stop()


class Ready:
    """A ready client: its requests (each a bool, blocking or not) wait in its door's queue."""

    def __init__(self, door: PacedDoor, requests: list[bool]) -> None:
        self.door: ReadyDoor = door
        self.step = -1
        self.requests = collections.deque(requests)


class PacedDoor(FrontDoor):
    """A door whose clients sit in the ready ring themselves, as the legacy door's sessions."""

    kinds: tuple[str, ...] = ()

    def __init__(self, loop: LoopAccess) -> None:
        self.loop = loop
        self.served: list[tuple[bool, int]] = []  # (blocking, Simulation.steps when served)

    def blocking(self, ready: Ready) -> bool:
        return bool(ready.requests) and ready.requests[0]

    def serve_ready(self, ready: Ready, step: int | None) -> None:
        blocking = ready.requests.popleft()
        if step is not None:
            ready.step = step
        self.served.append((blocking, self.loop.sim.steps))
        if ready.requests:
            self.loop.ring.put(ready)

    def watched(self) -> bool:
        return True  # the --speed 0 loop steps for its clients


@pytest.mark.parametrize("pacing", ["legacy", "immediate"])
def test_a_ready_clients_blocking_calls_are_paced(sim: Simulation, pacing: str) -> None:
    """Under legacy pacing, a ready client's consecutive blocking calls see distinct steps (its
    non-blocking calls are not held); ``immediate`` serves all as they come."""
    s = Served(sim, speed=0, pacing=pacing)
    door = PacedDoor(s.loop)
    s.loop.attach(door)
    sim.start()
    s.thread.start()
    try:
        wait_for(lambda: sim.steps > 0, "the first step")
        ready: ReadyClient = Ready(door, [True, True, True, False, False])
        s.loop.ring.put(ready)
        wait_for(lambda: len(door.served) == 5, "every request served")
    finally:
        s.stop()
    steps = [step for blocking, step in door.served if blocking]
    if pacing == "legacy":
        assert steps[0] < steps[1] < steps[2], door.served
    assert [blocking for blocking, _ in door.served] == [True, True, True, False, False]


def test_a_failed_step_is_told_to_every_doors_clients(sim: Simulation, monkeypatch: pytest.MonkeyPatch) -> None:
    """A step that raises stops the simulation; each client of each door is told at its next call."""
    s = Served(sim, speed=0)
    first, second = InProcessDoor(s.loop, kind="first"), InProcessDoor(s.loop, kind="second")
    s.loop.attach(first)
    s.loop.attach(second)
    s.thread.start()
    try:
        first.call("a", lambda sim: None).result(WAIT)
        second.call("b", lambda sim: None).result(WAIT)

        def broken() -> None:
            raise RuntimeError("a broken step")

        first.call("a", lambda sim: monkeypatch.setattr(sim, "step", broken)).result(WAIT)
        first.call("a", lambda sim: sim.start()).result(WAIT)
        wait_for(lambda: sim.state is RunState.STOPPED, "the failed step")
        assert not first.faults and not second.faults  # told at the next call, not before
        first.call("a", lambda sim: None).result(WAIT)
        second.call("b", lambda sim: None).result(WAIT)
        for door, client in ((first, "a"), (second, "b")):
            assert [c for c, _ in door.faults] == [client]
            assert "step failed" in door.faults[0][1] and "a broken step" in door.faults[0][1]
        first.call("a", lambda sim: None).result(WAIT)
        assert len(first.faults) == 1  # told once
    finally:
        s.stop()


def test_two_doors_cannot_declare_the_same_kind(sim: Simulation) -> None:
    loop = Loop(sim)
    try:
        loop.attach(InProcessDoor(loop))
        with pytest.raises(ValueError, match="in-process"):
            loop.attach(InProcessDoor(loop))
    finally:
        loop.courier.close()
