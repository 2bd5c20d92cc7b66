"""Each client's folder and budgets (issue 40, "Files"), in process: :class:`ClientFiles` with the
doors' caller set by hand (``acting``), as the ZMQ and legacy doors set it for each request.
tests/transport/test_client_folders.py has the same rules on a real server."""

from __future__ import annotations

import pytest

from simx_client.protocol import ArgumentError, RemoteError
from simx_server.base import limits
from simx_server.scene.client_files import CLIENTS, ClientFiles

SCENE = '<mujoco><worldbody><body name="B"><geom size=".1"/></body></worldbody></mujoco>'


@pytest.fixture
def files(tmp_path):
    (tmp_path / "scene.xml").write_text(SCENE)
    f = ClientFiles(tmp_path / "scene.xml")
    yield f
    f.close()


def test_the_total_budget_holds_across_clients_and_each_budget_is_its_own(files, monkeypatch):
    monkeypatch.setattr(limits, "MAX_CLIENT_FILES_BYTES", 100)
    monkeypatch.setattr(limits, "MAX_TRANSFER_FOLDER_BYTES", 250)
    for key in ("zmq:a", "zmq:b"):
        with files.acting(key):
            files.transfer_file("x.bin", b"x" * 100)
    with files.acting("zmq:a"), pytest.raises(RemoteError, match="MAX_CLIENT_FILES_BYTES"):
        files.transfer_file("y.bin", b"y")
    with files.acting("zmq:c"), pytest.raises(RemoteError, match="MAX_TRANSFER_FOLDER_BYTES"):
        files.transfer_file("z.bin", b"z" * 51)
    with files.acting("zmq:c"):
        files.transfer_file("z.bin", b"z" * 50)
        files.transfer_file("z.bin", b"z" * 50)  # the same file again: its old bytes count once
    files.release("zmq:a")  # a leaves: its 100 bytes are free for c
    with files.acting("zmq:c"):
        files.transfer_file("z.bin", b"z" * 100)
    assert len(list((files.files_dir / CLIENTS).glob("*/x.bin"))) == 1  # b's; a's folder went


def test_clients_never_see_each_others_files(files):
    with files.acting("legacy:a"):
        files.transfer_file("mine.xml", b"<mujoco/>")
        own = files.transfer_path("mine.xml")
        assert files.public(own) == "mine.xml"
        assert files.source("mine.xml", "legacy:a", "read") == own
    with files.acting("legacy:b"):
        with pytest.raises(RemoteError, match="no transferred file"):
            files.erase_file("mine.xml")
        with pytest.raises(RemoteError, match="refused"):
            files.source(str(own), "legacy:b", "read")
        with pytest.raises(ArgumentError, match="outside the transfer folder"):
            files.transfer_path("../" + own.parent.name + "/mine.xml")
    assert own.is_file()
    assert str(own.parent) not in files.scrub(f"cannot read {own}")


def test_a_folder_holding_the_loaded_scene_stays_until_the_scene_is_replaced(files, tmp_path):
    with files.acting("zmq:a"):
        files.transfer_file("scene.xml", SCENE.encode())
        scene = files.transfer_path("scene.xml")
    files.scene_installed(scene)
    files.release("zmq:a")
    assert scene.is_file()  # the loaded scene's folder stays after its client left
    files.scene_installed(tmp_path / "scene.xml")  # the operator's scene again
    assert not scene.parent.exists()


def test_who_writes_a_scripts_file(files, tmp_path):
    """A script in a client's folder acts as that client; the operator's script as the client
    calling it (on_behalf), else as the operator (None); a door's facade as the door's caller."""
    with files.acting("zmq:a"):
        files.transfer_file("s.lua", b"")
        sent = files.transfer_path("s.lua")
    operator_script = tmp_path / "keeper.lua"
    assert files.writer(sent) == "zmq:a"
    assert files.writer(operator_script) is None
    with files.acting("zmq:b"):
        assert files.writer(None) == "zmq:b" and files.writer(sent) == "zmq:a"
        assert files.writer(operator_script) is None  # a step or start the client triggered
        with files.on_behalf():
            assert files.writer(operator_script) == "zmq:b"
    assert files.target("out.xml", None, "sim.saveScene") == tmp_path / "out.xml"
    with pytest.raises(RemoteError, match="refused"):
        files.target(str(files.files_dir / "x.xml"), None, "sim.saveScene")


@pytest.mark.parametrize("name", ["a" * 5000, "d/" + "b" * (limits.MAX_FILE_NAME_PART_BYTES + 1),
                                  "/".join(["c" * 200] * 6), "é" * 126])
def test_a_name_too_long_is_refused_naming_the_bound_never_the_folder(files, name):
    """A 5,000-character name made simxEraseFile raise ENAMETOOLONG, an internal error whose
    message named the server's folder (issue 48): every file call refuses it with the bound."""
    with files.acting("legacy:a"):
        for call in (lambda: files.erase_file(name), lambda: files.transfer_file(name, b"x"),
                     lambda: files.resolve(name, 1, files.roots[0] / "scene.xml"),
                     lambda: files.target(name, "legacy:a", "sim.saveScene")):
            with pytest.raises(ArgumentError, match="MAX_FILE_NAME") as refused:
                call()
            assert str(files.files_dir) not in str(refused.value) and len(str(refused.value)) < 400
        files.transfer_file("é" * 125, b"x")  # 250 bytes: in bounds
        files.erase_file("é" * 125)
