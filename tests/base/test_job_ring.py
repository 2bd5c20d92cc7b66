"""A job ring's thread ends before a stopping server's interpreter does (issue 60): a daemon
thread alive at exit keeps what its frame holds, and OMPL's bindings print "leaked" lines for a
planner's objects (seen in CI when SIGINT came while the planning job's thread was returning)."""

from __future__ import annotations

import logging
import threading
import weakref

from simx_server.base import job_ring


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
