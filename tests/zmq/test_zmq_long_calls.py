"""ZMQ clients' long calls off the simulation thread (issue 57): ``simOMPL.solve`` with a huge
``maxTime`` held every other client 10 s, ``simOMPL.compute(task, 1e9, 1e9, 1e7)`` 185 s (and
grew the server to 7 GB), ``sim.convexDecompose`` 21-32 s, ``simIK.findConfig`` 10 s. Bounded
forms on a real server with raw sockets: another client's call is answered while the long call
runs (ordering: its reply is there before the long call's), the task refuses other calls
meanwhile, sizes past the reply's bound are refused before any work, and the work's time is
charged to its caller; the queue of long calls itself in-process."""

from __future__ import annotations

import threading

import cbor2
import pytest
import zmq

from conftest import ServerProcess, free_port
from simx_server.api import long_calls
from simx_server.sim import motion_planning as mp
from simx_server.zmq import codec
from simx_wire.protocol import BUSY, RemoteError

pytest.importorskip("ompl")
pytestmark = pytest.mark.renderers_on_demand

#: A one-link arm that a post blocks: Joint1 cannot turn from 0 to 2.5 rad (the link hits the post
#: at pi/2), so a planner searches until its time is up. A box shape to decompose.
SCENE = """<mujoco model="long calls">
  <compiler angle="radian"/>
  <worldbody>
    <body name="Link1" pos="0 0 0.3">
      <joint name="Joint1" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0.03 0 0 0.4 0 0" size="0.03"/>
    </body>
    <body name="Post" pos="0 0.25 0.3"><geom type="box" size="0.03 0.03 0.2"/></body>
    <body name="Block" pos="1 1 0.1"><geom type="box" size="0.1 0.05 0.02"/></body>
  </worldbody>
</mujoco>
"""


class Client:
    """A raw REQ socket speaking the protocol."""

    def __init__(self, port: int, uuid: str):
        self.ctx = zmq.Context()
        self.sock = self.ctx.socket(zmq.REQ)
        self.sock.setsockopt(zmq.RCVTIMEO, 60000)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.connect(f"tcp://127.0.0.1:{port}")
        self.uuid = uuid

    def send(self, func: str, *args) -> None:
        self.sock.send(codec.encode_request(func, list(args), self.uuid))

    def receive(self) -> dict:
        return cbor2.loads(self.sock.recv())

    def answered(self) -> bool:
        """Whether the reply to the request sent is there now (it is not read)."""
        return bool(self.sock.poll(0))

    def call(self, func: str, *args) -> dict:
        self.send(func, *args)
        return self.receive()

    def close(self) -> None:
        self.sock.close(0)
        self.ctx.term()


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("long_calls")
    (folder / "scene.xml").write_text(SCENE)
    port = free_port()
    srv = ServerProcess(str(folder / "scene.xml"), "--zmq-port", str(port), renderers="on-demand")
    srv.zmq_port = port
    yield srv
    log = srv.stop()
    assert "Traceback" not in log, log[-3000:]


@pytest.fixture
def clients(server):
    made = [Client(server.zmq_port, "planner"), Client(server.zmq_port, "other")]
    yield made
    for c in made:
        c.close()


def _blocked_task(c: Client) -> str:
    """A set-up task whose goal no path reaches (the post is in the way)."""
    joint = c.call("sim.getObject", "/Joint1")["ret"][0]
    task = c.call("simOMPL.createTask", "blocked")["ret"][0]
    assert "ret" in c.call("simOMPL.setAlgorithm", task, 30017)  # RRTConnect
    assert "ret" in c.call("simOMPL.setStateSpaceForJoints", task, [joint], [1])
    link, post = (c.call("sim.getObject", p)["ret"][0] for p in ("/Link1", "/Post"))
    assert "ret" in c.call("simOMPL.setCollisionPairs", task, [link, post])
    assert "ret" in c.call("simOMPL.setStartState", task, [0.0])
    assert "ret" in c.call("simOMPL.setGoalState", task, [2.5])
    assert "ret" in c.call("simOMPL.setup", task)
    return task


def test_planning_runs_off_the_simulation_thread(clients):
    """While one client's solve searches (2 s), another client's calls are answered, and the task
    refuses every other call until the solve has answered."""
    planner, other = clients
    task = _blocked_task(planner)
    planner.send("simOMPL.solve", task, 2.0)
    assert other.call("sim.getSimulationTime")["ret"][0] >= 0
    # The two sockets are queued fairly, not in the order sent: the solve may be read after the
    # other client's first calls, never after many. Ask until the task reports busy (each call
    # is a round trip that gives the server another turn to read the solve).
    for _ in range(50):
        busy = other.call("simOMPL.getPath", task)
        if "the task is busy" in busy.get("err", "") or planner.answered():
            break
    assert "the task is busy" in busy.get("err", ""), busy
    assert not planner.answered()  # the others were served while it searched
    assert "ret" in planner.receive()  # an approximate path at best: the post is in the way
    assert other.call("simOMPL.hasExactSolution", task) == {"ret": [False]}
    # a simplification answers once done: the next call finds the task free
    assert planner.call("simOMPL.simplifyPath", task, 0.2) == {"ret": []}
    assert "ret" in planner.call("simOMPL.interpolatePath", task, 10)
    assert "ret" in other.call("simOMPL.destroyTask", task)


def test_compute_refuses_a_path_past_the_replys_bound_before_planning(clients):
    """compute(task, 1e9, 1e9, 1e7) made 10^7 states (7 GB): refused before any planning."""
    planner, _ = clients
    task = _blocked_task(planner)
    reply = planner.call("simOMPL.compute", task, 1e9, 1e9, 10 ** 7)
    assert "MAX_PATH_VALUES" in reply.get("err", ""), reply
    reply = planner.call("simOMPL.interpolatePath", task, 10 ** 7)
    assert "MAX_PATH_VALUES" in reply.get("err", ""), reply
    reply = planner.call("simOMPL.setStateValidityCheckingResolution", task, 1e-9)
    assert "MIN_RESOLUTION" in reply.get("err", ""), reply
    assert "ret" in planner.call("simOMPL.destroyTask", task)


def test_convex_decomposition_runs_off_the_simulation_thread(clients):
    """V-HACD in its worker process, waited for off the simulation thread: another client is
    answered first; the shape is made once it is done."""
    pytest.importorskip("vhacdx")
    planner, other = clients
    block = planner.call("sim.getObject", "/Block")["ret"][0]
    planner.send("sim.convexDecompose", block, 0, [0] * 10, [0.0] * 10)
    assert other.call("sim.getSimulationTime")["ret"][0] >= 0
    assert not planner.answered()
    reply = planner.receive()
    assert "ret" in reply, reply
    assert other.call("sim.getObjectType", reply["ret"][0])["ret"] == [0]  # sim.sceneobject_shape


def test_find_config_is_bounded_by_a_requests_budget(tmp_path, monkeypatch):
    """simIK.findConfig with maxTime 1e9 searched 10 s on the simulation thread: a ZMQ client's
    search ends within limits.MAX_REQUEST_SECONDS, a script's keeps its maxTime (up to 10 s).
    In-process, each solve and each batch of random configurations' distance checks (CoppeliaSim
    4.1's gate: none lies within 0.1 m of a target out of reach) made to take 0.25 s of a
    stand-in clock: counted, not timed."""
    from simx_server.api import client_context, script_sim
    from simx_server.api.simik import config_gate, environments, search
    from simx_server.base import limits
    from simx_server.scene.simulation import Simulation
    from simx_server.sim import ik_batch

    (tmp_path / "scene.xml").write_text(SCENE)
    simulation = Simulation(tmp_path / "scene.xml", realtime=False)
    clock, restarts = [0.0], []
    solve = environments.solve

    def counted(*args, **kwargs):
        restarts.append(1)
        clock[0] += 0.25
        return solve(*args, **kwargs)

    far = config_gate.far

    def counted_far(*args):
        restarts.append(1)
        clock[0] += 0.25
        return far(*args)

    gate = ik_batch.Chain.gate

    def counted_gate(*args):
        restarts.append(1)
        clock[0] += 0.25
        return gate(*args)

    monkeypatch.setattr(search.time, "monotonic", lambda: clock[0])
    monkeypatch.setattr(environments, "solve", counted)
    monkeypatch.setattr(config_gate, "far", counted_far)
    monkeypatch.setattr(ik_batch.Chain, "gate", counted_gate)
    try:
        for ctx, seconds in ((client_context(simulation), limits.MAX_REQUEST_SECONDS),
                             (script_sim(simulation.world, simulation.world.resolve("Post").handle, simulation.signals,
                                         simulation=simulation).context,
                              search.MAX_SEARCH_SECONDS)):
            sim, ik = ctx.sim, ctx.simik
            joint, link = sim.getObject("/Joint1"), sim.getObject("/Link1")
            env = ik.createEnvironment()
            group = ik.createGroup(env)
            tip, target = sim.createDummy(0.01), sim.createDummy(0.01)
            sim.setObjectParent(tip, link, False)
            sim.setObjectPosition(tip, -1, [0.4, 0.0, 0.3])
            sim.setObjectPosition(target, -1, [5.0, 5.0, 5.0])  # out of reach: it searches until its time is up
            ik.addElementFromScene(env, group, -1, tip, target, 1)
            restarts.clear()
            assert ik.findConfig(env, group, [joint], 0.1, 1e9) is None
            assert len(restarts) == pytest.approx(seconds / 0.25, abs=1)
            sim.removeObjects([tip, target])
    finally:
        simulation.close()


# ------------------------------------------------------------------ in-process: the queue
def test_long_calls_are_served_round_robin_and_bounded_per_client():
    """One job at a time, round robin by client; a client's third job is refused "server busy"."""
    queue = long_calls.LongCalls()
    gate, order, finished = threading.Event(), [], threading.Event()

    def job(name: str):
        def run():
            gate.wait(30)
            order.append(name)
            if len(order) == 4:
                finished.set()
        return run

    queue.add("a", job("a1"))
    queue.add("b", job("b1"))
    queue.add("b", job("b2"))
    with pytest.raises(RemoteError, match=BUSY):
        queue.add("b", job("b3"))
    queue.add("c", job("c1"))
    assert queue.pending("b") == 2 and queue.pending() == 4
    gate.set()
    assert finished.wait(30)
    assert order == ["a1", "b1", "c1", "b2"]  # c's job before b's second


def test_an_interpolated_paths_count_is_known_before_it_is_made():
    """interpolatePath(0) at a fine resolution: the states are counted first (validSegmentCount
    per segment) and refused past MAX_PATH_VALUES, nothing made."""
    from simx_server.sim import ompl_spaces

    space = ompl_spaces.Space([ompl_spaces.Subspace("joint_position", (-3.0,), (3.0,), True)])
    problem = mp.Problem(space, lambda q: True, resolution=1e-4)
    problem.setup([0.0], [[2.5]], "RRTConnect")
    assert problem.solve(1.0)
    counted = problem.interpolated_count(0)
    assert counted > 1000
    problem.interpolate(0)
    assert len(problem.path_values()) == counted
    with pytest.raises(ValueError, match="MAX_PATH_VALUES"):
        problem.interpolate(mp.MAX_PATH_VALUES + 1)


def test_a_long_calls_work_is_charged_to_its_uuid_on_any_connection(tmp_path, monkeypatch):
    """The seconds a solve took off the simulation thread are charged to its connection and to
    its uuid before its reply leaves: that uuid's next call, from a new connection too, waits its
    turn, another client's does not. In-process, with a real simulation."""
    from simx_server.base import limits
    from simx_server.loop.clients import Clients
    from simx_server.scene.simulation import Simulation
    from simx_server.zmq.frontend import Incoming
    from simx_server.zmq.service import ZmqService

    (tmp_path / "scene.xml").write_text(SCENE)
    sim = Simulation(tmp_path / "scene.xml")
    sent, replied = [], threading.Event()

    class Frontend:
        def send(self, envelope, payload, held=0, **_):
            sent.append((envelope[0], cbor2.loads(payload)))
            replied.set()

        def expects(self, identity):
            return True

    server = type("Server", (), {"sim": sim, "clients": Clients(), "hold_pass": lambda self, client, seconds: None})
    service = ZmqService(server(), Frontend())

    def call(connection: bytes, uuid: str, func: str, *args):
        replied.clear()
        service.handle("zmq", Incoming([connection], codec.read_request(codec.encode_request(func, list(args), uuid)),
                                       len(connection), 10))
        assert replied.wait(30)
        return sent[-1][1]

    try:
        joint, link, post = (call(b"first", "planner", "sim.getObject", p)["ret"][0]
                             for p in ("/Joint1", "/Link1", "/Post"))
        task = call(b"first", "planner", "simOMPL.createTask", "t")["ret"][0]
        call(b"first", "planner", "simOMPL.setStateSpaceForJoints", task, [joint], [1])
        call(b"first", "planner", "simOMPL.setCollisionPairs", task, [link, post])
        call(b"first", "planner", "simOMPL.setStartState", task, [0.0])
        call(b"first", "planner", "simOMPL.setGoalState", task, [2.5])
        assert "ret" in call(b"first", "planner", "simOMPL.setup", task)
        monkeypatch.setattr(limits, "MAX_REQUEST_SECONDS", 0.0)  # every second of work counts
        monkeypatch.setattr(limits, "EDIT_DEBT_SECONDS", 0.0)  # any debt: the next call waits
        assert "ret" in call(b"first", "planner", "simOMPL.solve", task, 0.3)  # off this thread, 0.3 s
        assert service.connections[b"first"].debt > 0 and service.clients["planner"].share.debt > 0
        replied.clear()
        service.handle("zmq", Incoming([b"second"], codec.read_request(codec.encode_request(
            "sim.getSimulationTime", [], "planner")), 6, 10))
        assert not replied.is_set() and [d[1].uuid for d in service._deferred] == ["planner"]
        assert "ret" in call(b"third", "other", "sim.getSimulationTime")
    finally:
        sim.close()


class InProcess:
    """The ZMQ service on a real simulation, without sockets: requests by connection, tag and
    uuid; their replies by tag, as the frontend would send them (from any thread)."""

    def __init__(self, folder):
        from simx_server.loop.clients import Clients
        from simx_server.scene.simulation import Simulation
        from simx_server.zmq.service import ZmqService

        (folder / "scene.xml").write_text(SCENE)
        self.sim = Simulation(folder / "scene.xml")
        self.replies: dict[str, list] = {}
        self.arrived = threading.Condition()
        outer = self

        class Frontend:
            def send(self, envelope, payload, held=0, **_):
                with outer.arrived:
                    outer.replies.setdefault(envelope[1].decode(), []).append(cbor2.loads(payload))
                    outer.arrived.notify_all()

            def expects(self, identity):
                return True

        server = type("Server", (), {"sim": self.sim, "clients": Clients(),
                                     "hold_pass": lambda self, client, seconds: None})
        self.service = ZmqService(server(), Frontend())
        self.fds: dict[bytes, int] = {}  # connection -> its descriptor

    def send(self, tag: str, connection: bytes, uuid: str, func: str, *args) -> None:
        from simx_server.zmq.frontend import Incoming

        fd = self.fds.setdefault(connection, 10 + len(self.fds))
        self.service.handle("zmq", Incoming([connection, tag.encode()], codec.read_request(
            codec.encode_request(func, list(args), uuid)), fd, 10))

    def gone(self, connection: bytes) -> None:
        """The connection closes (the frontend's socket monitor)."""
        self.service.handle("zmq-gone", self.fds[connection])

    def reply(self, tag: str) -> dict:
        with self.arrived:
            assert self.arrived.wait_for(lambda: tag in self.replies, 60), tag
            return self.replies[tag][0]

    def blocked_tasks(self, n: int) -> list[int]:
        """``n`` set-up tasks whose goal no path reaches (a solve searches until its time is up)."""
        def call(func: str, *args):
            tag = f"setup{len(self.replies)}"
            self.send(tag, b"setup", "setup", func, *args)
            return self.reply(tag)["ret"]

        joint, link, post = (call("sim.getObject", p)[0] for p in ("/Joint1", "/Link1", "/Post"))
        tasks = []
        for k in range(n):
            task = call("simOMPL.createTask", f"t{k}")[0]
            call("simOMPL.setStateSpaceForJoints", task, [joint], [1])
            call("simOMPL.setCollisionPairs", task, [link, post])
            call("simOMPL.setStartState", task, [0.0])
            call("simOMPL.setGoalState", task, [2.5])
            call("simOMPL.setup", task)
            tasks.append(task)
        return tasks


@pytest.fixture
def in_process(tmp_path):
    made = InProcess(tmp_path)
    yield made
    made.sim.close()


def test_long_calls_take_turns_by_connection_and_go_with_their_client(in_process):
    """Issue 84: a victim's 0.3 s solve waited 120 s behind 12 clients that had left, and a
    client's turn and bound went by the uuid it claimed. Now one connection holds at most
    MAX_WAITING_PER_CLIENT long calls whatever uuids it claims, and when it closes its queued
    call is answered "not run" without running and its running one stops."""
    z = in_process
    tasks = z.blocked_tasks(4)
    z.send("a0", b"attacker", "a0", "simOMPL.solve", tasks[0], 9.0)  # runs
    z.send("a1", b"attacker", "a1", "simOMPL.solve", tasks[1], 9.0)  # waits
    z.send("a2", b"attacker", "a2", "simOMPL.solve", tasks[2], 9.0)  # a fresh uuid, the same connection
    assert BUSY in z.reply("a2").get("err", ""), z.replies["a2"]
    z.send("v", b"victim", "v", "simOMPL.solve", tasks[3], 0.2)
    assert "a0" not in z.replies
    z.gone(b"attacker")  # the attacker's connection closes
    assert long_calls.LEFT in z.reply("a1").get("err", "")  # answered without running
    assert long_calls.LEFT in z.reply("a0").get("err", "")  # stopped while it searched
    assert "ret" in z.reply("v")
    assert long_calls.waiting.settle(30) and long_calls.waiting.pending() == 0
    z.send("free", b"victim", "v", "simOMPL.getPath", tasks[1])  # the dropped call left its task free
    assert "busy" not in z.reply("free").get("err", ""), z.replies["free"]


def test_a_short_solve_waits_behind_slices_not_whole_solves(in_process):
    """Issue 84: 12 connections solving for 10 s each held a victim's 0.3 s solve 119 s. A
    solve off the simulation thread now runs in slices (long_calls.SLICE_SECONDS), the
    connections in turn: three 3 s solves started first, the victim's 0.3 s solve is answered
    while all three still search."""
    z = in_process
    tasks = z.blocked_tasks(4)
    for k in range(3):
        z.send(f"a{k}", f"attacker{k}".encode(), f"a{k}", "simOMPL.solve", tasks[k], 3.0)
    z.send("v", b"victim", "v", "simOMPL.solve", tasks[3], 0.3)
    assert "ret" in z.reply("v")
    with z.arrived:
        assert not any(f"a{k}" in z.replies for k in range(3)), z.replies
    for k in range(3):  # they go: their solves stop
        z.gone(f"attacker{k}".encode())
    assert long_calls.waiting.settle(30)


def test_a_decomposition_whose_client_left_stops_its_worker():
    """Issue 84: six convexDecompose calls of clients that had left held the ring 234 s. The
    running one's V-HACD worker is killed once its job is asked to stop (job_ring.cancel_all)."""
    pytest.importorskip("vhacdx")
    import numpy as np

    from simx_server.base import vhacd_worker

    n, m = 48, 24  # a torus: non-convex, slow to decompose at a high resolution
    a, b = np.meshgrid(2 * np.pi * np.arange(n) / n, 2 * np.pi * np.arange(m) / m, indexing="ij")
    r = 0.2 + 0.06 * np.cos(b)
    vertices = np.stack([r * np.cos(a), r * np.sin(a), 0.06 * np.sin(b)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    p, q, s, t = i * m + j, (i + 1) % n * m + j, (i + 1) % n * m + (j + 1) % m, i * m + (j + 1) % m
    faces = np.stack([np.stack([p, q, s], -1), np.stack([p, s, t], -1)], -2).reshape(-1, 3)
    outcome, started = [], threading.Event()

    def job() -> None:
        started.set()
        try:
            outcome.append(vhacd_worker.decompose(vertices, faces, 400_000, 64, 64))
        except vhacd_worker.DecompositionError as exc:
            outcome.append(exc)

    ring = long_calls.LongCalls()
    ring.add("zmq:gone", job)
    assert started.wait(30)
    ring.cancel("zmq:gone")
    assert ring.settle(60)
    assert isinstance(outcome[0], vhacd_worker.DecompositionError) and "client left" in str(outcome[0])
