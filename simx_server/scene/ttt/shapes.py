"""Shapes of a ``.ttt``/``.ttm`` file: the shared mesh pool (``VIN``), mesh and compound
records (``Ge2`` -> ``Gst``/``Gsg`` -> ``Geo``/``Wrp``), mass, inertia and dynamic flags."""

from __future__ import annotations

import struct

import numpy as np

from simx_server.scene.ttt import errors as E
from simx_server.scene.ttt.geometry import compose, mat_to_quat, pose7, projected_uv
from simx_server.scene.ttt.looks import Look, read_colour
from simx_server.scene.ttt.model import Mesh, Pose, ShapeData
from simx_server.scene.ttt.records import Records, packed_count, unpack_indices


class MeshPool:
    """The deduplicated arrays shapes point into (``VIN``): vertices, indices (normals are
    recomputed by MuJoCo, so they are not kept). Each array is decoded once, when a shape first
    points at it, and every shape that points at it gets the same numpy array (never a copy),
    as CoppeliaSim shares them (``CMeshManip``/``CMesh::serialize`` with its ``Vev``/``Inv``
    references into the scene's ``VIN`` pool). Keeps the file's totals of decoded vertices and
    triangles (``MAX_SCENE_VERTICES``, ``MAX_SCENE_TRIANGLES``), counted before decoding."""

    def __init__(self):
        self.vertices: list[tuple[Records, memoryview]] = []
        self.indices: list[tuple[Records, str, memoryview]] = []
        self._vertex_arrays: dict[int, np.ndarray] = {}
        self._faces: dict[int, np.ndarray] = {}
        self._checked: set[tuple[int, int]] = set()  # (vertex, index) pairs whose indices are in range
        self.total_vertices = 0
        self.total_triangles = 0

    def read(self, r: Records) -> None:
        """Take the pool's arrays from its record list (not decoded yet)."""
        for tag, payload in r:
            if tag == "Ver":
                self.vertices.append((r, payload))
            elif tag in ("Ind", "In2"):
                self.indices.append((r, tag, payload))

    def count(self, where: Records, tag: str, vertices: int = 0, triangles: int = 0) -> None:
        """Add to the file's totals before decoding; raises SceneFileError past a bound."""
        self.total_vertices += vertices
        self.total_triangles += triangles
        if self.total_vertices > E.MAX_SCENE_VERTICES:
            raise where.error(tag, f"more than MAX_SCENE_VERTICES = {E.MAX_SCENE_VERTICES:,} vertices in the file")
        if self.total_triangles > E.MAX_SCENE_TRIANGLES:
            raise where.error(tag, f"more than MAX_SCENE_TRIANGLES = {E.MAX_SCENE_TRIANGLES:,} triangles in the file")

    def vertex_array(self, index: int, where: Records) -> np.ndarray:
        """Pool vertex array ``index``, (N, 3) float64, m (shared: do not modify)."""
        if not 0 <= index < len(self.vertices):
            raise where.error("Vev", f"vertex array {index} not in the mesh pool ({len(self.vertices)})")
        array = self._vertex_arrays.get(index)
        if array is None:
            r, payload = self.vertices[index]
            array = self._vertex_arrays[index] = vertex_array(r, payload, self)
        return array

    def face_array(self, index: int, where: Records) -> np.ndarray:
        """Pool index array ``index`` as triangles, (M, 3) int64 (shared: do not modify)."""
        if not 0 <= index < len(self.indices):
            raise where.error("Inv", f"index array {index} not in the mesh pool ({len(self.indices)})")
        faces = self._faces.get(index)
        if faces is None:
            r, tag, payload = self.indices[index]
            indices = index_array(r, tag, payload, self)
            faces = self._faces[index] = indices[: len(indices) // 3 * 3].reshape(-1, 3)
        return faces

    def check_once(self, vertex: int, index: int) -> bool:
        """True the first time a (vertex array, index array) pair is asked for."""
        if (vertex, index) in self._checked:
            return False
        self._checked.add((vertex, index))
        return True


def vertex_array(r: Records, payload: memoryview, pool: MeshPool) -> np.ndarray:
    """A ``Ver`` record's vertices, (N, 3) float64; counted in ``pool``'s totals first."""
    n = len(payload) // 12
    if n > E.MAX_MESH_VERTICES:
        raise r.error("Ver", f"{n:,} vertices, more than MAX_MESH_VERTICES = {E.MAX_MESH_VERTICES:,}")
    pool.count(r, "Ver", vertices=n)
    return np.frombuffer(payload[:n * 12], dtype="<f4").reshape(n, 3).astype(np.float64)


def index_array(r: Records, tag: str, payload: memoryview, pool: MeshPool) -> np.ndarray:
    """An ``Ind`` (i32) or ``In2`` (packed) record's indices, int64; counted in ``pool``'s
    totals before decoding."""
    if tag == "In2":
        count = packed_count(payload, r, tag)
        pool.count(r, tag, triangles=count // 3)
        return unpack_indices(payload, r, tag)
    n = len(payload) // 4
    if n > 3 * E.MAX_MESH_TRIANGLES:
        raise r.error(tag, f"{n // 3:,} triangles, more than MAX_MESH_TRIANGLES = {E.MAX_MESH_TRIANGLES:,}")
    pool.count(r, tag, triangles=n // 3)
    return np.frombuffer(payload[:n * 4], dtype="<i4").astype(np.int64)


def _values(r: Records, tag: str, count: int) -> np.ndarray | None:
    """``count`` floats or doubles (told apart by the record's size)."""
    payload = r.get(tag)
    if payload is None:
        return None
    if len(payload) >= 8 * count:
        return np.frombuffer(payload[:8 * count], "<f8").astype(np.float64)
    if len(payload) >= 4 * count:
        return np.frombuffer(payload[:4 * count], "<f4").astype(np.float64)
    raise r.error(tag, f"{len(payload)} bytes, expected {count} numbers")


def read_shape(typed: Records, pool: MeshPool) -> ShapeData:
    """A shape's type part (``SHP`` after ``NXT``)."""
    ge2 = typed.sub("Ge2")
    top_tag = "Gst" if ge2.get("Gst") is not None else "Gsg"
    top = ge2.sub(top_tag)  # a mesh's (Gst) or compound's (Gsg) wrapper list: name, mass, inertia
    meshes: list[Mesh] = []
    if top_tag == "Gst":
        meshes.append(_mesh(ge2, ge2.get("Gst"), pool))
    else:
        _collect(top, pool, meshes)
    shape = ShapeData(meshes=meshes, compound=top_tag == "Gsg")
    mass = top.floats("_as", "Mas", 1)
    if mass is not None and np.isfinite(mass[0]) and mass[0] > 0:
        shape.mass = float(mass[0])
    ine = top.floats("_ne", "Ine", 10)
    imx = _values(top, "Imx", 9)
    if ine is not None:
        shape.inertia_frame = pose7(ine[:7], quat_first=False)
        shape.inertia = np.abs(ine[7:10]) * shape.mass
    elif imx is not None:
        com = _values(top, "Com", 3)
        frame = _values(top, "Ifr", 7)
        base = pose7(frame, quat_first=False) if frame is not None else Pose()
        m = imx.reshape(3, 3)
        m = 0.5 * (m + m.T)
        moments, axes = np.linalg.eigh(m)
        if np.linalg.det(axes) < 0:
            axes[:, 0] = -axes[:, 0]
        local = Pose(com if com is not None else np.zeros(3), mat_to_quat(axes))
        shape.inertia_frame = compose(base, local)
        shape.inertia = np.abs(moments) * shape.mass
    if not np.all(np.isfinite(shape.inertia)):
        shape.inertia = np.full(3, 1e-3 * shape.mass)
    sss = typed.byte("Sss")
    shape.static = not (sss & 0x80) if typed.get("Sss") is not None else True
    shape.respondable = bool(typed.byte("Ss3") & 1)
    mask = typed.ints("Dc2", 1, "<u2")
    if mask is not None:
        shape.respondable_mask = int(mask[0])
    shape.bullet_friction = _friction(typed)
    shape.friction = shape.bullet_friction[0] if shape.bullet_friction[0] is not None else shape.bullet_friction[1]
    return shape


def _friction(typed: Records) -> tuple[float | None, float | None]:
    """Bullet's friction coefficients of the shape's material (``Mat``): ``(2.78's, 2.83's)``.

    CoppeliaSim keeps two Bullet coefficients per material (coppeliaSimLib
    ``CDynMaterialObject``: ``simi_bullet_body_oldfriction``, the second float of ``_uN``/``BuN``
    and of the older ``Bul``, and ``simi_bullet_body_friction``, the third float of ``_uN``/
    ``BuN``). Bullet 2.78, V-REP's and CoppeliaSim 4.1's default engine, is given the first
    (``_simGetFriction_internal`` returns ``sim_bullet_body_oldfriction``; simDyn's Bullet 2.78
    ``CRigidBodyDyn`` calls it), Bullet 2.83 the second. A file with only ``Bul`` (before
    2016) has one: CoppeliaSim copies it into the second on load. A value that is not a
    number in [0, 100] is left out (None)."""
    mat = typed.sub("Mat")
    old = new = None
    for tag, dtype in (("_uN", "<f8"), ("BuN", "<f4")):
        payload = mat.get(tag)
        if payload is None or len(payload) < 8:
            continue
        nf, _ = struct.unpack_from("<ii", payload, 0)
        size = np.dtype(dtype).itemsize
        if nf >= 3 and len(payload) >= 8 + 3 * size:
            values = np.frombuffer(payload[8:8 + 3 * size], dtype)
            old, new = _coefficient(values[1]), _coefficient(values[2])
            break
    if old is None and new is None:
        payload = mat.get("Bul")  # restitution, old friction, damping... (f32)
        if payload is not None and len(payload) >= 8:
            old = new = _coefficient(np.frombuffer(payload[4:8], "<f4")[0])
    return old, new


def _coefficient(value: float) -> float | None:
    value = float(value)
    return value if np.isfinite(value) and 0 <= value <= 100 else None


def _collect(wrapper: Records, pool: MeshPool, out: list[Mesh]) -> None:
    """The meshes under a compound's wrapper list (``Gsg``/``Wrp``: ``Geo`` meshes and nested
    ``Wrp`` wrappers; nesting is bounded by the record reader)."""
    for t, payload in wrapper:
        if t == "Geo":
            out.append(_mesh(wrapper, payload, pool))
        elif t == "Wrp":
            _collect(wrapper.sub(t, payload), pool, out)


def _mesh(parent: Records, payload: memoryview, pool: MeshPool) -> Mesh:
    info = parent.sub("Geo", payload)
    r = parent.sub("Geo", payload, start=info.end)
    name = info.string("Nme")
    vev = inv = -1  # pool arrays (shared by every shape that points at them)
    if r.get("Vev") is not None:
        vev = r.int("Vev")
        vertices = pool.vertex_array(vev, r)
    elif r.get("Ver") is not None:
        vertices = vertex_array(r, r.get("Ver"), pool)
    else:
        vertices = np.zeros((0, 3))
    if r.get("Inv") is not None:
        inv = r.int("Inv")
        faces = pool.face_array(inv, r)
    elif r.get("Ind") is not None or r.get("In2") is not None:
        tag = "Ind" if r.get("Ind") is not None else "In2"
        indices = index_array(r, tag, r.get(tag), pool)
        faces = indices[: len(indices) // 3 * 3].reshape(-1, 3)
    else:
        faces = np.zeros((0, 3), np.int64)
    if faces.size and (vev < 0 or inv < 0 or pool.check_once(vev, inv)) and (
            faces.min() < 0 or faces.max() >= len(vertices)):
        raise r.error("Inv", f"mesh {name!r}: an index outside its {len(vertices):,} vertices")
    primitive, sizes = 0, np.zeros(3)
    for tag, fmt in (("_pr", "<iddd"), ("Ppr", "<ifff")):
        p = r.get(tag)
        if p is not None and len(p) >= struct.calcsize(fmt):
            vals = struct.unpack_from(fmt, p, 0)
            primitive, sizes = int(vals[0]), np.array(vals[1:4], dtype=np.float64)
            break
    frame = pose7(r.floats("_pf", "Ppf", 7), quat_first=False)
    look = read_colour(r.sub("Cl0")) or Look()
    color = np.array(look.diffuse)
    texture, uv, texture_mode, texture_map = -1, None, 0, None
    if r.get("Toj") is not None:
        toj = r.sub("Toj")
        mapping = None
        for tag, fmt in (("_ob", "<iidd"), ("Tob", "<iiff")):
            p = toj.get(tag)
            if p is not None and len(p) >= struct.calcsize(fmt):
                tid, mode, sx, sy = struct.unpack_from(fmt, p, 0)
                texture, mapping = int(tid), (int(mode), (float(sx), float(sy)))
                break
        else:
            tob = toj.ints("Tob", 1)
            if tob is not None:
                texture = int(tob[0])
        texture_mode = toj.int("Apm") if toj.get("Apm") is not None else (toj.byte("Bst") >> 1) & 1
        ftc = toj.get("Ftc")
        if ftc is not None and len(ftc) >= 8:
            uv = np.frombuffer(ftc[: len(ftc) // 8 * 8], "<f4").reshape(-1, 2).astype(np.float64)
        elif mapping is not None:  # coordinates V-REP computes from the texture's mapping
            texture_frame = pose7(toj.floats("_rc", "Trc", 7), quat_first=True)
            uv = projected_uv(vertices, faces, frame, texture_frame, *mapping)
            if uv is not None:
                texture_map = (mapping[0], mapping[1], texture_frame)
    convex = bool(r.byte("Va2") & 1) or bool(info.byte("Var") & 4)
    wireframe = bool(r.byte("Var") & 4)
    return Mesh(name, vertices, faces, frame, primitive, sizes, color, texture, uv, convex, wireframe, look, texture_mode,
                texture_map)
