"""Issue 40: a V-REP file's load does its heavy part off the simulation thread. Its conversion
(the worker process) and also MuJoCo's parse and compile of the converted file and the new
``World`` (``Editor.prepare_scene``) run on the conversion's thread; the simulation thread
only swaps the scene in. For a model (``.ttm``) the model's spec is prepared there and compiled
once alone, which leaves its meshes in MuJoCo's cache for the scene's compile
(``prepare_model``).

Counted, not timed: a file of many objects is loaded once (its conversion is then cached), so
that its second load is all parse, compile and World; meanwhile another client's blocking calls
keep being answered (before, on the simulation thread, none was)."""

from __future__ import annotations

import threading
import time

import mujoco
import pytest

try:
    from . import tttwriter as W
except ImportError:
    import tttwriter as W

try:
    from conftest import ServerProcess, free_port
except ImportError:
    from tests.conftest import ServerProcess, free_port

import vrep

B = vrep.simx_opmode_blocking
_OBJECTS = 6_000  # dummies (within a client's MAX_SCENE_ELEMENTS): a World of 6,000 objects


@pytest.fixture()
def folder(tmp_path, monkeypatch):
    """A scene folder: a start scene with a Floor, a file of many dummies and a Floor, a model
    of meshes; the conversion cache in the test's folder."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    floor = W.cuboid_shape(1, -1, "Floor", (2, 2, 0.1), dynamic=False)
    (scenes / "start.ttt").write_bytes(W.ttt_file(floor))
    many = b"".join(W.dummy(k, -1, f"D{k}") for k in range(2, _OBJECTS + 2))
    (scenes / "many.ttt").write_bytes(W.ttt_file(floor + many, compress=False))
    return scenes


def _load_while_another_client_calls(srv, load) -> tuple[int, int]:
    """Run ``load(cid)`` (blocking) on one client while another client makes blocking calls
    until it returns: ``(the load's return code, the other client's answered calls)``."""
    loader = vrep.simxStart("127.0.0.1", srv.port, True, True, -60_000, 5)
    other = vrep.simxStart("127.0.0.1", srv.ports[1], True, True, 10_000, 5)
    assert loader >= 0 and other >= 0
    assert vrep.simxGetObjectHandle(other, "Floor", B)[0] == 0
    done: dict[str, int] = {}
    thread = threading.Thread(target=lambda: done.setdefault("rc", load(loader)))
    thread.start()
    answered = 0
    while thread.is_alive():
        assert vrep.simxGetObjectHandle(other, "Floor", B)[0] == 0  # both scenes have a Floor
        answered += 1
        time.sleep(0.002)  # the count is the check: calls back to back only took CPU from the load
    thread.join()
    vrep.simxFinish(loader)
    vrep.simxFinish(other)
    return done["rc"], answered


def test_a_scenes_parse_compile_and_world_are_made_off_the_simulation_thread(folder):
    srv = ServerProcess(str(folder / "start.ttt"), "--stopped", renderers="on-demand",
                        ports=[free_port(), free_port()])
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, -60_000, 5)
        assert vrep.simxLoadScene(cid, "many.ttt", 0, B) == 0  # converted once: cached from now on
        assert vrep.simxLoadScene(cid, "start.ttt", 0, B) == 0
        vrep.simxFinish(cid)
        rc, answered = _load_while_another_client_calls(srv, lambda c: vrep.simxLoadScene(c, "many.ttt", 0, B))
        assert rc == 0
        # MuJoCo's parse and compile of 6,000 sites and a World of 6,000 objects: some tenths
        # of a second of one core, during which the other client's calls (one every
        # 2-3 ms) are answered; on the simulation thread they all waited (0-2 answered)
        assert answered >= 10
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert vrep.simxGetObjectHandle(cid, f"D{_OBJECTS + 1}", B)[0] == 0  # the new scene is served
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    assert f"scene 'many.ttt' loaded: {_OBJECTS + 1} objects" in log, log[-2000:]


def test_a_model_is_prepared_off_the_simulation_thread_and_attached_whole(folder):
    """A .ttm of meshes and a script: prepared on the conversion's thread (parsed, its files in
    memory, its script dropped, compiled once alone), then attached as before."""
    cube = W.cuboid_shape(1, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.5))
    (folder / "crate.ttm").write_bytes(W.ttt_file(W.model_base() + cube))
    srv = ServerProcess(str(folder / "start.ttt"), "--stopped", renderers="on-demand",
                        ports=[free_port(), free_port()])
    try:
        rc, answered = _load_while_another_client_calls(srv, lambda c: vrep.simxLoadModel(c, "crate.ttm", 0, B)[0])
        assert rc == 0 and answered >= 1
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        first = vrep.simxGetObjectHandle(cid, "Crate", B)
        rc, handle = vrep.simxLoadModel(cid, "crate.ttm", 0, B)  # again: a second crate, renamed
        assert first[0] == 0 and rc == 0 and handle not in (0, first[1])
        assert vrep.simxGetObjectHandle(cid, "Crate", B) == first
        vrep.simxFinish(cid)
    finally:
        srv.stop()


def test_prepare_model_leaves_the_models_meshes_in_mujocos_cache(tmp_path):
    """In-process: the model's meshes, compiled once alone under the names its spec gives
    them, are found in MuJoCo's cache by the scene's compile (the cache grows no more)."""
    from simx_server.scene.simulation import Simulation

    _rock_files(tmp_path, seed=3)
    (tmp_path / "start.xml").write_text('<mujoco><worldbody><body name="Floor"><geom size="1 1 .1" type="box"/>'
                                        '</body></worldbody></mujoco>')
    sim = Simulation(tmp_path / "start.xml", renderers_at_load=False)
    try:
        prepared = sim.editor.prepare_model(tmp_path / "rock.xml", "'rock.xml'")
        before = _cache_bytes()
        assert before > 0  # the rock, processed
        handle = sim.editor._attach_model(prepared)
        assert sim.world.get(handle).name == "Rock"
        assert _cache_bytes() == before  # the scene's compile found the rock processed already
    finally:
        sim.close()


def test_a_prepared_scenes_first_edit_finds_its_meshes_in_mujocos_cache(tmp_path):
    """In-process: a scene prepared with ``warm`` (a deferred load) has the edits' spec, whose
    files are in memory under names of their own, compiled once; the first edit's compile then
    finds its meshes processed (the cache grows no more), instead of processing them on the
    simulation thread."""
    from simx_server.scene.simulation import Simulation

    _rock_files(tmp_path, seed=4)
    (tmp_path / "start.xml").write_text('<mujoco><worldbody><body name="Floor"><geom size="1 1 .1" type="box"/>'
                                        '</body></worldbody></mujoco>')
    sim = Simulation(tmp_path / "start.xml", renderers_at_load=False)
    try:
        editor = sim.editor
        editor._swap_scene(editor.prepare_scene(tmp_path / "rock.xml", "'rock.xml'", None, warm=True))
        before = _cache_bytes()
        editor.create_dummy(0.01, None)  # an edit: the scene's spec compiled on the simulation thread
        assert _cache_bytes() == before
        assert sim.world.resolve("Rock").type == 0  # a shape
    finally:
        sim.close()


def _rock_files(folder, seed: int) -> None:
    """``rock.xml``: a free body of one random 6,000-triangle mesh (``meshes/rock.stl``)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    (folder / "meshes").mkdir()
    vertices = rng.random((3000, 3)).astype("<f4")
    faces = rng.integers(0, 3000, (6000, 3)).astype("<i4")
    _write_stl(folder / "meshes" / "rock.stl", vertices[faces])
    (folder / "rock.xml").write_text(
        '<mujoco model="rock"><compiler meshdir="meshes"/><asset><mesh name="rock" file="rock.stl"/></asset>'
        '<worldbody><body name="Rock"><freejoint/><geom type="mesh" mesh="rock"/></body></worldbody></mujoco>')


def _cache_bytes() -> int:
    """The bytes of MuJoCo's process-wide asset cache (processed meshes, by asset name)."""
    return mujoco.mj_getCacheSize(mujoco.mj_getCache())


def _write_stl(path, triangles) -> None:
    import numpy as np

    rec = np.zeros(len(triangles), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = triangles
    path.write_bytes(b"\0" * 80 + np.uint32(len(triangles)).tobytes() + rec.tobytes())
