"""Mesh operations of the API table added for ``pyrep`` (issue 51), as any caller uses them:
``sim.getDecimatedMesh``, ``sim.convexDecompose``, ``sim.applyTexture``, ``sim.createShape`` of
one triangle, ``sim.alignShapeBB``."""

from __future__ import annotations

import numpy as np
import pytest

from simx_server.api import client_context
from simx_server.scene.simulation import Simulation
from simx_wire.protocol import ArgumentError, UnsupportedError


def l_prism() -> tuple[np.ndarray, np.ndarray]:
    """An L-shaped prism (concave), 0.2 x 0.2 x 0.05 m: its outline extruded along z."""
    outline = np.array([[0, 0], [0.2, 0], [0.2, 0.05], [0.05, 0.05], [0.05, 0.2], [0, 0.2]])
    n = len(outline)
    v = np.vstack([np.column_stack([outline, np.zeros(n)]), np.column_stack([outline, np.full(n, 0.05)])])
    bottom = [[0, 2, 1], [0, 3, 2], [0, 5, 3], [3, 5, 4]]
    top = [[a + n, c + n, b + n] for a, b, c in bottom]
    sides = [f for i in range(n) for f in ([i, (i + 1) % n, (i + 1) % n + n], [i, (i + 1) % n + n, i + n])]
    return v, np.array(bottom + top + sides)


def grid(k: int) -> tuple[np.ndarray, np.ndarray]:
    """A flat k x k grid of 1 m, 2 (k-1)^2 triangles."""
    x, y = np.meshgrid(np.linspace(0, 1, k), np.linspace(0, 1, k))
    v = np.column_stack([x.ravel(), y.ravel(), 0.01 * np.sin(3 * x.ravel())])
    f = [[i * k + j, i * k + j + 1, (i + 1) * k + j] for i in range(k - 1) for j in range(k - 1)]
    f += [[i * k + j + 1, (i + 1) * k + j + 1, (i + 1) * k + j] for i in range(k - 1) for j in range(k - 1)]
    return v, np.array(f)


def scene() -> str:
    v, f = l_prism()
    return f"""<mujoco model="mesh_ops">
  <asset><mesh name="ell" vertex="{' '.join(map(str, v.ravel()))}" face="{' '.join(map(str, f.ravel()))}"/></asset>
  <worldbody>
    <body name="ell" pos="0.3 0.2 0.5" euler="0 0 0.3"><freejoint/><geom type="mesh" mesh="ell" rgba="0.2 0.4 0.6 1"/></body>
    <body name="ball" pos="0 0 1"><geom type="sphere" size="0.05"/></body>
  </worldbody>
</mujoco>
"""


@pytest.fixture
def sim(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(scene())
    simulation = Simulation(path)
    yield simulation, client_context(simulation, "test").sim
    simulation.close()


def test_decimated_mesh_keeps_the_fraction_asked(sim):
    _, api = sim
    v, f = grid(21)  # 800 triangles
    out_v, out_i = api.getDecimatedMesh(v.ravel().tolist(), f.ravel().tolist(), 0.25)
    assert 0 < len(out_i) // 3 <= 0.3 * len(f)
    out = np.array(out_v).reshape(-1, 3)
    assert out.min(0) == pytest.approx(v.min(0), abs=0.05) and out.max(0) == pytest.approx(v.max(0), abs=0.05)
    with pytest.raises(ArgumentError, match="fraction"):
        api.getDecimatedMesh(v.ravel().tolist(), f.ravel().tolist(), 1.5)
    with pytest.raises(ArgumentError, match="indices"):
        api.getDecimatedMesh(v.ravel().tolist(), [0, 1, 999], 0.5)


def test_convex_decomposition_new_shape_and_morph(sim):
    simulation, api = sim
    ell = api.getObject("/ell")
    mass = api.getShapeMass(ell)
    pose = api.getObjectPose(ell, -1)
    new = api.convexDecompose(ell, 128, [1, 500, 200, 4, 0, 10000, 20, 4, 4, 64], [100, 30, 0.25] + [0] * 7)
    assert new != ell and api.getObjectType(new) == api.object_shape_type
    assert api.getObjectPose(new, -1) == pytest.approx(pose, abs=1e-6)  # at the shape's pose
    assert api.getObjectInt32Param(new, api.shapeintparam_static) == 1  # CShape's defaults
    assert api.getObjectInt32Param(new, api.shapeintparam_respondable) == 0
    m = simulation.world.model
    hulls = np.flatnonzero(m.geom_bodyid == simulation.world.objects[new].mj_id)
    assert len(hulls) >= 2  # an L is not convex
    verts = np.array(api.getShapeMesh(new)[0]).reshape(-1, 3)
    assert verts.min(0) == pytest.approx([0, 0, 0], abs=0.02) and verts.max(0) == pytest.approx([0.2, 0.2, 0.05], abs=0.02)
    same = api.convexDecompose(ell, 1 | 4, [], [])  # morph, the last call's parameters
    assert same == ell and api.getShapeMass(ell) == pytest.approx(mass)
    assert len(np.flatnonzero(simulation.world.model.geom_bodyid == simulation.world.objects[ell].mj_id)) >= 2


def test_apply_texture_round_trip_and_flips(sim):
    simulation, api = sim
    ell = api.getObject("/ell")
    _, idx, _ = api.getShapeMesh(ell)
    uv = np.random.default_rng(1).random(2 * len(idx))
    image = np.arange(4 * 2 * 3, dtype=np.uint8).reshape(2, 4, 3)  # 4 x 2 RGB
    tex = api.applyTexture(ell, uv.tolist(), image.tobytes(), [4, 2], 0)
    viz = api.getShapeViz(ell, 0)
    assert viz["texture"]["id"] == tex and viz["texture"]["resolution"] == [4, 2]
    rgba = np.frombuffer(viz["texture"]["texture"], np.uint8).reshape(2, 4, 4)
    assert (rgba[:, :, :3] == image).all() and (rgba[:, :, 3] == 255).all()
    assert np.array(viz["texture"]["coordinates"]) == pytest.approx(uv, abs=1e-6)
    assert api.getShapeColor(ell, None, 0)[1] == pytest.approx([0.2, 0.4, 0.6])
    api.applyTexture(ell, uv.tolist(), np.dstack([image, image[:, :, :1]]).tobytes(), [4, 2], 16 | 32 | 64)
    flipped = np.frombuffer(api.getShapeViz(ell, 0)["texture"]["texture"], np.uint8).reshape(2, 4, 4)
    assert (flipped[:, :, :3] == image[::-1, ::-1]).all()
    with pytest.raises(ArgumentError, match="texture coordinates"):
        api.applyTexture(ell, uv[:-2].tolist(), image.tobytes(), [4, 2], 0)
    with pytest.raises(ArgumentError, match="4x2x3"):
        api.applyTexture(ell, uv.tolist(), image.tobytes()[:-1], [4, 2], 0)
    with pytest.raises(ArgumentError, match="one mesh"):
        api.applyTexture(api.getObject("/ball"), uv.tolist(), image.tobytes(), [4, 2], 0)


def test_create_shape_of_one_triangle(sim):
    simulation, api = sim
    h = api.createShape(0, 0.35, [-0.1, -0.1, 0, -0.1, 0.1, 0, 0.1, 0, 0], [0, 1, 2])
    assert api.getObjectType(h) == api.object_shape_type
    size = api.getShapeBB(h)  # along the mesh's main axes, x the smallest (CoppeliaSim's frame)
    assert size[0] < 1e-3  # the back face 0.1 mm behind
    assert size[1] * size[2] == pytest.approx(0.04, abs=1e-6)  # the triangle's smallest rectangles
    assert api.getShapeMass(h) > 0
    with pytest.raises(ArgumentError, match="line"):
        api.createShape(0, 0.35, [0, 0, 0, 1, 0, 0, 2, 0, 0], [0, 1, 2])


def test_a_created_shapes_mesh_is_a_file_of_mujocos_cache(sim, tmp_path):
    """``sim.createShape``'s mesh is an in-memory ``.msh`` file, not ``uservert`` (issue 84): MuJoCo
    keeps a processed file mesh in its cache, so the recompile of every later edit reuses it, and
    ``sim.saveScene`` writes it as a file next to the scene, which loads back the same mesh."""
    simulation, api = sim
    v, f = grid(11)
    h = api.createShape(0, 0.35, v.ravel().tolist(), f.ravel().tolist())
    name = simulation.world.get(h).name
    spec = simulation.editor._live_spec()
    mesh = spec.mesh(spec.body(name).first_geom().meshname)
    assert mesh.file.endswith(".msh") and mesh.file in spec.assets and len(mesh.uservert) == 0
    api.createDummy(0.01)  # an edit: the mesh comes from the file again
    m = simulation.world.model
    g = int(np.flatnonzero(m.geom_bodyid == simulation.world.get(h).mj_id)[0])
    k = int(m.geom_dataid[g])
    kept = m.mesh_vert[m.mesh_vertadr[k]:m.mesh_vertadr[k] + m.mesh_vertnum[k]].copy()
    api.saveScene(str(tmp_path / "saved.xml"))
    saved = list(tmp_path.glob("saved_*.msh"))
    assert len(saved) == 1 and saved[0].name in (tmp_path / "saved.xml").read_text()
    back = Simulation(tmp_path / "saved.xml")
    try:
        bm = back.world.model
        bg = int(np.flatnonzero(bm.geom_bodyid == back.world.by_name[name].mj_id)[0])
        bk = int(bm.geom_dataid[bg])
        assert bm.mesh_vert[bm.mesh_vertadr[bk]:bm.mesh_vertadr[bk] + bm.mesh_vertnum[bk]] == pytest.approx(kept)
    finally:
        back.close()


def test_align_shape_bb(sim):
    _, api = sim
    ell = api.getObject("/ell")
    before = np.array(api.getShapeMesh(ell)[0]).reshape(-1, 3)
    m0 = np.array(api.getObjectMatrix(ell, -1)).reshape(3, 4)
    world_before = before @ m0[:, :3].T + m0[:, 3]
    assert api.alignShapeBB(ell, [0, 0, 0, 0, 0, 0, 1]) == 1  # the world's axes
    m1 = np.array(api.getObjectMatrix(ell, -1)).reshape(3, 4)
    assert m1[:, :3] == pytest.approx(np.eye(3), abs=1e-9) and m1[:, 3] == pytest.approx(m0[:, 3], abs=1e-9)
    after = np.array(api.getShapeMesh(ell)[0]).reshape(-1, 3) @ m1[:, :3].T + m1[:, 3]
    assert np.sort(after, axis=0) == pytest.approx(np.sort(world_before, axis=0), abs=1e-6)  # nothing moved
    assert api.alignShapeBB(ell, [0] * 7) == 1  # its smallest box: the L's own axes
    size = sorted(api.getShapeBB(ell))
    assert size == pytest.approx([0.05, 0.2, 0.2], abs=1e-6)
    assert api.alignShapeBB(api.getObject("/ball"), [0] * 7) == 0  # a pure shape keeps its box


def test_convex_decompose_without_vhacdx_names_the_package(sim, tmp_path, monkeypatch):
    """V-HACD runs in a worker process (simx_server/base/vhacd_worker.py); where it cannot import
    vhacdx the call says what to install."""
    _, api = sim
    shadow = tmp_path / "shadow" / "vhacdx"
    shadow.mkdir(parents=True)
    (shadow / "__init__.py").write_text("raise ImportError('no vhacdx here')\n")
    monkeypatch.setenv("PYTHONPATH", str(shadow.parent))
    with pytest.raises(UnsupportedError, match="pip install vhacdx"):
        api.convexDecompose(api.getObject("/ell"), 0, [], [])
