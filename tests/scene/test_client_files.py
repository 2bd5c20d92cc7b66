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
    monkeypatch.setattr(limits, "MIN_CLIENT_FILES_BYTES", 0)  # no shares: the total alone
    monkeypatch.setattr(limits, "RESERVED_CLIENT_FILES_BYTES", 0)
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
    message named the server's folder (issue 48): every file call refuses it with the bound, a
    server-side path too (simxLoadScene/simxLoadModel with options 0, sim.loadScene, sim.loadImage:
    the same error then named the scene's folder), and the operator's own writes."""
    with files.acting("legacy:a"):
        for call in (lambda: files.erase_file(name), lambda: files.transfer_file(name, b"x"),
                     lambda: files.resolve(name, 1, files.roots[0] / "scene.xml"),
                     lambda: files.resolve(name, 0, files.roots[0] / "scene.xml"),
                     lambda: files.source(name, "legacy:a", "sim.loadImage"),
                     lambda: files.source(name, None, "sim.loadImage"),
                     lambda: files.target(name, None, "sim.saveScene"),
                     lambda: files.target(name, "legacy:a", "sim.saveScene")):
            with pytest.raises(ArgumentError, match="MAX_FILE_NAME") as refused:
                call()
            text = str(refused.value)
            assert str(files.files_dir) not in text and str(files.roots[0]) not in text and len(text) < 400
        files.transfer_file("é" * 125, b"x")  # 250 bytes: in bounds
        files.erase_file("é" * 125)


def test_a_group_cannot_fill_the_folder_and_a_newcomer_always_has_its_minimum(files, monkeypatch):
    """16 clients x 64 MiB filled the 1 GiB total and every other client's 1 kB file was refused
    for as long as they stayed (issue 48). Scaled down (total 1,300 bytes, 400 of them reserved
    for 40 minimums of 10 bytes, 400 a client at most): 16 clients writing all they can stop at
    their share of the pool (900 divided by the clients holding files, and what the pool has
    left); the total never fills, and newcomer after newcomer still writes its minimum."""
    monkeypatch.setattr(limits, "MAX_TRANSFER_FOLDER_BYTES", 1300)
    monkeypatch.setattr(limits, "RESERVED_CLIENT_FILES_BYTES", 400)
    monkeypatch.setattr(limits, "MIN_CLIENT_FILES_BYTES", 10)
    monkeypatch.setattr(limits, "MAX_CLIENT_FILES_BYTES", 400)
    held, refusals = [], []
    for i in range(16):
        key = f"legacy:greedy{i}"
        with files.acting(key):
            for j in range(40):  # 40 x 10 bytes: its whole MAX_CLIENT_FILES_BYTES
                try:
                    files.transfer_file(f"f{j}", b"g" * 10)
                except RemoteError as exc:
                    refusals.append(str(exc))
                    break
        held.append(files._usage[key][1])
    # 390 above the minimum each for two (shares 900 and 450), the pool's last 120 for the third,
    # the minimum for the others.
    assert held == [400, 400, 130] + [10] * 13
    assert len(refusals) == 14 and all("MIN_CLIENT_FILES_BYTES" in r for r in refusals), refusals
    assert "its share of the transfer folder with 2 clients" not in "".join(refusals)  # the 2nd got all it asked
    for i in range(24):  # the rest of the reserve: a minimum for each newcomer
        with files.acting(f"legacy:newcomer{i}"):
            files.transfer_file("small", b"n" * 10)
    assert sum(b for _, b in files._usage.values()) == 1300  # 40 minimums and the pool: nothing lost


def test_transfers_are_written_off_the_calling_thread_and_counted_before(files, monkeypatch):
    """With ``later`` the file is counted at once (the next transfer past the budget is refused
    before the first is written) and written by the files' thread; the client's next file call
    waits for it."""
    import threading
    gate, real = threading.Event(), files._write

    def held(*args):
        assert threading.current_thread() is not threading.main_thread()
        assert gate.wait(30)
        real(*args)

    files._write = held
    monkeypatch.setattr(limits, "MAX_UNWRITTEN_BYTES", 4 * limits.MAX_TRANSFER_FILE_BYTES)  # not the bound here
    with files.acting("legacy:a"):
        first = files.transfer_file("a.bin", b"a" * limits.MAX_TRANSFER_FILE_BYTES, later=True)
        second = files.transfer_file("b.bin", b"b" * limits.MAX_TRANSFER_FILE_BYTES, later=True)
        with pytest.raises(RemoteError, match="MAX_CLIENT_FILES_BYTES"):
            files.transfer_file("c.bin", b"c", later=True)  # counted, not written yet
        assert not first.done() and not (files.folder("legacy:a") / "a.bin").exists()
        with pytest.raises(RemoteError, match="server busy: 2 file.s. this client sent are being written"):
            files.erase_file("a.bin")  # never waits on the calling thread
        gate.set()
        assert first.result(timeout=30) is None and second.result(timeout=30) is None
        files.erase_file("a.bin")
        assert files._usage["legacy:a"][1] == limits.MAX_TRANSFER_FILE_BYTES
        files.transfer_file("c.bin", b"c", later=True).result(timeout=30)


def test_bytes_not_written_yet_are_bounded_per_client_and_in_all(files, monkeypatch):
    """Rewriting one file costs no room in the folder: the bytes handed to the files' thread are
    bounded instead (per client, and for all), answered "server busy" beyond."""
    import threading
    monkeypatch.setattr(limits, "MAX_UNWRITTEN_BYTES", 250)
    monkeypatch.setattr(limits, "MAX_UNWRITTEN_BYTES_TOTAL", 400)
    monkeypatch.setattr(limits, "MIN_CLIENT_FILES_BYTES", 10)
    gate, real = threading.Event(), files._write
    files._write = lambda *args: (gate.wait(30), real(*args))[1]
    writes = []
    with files.acting("legacy:a"):
        writes += [files.transfer_file("same.bin", b"a" * 100, later=True) for _ in range(2)]
        with pytest.raises(RemoteError, match=r"server busy: .*200 bytes .*MAX_UNWRITTEN_BYTES = 250"):
            files.transfer_file("same.bin", b"a" * 100, later=True)
    with files.acting("legacy:b"):
        writes.append(files.transfer_file("b.bin", b"b" * 200, later=True))
    with files.acting("legacy:c"), pytest.raises(RemoteError, match="MAX_UNWRITTEN_BYTES_TOTAL = 400"):
        files.transfer_file("c.bin", b"c" * 11, later=True)
    with files.acting("legacy:d"):  # a file of its minimum, none of its own being written: taken
        writes.append(files.transfer_file("d.bin", b"d" * 10, later=True))
        with pytest.raises(RemoteError, match="MAX_UNWRITTEN_BYTES_TOTAL = 400"):
            files.transfer_file("d2.bin", b"d", later=True)  # one at a time
    gate.set()
    assert [w.result(timeout=30) for w in writes] == [None] * 4
    with files.acting("legacy:c"):
        files.transfer_file("c.bin", b"c", later=True).result(timeout=30)


def test_the_files_thread_takes_the_clients_in_turn_each_clients_writes_in_order():
    """A client's file waits behind at most one write of each other client, not behind all they
    handed over (up to limits.MAX_UNWRITTEN_BYTES_TOTAL)."""
    import threading

    from simx_server.scene.file_writer import FileWriter

    writer, gate, order = FileWriter(), threading.Event(), []
    first = writer.submit("x", lambda: (order.append("x1"), gate.wait(30)))
    while order != ["x1"]:  # the thread holds x1 at the gate
        threading.Event().wait(0.01)
    jobs = [writer.submit(key, lambda name=name: order.append(name))
            for key, name in (("a", "a1"), ("a", "a2"), ("a", "a3"), ("b", "b1"), ("c", "c1"))]
    failing = writer.submit("b", lambda: 1 / 0)
    gate.set()
    assert first.result(timeout=30) is not None and [j.result(timeout=30) for j in jobs] == [None] * 5
    with pytest.raises(ZeroDivisionError):
        failing.result(timeout=30)  # its own Future says why; the thread goes on
    assert order == ["x1", "a1", "b1", "c1", "a2", "a3"]
    assert writer.submit("a", lambda: "next").result(timeout=30) == "next"


def test_every_client_the_doors_can_hold_has_room_for_its_minimum():
    """A minimum of 1 MiB with room for 256 of them let a group of 268 clients (12 at 64 MiB, the
    others at their minimum) fill the total and refuse a newcomer's 1 kB file (issue 48's next
    attack); the room kept is every client's the two doors can hold at once."""
    import queue

    from simx_server.legacy.sessions import Sessions

    assert limits.RESERVED_CLIENT_FILES_BYTES >= limits.MAX_FILE_HOLDERS * limits.MIN_CLIENT_FILES_BYTES
    assert Sessions(queue.SimpleQueue()).max_clients == limits.MAX_CLIENTS  # the legacy door's clients; the ZMQ door's likewise
    assert limits.MAX_FILE_HOLDERS == 2 * limits.MAX_CLIENTS + 2  # both doors, the in-process caller, a gone scene's
    pool = limits.MAX_TRANSFER_FOLDER_BYTES - limits.RESERVED_CLIENT_FILES_BYTES
    assert pool >= limits.MAX_TRANSFER_FOLDER_BYTES // 2 and 1024 <= limits.MIN_CLIENT_FILES_BYTES
