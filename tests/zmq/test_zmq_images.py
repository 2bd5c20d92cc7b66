"""ZMQ image calls rendered off the simulation thread (issue 29, item 5's image case), on a real
server: the images are the legacy door's, the simulation and other clients go on while a large
one renders, its reply counts toward the unread-reply bounds, and a client that leaves while its
image renders leaves nothing behind."""

from __future__ import annotations

import threading

import numpy as np
import cbor2
import pytest
import zmq

import simx_client as vrep
from conftest import ServerProcess, free_port
from simx_server.base import limits
from simx_server.zmq import codec

BIG = 4096  # limits.MAX_RESOLUTION: one RGB frame is 48 MiB, its render takes a software GL long
SCENE = f"""<mujoco model="images">
  <option timestep="0.005"/>
  <worldbody>
    <light name="light" pos="0 0 3"/>
    <geom name="floor" type="plane" size="2 2 0.1" rgba="0.2 0.5 0.3 1"/>
    <body name="Box" pos="0.1 0 0.1"><geom type="box" size="0.08 0.05 0.05" rgba="0.9 0.2 0.1 1"/></body>
    <body name="Ball" pos="-0.15 0.1 0.1"><geom type="sphere" size="0.06" rgba="0.1 0.3 0.9 1"/></body>
    <body name="SmallMount" pos="0 0 1"><camera name="small" fovy="60" resolution="64 48"/></body>
    <body name="BigMount" pos="0 0 1.2"><camera name="big" fovy="60" resolution="{BIG} {BIG}"/></body>
  </worldbody>
</mujoco>
"""
B = vrep.simx_opmode_blocking
HANDLE_ALL = -2


@pytest.fixture(scope="module")
def zmq_server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("images")
    (folder / "scene.xml").write_text(SCENE)
    port = free_port()
    srv = ServerProcess(str(folder / "scene.xml"), "--zmq-port", str(port), "--pacing", "immediate",
                        renderers="on-demand")
    srv.zmq_port = port
    yield srv
    log = srv.stop()
    assert "Traceback" not in log, log[-3000:]


class Client:
    """A raw REQ socket speaking the protocol (the official client's requests, by codec)."""

    def __init__(self, port: int, uuid: str, timeout_ms: int = 60000):
        self.ctx = zmq.Context()
        self.sock = self.ctx.socket(zmq.REQ)
        self.sock.setsockopt(zmq.RCVTIMEO, timeout_ms)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.connect(f"tcp://127.0.0.1:{port}")
        self.uuid = uuid

    def send(self, func: str, *args) -> None:
        self.sock.send(codec.encode_request(func, list(args), self.uuid))

    def recv(self) -> dict:
        return cbor2.loads(self.sock.recv())

    def call(self, func: str, *args) -> dict:
        self.send(func, *args)
        return self.recv()

    def ret(self, func: str, *args) -> list:
        reply = self.call(func, *args)
        assert "ret" in reply, (func, reply)
        return reply["ret"]

    def pending(self) -> bool:
        """Whether the reply to the request sent has not arrived yet."""
        return not self.sock.poll(0, zmq.POLLIN)

    def close(self, linger_ms: int = 0) -> None:
        """Close the socket; with ``linger_ms``, once what it sent has left (at most that long)."""
        if not self.sock.closed:
            self.sock.close(linger_ms)
            self.ctx.term()


@pytest.fixture
def clients(zmq_server):
    made: list[Client] = []

    def make(uuid: str) -> Client:
        made.append(Client(zmq_server.zmq_port, uuid))
        return made[-1]

    yield make
    for c in made:
        c.close()


@pytest.fixture
def stopped(clients):
    """The simulation stopped (one world state: every image call of a sensor shares its frame)."""
    c = clients("stopper")
    c.ret("sim.stopSimulation")
    yield
    c.ret("sim.stopSimulation")


def test_zmq_image_calls_return_the_legacy_doors_images(zmq_server, clients, stopped):
    """Every ZMQ call that renders answers what the legacy door's simxGetVisionSensorImage /
    simxGetVisionSensorDepthBuffer / simxReadVisionSensor answer for the same frame."""
    cid = vrep.simxStart("127.0.0.1", zmq_server.port, True, True, 5000, 5)
    assert cid >= 0
    try:
        rc, h = vrep.simxGetObjectHandle(cid, "small", B)
        assert rc == 0
        rc, res, image = vrep.simxGetVisionSensorImage(cid, h, 0, B)
        assert rc == 0 and res == [64, 48]
        rc, _, grey = vrep.simxGetVisionSensorImage(cid, h, 1, B)
        assert rc == 0
        rc, _, depth = vrep.simxGetVisionSensorDepthBuffer(cid, h, B)
        assert rc == 0
        rc, _, packets = vrep.simxReadVisionSensor(cid, h, B)
        assert rc == 0
    finally:
        vrep.simxFinish(cid)
    rgb = np.array(image, dtype=np.uint8).reshape(48, 64, 3)
    grey = np.array(grey, dtype=np.uint8).reshape(48, 64)
    depth = np.array(depth, dtype=np.float32).reshape(48, 64)
    assert rgb.std() > 5, "a uniform image would compare nothing"

    c = clients("images")
    assert c.ret("sim.getObject", "/small") == [h]
    assert c.ret("sim.getVisionSensorImg", h) == [rgb.tobytes(), [64, 48]]
    assert c.ret("sim.getVisionSensorImg", h, 1) == [grey.tobytes(), [64, 48]]
    assert c.ret("sim.getVisionSensorImg", h, 0, 0, [3, 5], [10, 7]) == [rgb[5:12, 3:13].tobytes(), [10, 7]]
    assert c.ret("sim.getVisionSensorCharImage", h) == [rgb.tobytes(), 64, 48]
    assert c.ret("sim.getVisionSensorImage", h, 0, 0, 0, 0, 1) == [rgb.tobytes()]
    (floats,) = c.ret("sim.getVisionSensorImage", h)
    assert np.array_equal(np.array(floats), rgb.reshape(-1) / 255.0)
    img, res = c.ret("sim.getVisionSensorDepth", h)
    assert res == [64, 48] and np.array_equal(np.frombuffer(img, np.float32).reshape(48, 64), depth)
    (buffer,) = c.ret("sim.getVisionSensorDepthBuffer", h)
    assert np.array_equal(np.array(buffer, np.float32).reshape(48, 64), depth)
    result, packet = c.ret("sim.readVisionSensor", h)
    assert result == 0 and np.allclose(packet, packets[0], atol=1e-6)
    assert np.allclose(c.ret("sim.handleVisionSensor", h)[1], packets[0], atol=1e-6)
    (ex,) = c.ret("sim.checkVisionSensorEx", h, HANDLE_ALL, True)
    assert np.array_equal(np.array(ex), rgb.reshape(-1) / 255.0)
    (ex,) = c.ret("sim.checkVisionSensorEx", h, HANDLE_ALL, False)
    assert np.array_equal(np.array(ex, np.float32).reshape(48, 64), depth)
    # errors are still the call's, named: a window outside the image, an object that is no sensor
    reply = c.call("sim.getVisionSensorImg", h, 0, 0, [60, 0], [10, 10])
    assert "sim.getVisionSensorImg" in reply.get("err", "") and "not inside" in reply["err"], reply
    reply = c.call("sim.getVisionSensorDepth", c.ret("sim.getObject", "/Box")[0])
    assert "sim.getVisionSensorDepth" in reply.get("err", ""), reply


def test_the_simulation_steps_while_a_large_image_renders(clients):
    """While one connection's 4096x4096 image renders, the simulation steps and another
    connection is answered: its simulation time advances before the image's reply comes (before,
    the image rendered on the simulation thread and nothing else moved until it was done). The
    image's reply is one byte (a 1x1 window of a grey image), so that the two replies cannot pass
    each other on their way. Tried a few times, in case a render is faster than a step."""
    loader, other = clients("loader"), clients("other")
    big = loader.ret("sim.getObject", "/big")[0]
    loader.ret("sim.startSimulation")
    try:
        for _ in range(5):
            loader.send("sim.getVisionSensorImg", big, 1, 0, [BIG // 2, BIG // 2], [1, 1])
            times = set()
            while loader.pending() and len(times) < 3:
                times.add(other.ret("sim.getSimulationTime")[0])
            still_rendering = loader.pending()
            image, res = loader.recv()["ret"]
            assert res == [1, 1] and len(image) == 1
            if still_rendering:
                break
        assert still_rendering and len(times) >= 3, times
    finally:
        loader.ret("sim.stopSimulation")


def test_the_simulation_steps_while_a_legacy_read_vision_sensor_renders(zmq_server, clients):
    """The legacy door's simxReadVisionSensor computes its packet on the render thread too: while
    a legacy client's packet of the 4096x4096 sensor renders, a ZMQ client sees the simulation
    time advance (before, the packet was computed on the simulation thread). Tried a few times,
    in case a render is faster than a step."""
    other = clients("watcher")
    big = other.ret("sim.getObject", "/big")[0]
    cid = vrep.simxStart("127.0.0.1", zmq_server.port, True, True, -60000, 5)  # blocking calls: 60 s
    assert cid >= 0
    other.ret("sim.startSimulation")
    try:
        for _ in range(5):
            done: list = []
            reader = threading.Thread(target=lambda: done.append(vrep.simxReadVisionSensor(cid, big, B)))
            reader.start()
            times = set()
            while reader.is_alive() and len(times) < 3:
                times.add(other.ret("sim.getSimulationTime")[0])
            still_rendering = reader.is_alive()
            reader.join(120)
            rc, detected, packets = done[0]
            assert rc == 0 and detected is False and len(packets[0]) == 15
            if still_rendering:
                break
        assert still_rendering and len(times) >= 3, times
    finally:
        other.ret("sim.stopSimulation")
        vrep.simxFinish(cid)


def _new_state(client: Client) -> None:
    """A simulation stopped in a new state: no frame of it drawn yet, the next image call renders."""
    client.ret("sim.startSimulation")
    client.ret("sim.stopSimulation")


def _images(clients, count: int, uuid: str) -> list[Client]:
    """``count`` connections, each sending a request for the whole 4096x4096 RGB image."""
    socks = [clients(f"{uuid}{i}") for i in range(count)]
    big = socks[0].ret("sim.getObject", "/big")[0]
    _new_state(socks[0])
    for s in socks[1:]:
        s.ret("sim.getSimulationTime")  # connected
    for s in socks:
        s.send("sim.getVisionSensorImg", big)
    return socks


def test_images_rendering_count_toward_the_unread_reply_bound(clients, stopped):
    """Each image rendering for a connection holds its reply's bytes for it: past
    limits.MAX_ZMQ_UNSENT_BYTES_TOTAL of them (with the replies not yet read), the next image
    call is answered "server busy" before anything is rendered; the others get their images."""
    per = BIG * BIG * 3
    count = limits.MAX_ZMQ_UNSENT_BYTES_TOTAL // per + 1  # one more than the bound holds
    replies = [s.recv() for s in _images(clients, count, "bound")]
    busy = [r for r in replies if "server busy" in r.get("err", "")]
    images = [r for r in replies if "ret" in r]
    assert len(busy) == 1 and "MAX_ZMQ_UNSENT_BYTES_TOTAL" in busy[0]["err"], [r.get("err") for r in replies]
    assert len(images) == count - 1 and all(len(r["ret"][0]) == per for r in images)


def test_a_client_that_leaves_while_its_image_renders_leaves_nothing_behind(zmq_server, clients, stopped):
    """Connections that close while their images render: the replies are dropped, what they held
    of the bound is given back (as many images as the bound holds are served afterwards at once),
    and the server goes on."""
    per = BIG * BIG * 3
    c = clients("after")
    for s in _images(clients, limits.MAX_ZMQ_UNSENT_BYTES_TOTAL // per, "leaving"):
        s.close(linger_ms=5000)  # its request sent, it goes without waiting for the reply
    small = c.ret("sim.getObject", "/small")[0]
    # rendered after theirs (one render thread, in order): their replies are done with by now
    assert c.ret("sim.getVisionSensorImg", small)[1] == [64, 48]
    replies = [s.recv() for s in _images(clients, limits.MAX_ZMQ_UNSENT_BYTES_TOTAL // per, "staying")]
    assert all(len(r.get("ret", [b""])[0]) == per for r in replies), [r.get("err") for r in replies]
    assert c.ret("sim.getSimulationTime") == [0.0]


def test_a_connection_sends_nothing_more_while_its_image_renders(zmq_server, clients, stopped):
    """A DEALER (which, unlike a REQ socket, may send again before its reply) asks for another
    call while its image renders: that request is refused at once ("one request at a time"),
    and the image still comes."""
    setup = clients("setup")
    big = setup.ret("sim.getObject", "/big")[0]
    _new_state(setup)
    ctx = zmq.Context()
    dealer = ctx.socket(zmq.DEALER)
    dealer.setsockopt(zmq.LINGER, 0)
    dealer.setsockopt(zmq.RCVTIMEO, 60000)
    dealer.connect(f"tcp://127.0.0.1:{zmq_server.zmq_port}")
    try:
        dealer.send_multipart([b"", codec.encode_request("sim.getVisionSensorImg", [big], "dealer")])
        dealer.send_multipart([b"", codec.encode_request("sim.getSimulationTime", [], "dealer")])
        first, second = (cbor2.loads(dealer.recv_multipart()[-1]) for _ in range(2))
    finally:
        dealer.close(0)
        ctx.term()
    assert "one request at a time" in first.get("err", ""), first
    assert len(second["ret"][0]) == BIG * BIG * 3 and second["ret"][1] == [BIG, BIG]
