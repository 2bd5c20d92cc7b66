"""Files and scenes sent by clients (issue 11, defects 3 to 5), against real servers.

3. A transfer folder is private to one server: files sent to server A cannot be loaded as
   trusted server-side files by server B (nor by A after a ``kill -9`` and a restart), errors
   never name the folder, stale folders of dead servers are swept at start.
4. Every file a client-sent scene or model names must lie in its transfer folder; the refusal
   reads the same for existing and missing server files.
5. Scene contents are bounded before MuJoCo parses them: the texture and ``<replicate>``
   bombs are refused at once while another client's blocking calls go on, and the server's
   memory stays small. Edits by clients respect the same body/element bounds (in-process).
"""

from __future__ import annotations

import os
import re
import shutil
import stat
import struct
import tempfile
import threading
import uuid
import zlib
from pathlib import Path

import pytest

import vrep
from conftest import SCENE, ServerProcess, free_port, wait_until
from simx_client.protocol import ArgumentError, RemoteError

pytestmark = pytest.mark.renderers_on_demand  # no image is read from an in-process Simulation here

TMP = Path(tempfile.gettempdir()).resolve()
OK, REMOTE = vrep.simx_return_ok, vrep.simx_return_remote_error_flag
WAIT = vrep.simx_opmode_blocking

#: A scene with a child script that, if it ever runs, sets the integer signal ``pwned``.
EVIL_SCENE = """<mujoco model="evil">
  <worldbody><body name="Evil" pos="0 0 1"><geom type="box" size="0.1 0.1 0.1"/></body></worldbody>
  <custom><text name="simx:Evil" data="child_script={script}"/></custom>
</mujoco>
"""
EVIL_SCRIPT = "def sysCall_init():\n    sim.setIntegerSignal('pwned', 1)\n"


def connect(port: int) -> int:
    cid = vrep.simxStart("127.0.0.1", port, True, True, 5000, 5)
    assert cid >= 0, f"could not connect to port {port}"
    return cid


def last_errors(cid: int) -> list[str]:
    rc, errors = vrep.simxGetLastErrors(cid, WAIT)
    assert rc == OK
    return errors


def untrusted_folder() -> Path:
    """A writable folder that server B does not trust: outside the temporary folder (its
    --scene-path) and the scene's folder, wherever the checkout lies (beside the tests, the
    home folder, /var/tmp or /dev/shm)."""
    trusted = (TMP, SCENE.resolve().parent)
    for place in (Path(__file__).resolve().parent, Path.home(), Path("/var/tmp"), Path("/dev/shm")):
        place = place.resolve()
        if place.is_dir() and os.access(place, os.W_OK) and not any(place.is_relative_to(t) for t in trusted):
            return place
    pytest.fail(f"no writable folder outside {', '.join(map(str, trusted))} for the refusal to test")


def folders_holding(name: str, tmp: Path = TMP) -> list[Path]:
    """Transfer folders (of any server) in ``tmp`` that hold a file called ``name`` (in a
    client's folder, ``.simx-clients/*``, or the folder itself)."""
    return [d for d in tmp.glob("simx-*") if (d / name).is_file() or any(d.glob(f".simx-clients/*/{name}"))]


def png(width: int, height: int, rgb=(255, 0, 0)) -> bytes:
    """A small RGB PNG of one colour (the 'secret' image a scene must not read)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    rows = b"".join(b"\0" + bytes(rgb) * width for _ in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


@pytest.fixture(scope="module")
def server_b():
    """A server whose operator (wrongly) lists the temporary folder as a scene folder."""
    srv = ServerProcess(str(SCENE), "--scene-path", str(TMP), ports=[free_port(), free_port()], renderers="on-demand")
    yield srv
    srv.stop()


@pytest.fixture
def client_b(server_b):
    cid = connect(server_b.port)
    yield cid
    vrep.simxFinish(cid)


def test_a_load_after_a_oneshot_transfer_of_the_same_message_sees_the_file(server_b):
    """V-REP runs a message's commands in order (simExtRemoteApi ``CSimxSocket::_executeCommands``):
    a scene sent by a oneshot ``simxTransferFile`` exists when the ``simxLoadScene`` of the same
    message runs, which then loads it (it was refused "busy, send it again": the write was still
    on the files' thread)."""
    import msgpack
    import zenoh

    from simx_client import protocol as P
    from simx_client.connection import client_config

    xml = ('<mujoco><worldbody><body name="SameMessage" pos="0 0 1"><geom type="box" size=".1 .1 .1"/>'
           '</body></worldbody></mujoco>').encode() + b" " * 3_000_000  # big enough to take a while
    session = zenoh.open(client_config("127.0.0.1", server_b.port))
    try:
        client = uuid.uuid4().hex

        def call(commands: list) -> list:
            for reply in session.get(P.call_key("simx", client), payload=P.request(client, commands), timeout=60):
                if reply.ok is not None:
                    return msgpack.unpackb(reply.ok.payload.to_bytes(), raw=False)[5]
            raise AssertionError("no reply")

        assert call([["StopSimulation", WAIT, []]])[0][0] is True
        results = call([["TransferFile", vrep.simx_opmode_oneshot, ["same.xml", xml]],
                        ["LoadScene", WAIT, ["same.xml", 1]]])
        assert [ok for ok, _ in results] == [True, True], results
        assert call([["GetObjectHandle", WAIT, ["SameMessage"]]])[0][0] is True  # the scene it sent
        assert call([["LoadScene", WAIT, [SCENE.name, 0]], ["StartSimulation", WAIT, []]]) == [[True, None]] * 2
    finally:
        session.close()


# ------------------------------------------------------------------ defect 3
def test_transfer_folder_is_private_to_one_server_and_swept_after_kill(server_b, client_b, tmp_path, monkeypatch):
    token = uuid.uuid4().hex[:8]
    scene, script = f"evil-{token}.xml", f"evil-{token}.py"
    # Server A and its restart keep their transfer folders in a temporary folder of their own
    # (TMPDIR), inside the one server B trusts: no other server on the host sweeps there, so
    # the sweep seen below is the restarted server's.
    host_tmp = (tmp_path / "host-tmp").resolve()
    host_tmp.mkdir()
    monkeypatch.setenv("TMPDIR", str(host_tmp))
    server_a = ServerProcess(str(SCENE), "--stopped", ports=[free_port()], renderers="on-demand")
    try:
        a = connect(server_a.port)
        for name, text in ((script, EVIL_SCRIPT), (scene, EVIL_SCENE.format(script=script))):
            (tmp_path / name).write_text(text)
            assert vrep.simxTransferFile(a, str(tmp_path / name), name, 5, WAIT) == OK
        assert vrep.simxLoadScene(a, str(tmp_path / scene), 1, WAIT) == REMOTE  # A refuses the client's code
        errors = last_errors(a)
        assert errors and not any(str(TMP) in e or "simx-" in e for e in errors), errors
        (folder,) = wait_until(lambda: folders_holding(scene, host_tmp), 5, what="A's transfer folder")
        assert stat.S_IMODE(folder.stat().st_mode) == 0o700
        assert f"simx-{server_a.proc.pid}-" in folder.name

        # Server B (even with the temporary folder as a --scene-path) refuses A's files; stopped
        # first, so that the loads are refused for where the files are, not for a running
        # simulation.
        assert vrep.simxStopSimulation(client_b, WAIT) == OK
        assert vrep.simxLoadScene(client_b, str(folder / scene), 0, WAIT) == REMOTE
        assert vrep.simxLoadModel(client_b, str(folder / scene), 0, WAIT)[0] == REMOTE
        assert all("refused" in e for e in last_errors(client_b)[-2:]), last_errors(client_b)
        # Server paths outside the scene's folder and --scene-path folders are refused too.
        outside_dir = Path(tempfile.mkdtemp(prefix=".simx-outside-", dir=untrusted_folder()))
        try:
            outside = outside_dir / "outside.xml"
            outside.write_text('<mujoco><worldbody><body name="Out"><geom size=".1"/></body></worldbody></mujoco>')
            assert vrep.simxLoadScene(client_b, str(outside), 0, WAIT) == REMOTE
            assert "refused" in last_errors(client_b)[-1], last_errors(client_b)
        finally:
            shutil.rmtree(outside_dir)
        assert vrep.simxStartSimulation(client_b, WAIT) == OK
        try:
            wait_until(lambda: vrep.simxGetObjectHandle(client_b, "UR5", WAIT)[0] == OK, 5, what="B's own scene")
            assert vrep.simxGetIntegerSignal(client_b, "pwned", WAIT)[0] != OK  # no script ran
        finally:
            assert vrep.simxStopSimulation(client_b, WAIT) == OK
        vrep.simxFinish(a)

        # kill -9 leaves the folder; the next server on the host sweeps it at start.
        server_a.proc.kill()
        server_a.proc.wait()
        assert folder.is_dir()
    finally:
        server_a.stop()
    mine = host_tmp / f"simx-{os.getpid()}-0-decoy{token}"  # a live process's folder stays
    mine.mkdir()
    (mine / ".simx-transfer-folder").write_text("")
    unmarked = host_tmp / f"simx-999999999-0-decoy{token}"  # not ours (no marker): stays
    unmarked.mkdir()
    try:
        restarted = ServerProcess(str(SCENE), "--stopped", ports=[free_port()], renderers="on-demand")
        try:
            assert not folder.exists()
            assert mine.is_dir() and unmarked.is_dir()
            (own,) = [d for d in host_tmp.glob(f"simx-{restarted.proc.pid}-*")]
        finally:
            log = restarted.stop()
        assert not own.exists()  # removed at exit
        assert "swept" in log
    finally:
        for d in (mine, unmarked):
            (d / ".simx-transfer-folder").unlink(missing_ok=True)
            d.rmdir()


# ------------------------------------------------------------------ defect 4
def test_client_scene_may_name_only_files_sent_with_it(client_b, tmp_path):
    vrep.simxStopSimulation(client_b, WAIT)  # the server starts running; a scene loads only when stopped
    secret = tmp_path / "secret.png"  # a server file a client must not see through a camera
    secret.write_bytes(png(8, 8))
    missing = tmp_path / "absent.png"  # as long a name as secret.png
    mesh = (Path(__file__).resolve().parents[1] / "scenes" / "tetra.obj").resolve()
    good_png = png(4, 4, (0, 255, 0))

    def send(name: str, data: bytes) -> str:
        local = tmp_path / name.replace("/", "_")
        local.write_bytes(data)
        assert vrep.simxTransferFile(client_b, str(local), name, 5, WAIT) == OK
        return str(local)

    def scene(asset: str = "", extra: str = "", compiler: str = "") -> str:
        return (f'<mujoco>{compiler}<asset>{asset}</asset>{extra}<worldbody><body name="B" pos="0 0 1">'
                '<geom type="box" size=".1 .1 .1"/></body></worldbody></mujoco>')

    def refused(xml: str, name: str = "c.xml") -> str:
        local = send(name, xml.encode())
        assert vrep.simxLoadScene(client_b, local, 1, WAIT) == REMOTE, xml
        assert vrep.simxLoadModel(client_b, local, 1, WAIT)[0] == REMOTE, xml
        (scene_error, model_error) = last_errors(client_b)[-2:]
        return scene_error

    tex = '<texture name="t" type="2d" file="{}"/>'
    texts = {str(secret): refused(scene(tex.format(secret))), str(missing): refused(scene(tex.format(missing)))}
    # Same message whether the server file exists or not.
    assert re.sub("'[^']*'", "P", texts[str(secret)]) == re.sub("'[^']*'", "P", texts[str(missing)])
    assert "sent" in texts[str(secret)]
    up = os.path.relpath(secret, TMP / "x" / "y")
    for xml in (scene(f'<mesh name="m" file="{mesh}"/>'),
                scene(f'<hfield name="h" file="{secret}" size="1 1 1 1"/>'),
                scene(f'<texture name="c" type="cube" fileright="{secret}"/>'),
                scene(tex.format(f"../../../../../../../..{secret}")),
                scene(tex.format("secret.png"), compiler=f'<compiler texturedir="{secret.parent}"/>'),
                scene(tex.format("secret.png"), compiler=f'<compiler assetdir="{secret.parent}"/>'),
                scene(tex.format(up), compiler='<compiler texturedir="x/y"/>'),
                scene(extra=f'<include file="{SCENE}"/>'),
                scene(extra='<include file="../../../../../../../../etc/hostname"/>'),
                scene(extra=f'<include xmlns="urn:x" file="{SCENE}"/>'),  # MuJoCo ignores namespaces
                scene(extra=f'<include file=" {SCENE}"/>')):
        refused(xml)
    # Files sent with the scene are fine, also in sub-folders.
    send("tex/green.png", good_png)
    ok = send("ok.xml", scene(tex.format("green.png"), compiler='<compiler texturedir="tex"/>').encode())
    assert vrep.simxLoadScene(client_b, ok, 1, WAIT) == OK
    assert vrep.simxGetObjectHandle(client_b, "B", WAIT)[0] == OK
    # The scene's path is its name in the transfer folder, not the folder's path.
    assert vrep.simxGetStringParameter(client_b, 13, WAIT) == (OK, "ok.xml")  # sim_stringparam_scene_path_and_name
    model = send("model.xml", b'<mujoco><asset><texture name="g" type="2d" file="tex/green.png"/></asset>'
                              b'<worldbody><body name="M"><geom size=".1"/></body></worldbody></mujoco>')
    assert vrep.simxLoadModel(client_b, model, 1, WAIT)[0] == OK
    assert vrep.simxLoadScene(client_b, str(SCENE.name), 0, WAIT) == OK  # back to the operator's scene


# ------------------------------------------------------------------ defect 5
TEXTURE_BOMB = ('<mujoco><asset><texture name="t" type="2d" builtin="checker" width="40000" '
                'height="40000"/></asset><worldbody/></mujoco>')
REPLICATE_BOMB = ('<mujoco><worldbody><replicate count="300" offset="0 0 1"><replicate count="300" '
                  'offset="1 0 0"><body><geom size=".1"/></body></replicate></replicate></worldbody></mujoco>')


def vm_hwm_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    raise AssertionError("no VmHWM")


def test_scene_bombs_are_refused_at_once_while_others_are_served(server_b, client_b, tmp_path):
    """The bombs are refused before anything is parsed (the errors name the guard's bounds, the
    server's peak memory stays small), and another client's blocking calls, made throughout,
    are all answered: none runs into its 5 s blocking timeout (the client's timer), which each
    call in flight during a freeze like the one before the fix (22-30 s) would. Stated without
    a latency in seconds, which the machine's speed and load decide."""
    assert len(TEXTURE_BOMB) < 260 and len(REPLICATE_BOMB) < 260
    other = connect(server_b.ports[1])  # one connection per port and process, as in V-REP
    try:
        codes, stop = [], threading.Event()  # the return code of each of the other client's calls

        def keep_calling():
            while not stop.is_set():
                codes.append(vrep.simxGetObjectHandle(other, "UR5", WAIT)[0])

        worker = threading.Thread(target=keep_calling)
        worker.start()
        try:
            wait_until(lambda: len(codes) >= 5, 30, what="the other client's first calls")
            for name, xml in (("texture_bomb.xml", TEXTURE_BOMB), ("replicate_bomb.xml", REPLICATE_BOMB)):
                local = tmp_path / name
                local.write_text(xml)
                for load in (lambda: vrep.simxLoadScene(client_b, str(local), 1, WAIT),
                             lambda: vrep.simxLoadModel(client_b, str(local), 1, WAIT)[0]):
                    assert load() == REMOTE  # the errors below name the guard's bounds: refused unparsed
            after = len(codes)
            wait_until(lambda: len(codes) >= after + 5, 30, what="the other client's calls after the loads")
        finally:
            stop.set()
            worker.join()
        assert codes == [OK] * len(codes), codes  # the bombs froze clients 22-30 s before the fix
        errors = last_errors(client_b)
        assert any("texture" in e and "pixels" in e for e in errors), errors
        assert any("bodies" in e for e in errors), errors
        assert vm_hwm_kb(server_b.proc.pid) < 600_000  # 9.2 GB before the fix
    finally:
        vrep.simxFinish(other)


# ------------------------------------------------------------------ in-process bounds
@pytest.fixture
def sim():
    from simx_server.scene.simulation import Simulation

    s = Simulation(SCENE, dt=0.05, realtime=False)
    yield s
    s.close()


def test_edits_by_clients_respect_the_body_bound(sim, monkeypatch):
    from simx_server.base import limits
    from simx_server.commands.editing import EDITING_HANDLERS as H

    w = sim.world
    monkeypatch.setattr(limits, "MAX_SCENE_BODIES", w.model.nbody - 1 + 2)  # the world body not counted
    sphere = w.resolve("Sphere").handle
    with sim.editor.files.acting("a-client"):  # a client's edits (the operator's are not bounded)
        H["CopyPasteObjects"](sim, [[sphere]])
        H["CopyPasteObjects"](sim, [[sphere]])  # now at the bound
        model = w.model
        with pytest.raises(RemoteError, match="MAX_SCENE_BODIES"):
            H["CopyPasteObjects"](sim, [[sphere]])
        box = (Path(__file__).resolve().parents[1] / "scenes" / "model_box.xml").read_bytes()
        H["TransferFile"](sim, ["box.xml", box])
        with pytest.raises(RemoteError, match="MAX_SCENE_BODIES"):
            H["LoadModel"](sim, ["box.xml", 1])
        assert sim.world.model is model  # refused edits change nothing
        H["RemoveObject"](sim, [sphere])  # shrinking is always allowed
        monkeypatch.setattr(limits, "MAX_SCENE_ELEMENTS", 0)
        with pytest.raises(RemoteError, match="MAX_SCENE_ELEMENTS"):
            H["CreateDummy"](sim, [0.1, None])


def test_transfer_folder_bounds(sim, monkeypatch):
    from simx_server.base import limits
    from simx_server.commands.editing import EDITING_HANDLERS as H

    monkeypatch.setattr(limits, "MAX_TRANSFER_FILE_BYTES", 100)
    monkeypatch.setattr(limits, "MAX_TRANSFER_FILES", 3)
    monkeypatch.setattr(limits, "MAX_TRANSFER_FOLDER_BYTES", 250)
    with pytest.raises(ArgumentError, match="MAX_TRANSFER_FILE_BYTES"):
        H["TransferFile"](sim, ["big", b"x" * 101])
    H["TransferFile"](sim, ["a", b"x" * 100])
    H["TransferFile"](sim, ["b", b"x" * 100])
    with pytest.raises(RemoteError, match="MAX_TRANSFER_FOLDER_BYTES"):
        H["TransferFile"](sim, ["c", b"x" * 100])
    H["TransferFile"](sim, ["b", b"x" * 10])  # replacing a file counts its new size only
    H["TransferFile"](sim, ["c", b"x" * 10])
    with pytest.raises(RemoteError, match="MAX_TRANSFER_FILES"):
        H["TransferFile"](sim, ["d", b"x"])
    with pytest.raises(ArgumentError, match="reserved"):
        H["TransferFile"](sim, [".simx-transfer-folder", b""])
    assert sorted(p.name for p in sim.editor.files_dir.iterdir() if not p.name.startswith(".")) == ["a", "b", "c"]


@pytest.mark.parametrize("xml, bound", [
    ('<mujoco><include file="a.xml"/><include file="a.xml"/></mujoco>', "MAX_XML_DEPTH"),
    ('<mujoco><worldbody>' + '<body>' * 500 + '</body>' * 500 + '</worldbody></mujoco>', "MAX_XML_DEPTH"),
    ('<mujoco><worldbody><camera name="c" resolution="40000 40000"/></worldbody></mujoco>', "MAX_RESOLUTION"),
    ('<mujoco><size memory="10G"/></mujoco>', "MAX_ARENA_BYTES"),
    ('<mujoco><size nkey="100000000"/></mujoco>', "MAX_SIZE_ENTRIES"),
    ('<mujoco><option iterations="100000000"/></mujoco>', "MAX_SOLVER_ITERATIONS"),
    ('<mujoco><option timestep="1e-9"/></mujoco>', "MAX_SUBSTEPS"),
    ('<mujoco><visual><quality shadowsize="100000"/></visual></mujoco>', "MAX_VISUAL_SIZE"),
    ('<mujoco><visual><global offwidth="100000"/></visual></mujoco>', "MAX_VISUAL_SIZE"),
    ('<mujoco><worldbody><composite type="particle" count="100 100 100" spacing="0.01"><geom size=".001"/>'
     '</composite></worldbody></mujoco>', "MAX_SCENE_BODIES"),
    ('<mujoco><worldbody><flexcomp name="f" type="grid" count="200 200 200" spacing=".1 .1 .1" dim="3"/>'
     '</worldbody></mujoco>', "MAX_SCENE_BODIES"),
    ('<mujoco><asset><hfield name="h" nrow="40000" ncol="40000" size="1 1 1 1"/></asset></mujoco>', "MAX_HFIELD_CELLS"),
    ('<mujoco><asset><texture name="t" type="skybox" builtin="flat" width="40000"/></asset></mujoco>',
     "MAX_TEXTURE_PIXELS"),
    ('<mujoco><worldbody>' + '<geom size=".1"/>' * 10_001 + '</worldbody></mujoco>', "MAX_SCENE_ELEMENTS"),
    ('<!DOCTYPE m [<!ENTITY a "aaaaaaaa">]><mujoco/>', "DOCTYPE"),
    ('<mujoco><extension><plugin plugin="mujoco.elasticity.cable"/></extension></mujoco>', "plugins"),
    ('<mujoco><asset><model name="m" file="a.xml"/></asset></mujoco>', "<model>"),
])
def test_scene_contents_are_bounded_before_mujoco_parses_them(sim, xml, bound, monkeypatch):
    """Each bomb is refused with the name of the bound it passes, before MuJoCo compiles it
    (allocates what it asks for)."""
    import mujoco

    from simx_server.commands.editing import EDITING_HANDLERS as H

    H["TransferFile"](sim, ["a.xml", xml.encode()])

    def compiled(*args, **kwargs):
        raise AssertionError("MuJoCo compiled a scene the guard should have refused")

    monkeypatch.setattr(mujoco.MjSpec, "compile", compiled)
    for command in ("LoadScene",) if bound == "MAX_SUBSTEPS" else ("LoadScene", "LoadModel"):  # a model
        with pytest.raises(RemoteError, match=re.escape(bound)):  # brings no <option> with it
            H[command](sim, ["a.xml", 1])


def test_asset_files_are_measured_before_mujoco_reads_them(sim):
    """A PNG whose header claims 40000x40000 pixels (decoded: 6.4 GB) and an STL claiming 10^6
    triangles are refused from their headers; a mesh file named by a model likewise."""
    from simx_server.commands.editing import EDITING_HANDLERS as H

    ihdr = struct.pack(">IIBBBBB", 40000, 40000, 8, 2, 0, 0, 0)
    H["TransferFile"](sim, ["big.png", b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + b"IHDR" + ihdr
                            + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))])
    H["TransferFile"](sim, ["big.stl", b"\0" * 80 + struct.pack("<I", 1_000_000)])
    for xml, bound in (('<texture name="t" type="2d" file="big.png"/>', "MAX_TEXTURE_PIXELS"),
                       ('<mesh name="m" file="big.stl"/>', "MAX_MESH_VERTICES")):
        H["TransferFile"](sim, ["a.xml", f"<mujoco><asset>{xml}</asset></mujoco>".encode()])
        for command in ("LoadScene", "LoadModel"):
            with pytest.raises(RemoteError, match=bound):
                H[command](sim, ["a.xml", 1])


def test_server_side_paths_after_a_client_scene_and_a_closed_scene(sim, tmp_path):
    """Relative server-side paths fall back to the first scene's folder while the scene is a
    client's (or the empty scene of simxCloseScene, which lives in the transfer folder)."""
    from simx_server.commands.editing import EDITING_HANDLERS as H

    H["TransferFile"](sim, ["f", b"x"])
    H["TransferFile"](sim, ["m.xml", b'<mujoco><asset><texture name="t" type="2d" file="gone.png"/></asset></mujoco>'])
    for command, args in (("TransferFile", ["f/x", b"x"]), ("LoadScene", ["f", 1]), ("LoadModel", ["f", 1]),
                          ("LoadScene", ["m.xml", 1]), ("LoadModel", ["m.xml", 1])):
        with pytest.raises(RemoteError) as failed:  # an OSError or MuJoCo's text would name the folder
            H[command](sim, args)
        assert str(sim.editor.files_dir) not in str(failed.value) and "simx-" not in str(failed.value)
    H["CloseScene"](sim, [])
    assert sim.world.objects == {}
    H["LoadScene"](sim, [SCENE.name, 0])
    assert "UR5" in sim.world.by_name
    own = b'<mujoco><worldbody><body name="Own"><geom size=".1"/></body></worldbody></mujoco>'
    H["TransferFile"](sim, ["own.xml", own])
    H["LoadScene"](sim, ["own.xml", 1])
    with pytest.raises(RemoteError, match="refused"):
        H["LoadScene"](sim, [str(sim.editor.files_dir / "own.xml"), 0])  # its own file, but sent by a client
    (tmp_path / "exists.xml").write_text("<mujoco/>")
    with pytest.raises(RemoteError, match="refused") as missing:
        H["LoadScene"](sim, [str(tmp_path / "absent.xml"), 0])
    with pytest.raises(RemoteError, match="refused") as elsewhere:
        H["LoadScene"](sim, [str(tmp_path / "exists.xml"), 0])
    assert re.sub("'[^']*'", "P", str(missing.value)) == re.sub("'[^']*'", "P", str(elsewhere.value))
    H["LoadScene"](sim, [SCENE.name, 0])
    assert "UR5" in sim.world.by_name


def test_scene_path_must_be_a_folder(tmp_path):
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "simx_server.cli", "--scene-path", str(tmp_path / "no"),
                           "--port", str(free_port())], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "--scene-path" in proc.stderr and "not a folder" in proc.stderr


def test_includes_count_toward_one_xml_budget(sim, monkeypatch):
    """Many distinct included files (each small enough) may not add up past the XML budget."""
    from simx_server.base import limits
    from simx_server.commands.editing import EDITING_HANDLERS as H

    monkeypatch.setattr(limits, "MAX_SCENE_FILE_BYTES", 1000)
    part = b'<mujoco><custom><text name="t%d" data="' + b"x" * 300 + b'"/></custom></mujoco>'
    for i in range(4):
        H["TransferFile"](sim, [f"part{i}.xml", part.replace(b"%d", str(i).encode())])
    includes = "".join(f'<include file="part{i}.xml"/>' for i in range(4))
    H["TransferFile"](sim, ["a.xml", f"<mujoco>{includes}</mujoco>".encode()])
    with pytest.raises(RemoteError, match="MAX_SCENE_FILE_BYTES"):
        H["LoadScene"](sim, ["a.xml", 1])
    H["TransferFile"](sim, ["a.xml", f"<mujoco>{includes[:len(includes) // 2]}</mujoco>".encode()])
    H["LoadScene"](sim, ["a.xml", 1])  # two of them fit


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-32"])
def test_a_doctype_in_utf16_or_utf32_xml_is_refused_before_mujoco_parses_it(sim, encoding):
    """Issue 23 part 6: the byte search for a DOCTYPE missed UTF-16 text (with or without BOM)."""
    from simx_server.commands.editing import EDITING_HANDLERS as H

    text = ('<?xml version="1.0"?>\n<!DOCTYPE m [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;">]>\n'
            '<mujoco><worldbody><body name="B"><geom size="0.1"/></body></worldbody></mujoco>')
    H["TransferFile"](sim, ["wide.xml", text.encode(encoding)])
    model = sim.world.model
    with pytest.raises(RemoteError, match=r"not UTF-8 text .*MuJoCo reads UTF-8 XML only"):
        H["LoadModel"](sim, ["wide.xml", 1])
    assert sim.world.model is model


def _spheres(n: int, iterations: int = 100, timestep: float = 0.002, memory: str = "", gap: float = 0.001) -> bytes:
    """``n`` free spheres of radius 5 cm in a column, ``gap`` m apart (1 mm: all overlapping)."""
    bodies = "".join(f'<body name="s{i}" pos="0 0 {0.1 + i * gap:.3f}"><freejoint/><geom size="0.05"/></body>'
                     for i in range(n))
    size = f'<size memory="{memory}"/>' if memory else ""
    return (f'<mujoco><option iterations="{iterations}" timestep="{timestep}"/>{size}<worldbody>{bodies}'
            '</worldbody></mujoco>').encode()


def test_a_client_scene_whose_arena_or_step_work_is_too_big_is_refused_before_it_replaces_the_scene(sim):
    """Issue 23 part 3: MuJoCo sizes the arena of overlapping spheres itself (1,000 of them:
    1.65 GiB), and 300 piled spheres at 1,000 iterations and a 5e-4 s timestep froze every client."""
    from simx_server.commands.editing import EDITING_HANDLERS as H

    world = sim.world
    H["TransferFile"](sim, ["pile.xml", _spheres(400)])  # about 400 MiB of arena, sized by MuJoCo
    with pytest.raises(RemoteError, match="MAX_ARENA_BYTES"):
        H["LoadScene"](sim, ["pile.xml", 1])
    H["TransferFile"](sim, ["slow.xml", _spheres(300, iterations=1000, timestep=5e-4, memory="32M")])
    with pytest.raises(RemoteError, match="MAX_STEP_WORK"):
        H["LoadScene"](sim, ["slow.xml", 1])
    assert sim.world is world  # nothing replaced
    H["TransferFile"](sim, ["fine.xml", _spheres(20)])
    H["LoadScene"](sim, ["fine.xml", 1])
    assert sim.world is not world and len(sim.world.objects) == 20


def test_obj_vertices_are_counted_as_mujocos_reader_reads_them():
    from simx_server.base.scene_guard import mesh_vertices

    lf, cr, crlf, indented = (b"v 0 0 0\nv 1 0 0\nvn 0 0 1\n# v 9 9 9\n", b"v 0 0 0\rv 1 0 0\rv 0 1 0\r",
                              b"v 0 0 0\r\nv 1 0 0\r\n", b"  v 0 0 0\n\tv 1 0 0\n")
    assert [mesh_vertices(d, "m.obj") for d in (lf, cr, crlf, indented)] == [2, 3, 2, 2]
