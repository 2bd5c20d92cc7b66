"""Serving in place (Loop.serve_or_deliver): a front door's thread serves a request itself while
the simulation thread waits for work, and hands it to the ready ring otherwise.

A real Simulation and Loop, and the in-process front door; no sockets.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import loop_fixtures
import pytest
from loop_fixtures import WAIT, LoopThread

from simx_server.loop.in_process import InProcessDoor
from simx_server.scene.simulation import Simulation

sim = loop_fixtures.sim  # the shared fixture


def thread_name(sim: Simulation) -> str:
    return threading.current_thread().name


class Served(LoopThread):
    """A loop at full speed (it waits for work: nobody steps it) with an in-process door, and
    the thread that will serve it (not started)."""

    def __init__(self, sim: Simulation) -> None:
        super().__init__(sim, speed=0)
        self.door = InProcessDoor(self.loop)
        self.loop.attach(self.door)


@pytest.fixture
def served(sim: Simulation) -> Iterator[Served]:
    s = Served(sim)
    yield s
    if s.thread.is_alive():
        s.loop.request_stop()
        s.thread.join(WAIT)
    s.loop.close()


def test_a_call_is_served_on_the_calling_thread_while_the_loop_waits(served: Served) -> None:
    door, thread = served.door, served.thread
    thread.start()
    here = threading.current_thread().name
    for _ in range(50):  # the loop waits for work nearly all the time: served here at once
        future = door.call("a", thread_name, in_place=True)
        if future.done():  # served in place: answered before serve_or_deliver returned
            assert future.result() == here
            break
        # the loop was busy (starting, its housekeeping): the ring's, served by the loop's thread
        assert future.result(WAIT) == "test-loop"
        time.sleep(0.01)
    else:
        pytest.fail("50 calls and none was served in place")
    assert door.call("a", thread_name).result(WAIT) == "test-loop"  # delivered: the loop's thread


def test_a_call_waits_in_the_ring_while_the_simulation_thread_works(served: Served) -> None:
    door, thread = served.door, served.thread
    thread.start()
    release, started = threading.Event(), threading.Event()

    def busy(sim: Simulation) -> str:
        started.set()
        release.wait(WAIT)
        return "done"

    first = door.call("a", busy)
    assert started.wait(WAIT)
    second = door.call("b", thread_name, in_place=True)  # the simulation thread holds the loop
    assert not second.done()
    release.set()
    assert first.result(WAIT) == "done"
    assert second.result(WAIT) == "test-loop"  # served after, by the simulation thread


def test_nothing_is_served_in_place_before_serve_or_after_it(served: Served) -> None:
    door, thread = served.door, served.thread
    early = door.call("a", thread_name, in_place=True)
    assert not early.done()  # no loop yet: it waits in the ring
    thread.start()
    assert early.result(WAIT) == "test-loop"
    served.loop.request_stop()
    thread.join(WAIT)
    assert not thread.is_alive()
    late = door.call("a", thread_name, in_place=True)
    assert not late.done()  # the loop has ended: nobody serves it, and nothing raised


def test_a_call_that_raises_in_place_goes_back_to_its_caller(served: Served) -> None:
    door, thread = served.door, served.thread
    thread.start()
    for _ in range(50):
        future = door.call("a", lambda sim: 1 / 0, in_place=True)
        if future.done():  # served in place: its exception is the caller's at once
            with pytest.raises(ZeroDivisionError):
                future.result(0)
            break
        with pytest.raises(ZeroDivisionError):  # the ring's, served by the loop's thread
            future.result(WAIT)
        time.sleep(0.01)
    else:
        pytest.fail("50 calls and none was served in place")
    assert door.call("a", lambda sim: 42, in_place=True).result(WAIT) == 42
