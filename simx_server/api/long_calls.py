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
A script that acts for a client (a client's scene's, with ``--allow-remote-code``, or one a
client calls into; :func:`for_client`) is held to the same: in a Lua thread, its long call runs
off the simulation thread and the thread yields until it is done (:func:`deferring`, as
``sim.wait`` yields: :mod:`simx_server.scripts.threads`); elsewhere (a non-threaded callback,
which cannot yield) the work runs at once but stops once it has taken what the scripts' pass
has left (:func:`time_left`: ``limits.MAX_SCRIPTS_STEP_TIME``, ``SCRIPTS_SHARE``), an error
naming the bound. The operator's scripts (trusted) and in-process callers (``pyrep``) run the
work at once, as CoppeliaSim's do, with their time.
"""

from __future__ import annotations

import contextlib
import inspect
import logging
import math
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future, InvalidStateError
from typing import Any

from simx_server.api.context import CallContext
from simx_server.base import job_ring
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
            reason = job_ring.stop_reason()
            raise Stopped(LEFT if reason == "its client left" else f"stopped: {reason}")
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


#: s of work a long call done in slices (``work`` returns a generator: a planner's solve) does in
#: one turn: another client's call waits behind one slice of each other connection's, not a
#: whole solve (12 connections solving for 10 s each held a victim's 0.3 s solve 119 s).
SLICE_SECONDS = 0.1


def _whole(value: Any) -> Any:
    """``value``, or the return value of the generator ``value`` run to its end (the slices of
    a work done at once, back to back)."""
    if not inspect.isgenerator(value):
        return value
    while True:
        try:
            next(value)
        except StopIteration as end:
            return end.value


_deferring: list[CallContext | None] = [None]  # the script context whose Lua thread waits for a Deferred


@contextlib.contextmanager
def deferring(ctx: CallContext) -> Iterator[None]:
    """A script's call from a thread that can yield until a Deferred is done (simulation thread):
    a long call of ``ctx`` inside the block runs off the simulation thread when the script acts
    for a client (:func:`for_client`)."""
    previous, _deferring[0] = _deferring[0], ctx
    try:
        yield
    finally:
        _deferring[0] = previous


def for_client(ctx: CallContext) -> bool:
    """Whether a script's call acts for a client: the script was sent by one (its file lies in a
    client's folder, or its client left), or a client's call into it runs now. False for the
    operator's scripts on their own and for a door's calls."""
    script, files = ctx.script, getattr(getattr(ctx.view, "editor", None), "files", None)
    if script is None or files is None:
        return False
    try:
        return files.writer(getattr(script, "path", None)) is not None
    except RemoteError:  # sent by a client that has left
        return True


def off_thread(ctx: CallContext) -> bool:
    """Whether ``ctx``'s calls run their long work off the simulation thread: a remote client's
    door that replies once a Deferred is done (the ZMQ service), or a Lua thread of a script
    that acts for a client (:func:`deferring`); not another script, not ``pyrep``."""
    if ctx.remote:
        return ctx.defer_renders and ctx.view is not None
    return _deferring[0] is ctx and ctx.view is not None and for_client(ctx)


def time_left(ctx: CallContext) -> float:
    """s a long call run at once may take: for a script that acts for a client, what the
    scene's scripts' pass and share have left (its own ``script_timeout`` at most; CPU time of
    the simulation thread, taken as wall time); unbounded for everyone else."""
    script = ctx.script
    if script is None or not for_client(ctx):
        return math.inf
    budget = getattr(script, "budget", None)
    own = float(getattr(script, "timeout", 1.0))
    return max(0.0, budget.bound(own)[0]) if budget is not None else own


def later(ctx: CallContext, work: Callable[[], Any], finish: Callable[[Any], Any] | None = None,
          done: Callable[[], None] | None = None) -> Any:
    """``work()`` (then ``finish(its value)`` on the simulation thread), off the simulation
    thread for a remote client (:func:`off_thread`), at once otherwise.

    Args:
        ctx: the caller's context.
        work: what runs off the simulation thread: it reads only the snapshot it closes over
            (taken by the caller, on the simulation thread), never the live scene. It may return
            a generator instead of its value (which the generator returns): off the thread its
            steps run :data:`SLICE_SECONDS` a turn, at once back to back.
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
        seconds = time_left(ctx)
        bound = (job_ring.bounded(seconds, f"it reached what the scripts' pass had left ({seconds:.2g} s; "
                                           "limits.MAX_SCRIPTS_STEP_TIME, SCRIPTS_SHARE: in a threaded script it "
                                           "runs off the simulation thread)")
                 if seconds < math.inf else contextlib.nullcontext())
        try:
            with bound:
                value = _whole(work())
        finally:
            if done is not None:
                done()
        return finish(value) if finish is not None else value
    files = getattr(getattr(view, "editor", None), "files", None)
    caller = getattr(files, "caller", None)
    if ctx.script is not None and files is not None:  # a client's script: its jobs are its client's
        caller = files.writer(getattr(ctx.script, "path", None))
    future: Future[Any] = Future()
    deferred = Deferred(future)

    def install(value: Any) -> None:  # the simulation thread
        if future.cancelled():  # its script's thread ended meanwhile: nothing is made
            return
        try:
            if files is not None:
                with files.acting(caller):
                    future.set_result(finish(value))  # type: ignore[misc]
            else:
                future.set_result(finish(value))  # type: ignore[misc]
        except Exception as exc:
            future.set_exception(exc)

    steps: list[Any] = []  # a work done in slices: its generator, once started

    def job() -> bool:  # the background thread; True: more to do, in the caller's next turn
        start = time.monotonic()
        value = error = None
        try:
            if not steps:
                value = work()
                if not inspect.isgenerator(value):
                    raise StopIteration(value)
                steps.append(value)
            while time.monotonic() - start < SLICE_SECONDS:
                next(steps[0])
            deferred.seconds += time.monotonic() - start
            return True
        except StopIteration as end:
            value = end.value
        except BaseException as exc:
            error = exc
        if done is not None:  # before the reply can leave: the caller's next call finds the task free
            done()
        deferred.seconds += time.monotonic() - start
        try:
            if error is not None:
                future.set_exception(error)
            elif finish is None:
                future.set_result(value)
            elif not future.cancelled():
                post(lambda: install(value))  # type: ignore[misc]  # not None: off_thread with a finish needs it
        except InvalidStateError:  # cancelled meanwhile: its script's thread ended
            pass
        return False

    def cancelled() -> None:  # dropped before it ran: its client left
        if done is not None:
            done()
        if not future.cancelled():
            future.set_exception(RemoteError(LEFT))

    try:
        waiting.add(caller, job, cancelled)
    except RemoteError:
        if done is not None:
            done()
        raise
    return deferred
