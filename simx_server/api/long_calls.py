"""Remote clients' long API calls, run off the simulation thread: motion planning
(``simOMPL.solve``, ``simplifyPath``, ``compute``) and convex decomposition
(``sim.convexDecompose``).

These calls run for seconds by design (a planner's ``maxTime``, V-HACD's voxels): on the
simulation thread, a ZMQ client's ``simOMPL.solve(task, 1e9)`` kept every other client waiting
10 s, ``simOMPL.compute`` 185 s, ``sim.convexDecompose`` at 400,000 voxels 21-32 s. For a caller
whose door replies once a :class:`~simx_server.sim.vision_results.Deferred` is done (the ZMQ
service's context: :attr:`CallContext.defer_renders
<simx_server.api.context.CallContext.defer_renders>`), :func:`later` takes what the call needs
(its arguments checked, a snapshot of the state it reads, made on the simulation thread), runs
the work on one background thread and answers a Deferred at once; what must change the scene
(the decomposed shape) is handed back to the simulation thread (``sim.post``, as
:mod:`simx_server.scene.conversions` installs a converted scene). The simulation keeps stepping
and every other client keeps being served meanwhile.

One job runs at a time, taken round robin by connection (the ZMQ door names the connection a
request came on, :func:`simx_server.base.job_ring.serving`: a client may claim a new uuid at
every call, not a new connection), so that a client's job waits behind at most one job of each
other connection; a connection has at most :data:`MAX_WAITING_PER_CLIENT` jobs running or
waiting (more: ``server busy``). When a client leaves (its connection closes, ``_*end*_``,
expiry) its jobs not started are dropped, their callers answered "not run", and its job running
is asked to stop (:func:`stoppable`: a planner's validity check raises; V-HACD's worker is
killed). The work's seconds are kept on the Deferred (``seconds``) for the door to charge to
the caller's share.
Scripts (the scene's own, trusted, and their Lua callbacks run on the simulation thread) and
in-process callers (``pyrep``) run the work at once, as before.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

from simx_server.api.context import CallContext
from simx_server.base.job_ring import JobRing, stop_requested
from simx_server.sim.vision_results import Deferred
from simx_wire.protocol import BUSY, RemoteError

log = logging.getLogger("simx.api")

#: Jobs of one client (its connection, for a ZMQ client) running or waiting at once.
MAX_WAITING_PER_CLIENT = 2
#: Why a long call's job ended unanswered: its client left.
LEFT = "not run: its client left (its connection closed, it ended, or it expired)"


class Stopped(RemoteError):
    """A long call's work stopped because its client left (:func:`stoppable`)."""


def stoppable(valid: Callable[[Any], bool]) -> Callable[[Any], bool]:
    """``valid`` (a planner's state validity check) that raises :class:`Stopped` once the long
    call running it is asked to stop (its client left): OMPL ends the solve at the next state it
    checks (:func:`simx_server.base.job_ring.stop_requested`)."""

    def check(q: Any) -> bool:
        if stop_requested():
            raise Stopped(LEFT)
        return valid(q)

    return check


class LongCalls(JobRing):
    """The long calls waiting for the one background thread, served round robin by client
    (the thread is started when a job comes and ends when none waits)."""

    def __init__(self) -> None:
        super().__init__(MAX_WAITING_PER_CLIENT, "simx-long-calls", log, "long call")

    def busy(self, mine: int) -> str:
        return (f"{BUSY}: {mine} long call(s) of this client (planning, convex decomposition) run "
                f"or wait already (long_calls.MAX_WAITING_PER_CLIENT = {MAX_WAITING_PER_CLIENT})")


waiting = LongCalls()


def off_thread(ctx: CallContext) -> bool:
    """Whether ``ctx``'s calls run their long work off the simulation thread: a remote client's
    door that replies once a Deferred is done (the ZMQ service), not a script, not ``pyrep``."""
    return ctx.remote and ctx.defer_renders and ctx.view is not None


def later(ctx: CallContext, work: Callable[[], Any], finish: Callable[[Any], Any] | None = None,
          done: Callable[[], None] | None = None) -> Any:
    """``work()`` (then ``finish(its value)`` on the simulation thread), off the simulation
    thread for a remote client (:func:`off_thread`), at once otherwise.

    Args:
        ctx: the caller's context.
        work: what runs off the simulation thread: it reads only the snapshot it closes over
            (taken by the caller, on the simulation thread), never the live scene.
        finish: what must run on the simulation thread with ``work``'s value (a scene edit);
            its return value is the call's. None: ``work``'s value is the call's.
        done: run after ``work`` (in its thread, whatever happened): releases what the call
            holds (a task marked busy).

    Returns:
        The call's value, or for a remote client a Deferred of it (``seconds``: the work's).

    Raises:
        RemoteError: ``server busy`` (:data:`MAX_WAITING_PER_CLIENT`); at once: what ``work``
            or ``finish`` raise.
    """
    view = ctx.view
    post = getattr(view, "post", None)
    if not off_thread(ctx) or (finish is not None and post is None):
        try:
            value = work()
        finally:
            if done is not None:
                done()
        return finish(value) if finish is not None else value
    files = getattr(getattr(view, "editor", None), "files", None)
    caller = getattr(files, "caller", None)
    future: Future[Any] = Future()
    deferred = Deferred(future)

    def install(value: Any) -> None:  # the simulation thread
        try:
            if files is not None:
                with files.acting(caller):
                    future.set_result(finish(value))  # type: ignore[misc]
            else:
                future.set_result(finish(value))  # type: ignore[misc]
        except Exception as exc:
            future.set_exception(exc)

    def job() -> None:  # the background thread
        start = time.monotonic()
        value = error = None
        try:
            value = work()
        except BaseException as exc:
            error = exc
        if done is not None:  # before the reply can leave: the caller's next call finds the task free
            done()
        deferred.seconds = time.monotonic() - start
        if error is not None:
            future.set_exception(error)
        elif finish is None:
            future.set_result(value)
        else:
            post(lambda: install(value))  # type: ignore[misc]  # not None: off_thread with a finish needs it

    def cancelled() -> None:  # dropped before it ran: its client left
        if done is not None:
            done()
        future.set_exception(RemoteError(LEFT))

    try:
        waiting.add(caller, job, cancelled)
    except RemoteError:
        if done is not None:
            done()
        raise
    return deferred
