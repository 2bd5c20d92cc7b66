"""A job ring's thread ends before a stopping server's interpreter does (issue 60): a daemon
thread alive at exit keeps what its frame holds, and OMPL's bindings print "leaked" lines for a
planner's objects (seen in CI when SIGINT came while the planning job's thread was returning)."""

from __future__ import annotations

import logging
import threading
import weakref
from collections.abc import Callable

import pytest

from simx_server.base import job_ring
from simx_wire.protocol import RemoteError


class Ring(job_ring.JobRing):
    def busy(self, mine: int) -> str:
        return "busy"


class Planner:
    """Stands for a planner's objects, which the job closes over."""


def test_settle_waits_for_the_thread_and_drops_the_job() -> None:
    ring = Ring(2, "test-ring", logging.getLogger("test"), "job")
    planner = Planner()
    gone = weakref.ref(planner)
    answered, returning = threading.Event(), threading.Event()

    def job(planner: Planner = planner) -> None:
        answered.set()  # the reply leaves here; the thread returns after
        returning.wait(10)
        assert planner is not None

    ring.add("zmq:a", job)
    del job, planner
    assert answered.wait(10)
    assert gone() is not None  # the job's thread still holds it
    returning.set()
    assert ring.settle(10)
    assert gone() is None
    assert ring.pending() == 0


def test_settle_all_reports_a_job_that_outlasts_the_timeout() -> None:
    ring = Ring(2, "test-ring", logging.getLogger("test"), "job")
    release = threading.Event()

    def job() -> None:
        release.wait(10)

    ring.add(None, job)
    try:
        assert not job_ring.settle_all(0.05)
    finally:
        release.set()
    assert job_ring.settle_all(10)


def test_turns_are_taken_by_connection_and_a_leaving_client_is_forgotten() -> None:
    """Issue 84: a victim's job waited behind 12 fresh uuids' jobs (each its own turn), and behind
    the jobs of clients that had left. Jobs take their connection's turn (job_ring.serving) and
    count toward its limit, whatever uuid they claim; cancelling a key drops its jobs not started
    (their callers told) and asks its running job to stop."""
    ring = Ring(2, "test-ring", logging.getLogger("test"), "job")
    gate, stopped, started = threading.Event(), threading.Event(), threading.Event()
    order: list[str] = []
    dropped: list[str] = []

    def job(name: str) -> Callable[[], None]:
        def run() -> None:
            started.set()
            gate.wait(10)
            if job_ring.stop_requested():
                stopped.set()
            order.append(name)

        return run

    with job_ring.serving(b"attacker", "zmq:a0"):
        ring.add("zmq:a0", job("a0"), lambda: dropped.append("a0"))
    with job_ring.serving(b"attacker", "zmq:a1"):
        ring.add("zmq:a1", job("a1"), lambda: dropped.append("a1"))
    with job_ring.serving(b"attacker", "zmq:a2"), pytest.raises(RemoteError, match="busy"):
        ring.add("zmq:a2", job("a2"))  # a third job of the connection, under a fresh uuid
    with job_ring.serving(b"victim", "zmq:v"):
        ring.add("zmq:v", job("v"))
    assert ring.pending(b"attacker") == 2 and ring.pending(b"victim") == 1
    assert started.wait(10)  # a0 runs
    assert job_ring.cancel_all(b"attacker") == 1  # a1 dropped; a0 asked to stop
    assert dropped == ["a1"] and ring.pending(b"attacker") == 1
    gate.set()
    assert ring.settle(10)
    assert order == ["a0", "v"] and stopped.is_set() and ring.pending() == 0


def test_a_job_dropped_for_its_owner_and_the_others_kept() -> None:
    ring = Ring(4, "test-ring", logging.getLogger("test"), "job")
    gate, order = threading.Event(), []

    def first() -> None:  # runs: the others wait behind it
        gate.wait(10)

    def job(name: str) -> Callable[[], None]:
        return lambda: order.append(name)

    ring.add("first", first)
    for name in ("x", "y", "x"):
        ring.add(name, job(name))
    assert ring.cancel("x") == 2
    gate.set()
    assert ring.settle(10)
    assert order == ["y"]


def test_a_job_in_slices_goes_on_in_its_next_turn() -> None:
    """A job that returns True has more to do: its next slice comes after every other turn's job."""
    ring = Ring(4, "test-ring", logging.getLogger("test"), "job")
    gate = threading.Event()
    order: list[str] = []
    slices = iter([True, True, False])

    def long() -> bool:
        gate.wait(10)
        order.append("long")
        return next(slices)

    def short(name: str) -> Callable[[], None]:
        return lambda: order.append(name)

    ring.add("a", long)
    ring.add("b", short("b1"))
    ring.add("c", short("c1"))
    ring.add("b", short("b2"))
    gate.set()
    assert ring.settle(10)
    assert order == ["long", "b1", "c1", "long", "b2", "long"]
    assert ring.pending() == 0
