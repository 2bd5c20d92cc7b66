"""Files a client can write and read (issue 40, "Files"), on a real server on loopback.

Every call that writes a file writes into the calling client's own folder of the transfer
folder (``<transfer folder>/.simx-clients/<hash>``), never over a file it did not write, within
its own budget (``MAX_CLIENT_FILES_BYTES``) and the total (``MAX_TRANSFER_FOLDER_BYTES``); reads
come from the scene folders and that client's own folder. The operator's folder is read-only to
clients. The reproduction: over ZMQ with no credentials, ``sim.saveScene('adv.xml')`` and
``sim.saveImage`` wrote into the operator's scene folder, over an existing scene file there.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import cbor2
import numpy as np
import pytest
import zmq

import vrep
from conftest import ServerProcess, free_port, wait_until
from simx_server.base import limits
from simx_server.zmq import codec

pytestmark = pytest.mark.renderers_on_demand  # no image is rendered

SCENE = """<mujoco model="folders">
  <worldbody>
    <body name="Keeper" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body>
  </worldbody>
  <custom><text name="simx:Keeper" data="child_script=keeper.lua"/></custom>
</mujoco>
"""
#: The operator's script: writes what a caller names (V-REP's scripts wrote beside the scene).
KEEPER = """
function save(name) sim.saveScene(name) return 1 end
function try_save(name) local ok, err = pcall(sim.saveScene, name) return ok and 'ok' or tostring(err) end
"""
#: A client's scene with a script (loaded with --allow-remote-code): it acts as that client.
CLIENT_SCENE = """<mujoco model="sent">
  <worldbody>
    <body name="Sent" pos="0 0 0.1"><geom type="box" size="0.05 0.05 0.05"/></body>
  </worldbody>
  <custom><text name="simx:Sent" data="child_script=sent.lua"/></custom>
</mujoco>
"""
SENT = """
function try_save(ints, floats, strings, buffer)  -- simxCallScriptFunction's form
  local ok, err = pcall(sim.saveScene, strings[1])
  return {}, {}, {ok and 'ok' or tostring(err)}, ''
end
function sysCall_init() pcall(sim.saveScene, 'at_init.xml') end
"""
B = vrep.simx_opmode_blocking
PNG_2x2 = bytes([255, 0, 0] * 4)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("operator")
    (folder / "scene.xml").write_text(SCENE)
    (folder / "adv.xml").write_text(SCENE)  # an operator's scene file a client must not overwrite
    (folder / "keeper.lua").write_text(KEEPER)
    import cv2  # noqa: PLC0415
    cv2.imwrite(str(folder / "operator.png"), np.zeros((3, 5, 3), np.uint8))
    zport = free_port()
    srv = ServerProcess(str(folder / "scene.xml"), "--zmq-port", str(zport), "--allow-remote-code",
                        ports=[free_port(), free_port()], renderers="on-demand")
    srv.zmq_port, srv.folder = zport, folder
    yield srv
    log = srv.stop()
    assert "Traceback" not in log, log[-3000:]


class Zmq:
    """A raw REQ socket speaking the ZMQ remote API (the official client's requests, by codec)."""

    def __init__(self, port: int, uuid: str):
        self.ctx = zmq.Context()
        self.sock = self.ctx.socket(zmq.REQ)
        self.sock.setsockopt(zmq.RCVTIMEO, 30000)
        self.sock.setsockopt(zmq.LINGER, 0)
        self.sock.connect(f"tcp://127.0.0.1:{port}")
        self.uuid = uuid

    def call(self, func: str, *args) -> dict:
        self.sock.send(codec.encode_request(func, list(args), self.uuid))
        return cbor2.loads(self.sock.recv())

    def close(self) -> None:
        try:
            self.call(codec.END)
        finally:
            self.sock.close(0)
            self.ctx.term()


def transfer_folder(srv) -> Path:
    (found,) = Path(tempfile.gettempdir()).glob(f"simx-{srv.proc.pid}-*")
    return found


def client_files(srv) -> dict[str, list[str]]:
    """Each client folder's files by the folder's name (the server's own .simx files left out)."""
    root = transfer_folder(srv) / ".simx-clients"
    if not root.is_dir():
        return {}
    found = {}
    for d in root.iterdir():
        try:  # the server may remove a folder while it is read: a client left meanwhile
            found[d.name] = sorted(p.relative_to(d).as_posix() for p in d.rglob("*") if p.is_file()
                                   and not p.relative_to(d).as_posix().startswith(".simx"))
        except FileNotFoundError:
            continue
    return found


@pytest.fixture
def zmq_pair(server):
    a, b = Zmq(server.zmq_port, "client-a-" + str(time.monotonic_ns())), Zmq(server.zmq_port, "client-b-" + str(time.monotonic_ns()))
    yield a, b
    a.close()
    b.close()


def test_zmq_save_scene_goes_into_the_clients_folder_not_over_the_operators_scene(server, zmq_pair):
    """The reproduction: ``sim.saveScene('adv.xml')`` with no credentials leaves the operator's
    adv.xml as it was and writes the client's own adv.xml into its own folder; names that leave
    its folder are refused."""
    a, _ = zmq_pair
    before = (server.folder / "adv.xml").read_bytes()
    assert "ret" in a.call("sim.saveScene", "adv.xml"), "saveScene into its own folder"
    assert (server.folder / "adv.xml").read_bytes() == before
    # the scene and its script beside it, as a saved scene names it (simx_server/scene/scene_file.py)
    assert any(files == ["adv.xml", "adv_Keeper_child.lua"] for files in client_files(server).values()), \
        client_files(server)
    for bad in (str(server.folder / "adv.xml"), "../adv.xml", "../../x.xml", ".simx-clients/x.xml"):
        reply = a.call("sim.saveScene", bad)
        assert "refused" in reply.get("err", ""), (bad, reply)
    assert (server.folder / "adv.xml").read_bytes() == before
    assert sorted(p.name for p in server.folder.iterdir()) == ["adv.xml", "keeper.lua", "operator.png", "scene.xml"]


def test_zmq_save_image_and_load_image_use_the_clients_folder(server, zmq_pair):
    """``sim.saveImage`` writes into the client's folder (never over the operator's
    operator.png); ``sim.loadImage`` reads the client's own file by its name, the scene folder's
    files, and never another client's file or a file outside those folders."""
    a, b = zmq_pair
    assert "ret" in a.call("sim.saveImage", PNG_2x2, [2, 2], 0, "operator.png", -1)
    assert "ret" in a.call("sim.saveImage", PNG_2x2, [2, 2], 0, "shot.png", -1)
    assert not (server.folder / "shot.png").exists()
    mine = a.call("sim.loadImage", 0, "operator.png")["ret"]  # its own operator.png: 2x2 red
    assert mine[1] == [2, 2] and mine[0] == PNG_2x2
    theirs = b.call("sim.loadImage", 0, "operator.png")["ret"]  # b has none: the scene folder's
    assert theirs[1] == [5, 3]
    assert "err" in b.call("sim.loadImage", 0, "shot.png")  # a's file is not b's
    (folder,) = [name for name, files in client_files(server).items() if "shot.png" in files]
    a_file = transfer_folder(server) / ".simx-clients" / folder / "shot.png"
    assert "refused" in b.call("sim.loadImage", 0, str(a_file))["err"]
    assert "ret" in a.call("sim.loadImage", 0, str(a_file))  # its own, by the full path too
    outside = server.folder.parent / "outside.png"
    outside.write_bytes((server.folder / "operator.png").read_bytes())
    assert "refused" in a.call("sim.loadImage", 0, str(outside))["err"]
    assert "refused" in a.call("sim.saveImage", PNG_2x2, [2, 2], 0, str(outside), -1)["err"]


def test_zmq_save_model_and_export_mesh_go_into_the_clients_folder(server, zmq_pair):
    a, _ = zmq_pair
    keeper = a.call("sim.getObject", "/Keeper")["ret"][0]
    assert "ret" in a.call("sim.saveModel", keeper, "keeper_model.xml")
    verts, faces = [0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0.1], [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3]
    assert "ret" in a.call("sim.exportMesh", 0, "tetra.obj", 0, 1.0, [verts], [faces])
    assert "refused" in a.call("sim.exportMesh", 0, str(server.folder / "tetra.obj"), 0, 1.0, [verts], [faces])["err"]
    (files,) = [f for f in client_files(server).values() if "tetra.obj" in f]
    assert files == ["keeper_model.xml", "tetra.obj"]
    assert not (server.folder / "tetra.obj").exists() and not (server.folder / "keeper_model.xml").exists()
    back = a.call("sim.importMesh", 0, "tetra.obj")["ret"]  # its own file, read back
    assert len(back[1][0]) == 12


def test_an_operators_script_called_by_a_client_writes_into_that_clients_folder(server, zmq_pair):
    """The operator's script is trusted, but what a client makes it write goes into the
    client's folder: ``save('adv.xml')`` of keeper.lua does not overwrite the operator's file."""
    a, _ = zmq_pair
    before = (server.folder / "adv.xml").read_bytes()
    assert "ret" in a.call("sim.startSimulation")
    try:
        reply = a.call("sim.callScriptFunction", "save@/Keeper", 1, "adv.xml")
        assert reply.get("ret") == [1], reply
        assert (server.folder / "adv.xml").read_bytes() == before
        assert any("adv.xml" in f for f in client_files(server).values())
        refused = a.call("sim.callScriptFunction", "try_save@/Keeper", 1, str(server.folder / "adv.xml"))["ret"][0]
        assert "refused" in refused, refused
    finally:
        a.call("sim.stopSimulation")
    assert (server.folder / "adv.xml").read_bytes() == before


def _legacy(server, port: int = 0) -> int:
    """A legacy client on the server's ``port``-th port (vrep.py connects once per port)."""
    cid = vrep.simxStart("127.0.0.1", server.ports[port], True, True, 5000, 5)
    assert cid >= 0
    return cid


def test_each_clients_budget_is_its_own_and_freed_when_it_leaves(server, tmp_path):
    """One client fills its MAX_CLIENT_FILES_BYTES with simxTransferFile; its next file is
    refused naming the bound, another client's transfer still succeeds (before issue 40 one
    client's 8 x 32 MiB locked everyone out until a restart); when the first leaves, its folder
    and its budget go."""
    big = tmp_path / "big.bin"
    big.write_bytes(b"\0" * limits.MAX_TRANSFER_FILE_BYTES)
    small = tmp_path / "small.bin"
    small.write_bytes(b"x" * 1000)
    a, b = _legacy(server), _legacy(server, 1)
    try:
        try:
            before = set(client_files(server))
            for i in range(limits.MAX_CLIENT_FILES_BYTES // limits.MAX_TRANSFER_FILE_BYTES):
                assert vrep.simxTransferFile(a, str(big), f"big{i}.bin", 30, B) == vrep.simx_return_ok
            assert vrep.simxTransferFile(a, str(small), "one_more.bin", 30, B) == vrep.simx_return_remote_error_flag
            errors = vrep.simxGetLastErrors(a, B)[1]
            assert any("MAX_CLIENT_FILES_BYTES" in e for e in errors), errors
            assert vrep.simxTransferFile(b, str(small), "small.bin", 30, B) == vrep.simx_return_ok
            folders = {k: v for k, v in client_files(server).items() if k not in before}
            assert sorted(map(sorted, folders.values())) == [["big0.bin", "big1.bin"], ["small.bin"]]
            (a_folder,) = [k for k, v in folders.items() if "big0.bin" in v]
        finally:
            vrep.simxFinish(a)
        wait_until(lambda: a_folder not in client_files(server), timeout=20, what="the folder of the client that left removed")
        assert vrep.simxTransferFile(b, str(small), "small2.bin", 30, B) == vrep.simx_return_ok
    finally:  # b is finished whatever failed: vrep.py connects once per port, later tests need port 1
        vrep.simxFinish(b)


def test_a_client_scenes_script_is_confined_to_that_clients_folder(server, tmp_path):
    """A scene a client sent (--allow-remote-code) acts as that client: its script writes into
    the client's folder, never into the operator's; its folder stays while the scene is loaded
    after the client left, and goes when another scene replaces it."""
    (tmp_path / "sent.xml").write_text(CLIENT_SCENE)
    (tmp_path / "sent.lua").write_text(SENT)
    cid = _legacy(server)
    left = server.log_so_far().count(" disconnected")
    try:
        before = set(client_files(server))
        vrep.simxStopSimulation(cid, B)  # the server starts running; a scene loads only when stopped
        for name in ("sent.lua", "sent.xml"):
            assert vrep.simxTransferFile(cid, str(tmp_path / name), name, 30, B) == vrep.simx_return_ok
        assert vrep.simxLoadScene(cid, str(tmp_path / "sent.xml"), 1, B) == vrep.simx_return_ok
        assert vrep.simxStartSimulation(cid, B) == vrep.simx_return_ok
        rc, _, _, strings, _ = vrep.simxCallScriptFunction(cid, "Sent", vrep.sim_scripttype_childscript, "try_save",
                                                           [], [], [str(server.folder / "adv_from_script.xml")],
                                                           bytearray(), B)
        assert rc == vrep.simx_return_ok and "refused" in strings[0], strings
        rc, _, _, strings, _ = vrep.simxCallScriptFunction(cid, "Sent", vrep.sim_scripttype_childscript, "try_save",
                                                           [], [], ["mine.xml"], bytearray(), B)
        assert rc == vrep.simx_return_ok and strings == ["ok"], strings
        vrep.simxStopSimulation(cid, B)
        (folder,) = [k for k in client_files(server) if k not in before]
        assert client_files(server)[folder] == ["at_init.xml", "at_init_Sent_child.lua", "mine.xml",
                                                "mine_Sent_child.lua", "sent.lua", "sent.xml"]
        assert not (server.folder / "adv_from_script.xml").exists() and not (server.folder / "mine.xml").exists()
    finally:
        vrep.simxFinish(cid)
    wait_until(lambda: server.log_so_far().count(" disconnected") > left, timeout=20, what="the server saw the client leave")
    assert folder in client_files(server)  # the loaded scene's folder stays
    other = _legacy(server, 1)
    try:
        assert vrep.simxLoadScene(other, "scene.xml", 0, B) == vrep.simx_return_ok
        wait_until(lambda: folder not in client_files(server), timeout=20, what="the folder goes with the scene")
    finally:
        vrep.simxFinish(other)


def test_a_zmq_clients_folder_goes_when_it_leaves(server):
    """A ZMQ client's files (and their room) go when it ends (the official client's _*end*_)."""
    c = Zmq(server.zmq_port, "leaving-" + str(time.monotonic_ns()))
    before = set(client_files(server))
    assert "ret" in c.call("sim.saveImage", PNG_2x2, [2, 2], 0, "bye.png", -1)
    (folder,) = set(client_files(server)) - before
    c.close()
    wait_until(lambda: folder not in client_files(server), timeout=20, what="the folder of the ZMQ client that left removed")
