"""The simulation loop (simx_server/loop/core.py) through an in-process front door, no sockets.

A real :class:`~simx_server.scene.simulation.Simulation` of a small scene this file writes, a
real :class:`~simx_server.loop.core.Loop` on a thread of its own, and
:class:`~simx_server.loop.in_process.InProcessDoor` handing it calls from the test's thread.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from concurrent.futures import Future
from typing import Any

import loop_fixtures
import pytest
from loop_fixtures import WAIT, LoopThread

from simx_server.loop.core import Loop
from simx_server.loop.front_door import FrontDoor, LoopAccess
from simx_server.loop.in_process import InProcessDoor
from simx_server.scene.simulation import Simulation
from simx_server.sim.state import RunState

sim = loop_fixtures.sim  # the shared fixture

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here


class Served(LoopThread):
    """A loop serving on a thread, with an in-process door attached."""

    def __init__(self, sim: Simulation, **kwargs: Any) -> None:
        super().__init__(sim, **kwargs)
        self.door = InProcessDoor(self.loop)
        self.loop.attach(self.door)

    def call(self, fn: Any, client: str = "a", after_step: bool = False) -> Any:
        return self.door.call(client, fn, after_step).result(WAIT)


@pytest.fixture
def served(sim: Simulation) -> Iterator[Served]:
    s = Served(sim, speed=0)
    s.thread.start()
    yield s
    if s.thread.is_alive():
        s.stop()


def test_the_doors_satisfy_the_interface(sim: Simulation) -> None:
    loop = Loop(sim)
    door = InProcessDoor(loop)
    assert isinstance(door, FrontDoor)
    access: LoopAccess = loop  # mypy checks that the loop offers what a door may use
    assert access.deliver == loop.deliver
    loop.courier.close()


def test_a_call_runs_on_the_simulation_thread(served: Served) -> None:
    names = served.call(lambda sim: threading.current_thread().name)
    assert names == "test-loop"
    assert served.call(lambda sim: sim.world.dt) == pytest.approx(0.01)


def test_an_exception_goes_back_to_its_caller_and_the_loop_goes_on(served: Served) -> None:
    with pytest.raises(ZeroDivisionError):
        served.call(lambda sim: 1 / 0)
    assert served.call(lambda sim: 42) == 42


def test_a_door_that_raises_does_not_end_the_loop(served: Served, caplog: pytest.LogCaptureFixture) -> None:
    served.loop.deliver(("in-process", "not a call"))  # handle() raises AttributeError on it
    assert served.call(lambda sim: "still serving") == "still serving"
    assert "simulation loop" in caplog.text


def test_the_loop_steps_when_running_and_after_step_answers(served: Served) -> None:
    served.call(lambda sim: sim.start())
    first = served.call(lambda sim: sim.steps)
    assert served.call(lambda sim: sim.steps, after_step=True) >= first  # its value: when it ran
    assert served.call(lambda sim: sim.steps) > first  # it was answered once a step had run since
    served.call(lambda sim: sim.stop())
    steps = served.call(lambda sim: sim.steps)
    time.sleep(0.1)
    assert served.call(lambda sim: sim.steps) == steps  # stopped: no steps
    assert served.call(lambda sim: sim.state) is RunState.STOPPED


def test_an_idle_loop_at_full_speed_takes_no_steps(sim: Simulation) -> None:
    """--speed 0 with no client: no steps; a client of a door counts as one."""
    s = Served(sim, speed=0)
    sim.start()
    s.thread.start()
    try:
        time.sleep(0.2)
        assert sim.steps == 0
        s.call(lambda sim: None)  # now the door has a client: the loop steps for it
        deadline = time.monotonic() + WAIT
        while sim.steps < 5 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert sim.steps >= 5
    finally:
        s.stop()


def test_the_synchronous_barrier_steps_once_every_client_triggered(served: Served) -> None:
    door = served.door
    door.stepping("a", True).result(WAIT)
    door.stepping("b", True).result(WAIT)
    served.call(lambda sim: sim.start())
    start = served.call(lambda sim: sim.steps)
    time.sleep(0.1)
    assert served.call(lambda sim: sim.steps) == start  # nobody triggered: no step
    b: Future[Any] = door.trigger("b")
    time.sleep(0.1)
    assert not b.done() and served.call(lambda sim: sim.steps) == start  # still waits for a
    assert door.trigger("a").result(WAIT) == start + 1  # a completes the barrier: one step
    assert b.result(WAIT) == start  # b's trigger answered after that step
    door.stepping("b", False).result(WAIT)  # b leaves: the barrier is a's alone
    assert door.trigger("a").result(WAIT) == start + 2
    door.stepping("a", False).result(WAIT)  # nobody left: asynchronous, the loop steps on its own
    assert served.call(lambda sim: sim.synchronous) is False


def test_a_silent_client_expires(sim: Simulation) -> None:
    s = Served(sim, speed=0, client_expiry=0.2)
    s.thread.start()
    try:
        s.door.stepping("quiet", True).result(WAIT)
        assert sim.is_synchronous("quiet")
        deadline = time.monotonic() + WAIT
        while not s.door.expired and time.monotonic() < deadline:
            time.sleep(0.05)
        assert s.door.expired == ["quiet"] and s.door.client_count() == 0
        assert not s.call(lambda sim: sim.is_synchronous("quiet"), client="other")  # left the barrier
    finally:
        s.stop()


def test_calls_past_the_bound_are_refused_at_once(sim: Simulation) -> None:
    loop = Loop(sim)  # not serving: calls stay pending
    door = InProcessDoor(loop, max_pending=2)
    loop.attach(door)
    try:
        pending = [door.call("a", lambda sim: None) for _ in range(2)]
        refused = door.call("a", lambda sim: None)
        assert not any(f.done() for f in pending)
        with pytest.raises(RuntimeError, match="max_pending"):
            refused.result(0)
    finally:
        loop.courier.close()


def test_a_failed_step_stops_the_simulation_and_the_loop_goes_on(
    served: Served, monkeypatch: pytest.MonkeyPatch
) -> None:
    sim = served.loop.sim

    def broken() -> None:
        raise RuntimeError("a broken step")

    served.call(lambda s: monkeypatch.setattr(s, "step", broken))
    served.call(lambda s: s.start())
    deadline = time.monotonic() + WAIT
    while sim.state is not RunState.STOPPED and time.monotonic() < deadline:
        time.sleep(0.01)
    assert served.call(lambda s: s.state) is RunState.STOPPED
    assert served.call(lambda s: "serving") == "serving"


def test_request_stop_ends_serve_and_close_closes_the_doors(sim: Simulation) -> None:
    s = Served(sim, speed=0)
    closed: list[str] = []
    s.door.close = lambda: closed.append("door")  # type: ignore[method-assign]
    s.thread.start()
    s.call(lambda sim: None)
    s.stop()
    assert closed == ["door"]
