"""Exact mesh queries bounded (issue 84, item 1): two nested 200,000-triangle spheres held the
simulation thread 15.4 s in one ``sim.checkCollision`` (coal holds the interpreter for a whole
call), their trees were built on that thread for every new model, and kept once per model.
Scaled down here: spheres of some 2,000 triangles, pieces of 64 and a bound of no time, set
through ``mesh_geometry``'s constants; what is asserted is the calls made and refused, where
trees are built and how many are kept, never a time."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from simx_server.scene.simulation import Simulation
from simx_server.sim import collisions, mesh_geometry
from simx_server.sim.mesh_geometry import TreesPending, Work
from simx_wire.protocol import ArgumentError


def sphere(faces: int, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """A UV sphere of about ``faces`` triangles, outward."""
    rings = int(np.sqrt(faces / 4))
    around = 2 * rings
    theta = np.linspace(0, np.pi, rings + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, around, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    v = np.column_stack([np.sin(t).ravel() * np.cos(p).ravel(), np.sin(t).ravel() * np.sin(p).ravel(),
                         np.cos(t).ravel()])
    v = np.vstack([v, [[0, 0, 1], [0, 0, -1]]]) * radius
    top, bottom = len(v) - 2, len(v) - 1
    at = lambda i, j: i * around + j % around  # noqa: E731
    f = [[top, at(0, j), at(0, j + 1)] for j in range(around)]
    f += [[bottom, at(rings - 2, j + 1), at(rings - 2, j)] for j in range(around)]
    for i in range(rings - 2):
        for j in range(around):
            f += [[at(i, j), at(i + 1, j), at(i, j + 1)], [at(i, j + 1), at(i + 1, j), at(i + 1, j + 1)]]
    return v, np.array(f)


def nested_scene(gap: float = 0.002) -> str:
    """Two spheres of radius 0.5 and 0.5 - ``gap``, one inside the other: a near miss (the inner one
    free, for a planner to move)."""
    def mesh(name, radius):
        v, f = sphere(2000, radius)
        return (f'<mesh name="{name}" vertex="{" ".join(f"{x:.6f}" for x in v.ravel())}" '
                f'face="{" ".join(map(str, f.ravel()))}"/>')
    return f"""<mujoco model="nested">
  <asset>{mesh("outer", 0.5)}{mesh("inner", 0.5 - gap)}</asset>
  <worldbody>
    <body name="Outer" pos="0 0 1"><geom type="mesh" mesh="outer" contype="0" conaffinity="0"/></body>
    <body name="Inner" pos="0 0 1"><freejoint/><geom type="mesh" mesh="inner" contype="0" conaffinity="0"/></body>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def trees(monkeypatch):
    """A store of trees of this test's own, pieces of 64 triangles; the trees made, counted."""
    monkeypatch.setattr(mesh_geometry, "TREES", mesh_geometry._Trees())
    monkeypatch.setattr(mesh_geometry, "PIECE_FACES", 64)
    made: list[str] = []
    tree_init = mesh_geometry.Tree.__init__

    def counted(self, vertices, faces):
        made.append(threading.current_thread().name)
        tree_init(self, vertices, faces)

    monkeypatch.setattr(mesh_geometry.Tree, "__init__", counted)
    return made


@pytest.fixture
def sim(tmp_path, trees):
    (tmp_path / "nested.xml").write_text(nested_scene())
    simulation = Simulation(tmp_path / "nested.xml")
    yield simulation
    simulation.close()


def _shapes(sim) -> tuple[int, int]:
    return sim.world.resolve("Outer").handle, sim.world.resolve("Inner").handle


def test_a_client_query_stops_at_its_bound_before_its_next_call_to_coal(sim, monkeypatch):
    outer, inner = _shapes(sim)
    assert collisions.collision(sim, outer, inner) is False  # the operator's query: answered, unbounded
    assert collisions.distance(sim, outer, inner) == pytest.approx(0.002, abs=2e-4)
    # a client's, within its bound (the pieces' worst cases multiplied would pass any small bound):
    assert collisions.collision(sim, outer, inner, work=Work.client()) is False
    calls: list[int] = []
    collide, distance = mesh_geometry.coal.collide, mesh_geometry.coal.distance
    monkeypatch.setattr(mesh_geometry.coal, "collide", lambda *a: calls.append(1) or collide(*a))
    monkeypatch.setattr(mesh_geometry.coal, "distance", lambda *a: calls.append(1) or distance(*a))
    monkeypatch.setattr(mesh_geometry, "MAX_QUERY_SECONDS", 0.0)  # spent by the first call
    with pytest.raises(ArgumentError, match="MAX_QUERY_SECONDS"):
        collisions.collision(sim, outer, inner, work=Work.client())
    assert calls == [1]  # no call once the bound is passed
    with pytest.raises(ArgumentError, match="MAX_QUERY_SECONDS"):
        collisions.distance(sim, outer, inner, work=Work.client())
    assert calls == [1, 1]


def test_each_call_to_coal_takes_one_piece_of_each_mesh(sim, monkeypatch):
    """The interpreter is let go between calls: none tests more than the pieces' triangles."""
    outer, inner = _shapes(sim)
    sizes: list[int] = []
    distance = mesh_geometry.coal.distance

    def counted(s1, t1, s2, t2, request, result):
        sizes.append(max(s1.num_tris, s2.num_tris))
        return distance(s1, t1, s2, t2, request, result)

    monkeypatch.setattr(mesh_geometry.coal, "distance", counted)
    collisions.distance(sim, outer, inner)
    assert len(sizes) > 1 and max(sizes) <= 64


def test_a_mesh_tree_is_built_once_for_every_model_of_it(sim, trees):
    outer, inner = _shapes(sim)
    collisions.distance(sim, outer, inner)
    assert len(trees) == 2  # one per mesh
    sim.editor.create_dummy(0.01, None)  # an edit: a new model, the same meshes
    collisions.distance(sim, outer, inner)
    assert len(trees) == 2


def test_the_trees_kept_are_bounded(sim, trees, monkeypatch):
    outer, inner = _shapes(sim)
    collisions.distance(sim, outer, inner)
    one = mesh_geometry.TREES.held() // 2
    monkeypatch.setattr(mesh_geometry, "MAX_TREE_BYTES", one + one // 2)  # room for one of the two
    sim.editor.create_dummy(0.01, None)
    mesh_geometry.TREES.put(b"another", mesh_geometry.Tree(*sphere(300, 0.1)))
    assert mesh_geometry.TREES.held() <= one + one // 2 + mesh_geometry.TREES.get(b"another").bytes


def test_a_deferring_query_never_builds_a_tree_on_its_thread(sim, trees):
    outer, inner = _shapes(sim)
    with pytest.raises(TreesPending) as pending:
        collisions.collision(sim, outer, inner, work=Work.client(defer=True))
    assert "server busy" in str(pending.value)
    pending.value.future.result(timeout=60)
    while True:  # the first tree built: the query may meet the second
        try:
            assert collisions.collision(sim, outer, inner, work=Work.client(defer=True)) is False
            break
        except TreesPending as more:
            more.future.result(timeout=60)
    assert trees == ["simx-mesh-trees"] * 2  # both on the builders' thread
