"""Issue 40: V-REP files are read and converted in a bounded worker process, off the
simulation thread. In-process: the worker's memory and CPU bounds and its errors. On real
servers (legacy remote API over Zenoh, ZMQ): while a hostile file is converted until its CPU
bound, another client's blocking calls are answered (counted, not timed), the error names the
file and the bound, and the server's memory is back where it was; a model (``.ttm``) and a
client's file likewise; the command-line file goes through the same worker."""

from __future__ import annotations

import functools
import threading
import time

import numpy as np
import pytest

from simx_server.scene.ttt import worker
from simx_server.scene.ttt.errors import SceneFileError

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
#: The worker's CPU bound (s) in the tests of a file past it, and files far past it on any machine:
#: about 3x it for a small file on a busy 2-core machine (a 1 s bound refused a one-box model there,
#: issue 60), and the files past it need 3x it on this project's machines, so that a machine three
#: times as fast still passes it.
BOUND = 3
_MANY = 120_000  # dummies: about 10 s of one core to convert


@functools.cache  # the same bytes for every test: made once (0.2 s)
def _many_dummies() -> bytes:
    return W.ttt_file(b"".join(W.dummy(k, -1, f"D{k}") for k in range(1, _MANY + 1)), compress=False)


@functools.cache  # the same bytes for every test: made once
def _heavy_meshes() -> bytes:
    """Sixteen shapes of 199,000 random triangles over one pool array of 100,000 vertices (40 MB):
    about 9 s of one core to convert (MuJoCo's convex hulls), within every reader bound."""
    rng = np.random.default_rng(40)
    pool = W.mesh_pool(rng.random((100_000, 3)), rng.integers(0, 100_000, 3 * 199_000))
    more = b"".join(W.rec("VIN", W.lst(W.rec("Ind", rng.integers(0, 100_000, 3 * 199_000).astype("<i4").tobytes())))
                    for _ in range(15))
    shapes = b"".join(W.pool_shape(k + 1, -1, f"S{k}", 0, k) for k in range(16))
    return W.ttt_file(pool + more + shapes, compress=False)


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        line = next(line for line in f if line.startswith("VmRSS:"))
    return int(line.split()[1]) / 1024


def test_the_worker_converts_a_file_and_says_a_reader_error_as_the_reader_does(tmp_path):
    (tmp_path / "ok").mkdir()
    worker.convert("cell.ttt", W.simple_scene(), tmp_path / "ok", "scene")
    assert (tmp_path / "ok" / "scene.xml").is_file() and (tmp_path / "ok" / "report.json").is_file()
    (tmp_path / "bad").mkdir()
    with pytest.raises(SceneFileError, match="^chain.ttt: record DMY: .* more than MAX_TREE_DEPTH = 200$") as err:
        worker.convert("chain.ttt", W.ttt_file(W.dummy(1, -1, "D1") + b"".join(
            W.dummy(k, k - 1, f"D{k}") for k in range(2, 5001))), tmp_path / "bad", "scene")
    assert err.value.record == "DMY"


def test_a_clients_file_has_no_more_objects_than_a_clients_scene_has_elements(tmp_path):
    from simx_server.base import limits as L

    many = W.ttt_file(b"".join(W.dummy(k, -1, f"D{k}") for k in range(1, L.MAX_SCENE_ELEMENTS + 2)), compress=False)
    with pytest.raises(SceneFileError, match=f"more than MAX_OBJECTS = {L.MAX_SCENE_ELEMENTS:,} objects"):
        worker.convert("many.ttt", many, tmp_path, "scene", client=True)


def test_the_worker_stops_at_its_memory_bound(tmp_path, monkeypatch):
    monkeypatch.setenv("SIMX_TTT_WORKER_MB", "100")  # less than the interpreter and its libraries need
    with pytest.raises(SceneFileError, match=r"^s.ttt: record worker: conversion ran out of its memory bound "
                                             r"\(RLIMIT_AS = 100 MiB, SIMX_TTT_WORKER_MB\)$"):
        worker.convert("s.ttt", W.ttt_file(W.dummy(1, -1, "D")), tmp_path, "scene")


def test_the_worker_stops_at_its_cpu_bound(tmp_path, monkeypatch):
    monkeypatch.setenv("SIMX_TTT_WORKER_CPU_S", "1")
    with pytest.raises(SceneFileError, match=r"record worker: conversion took more than its CPU-time bound "
                                             r"\(RLIMIT_CPU = 1 s, SIMX_TTT_WORKER_CPU_S\)"):
        worker.convert("many.ttt", _many_dummies(), tmp_path, "scene")


@pytest.fixture()
def bounded(tmp_path, monkeypatch):
    """A scene folder with a plain start scene, a file that takes far more than BOUND s of CPU
    to convert as a scene and as a model, the conversion cache in the test's folder, the
    worker's CPU bound at BOUND s."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("SIMX_TTT_WORKER_CPU_S", str(BOUND))
    folder = tmp_path / "scenes"
    folder.mkdir()
    (folder / "start.ttt").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Floor", (2, 2, 0.1), dynamic=False)))
    heavy = _heavy_meshes()
    (folder / "many.ttt").write_bytes(heavy)
    (folder / "many.ttm").write_bytes(heavy)
    (folder / "dummies.ttt").write_bytes(_many_dummies())
    return folder


def _load_while_another_client_calls(srv, load) -> tuple[int, int]:
    """Run ``load(cid)`` (a blocking load) on one client while another client makes blocking
    calls until it returns: ``(the load's return code, the other client's answered calls)``."""
    loader = vrep.simxStart("127.0.0.1", srv.port, True, True, -60_000, 5)  # blocking calls wait 60 s
    other = vrep.simxStart("127.0.0.1", srv.ports[1], True, True, 5000, 5)  # V-REP: one connection per port
    assert loader >= 0 and other >= 0
    assert vrep.simxGetObjectHandle(other, "Floor", B)[0] == 0
    done: dict[str, int] = {}
    thread = threading.Thread(target=lambda: done.setdefault("rc", load(loader)))
    thread.start()
    answered = 0
    while thread.is_alive():
        assert vrep.simxGetObjectHandle(other, "Floor", B)[0] == 0
        answered += 1
        time.sleep(0.01)  # the count is the check: calls back to back only took CPU from the worker
    thread.join()
    vrep.simxFinish(loader)
    vrep.simxFinish(other)
    return done["rc"], answered


@pytest.mark.parametrize("kind", ["scene", "model"])
def test_a_file_past_its_cpu_bound_leaves_the_server_serving_and_its_memory_as_it_was(bounded, kind):
    srv = ServerProcess(str(bounded / "start.ttt"), "--stopped", renderers="on-demand", ports=[free_port(), free_port()])
    try:
        before = _rss_mb(srv.proc.pid)
        if kind == "scene":
            rc, answered = _load_while_another_client_calls(srv, lambda c: vrep.simxLoadScene(c, "many.ttt", 0, B))
        else:
            rc, answered = _load_while_another_client_calls(srv, lambda c: vrep.simxLoadModel(c, "many.ttm", 0, B)[0])
        assert rc == vrep.simx_return_remote_error_flag
        # the conversion took at least its BOUND s of CPU in the worker; the other client's calls
        # (one every 10 ms or so) went on meanwhile: the simulation thread was not held
        assert answered >= 10
        assert _rss_mb(srv.proc.pid) - before < 100
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, 5000, 5)
        assert vrep.simxGetObjectHandle(cid, "Floor", B)[0] == 0  # the old scene, still served
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    name = "many.ttt" if kind == "scene" else "many.ttm"
    assert (f"cannot load '{name}': {name}: record worker: conversion took more than its "
            f"CPU-time bound (RLIMIT_CPU = {BOUND} s, SIMX_TTT_WORKER_CPU_S)") in log, log[-2000:]


def test_a_clients_file_and_a_good_scene_file_load_through_the_worker(bounded, tmp_path, monkeypatch):
    # The reader's bounds are under test here, not the worker's CPU bound: a busy machine took more
    # than 1 s of CPU to read dummies.ttt's first 10,000 objects and answered with that bound
    # instead (issue 60). The worker gets the default's 60 s, which no machine reaches first.
    monkeypatch.setenv("SIMX_TTT_WORKER_CPU_S", "60")
    chain = W.ttt_file(W.dummy(1, -1, "D1") + b"".join(W.dummy(k, k - 1, f"D{k}") for k in range(2, 5001)))
    (tmp_path / "chain.ttt").write_bytes(chain)
    (tmp_path / "box.ttt").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Box", (0.1, 0.1, 0.1), (0, 0, 1))))
    srv = ServerProcess(str(bounded / "start.ttt"), "--stopped", renderers="on-demand")
    try:
        cid = vrep.simxStart("127.0.0.1", srv.port, True, True, -30_000, 5)  # blocking calls wait 30 s
        assert cid >= 0
        # options 1: the client sends its file. A 5,000-deep chain: its bound, not "internal
        # error ... RecursionError"
        assert vrep.simxLoadScene(cid, str(tmp_path / "chain.ttt"), 1, B) == vrep.simx_return_remote_error_flag
        assert vrep.simxLoadScene(cid, str(tmp_path / "box.ttt"), 1, B) == 0
        assert vrep.simxGetObjectHandle(cid, "Box", B)[0] == 0
        # a scene-folder file a client asks for is read under a client's bounds too
        assert vrep.simxLoadScene(cid, "dummies.ttt", 0, B) == vrep.simx_return_remote_error_flag
        vrep.simxFinish(cid)
    finally:
        log = srv.stop()
    assert "dummies.ttt: record DMY: more than MAX_OBJECTS = 10,000 objects" in log
    assert "chain.ttt: record DMY: object 'D201' lies 201 levels deep, more than MAX_TREE_DEPTH = 200" in log
    assert "RecursionError" not in log


def test_zmq_loads_of_vrep_files_answer_once_loaded(bounded, official):
    port = free_port()
    srv = ServerProcess(str(bounded / "start.ttt"), "--stopped", "--zmq-port", str(port), renderers="on-demand")
    try:
        sim = official(port).require("sim")
        with pytest.raises(Exception, match=f"RLIMIT_CPU = {BOUND} s"):
            sim.loadScene(str(bounded / "many.ttt"))
        (bounded / "crate.ttm").write_bytes(W.ttt_file(W.cuboid_shape(1, -1, "Crate", (0.2, 0.2, 0.2), (0, 0, 0.5))))
        base = sim.loadModel(str(bounded / "crate.ttm"))
        assert base == sim.getObject("/Crate")
        assert sim.loadScene(str(bounded / "start.ttt")) is None
        assert sim.getObject("/Floor") >= 0
    finally:
        srv.stop()


def test_the_command_line_file_is_converted_in_the_bounded_worker(bounded):
    with pytest.raises(RuntimeError, match=r"simx-server: dummies.ttt: record worker: conversion took more than its "
                                           rf"CPU-time bound \(RLIMIT_CPU = {BOUND} s"):
        ServerProcess(str(bounded / "dummies.ttt"), "--stopped", renderers="on-demand")
