"""Clients' calls that wait for meshes' trees: a client's mesh query (ZMQ ``sim.checkCollision``,
``checkDistance``, ``handleCollision``, ``simOMPL.isStateValid``...; legacy ``simxCheckCollision``,
``simxReadDistance``...) never builds a mesh's tree on the simulation thread
(:class:`~simx_server.sim.mesh_geometry.TreesPending`: a 200,000-triangle mesh takes 0.85 s of
CPU). A door answers such a call once the tree is built, off that thread, and the call made again
on the simulation thread (``sim.post``, :mod:`simx_server.loop.tasks`); the simulation and every
other client go on meanwhile. The reply leaves as a rendered call's does (a Deferred).
"""

from __future__ import annotations

from concurrent.futures import Future
from typing import Any, Callable

from simx_server.api.context import CallContext
from simx_server.sim.mesh_geometry import UNBOUNDED, TreesPending, Work
from simx_server.sim.vision import Deferred


def answered(sim: Any, call: Callable[[], Any]) -> Any:
    """``call()`` (an API function's call, on the simulation thread, for the client its editor's
    files act for); when it meets a tree being built, a Deferred of its value: made again on the
    simulation thread once the builds are done, as often as it meets another (its error, or a
    build's, is the Deferred's).

    Without a loop to post to (``sim.post`` None: a simulation served in process), the builds
    are waited for here and the call made again at once.
    """
    try:
        return call()
    except TreesPending as pending:
        post = getattr(sim, "post", None)
        first = pending.future
    while post is None:
        first.result()
        try:
            return call()
        except TreesPending as more:
            first = more.future
    out: Future = Future()
    files = sim.editor.files
    key = files.caller

    def again() -> None:  # the simulation thread
        try:
            with files.acting(key):
                value = call()
        except TreesPending as more:
            more.future.add_done_callback(built)
            return
        except BaseException as exc:  # the reply says it
            out.set_exception(exc)
            return
        out.set_result(value)

    def built(future: Future) -> None:  # the builder's thread
        error = future.exception()
        if error is not None:
            out.set_exception(error)
        else:
            post(again)

    first.add_done_callback(built)
    return Deferred(out)


def door_client(ctx: CallContext) -> bool:
    """Whether ``ctx`` is a door's remote client (ZMQ: a client whose replies may wait), whose
    mesh queries and planning tasks are bounded; not a script, nor ``pyrep`` in process (the
    operator's, as its scene edits are)."""
    return ctx.remote and ctx.defer_renders


def query_work(ctx: CallContext) -> Work:
    """The bound of a mesh query ``ctx`` makes (:class:`~simx_server.sim.mesh_geometry.Work`): a
    door's client's (:func:`door_client`) is bounded (``mesh_geometry.MAX_QUERY_SECONDS``) and
    never builds a mesh's tree on the simulation thread (the door asks again once built:
    :class:`~simx_server.sim.mesh_geometry.TreesPending`); a script's and an in-process caller's
    are not bounded."""
    return Work.client() if door_client(ctx) else UNBOUNDED
