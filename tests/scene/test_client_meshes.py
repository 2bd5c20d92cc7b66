"""A client's MJCF/URDF meshes (issue 48): bounded by faces as well as vertices, and a client's
MJCF/URDF file parsed and compiled off the simulation thread, as its ``.ttt`` files are. Two OBJ
meshes in bounds by vertices (199,000 each) but of 470,000 faces froze every client 9.4 s and
took the server from 230 MB to 1,349 MB. Generated meshes, small bounds monkeypatched."""

from __future__ import annotations

import queue
import threading

import pytest

from conftest import SCENE
from simx_client.protocol import RemoteError
from simx_server.base import limits as L
from simx_server.base.scene_guard import mesh_faces
from simx_server.commands.editing import EDITING_HANDLERS as H
from simx_server.scene.simulation import Simulation
from simx_server.sim.vision_results import Deferred

pytestmark = pytest.mark.renderers_on_demand


def grid_obj(n: int, quads: bool = False) -> bytes:
    """An n x n grid of vertices in a slightly bent sheet, as OBJ: 2 (n-1)^2 triangles, or
    (n-1)^2 quads (each 2 triangles to MuJoCo)."""
    lines = [f"v {i / n:.4f} {j / n:.4f} {((i * j) % 7) / 100:.4f}" for i in range(n) for j in range(n)]
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j + 1, (i + 1) * n + j + 1, (i + 1) * n + j + 2, i * n + j + 2
            lines += [f"f {a} {b} {c} {d}"] if quads else [f"f {a} {b} {c}", f"f {a} {c} {d}"]
    return ("\n".join(lines) + "\n").encode()


def scene(meshes: int) -> bytes:
    assets = "".join(f'<mesh name="m{i}" file="grid.obj" scale="1 1 {1 + i}"/>' for i in range(meshes))
    bodies = "".join(f'<body pos="{i} 0 1"><geom type="mesh" mesh="m{i}"/></body>' for i in range(meshes))
    return f"<mujoco><asset>{assets}</asset><worldbody>{bodies}</worldbody></mujoco>".encode()


@pytest.fixture
def sim():
    s = Simulation(SCENE, dt=0.05, realtime=False, renderers_at_load=False)
    yield s
    s.close()


def test_faces_are_counted_as_mujoco_triangulates_them():
    assert mesh_faces(grid_obj(11), "g.obj") == 200
    assert mesh_faces(grid_obj(11, quads=True), "g.obj") == 200  # a quad is two triangles
    assert mesh_faces(b"v 0 0 0\r\n  f 1 2 3 4 5\rf 1 2 3", "g.obj") == 4  # CR, leading blanks, a pentagon
    stl = b"\0" * 80 + (7).to_bytes(4, "little") + b"\0" * 50 * 7
    assert mesh_faces(stl, "g.stl") == 7


def test_a_mesh_in_bounds_by_vertices_and_past_them_by_faces_is_refused(sim, monkeypatch):
    """Scaled down: 400 vertices allowed, 11 x 11 = 121 vertices and 200 faces a mesh."""
    monkeypatch.setattr(L, "MAX_MESH_VERTICES", 400)
    monkeypatch.setattr(L, "MAX_SCENE_MESH_VERTICES", 800)
    monkeypatch.setattr(L, "MAX_MESH_FACES", 199)
    monkeypatch.setattr(L, "MAX_SCENE_MESH_FACES", 300)
    world = sim.world
    H["TransferFile"](sim, ["grid.obj", grid_obj(11)])
    H["TransferFile"](sim, ["one.xml", scene(1)])
    H["TransferFile"](sim, ["two.xml", scene(2)])
    with pytest.raises(RemoteError, match=r"mesh 'm0'.*200 mesh faces, more than MAX_MESH_FACES = 199"):
        H["LoadScene"](sim, ["one.xml", 1])
    with pytest.raises(RemoteError, match="mesh faces"):
        H["LoadModel"](sim, ["one.xml", 1])
    monkeypatch.setattr(L, "MAX_MESH_FACES", 200)
    with pytest.raises(RemoteError, match=r"400 mesh faces in all, more than MAX_SCENE_MESH_FACES = 300"):
        H["LoadScene"](sim, ["two.xml", 1])
    assert sim.world is world  # nothing replaced
    H["LoadScene"](sim, ["one.xml", 1])
    assert sim.world is not world


def test_a_clients_mjcf_is_compiled_off_the_simulation_thread(sim, monkeypatch):
    """With a loop (``sim.post``) a client's MJCF scene and model loads answer a Deferred: the
    parse and compile run on the conversions' thread, and the simulation thread only swaps in
    the scene (or attaches the model) when the job it is handed runs."""
    jobs: queue.SimpleQueue = queue.SimpleQueue()
    sim.post = jobs.put
    threads = []
    editor = type(sim.editor)
    for name in ("prepare_scene", "prepare_model"):
        real = getattr(editor, name)

        def spy(self, *args, _real=real, **kwargs):
            threads.append(threading.current_thread())
            return _real(self, *args, **kwargs)

        monkeypatch.setattr(editor, name, spy)
    for name, data in (("grid.obj", grid_obj(30)), ("one.xml", scene(1))):
        H["TransferFile"](sim, [name, data]).future.result(timeout=30)  # written off this thread
    world = sim.world
    deferred = H["LoadScene"](sim, ["one.xml", 1])
    assert type(deferred) is Deferred and sim.world is world  # not loaded yet
    jobs.get(timeout=60)()  # the simulation thread's part
    assert deferred.future.result(timeout=0) is None and sim.world is not world
    model = H["LoadModel"](sim, ["one.xml", 1])
    assert type(model) is Deferred
    jobs.get(timeout=60)()
    assert type(model.future.result(timeout=0)) is int
    assert len(threads) == 2 and threading.main_thread() not in threads
    # an operator's own MJCF (options 0) is loaded at once, as before
    assert H["LoadScene"](sim, [str(SCENE), 0]) is None


def test_models_loaded_again_and_again_stop_at_the_scenes_mesh_bounds_before_compiling(sim, monkeypatch):
    """Each model in bounds, the scene they grew was not: a client loading a 396,000-face model
    five times took a server from 542 to 1,961 MB and a compile of the scene on the simulation
    thread to 5 s. Scaled down: 200 faces a model, 500 more in the scene; the third load is refused
    by the scene's count, when the model is prepared (before its compile and the attach's), and
    an edit that adds meshes otherwise is checked at the attach."""
    start = sim.world.model.nmeshface  # the UR5 scene's own
    monkeypatch.setattr(L, "MAX_MESH_FACES", 200)
    monkeypatch.setattr(L, "MAX_SCENE_MESH_FACES", start + 500)
    H["TransferFile"](sim, ["grid.obj", grid_obj(11)])
    H["TransferFile"](sim, ["one.xml", scene(1)])
    for _ in range(2):
        H["LoadModel"](sim, ["one.xml", 1])
    assert sim.world.model.nmeshface == start + 400
    with pytest.raises(RemoteError, match=rf"model 'one.xml': the scene with it would hold {start + 600:,} mesh "
                                          rf"faces, more than MAX_SCENE_MESH_FACES = {start + 500:,}"):
        H["LoadModel"](sim, ["one.xml", 1])
    editor = sim.editor
    prepared = editor.prepare_model(editor.resolve("one.xml", 1), "'one.xml'", None, warm=False)  # no scene count
    with editor.files.acting("a-client"), pytest.raises(
            RemoteError, match=r"edit refused: the scene would hold .* MAX_SCENE_MESH_FACES"):
        editor._attach_model(prepared)
    assert sim.world.model.nmeshface == start + 400


def test_the_operators_own_models_are_not_held_to_the_clients_scene_bounds(monkeypatch, tmp_path):
    """The scene bounds stop clients (a client's file, or a load a client asks for); the operator's
    own loads of its server-side files (in process: PyRep's import_model, RLBench's task models of
    400,000 faces and more; its scene scripts) are not bounded by them, as before those bounds."""
    (tmp_path / "grid.obj").write_bytes(grid_obj(11))
    (tmp_path / "one.xml").write_bytes(scene(1))
    s = Simulation(SCENE, dt=0.05, realtime=False, renderers_at_load=False, scene_paths=[tmp_path])
    try:
        start = s.world.model.nmeshface
        monkeypatch.setattr(L, "MAX_SCENE_MESH_FACES", start + 300)
        monkeypatch.setattr(L, "MAX_SCENE_BODIES", len(s.world.model.body_pos))
        for _ in range(3):
            H["LoadModel"](s, [str(tmp_path / "one.xml"), 0])
        assert s.world.model.nmeshface == start + 600
        with s.editor.files.acting("a-client"), pytest.raises(RemoteError, match="MAX_SCENE_MESH_FACES"):
            H["LoadModel"](s, [str(tmp_path / "one.xml"), 0])  # the same file, asked for by a client
        assert s.world.model.nmeshface == start + 600
    finally:
        s.close()
