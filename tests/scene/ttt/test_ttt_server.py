"""``simx-server scene.ttt`` and ``simxLoadScene``/``simxLoadModel`` with V-REP files, on real
server processes over Zenoh: objects by their V-REP names and poses, a model added, a corrupted
file refused with the server still serving, and the conversion cached by content."""

from __future__ import annotations

import time

import pytest

import tttwriter as W

try:
    from conftest import ServerProcess, free_port
except ImportError:
    from tests.conftest import ServerProcess, free_port

import vrep

B = vrep.simx_opmode_blocking


@pytest.fixture()
def script_port():
    """The port the scene's threaded script opens (simRemoteApi.start): a free one, never V-REP's
    fixed 19999 beside parallel tests."""
    return free_port()


@pytest.fixture()
def cell(tmp_path, monkeypatch, script_port):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    folder = tmp_path / "scenes"
    folder.mkdir()
    (folder / "cell.ttt").write_bytes(W.simple_scene(port=script_port))
    model = W.cuboid_shape(1, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.5), dynamic=False) + \
        W.dummy(2, 1, "Crate_handle", (0, 0, 0.1))
    (folder / "crate.ttm").write_bytes(W.ttt_file(model))
    data = bytearray(W.simple_scene())
    data[1200:1260] = bytes(60)  # the Huffman stream broken in its middle
    (folder / "broken.ttt").write_bytes(bytes(data))
    sent = tmp_path / "client"
    sent.mkdir()
    (sent / "plain.ttt").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Sent", (0.1, 0.1, 0.1), (0, 0, 0.2))))
    return folder


def _position(cid, name):
    rc, h = vrep.simxGetObjectHandle(cid, name, B)
    assert rc == 0, f"no object {name!r}"
    rc, pos = vrep.simxGetObjectPosition(cid, h, -1, B)
    assert rc == 0
    return pos


def _connect(port: int, seconds: float = 10.0) -> int:
    """A legacy client on ``port``, retried while the server opens it (a few passes a second)."""
    end = time.monotonic() + seconds
    while True:
        cid = vrep.simxStart("127.0.0.1", port, True, True, 2000, 5)
        if cid >= 0 or time.monotonic() > end:
            return cid
        time.sleep(0.2)


def test_serve_load_model_and_refuse_a_broken_file(cell, tmp_path, script_port):
    srv = ServerProcess(str(cell / "cell.ttt"), renderers="on-demand")
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert cid >= 0
        # the base's threaded script ran simRemoteApi.start(port): the server serves that port too
        other = _connect(script_port)
        assert other >= 0, f"the scene's script did not open port {script_port}"
        assert vrep.simxGetObjectHandle(other, "Tip", B)[0] == 0
        vrep.simxFinish(other)
        # V-REP's names, '#' copies included; poses from the file (the joint at 0.3 rad turns
        # the link about z, which leaves these positions on the axis)
        assert _position(cid, "Base_joint1") == pytest.approx([0, 0, 0.25], abs=1e-6)
        assert _position(cid, "Link#0") == pytest.approx([0, 0, 0.45], abs=1e-6)
        assert _position(cid, "Tip") == pytest.approx([0, 0, 0.65], abs=1e-6)
        rc, j = vrep.simxGetObjectHandle(cid, "Base_joint1", B)
        assert vrep.simxGetJointPosition(cid, j, B) == (0, pytest.approx(0.3, abs=1e-6))
        # the scene is the .ttt (not its conversion in the cache)
        assert vrep.simxGetStringParameter(cid, vrep.sim_stringparam_scene_path_and_name, B) == \
            (0, str(cell / "cell.ttt"))
        rc, link = vrep.simxGetObjectHandle(cid, "Link#0", B)
        assert vrep.simxGetObjectParent(cid, link, B) == (0, j)
        # the file's collections, by their names (handles from 2,000,000, in name order)
        assert vrep.simxGetCollectionHandle(cid, "Arm", B) == (0, 2_000_000)
        assert vrep.simxGetCollectionHandle(cid, "NotCube", B) == (0, 2_000_001)
        assert vrep.simxGetCollectionHandle(cid, "Nothing", B)[0] == vrep.simx_return_remote_error_flag
        # a .ttm beside the scene: loaded as the real file, its base's handle back
        rc, base = vrep.simxLoadModel(cid, "crate.ttm", 0, B)
        assert rc == 0 and base >= 0
        assert _position(cid, "Crate_handle") == pytest.approx([0, 0, 0.6], abs=1e-6)
        # a corrupted .ttt: a remote error naming the file and the record, and the server goes on
        assert vrep.simxStopSimulation(cid, B) == 0  # scenes load stopped
        assert vrep.simxLoadScene(cid, "broken.ttt", 0, B) == vrep.simx_return_remote_error_flag
        assert _position(cid, "Tip") == pytest.approx([0, 0, 0.65], abs=1e-6)
        # a client's own .ttt (options bit 0: sent through the transfer folder; with scripts it
        # would need --allow-remote-code, as a client's MJCF)
        assert vrep.simxLoadScene(cid, str(tmp_path / "client" / "plain.ttt"), 1, B) == 0
        assert _position(cid, "Sent") == pytest.approx([0, 0, 0.2], abs=1e-6)
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    # converted off the simulation thread (scene.conversions): its failure is logged there, once
    assert "simx.editing: cannot load 'broken.ttt': broken.ttt: record " in log, log[-2000:]


def test_second_start_uses_the_cache(cell, tmp_path):
    srv = ServerProcess(str(cell / "cell.ttt"), renderers="on-demand")
    srv.stop()
    converted = list((tmp_path / "cache" / "simx" / "ttt").glob("*/scene.xml"))
    assert len(converted) == 1
    stamp = converted[0].stat().st_mtime_ns
    time.sleep(0.05)
    srv = ServerProcess(str(cell / "cell.ttt"), renderers="on-demand")
    srv.stop()
    assert list((tmp_path / "cache" / "simx" / "ttt").glob("*/scene.xml")) == converted
    assert converted[0].stat().st_mtime_ns == stamp  # not converted again
