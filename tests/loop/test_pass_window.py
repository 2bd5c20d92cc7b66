"""A running pass's service window (Loop.hold_pass): CoppeliaSim's ZMQ remote API add-on
(``zmqRemoteApi.handleQueue``, from ``sysCall_actuation``) keeps serving requests for 2 ms per
client once one came in a pass, so a client that does not step gets several calls per pass
however fast the passes run. Counts of steps only; the windows here are long (seconds) so that
a loaded machine cannot end one early, and each is ended by the loop, not by the test.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import loop_fixtures
import pytest
from loop_fixtures import WAIT, LoopThread

from simx_server.base import limits
from simx_server.loop.in_process import InProcessDoor
from simx_server.scene.simulation import Simulation

sim = loop_fixtures.sim  # the shared fixture

pytestmark = pytest.mark.renderers_on_demand

WINDOW = 2.0  # s: longer than a few in-process calls take on a loaded machine


class Served(LoopThread):
    def __init__(self, sim: Simulation) -> None:
        super().__init__(sim, speed=0)  # as fast as possible: only the window holds a step
        self.door = InProcessDoor(self.loop)
        self.loop.attach(self.door)

    def call(self, fn: Any, client: str = "a", after_step: bool = False) -> Any:
        return self.door.call(client, fn, after_step).result(WAIT)


@pytest.fixture
def served(sim: Simulation) -> Iterator[Served]:
    s = Served(sim)
    s.thread.start()
    yield s
    if s.thread.is_alive():
        s.stop()


def test_calls_in_a_held_pass_all_see_the_same_step_and_the_step_follows(served: Served) -> None:
    loop = served.loop
    served.call(lambda sim: sim.start())
    served.call(lambda sim: None, after_step=True)  # running, stepping at full speed

    def held(sim: Simulation) -> int:
        loop.hold_pass("a", WINDOW)
        return sim.steps

    first = served.call(held)
    seen = [served.call(lambda sim: sim.steps) for _ in range(5)]
    assert seen == [first] * 5  # the pass's window is open: no step between the calls
    served.call(lambda sim: None, after_step=True)  # answered once the window is over and a step ran
    assert served.call(lambda sim: sim.steps) > first
    served.call(lambda sim: sim.stop())


def test_a_second_client_served_in_the_pass_lengthens_it(served: Served) -> None:
    """Two clients served in a pass: both are in its window (CoppeliaSim: timeout x clientCnt);
    the calls of either see the same step until it is over."""
    loop = served.loop
    served.call(lambda sim: sim.start())
    served.call(lambda sim: None, after_step=True)

    def held(client: str) -> Any:
        def fn(sim: Simulation) -> int:
            loop.hold_pass(client, WINDOW / 2)
            return sim.steps

        return fn

    first = served.call(held("a"))
    assert served.call(held("b"), client="b") == first
    assert served.call(lambda sim: sim.steps) == first
    served.call(lambda sim: None, after_step=True)
    assert served.call(lambda sim: sim.steps) > first
    served.call(lambda sim: sim.stop())


def test_no_window_while_stopped(served: Served) -> None:
    """A hold while the simulation is stopped is nothing: the first pass after the start is not
    held by what a client did before it."""
    loop = served.loop
    served.call(lambda sim: loop.hold_pass("a", 60.0))  # would hold the first pass a minute
    served.call(lambda sim: sim.start())
    start = served.call(lambda sim: sim.steps)
    served.call(lambda sim: None, after_step=True)  # a step within WAIT, not a minute
    assert served.call(lambda sim: sim.steps) > start
    served.call(lambda sim: sim.stop())


def test_the_zmq_window_is_coppeliasims() -> None:
    """``msgQueueTimeout_running = 0.002`` in the ZMQ remote API server add-on's sysCall_init."""
    assert limits.ZMQ_PASS_WINDOW == 0.002
