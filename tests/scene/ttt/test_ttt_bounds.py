"""Issue 40's hostile scene files, read in-process: every bound is checked before the work it
bounds, shared pool arrays are decoded once and shared, the tree walks are linear and
iterative, packed indices are decoded with numpy. Synthetic files (tttwriter), bounds lowered
with monkeypatch where a file at the real bound would be large."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from simx_server.scene.ttt import convert, reader
from simx_server.scene.ttt import errors as E
from simx_server.scene.ttt.errors import SceneFileError
from simx_server.scene.ttt.records import Records, unpack_indices

try:
    from . import tttwriter as W
except ImportError:
    import tttwriter as W

_CUBE_V = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) * 0.1
_CUBE_F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                    [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])


def _write(tmp_path, body: bytes, name: str = "x.ttt") -> object:
    f = tmp_path / name
    f.write_bytes(W.ttt_file(body, compress=False))
    return f


def test_shapes_that_share_a_pool_array_share_it_decoded_and_written_once(tmp_path):
    body = W.mesh_pool(_CUBE_V, _CUBE_F.ravel()) + b"".join(
        W.pool_shape(k + 1, -1, f"S{k}", pos=(0.2 * k, 0, 0)) for k in range(50))
    scene = reader.read(_write(tmp_path, body))
    meshes = [o.data.meshes[0] for o in scene.objects.values()]
    assert len(meshes) == 50
    assert all(m.vertices is meshes[0].vertices and m.faces is meshes[0].faces for m in meshes)
    xml, _ = convert.convert(scene, tmp_path / "out", "scene")
    assert len(list((tmp_path / "out" / "meshes").iterdir())) == 1  # one mesh asset, 50 geoms
    assert xml.read_text().count('mesh="ttt_mesh1"') == 50


def test_the_files_vertex_total_is_checked_before_decoding(tmp_path, monkeypatch):
    monkeypatch.setattr(E, "MAX_SCENE_VERTICES", 20)
    body = b"".join(W.cuboid_shape(k + 1, -1, f"C{k}") for k in range(3))  # 8 vertices each
    with pytest.raises(SceneFileError, match="MAX_SCENE_VERTICES = 20"):
        reader.read(_write(tmp_path, body))


def test_a_shared_pool_counts_once_in_the_files_totals(tmp_path, monkeypatch):
    monkeypatch.setattr(E, "MAX_SCENE_VERTICES", 10)
    body = W.mesh_pool(_CUBE_V, _CUBE_F.ravel()) + b"".join(W.pool_shape(k + 1, -1, f"S{k}") for k in range(20))
    assert len(reader.read(_write(tmp_path, body)).objects) == 20


def test_packed_indices_decode_across_chunks_as_written():
    rng = np.random.default_rng(7)
    where = Records(b"EOO", "x.ttt")
    for size in (1, 3, 1000, 70_000):  # 70,000 values: several walker chunks, every value length
        values = np.cumsum(rng.integers(-3_000_000, 3_000_000, size) * (rng.random(size) < 0.3)) + 5
        assert unpack_indices(memoryview(W.packed(values)), where, "In2").tolist() == values.tolist()
    two_byte = struct.pack("<i", 4096) + b"\x40\x20" * 4096  # every value 2 bytes: half the walkers start mid-value
    assert unpack_indices(memoryview(two_byte), where, "In2").tolist() == np.cumsum([(0x20 << 6) - 8191] * 4096).tolist()


def test_packed_indices_past_their_bound_are_refused_before_decoding(tmp_path, monkeypatch):
    monkeypatch.setattr(E, "MAX_MESH_TRIANGLES", 100)
    where = Records(b"EOO", "x.ttt")
    with pytest.raises(SceneFileError, match="3 x MAX_MESH_TRIANGLES = 300"):
        unpack_indices(memoryview(W.packed([0] * 301)), where, "In2")
    short = struct.pack("<i", 4) + W.packed([0, 100_000])[4:]  # 4 bytes hold 2 values, not the 4 declared
    with pytest.raises(SceneFileError, match="end after 2 of 4"):
        unpack_indices(memoryview(short), where, "In2")


def test_the_files_triangle_total_bounds_packed_arrays_of_several_shapes(tmp_path, monkeypatch):
    monkeypatch.setattr(E, "MAX_SCENE_TRIANGLES", 2000)
    body = W.mesh_pool(_CUBE_V, W.packed([0, 1, 2] * 900))  # 900 triangles, in the pool once
    body += W.mesh_pool(_CUBE_V, W.packed([0, 1, 2] * 900)) + W.mesh_pool(_CUBE_V, W.packed([0, 1, 2] * 900))
    body += b"".join(W.pool_shape(k + 1, -1, f"S{k}", k, k) for k in range(3))
    with pytest.raises(SceneFileError, match="MAX_SCENE_TRIANGLES = 2,000"):
        reader.read(_write(tmp_path, body))


def test_script_text_is_bounded_before_it_is_decoded(tmp_path, monkeypatch):
    monkeypatch.setattr(E, "MAX_STRING_BYTES", 1000)
    body = W.dummy(1, -1, "D") + W.script(100, 1, "-- " + "x" * 2000)
    with pytest.raises(SceneFileError, match=r"record LST/Ste: script text of 2,003 bytes, more than MAX_STRING_BYTES"):
        reader.read(_write(tmp_path, body))
    monkeypatch.setattr(E, "MAX_SCRIPT_BYTES", 1500)
    body = W.dummy(1, -1, "D") + W.script(100, 1, "-- " + "x" * 900) + W.script(101, 1, "-- " + "y" * 900)
    with pytest.raises(SceneFileError, match="MAX_SCRIPT_BYTES = 1,500"):
        reader.read(_write(tmp_path, body))


def test_a_parent_cycle_of_20000_objects_hangs_them_from_the_world(tmp_path):
    n = 20_000
    body = b"".join(W.dummy(k, k % n + 1, f"D{k}") for k in range(1, n + 1))  # k's parent is k + 1, n's is 1
    scene = reader.read(_write(tmp_path, body))
    assert len(scene.roots) == n and all(o.parent == -1 and not o.children for o in scene.objects.values())


def test_a_cycle_with_a_subtree_and_a_sound_tree_beside_it(tmp_path):
    body = (W.dummy(1, 2, "A") + W.dummy(2, 1, "B") + W.dummy(3, 1, "UnderA")
            + W.dummy(4, -1, "Root") + W.dummy(5, 4, "Child"))
    scene = reader.read(_write(tmp_path, body))
    by = {o.name: o for o in scene.objects.values()}
    assert by["Child"].parent == 4 and by["Root"].children == [by["Child"]]
    assert {o.name for o in scene.roots} == {"A", "B", "UnderA", "Root"}


def test_a_5000_deep_chain_is_refused_by_its_bound_not_by_recursion(tmp_path):
    body = W.dummy(1, -1, "D1") + b"".join(W.dummy(k, k - 1, f"D{k}") for k in range(2, 5001))
    with pytest.raises(SceneFileError, match="more than MAX_TREE_DEPTH = 200"):
        reader.read(_write(tmp_path, body))


def test_a_chain_at_the_depth_bound_converts_and_compiles(tmp_path):
    body = W.dummy(1, -1, "D1") + b"".join(
        W.cuboid_shape(k, k - 1, f"S{k}", dynamic=False) for k in range(2, E.MAX_TREE_DEPTH + 1))
    scene = reader.read(_write(tmp_path, body))
    xml, _ = convert.convert(scene, tmp_path / "out", "scene")
    import mujoco

    assert mujoco.MjModel.from_xml_path(str(xml)).nbody == E.MAX_TREE_DEPTH  # world + 199 shapes


def test_too_many_objects_are_refused_as_they_are_read(tmp_path, monkeypatch):
    monkeypatch.setattr(E, "MAX_OBJECTS", 100)
    body = b"".join(W.dummy(k, -1, f"D{k}") for k in range(1, 102))
    with pytest.raises(SceneFileError, match="more than MAX_OBJECTS = 100 objects"):
        reader.read(_write(tmp_path, body))


def test_a_texture_past_its_pixel_bound_is_refused_before_it_is_used(tmp_path, monkeypatch):
    monkeypatch.setattr(E, "MAX_TEXTURE_PIXELS", 100)
    body = W.dummy(1, -1, "D") + W.texture(7, "big", np.zeros((20, 20, 3), np.uint8))
    with pytest.raises(SceneFileError, match=r"TEX/Ipa: texture of 20 x 20 pixels, more than MAX_TEXTURE_PIXELS = 100"):
        reader.read(_write(tmp_path, body))
    monkeypatch.setattr(E, "MAX_TEXTURE_PIXELS", 1000)
    monkeypatch.setattr(E, "MAX_SCENE_TEXTURE_PIXELS", 1000)
    body += W.texture(8, "again", np.zeros((20, 20, 3), np.uint8)) + W.texture(9, "more", np.zeros((20, 20, 3), np.uint8))
    with pytest.raises(SceneFileError, match="MAX_SCENE_TEXTURE_PIXELS = 1,000"):
        reader.read(_write(tmp_path, body))
