"""Jobs that other threads hand to the simulation thread: a front door of kind ``"task"``.

A job is a callable of no argument, run between two physics steps like any request. What it
serves: the end of work done off the simulation thread, e.g. a ``.ttt`` scene converted in its
worker process (:mod:`simx_server.scene.conversions`), whose install must run where the
simulation is owned. ``simx-server`` attaches one (:func:`attach`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from simx_server.loop.front_door import FrontDoor

log = logging.getLogger("simx.server")


class Tasks(FrontDoor):
    """Runs each delivered ``("task", job)`` on the simulation thread; a job that raises is
    logged (the job itself tells its requester)."""

    kinds: tuple[str, ...] = ("task",)

    def handle(self, kind: str, item: Any) -> None:
        """Run ``item()``; never raises."""
        try:
            item()
        except Exception:
            log.exception("a job handed to the simulation thread")


def attach(loop: Any, sim: Any) -> None:
    """Attach a :class:`Tasks` door to ``loop`` and give ``sim`` its ``post(job)``: thread-safe,
    never blocks, runs ``job()`` on the simulation thread at its next pass."""
    loop.attach(Tasks())
    deliver: Callable[[Any], None] = loop.deliver

    def post(job: Callable[[], Any]) -> None:
        deliver(("task", job))

    sim.post = post
