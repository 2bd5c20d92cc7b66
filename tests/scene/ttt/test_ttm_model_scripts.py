"""A V-REP model (``.ttm``) with a child and a customization script, loaded with
``simxLoadModel`` on real servers over Zenoh: from the scene's folder its scripts run as the
scene's own; sent by the client (options bit 0, its transfer folder) they run only on a server
started with ``--allow-remote-code``, and the model loads without them otherwise
(docs/SECURITY.md). The scripts set integer signals the client reads."""

from __future__ import annotations

import time

import pytest

import tttwriter as W

try:
    from conftest import ServerProcess
except ImportError:
    from tests.conftest import ServerProcess

import vrep

B = vrep.simx_opmode_blocking

CHILD = """function sysCall_init()
  sim.setInt32Signal('child_init', sim.getObjectHandle('Crate_handle'))
end
"""
CUSTOM = "function sysCall_init() sim.setInt32Signal('custom_init', 1) end\n"


@pytest.fixture()
def folder(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    (scenes / "floor.xml").write_text('<mujoco><worldbody><geom type="plane" size="2 2 0.1"/></worldbody></mujoco>')
    model = W.cuboid_shape(1, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.5), dynamic=False) + \
        W.dummy(2, 1, "Crate_handle", (0, 0, 0.1)) + W.script(10, 1, CHILD) + W.script(11, 1, CUSTOM, kind=6)
    (scenes / "crate.ttm").write_bytes(W.ttt_file(model))
    sent = tmp_path / "client"
    sent.mkdir()
    (sent / "sent.ttm").write_bytes(W.ttt_file(model))
    return tmp_path


def _signal(cid, name, seconds=5.0):
    """The integer signal ``name``, waited for up to ``seconds`` (a child script's init comes
    with the next pass of the running simulation); None when it never came."""
    end = time.monotonic() + seconds
    while True:
        rc, value = vrep.simxGetIntegerSignal(cid, name, B)
        if rc == 0 or time.monotonic() > end:
            return value if rc == 0 else None
        time.sleep(0.05)


def _start(folder, *flags):
    srv = ServerProcess(str(folder / "scenes" / "floor.xml"), *flags, renderers="on-demand")
    cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
    assert cid >= 0
    return srv, cid


def test_a_ttm_models_scripts_run_from_a_trusted_folder_and_from_a_client_only_when_allowed(folder):
    srv, cid = _start(folder)
    try:
        rc, base = vrep.simxLoadModel(cid, "crate.ttm", 0, B)  # the scene's folder: trusted
        assert rc == 0
        assert _signal(cid, "custom_init") == 1
        handle = vrep.simxGetObjectHandle(cid, "Crate_handle", B)[1]
        assert _signal(cid, "child_init") == handle  # in the running simulation's next pass
        assert vrep.simxClearIntegerSignal(cid, "", B) == 0
        # the same model sent by the client: loaded, its scripts not run
        rc, sent = vrep.simxLoadModel(cid, str(folder / "client" / "sent.ttm"), 1, B)
        assert rc == 0 and sent != base
        assert vrep.simxGetObjectHandle(cid, "Crate_handle#0", B)[0] == 0
        assert _signal(cid, "custom_init", 1.0) is None and _signal(cid, "child_init", 0.5) is None
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    assert log.count("do not run: simx runs code sent by clients only when the server is started with "
                     "--allow-remote-code") == 1, log[-3000:]

    srv, cid = _start(folder, "--allow-remote-code")
    try:
        rc, sent = vrep.simxLoadModel(cid, str(folder / "client" / "sent.ttm"), 1, B)
        assert rc == 0
        assert _signal(cid, "custom_init") == 1
        assert _signal(cid, "child_init") == vrep.simxGetObjectHandle(cid, "Crate_handle", B)[1]
        vrep.simxFinish(cid)
    finally:
        srv.stop()
