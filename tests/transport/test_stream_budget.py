"""Streamed commands within a time budget per step (issue 84, item 1): one streamed
``simxCheckCollision`` of two 200,000-triangle meshes held the simulation thread 32.9 s after each
step, and a connected legacy client was dropped. Now every client's streams together take at
most ``limits.MAX_STREAMS_STEP_SECONDS`` of the thread's time a step; the rest skip the step, the
clients taken in turn; a query whose mesh's tree is being built skips the step too. In-process,
the legacy door's stream pass (``StreamPublisher._publish_each``) with a clock of the test's
own: what is asserted is which streams ran in which step, never a time."""

from __future__ import annotations

from concurrent.futures import Future
from types import SimpleNamespace

import pytest

from simx_server.base import limits
from simx_server.legacy import streams as streams_module
from simx_server.legacy.streams import StreamPublisher, _Stream
from simx_server.sim.mesh_geometry import TreesPending
from simx_server.sim.state import RunState


class Door(StreamPublisher):
    """What the stream pass reads of the legacy door: the clients' streams and their sessions;
    each update handed over is kept (client -> the commands it carries)."""

    def __init__(self, clients: dict[str, list[str]]):
        self._streams = {c: {(name, i): _Stream(name, [i], 0) for i, name in enumerate(names)}
                         for c, names in clients.items()}
        self.sessions = SimpleNamespace(get=lambda client: None, can_send=lambda session: True)
        self.updates: list[dict[str, list]] = []

    def _put_stream(self, client, session, entries, renders, encodings, bulk=False, stepped=False):
        self.updates[-1][client] = [(e[0], e[2]) for e in entries]
        return None

    def step(self) -> dict[str, list]:
        self.updates.append({})
        sim = SimpleNamespace(state=RunState.RUNNING, is_synchronous=lambda client: False,
                              editor=SimpleNamespace(files=SimpleNamespace(caller=None)))
        self._publish_each(sim, 0.0, False, [])
        return self.updates[-1]


@pytest.fixture
def commands(monkeypatch):
    """Streamed commands of the test's own: each costs its 0.2 s of the test's clock, and
    ``Pending`` meets a tree being built."""
    clock = [0.0]
    monkeypatch.setattr(streams_module.time, "thread_time", lambda: clock[0])

    def costly(sim, args):
        clock[0] += 0.2
        return 1

    def pending(sim, args):
        raise TreesPending(Future(), 1000)

    monkeypatch.setitem(streams_module.HANDLERS, "Costly", costly)
    monkeypatch.setitem(streams_module.HANDLERS, "Pending", pending)
    monkeypatch.setattr(limits, "MAX_STREAMS_STEP_SECONDS", 0.5)


def test_streams_past_the_steps_budget_skip_it_and_the_clients_take_turns(commands):
    door = Door({"a": ["Costly"] * 3, "b": ["Costly"] * 3, "c": ["Costly"] * 3})
    seen = [door.step() for _ in range(3)]
    for step in seen:  # the budget's worth of each step, 0.5 s: three commands (the third starts at 0.4 s)
        assert sum(len(entries) for entries in step.values()) == 3
    assert [list(step) for step in seen] == [["a"], ["b"], ["c"]]  # each step begins with the next client


def test_a_query_whose_tree_is_being_built_skips_the_step(commands):
    door = Door({"a": ["Pending", "Costly"]})
    assert door.step() == {"a": [("Costly", True)]}  # no error sent: the step's update leaves it out
