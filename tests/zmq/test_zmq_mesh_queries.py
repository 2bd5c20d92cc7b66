"""A ZMQ client's exact mesh queries (issue 84, item 1): bounded, their trees built off the
simulation thread, and a kept planning task counted against the tasks' memory budget. The
scaled-down nested spheres of tests/sim/test_mesh_bounds.py; in-process, the test's thread
serving the jobs handed to the simulation thread (``sim.post``)."""

from __future__ import annotations

import queue
import sys
import threading
import time
from pathlib import Path

import cbor2
import pytest

from simx_server.api.simompl import tasks
from simx_server.loop.clients import Clients
from simx_server.scene.simulation import Simulation
from simx_server.sim import mesh_geometry
from simx_server.zmq import codec
from simx_server.zmq.frontend import Incoming
from simx_server.zmq.service import ZmqService

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sim"))
from test_mesh_bounds import nested_scene  # noqa: E402


@pytest.fixture
def service(tmp_path, monkeypatch):
    monkeypatch.setattr(mesh_geometry, "TREES", mesh_geometry._Trees())
    monkeypatch.setattr(mesh_geometry, "PIECE_FACES", 64)
    (tmp_path / "nested.xml").write_text(nested_scene())
    sim = Simulation(tmp_path / "nested.xml")
    jobs: queue.SimpleQueue = queue.SimpleQueue()
    sim.post = jobs.put  # the jobs other threads hand to the simulation thread: this test's
    replies: list = []
    replied = threading.Event()

    def send(self, envelope, payload, held=0, **_):
        replies.append(cbor2.loads(payload))
        replied.set()

    frontend = type("Frontend", (), {"send": send, "expects": lambda self, identity: True,
                                     "release": lambda self, identity, held: None})()
    server = type("Server", (), {"sim": sim, "clients": Clients(), "hold_pass": lambda self, client, seconds: None})()
    made = ZmqService(server, frontend)

    def call(func: str, *args, posts: int = 0) -> dict:
        """Send; serve the jobs posted until the reply came (as the simulation thread would)."""
        replied.clear()
        made.handle("zmq", Incoming([b"id"], codec.read_request(codec.encode_request(func, list(args), "c")), 1, 10))
        served, end = 0, time.monotonic() + 60  # a bound on a loaded machine, not a timing under test
        while not replied.is_set():  # the reply may come from another thread (a long call's)
            assert time.monotonic() < end, f"no reply to {func}"
            try:
                job = jobs.get(timeout=0.05)
            except queue.Empty:
                continue
            job()
            served += 1
        call.posts = served
        return replies[-1]

    made.call = call
    yield made
    sim.close()


def _handles(service) -> tuple[int, int]:
    return tuple(service.call("sim.getObject", p)["ret"][0] for p in ("/Outer", "/Inner"))


def test_a_query_is_answered_once_its_trees_are_built_off_the_simulation_thread(service):
    outer, inner = _handles(service)
    reply = service.call("sim.checkCollision", outer, inner)
    assert reply == {"ret": [0, [-1, -1]]} and service.call.posts >= 1  # made again once built
    assert service.call("sim.checkCollision", outer, inner) == {"ret": [0, [-1, -1]]}
    assert service.call.posts == 0  # built: answered at once
    d = service.call("sim.checkDistance", outer, inner)["ret"][1][6]
    assert d == pytest.approx(0.002, abs=2e-4)


def test_a_query_past_its_bound_is_refused(service, monkeypatch):
    outer, inner = _handles(service)
    service.call("sim.checkDistance", outer, inner)  # the trees built
    monkeypatch.setattr(mesh_geometry, "MAX_QUERY_SECONDS", 0.0)
    reply = service.call("sim.checkDistance", outer, inner)
    assert "MAX_QUERY_SECONDS" in reply.get("err", ""), reply


def test_a_planning_tasks_checks_are_bounded_and_its_copies_budgeted(service, monkeypatch):
    pytest.importorskip("ompl")
    outer, inner = _handles(service)
    service.call("sim.checkDistance", outer, inner)  # the trees built
    space = service.call("simOMPL.createStateSpace", "p", 50003, inner, [-1, -1, 0.5], [1, 1, 1.5], 1)["ret"][0]
    task = service.call("simOMPL.createTask", "t")["ret"][0]
    for func, *args in (("setStateSpace", [space]), ("setCollisionPairs", [inner, outer]),
                        ("setStartState", [0, 0, 1]), ("setGoalState", [0.1, 0, 1]), ("setup",)):
        assert "ret" in service.call(f"simOMPL.{func}", task, *args), func
    assert service.call("simOMPL.isStateValid", task, [0, 0, 1]) == {"ret": [True]}
    monkeypatch.setattr(mesh_geometry, "MAX_QUERY_SECONDS", 0.0)
    reply = service.call("simOMPL.isStateValid", task, [0, 0, 1])
    assert "MAX_QUERY_SECONDS" in reply.get("err", ""), reply
    reply = service.call("simOMPL.solve", task, 5.0)  # off the simulation thread: its checks bounded too
    assert "MAX_QUERY_SECONDS" in reply.get("err", ""), reply
    monkeypatch.setattr(tasks, "MAX_KEPT_BYTES", 1)
    reply = service.call("simOMPL.setup", task)
    assert "server busy" in reply.get("err", "") and "MAX_KEPT_BYTES" in reply["err"], reply


def test_without_a_loop_the_builds_are_waited_for_in_place():
    """A simulation served in process (no ``sim.post``): the call is made again once built."""
    from concurrent.futures import Future
    from types import SimpleNamespace

    from simx_server.api.mesh_waits import answered
    from simx_server.sim.mesh_geometry import TreesPending

    built: Future = Future()
    built.set_result(None)
    calls = []

    def call():
        calls.append(1)
        if len(calls) == 1:
            raise TreesPending(built, 10)
        return "answer"

    assert answered(SimpleNamespace(post=None), call) == "answer" and len(calls) == 2


def test_only_a_doors_clients_queries_are_bounded(service):
    """A ZMQ client's context is bounded; a script's and PyRep's in process (the operator's) not."""
    from simx_server.api import CallContext, Callers
    from simx_server.api.mesh_waits import query_work
    from simx_server.sim.mesh_geometry import UNBOUNDED

    from pyrep.pyrep import _InProcessContext

    sim = service.sim
    assert query_work(service.remote).limit == mesh_geometry.MAX_QUERY_SECONDS
    assert query_work(_InProcessContext(None, -1, sim.signals, "pyrep", caller=Callers.CLIENTS,
                                        live=lambda: sim)) is UNBOUNDED
    assert query_work(CallContext(sim.world, -1, sim.signals, "script", view=sim)) is UNBOUNDED
