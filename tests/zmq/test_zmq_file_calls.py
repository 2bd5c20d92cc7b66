"""A ZMQ client's file calls serialise on the files' thread (issue 84, item 4): ``sim.saveScene``
of a scene with a 200,000-triangle mesh held every other client 5.5-8.1 s on the simulation
thread, ``sim.exportMesh`` 4.3 s. Now what reads the scene is copied there, and the text is made
and written by the files' thread (``ClientFiles.write_later``), the reply leaving once written.
In-process, with a real simulation; the files' thread's name shows where each write ran."""

from __future__ import annotations

import threading

import cbor2
import numpy as np
import pytest

from simx_server.loop.clients import Clients
from simx_server.scene.client_files import ClientFiles
from simx_server.scene.simulation import Simulation
from simx_server.zmq import codec
from simx_server.zmq.frontend import Incoming
from simx_server.zmq.service import ZmqService

SCENE = """<mujoco model="file calls">
  <worldbody>
    <body name="Box" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body>
  </worldbody>
</mujoco>
"""
TETRA = ([0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1], [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3])


@pytest.fixture
def service(tmp_path, monkeypatch):
    (tmp_path / "scene.xml").write_text(SCENE)
    sim = Simulation(tmp_path / "scene.xml")
    written: list[tuple[str, str]] = []  # (file name, the thread that wrote it)
    store = ClientFiles.store

    def recorded(self, path, data, key, name):
        written.append((path.name, threading.current_thread().name))
        return store(self, path, data, key, name)

    monkeypatch.setattr(ClientFiles, "store", recorded)
    replies: list = []
    replied = threading.Condition()

    def send(self, envelope, payload, held=0, **_):
        with replied:
            replies.append(cbor2.loads(payload))
            replied.notify_all()

    frontend = type("Frontend", (), {"send": send, "expects": lambda self, identity: True,
                                     "release": lambda self, identity, held: None})()
    server = type("Server", (), {"sim": sim, "clients": Clients(), "hold_pass": lambda self, client, seconds: None})()
    made = ZmqService(server, frontend)

    def call(func: str, *args) -> dict:
        count = len(replies)
        made.handle("zmq", Incoming([b"id"], codec.read_request(codec.encode_request(func, list(args), "saver")), 1, 10))
        with replied:
            assert replied.wait_for(lambda: len(replies) > count, timeout=60), func
        return replies[-1]

    made.call, made.written = call, written
    yield made
    sim.close()


@pytest.mark.parametrize("func, args, names", [
    ("sim.saveScene", ["saved.xml"], {"saved.xml"}),
    ("sim.saveModel", ["Box", "box.xml"], {"box.xml"}),
    ("sim.exportMesh", [0, "mesh.obj", 0, 1.0, [TETRA[0]], [TETRA[1]]], {"mesh.obj"}),
    ("sim.saveImage", [bytes(4 * 4 * 3), [4, 4], 0, "image.png", -1], {"image.png"}),
])
def test_a_file_call_serialises_on_the_files_thread(service, func, args, names):
    if func == "sim.saveModel":
        args = [service.call("sim.getObject", "/Box")["ret"][0], *args[1:]]
    reply = service.call(func, *args)
    assert "ret" in reply, reply
    if func == "sim.saveImage":
        assert reply["ret"] == [b""]  # as when written at once
    ran = {name: thread for name, thread in service.written}
    assert names <= set(ran) and all(thread == "simx-files" for thread in ran.values()), service.written
    folder = service.sim.editor.files.folder(service.clients["saver"].files_key)
    assert all((folder / name).is_file() for name in names)


def test_a_saved_scene_with_a_created_shape_loads_back(service, tmp_path):
    v = np.array(TETRA[0], float)
    h = service.call("sim.createShape", 0, 0.0, v.tolist(), TETRA[1])["ret"][0]
    assert "ret" in service.call("sim.saveScene", "withshape.xml"), service.written
    folder = service.sim.editor.files.folder(service.clients["saver"].files_key)
    assert any(name.endswith(".msh") for name, _ in service.written)
    back = Simulation(folder / "withshape.xml")
    try:
        assert service.sim.world.get(h).name in back.world.by_name
    finally:
        back.close()
