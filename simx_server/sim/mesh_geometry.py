"""Exact collision and distance of geoms on their triangle meshes, with coal (FCL's successor).

MuJoCo's narrow phase (``mj_geomDistance``) sees a mesh geom as its convex hull; CoppeliaSim's
``sim.checkCollision`` / ``sim.checkDistance`` (coppeliaSimLib ``CCollisionRoutine``,
``CDistanceRoutine``, on the geometric plugin's OBB trees) test the triangles themselves. Here a
pair with a mesh geom is answered by coal on the mesh's triangles (``mesh_vert`` / ``mesh_face``
as MuJoCo compiled them: scaled, in the geom's frame); the other geom as coal's primitive
(sphere, capsule, cylinder, box, ellipsoid). The poses are MuJoCo's (``geom_xpos`` /
``geom_xmat`` of the data asked about: the live simulation or a planner's scratch copy); physics
stays MuJoCo's.

**A mesh's tree** (:class:`Tree`): the mesh cut into pieces of at most :data:`PIECE_FACES`
triangles that lie together (its triangles split at the median of their centres along the
widest axis, again and again), each piece a bounding volume hierarchy of its own
(``coal.BVHModelOBBRSS``) with coal's own bounding sphere of it (``computeLocalAABB``:
``aabb_center``, ``aabb_radius``). A query first tests the pieces' spheres (numpy), then calls coal
on the pairs of pieces that may touch, nearest first. So that no call holds the interpreter
long: coal holds it for the whole of a call (a single call on two nested 200,000-triangle spheres
took 15 s of the simulation thread, and a planner's check on them held every other thread for
seconds), and one call on two pieces tests at most :data:`PIECE_FACES` squared triangle pairs.

**Built once per mesh**: trees are kept by the mesh's content (its vertices and triangles), not by
model, so that an edit of the scene (a new model, the same meshes) finds them; at most
:data:`MAX_TREE_BYTES` of them (coal's own count, ``memUsage``), the least recently used
dropped beyond. Building one takes time (a 200,000-triangle mesh: 0.85 s of CPU): a client's
query on the simulation thread never builds; it raises :class:`TreesPending` with the future of
the builds, which a thread of their own makes (piece by piece, the interpreter let go between
pieces), and the door answers once they are done (:mod:`simx_server.api.mesh_queries`).

**Each query's work is bounded** (:class:`Work`): one call to coal takes at most two pieces (at
worst :data:`PIECE_FACES` squared pairs of triangles, by construction, before the call), and a
client's query checks, before each call, the CPU time its thread has spent on it since its first
call: past :data:`MAX_QUERY_SECONDS` it stops with an error naming the bound. A bound on the
worst case of the calls (triangles multiplied) refused a robot arm's ordinary check against the
scene (a few pairs of 2,500-triangle links within each other's spheres), which coal answers in
milliseconds; the time a query really takes is what holds the others. The operator's own queries
(scripts, ``pyrep`` in process) are not bounded.

Pairs of two primitives stay with ``mj_geomDistance`` (exact for primitives), and so does a mesh
against a plane: MuJoCo's plane is the half-space below it, and a half-space is nearest to (or
deepest into) a mesh at one of its vertices, which its hull shares, so the hull's answer is the
mesh's (and MuJoCo's is far cheaper than coal's triangle by triangle). A mesh against a height
field or an SDF geom stays with MuJoCo too (coal has no such shape here): that answer is on the
hull.

A mesh is a surface for coal as for CoppeliaSim: a shape wholly inside a closed mesh, touching
none of its triangles, does not collide with it.
"""

from __future__ import annotations

import collections
import hashlib
import queue
import threading
import time
import weakref
from concurrent.futures import Future
from typing import Any

import coal
import mujoco
import numpy as np

from simx_wire.protocol import BUSY, ArgumentError, RemoteError

_MESH = int(mujoco.mjtGeom.mjGEOM_MESH)
_SPHERE = int(mujoco.mjtGeom.mjGEOM_SPHERE)
_CAPSULE = int(mujoco.mjtGeom.mjGEOM_CAPSULE)
_ELLIPSOID = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
_CYLINDER = int(mujoco.mjtGeom.mjGEOM_CYLINDER)
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
#: geom types coal answers for when the pair has a mesh (a plane, a height field, an SDF: MuJoCo)
_COAL_TYPES = frozenset({_MESH, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX})
_COAL_KINDS = np.array(sorted(_COAL_TYPES))  # the same, for :func:`handled`

#: Triangles of one piece of a mesh's tree: one call to coal tests at most this squared pairs of
#: triangles (about 20-50 ns a pair: 0.3-0.8 s at worst, for triangles made to defeat the
#: bounding volumes; a near miss of two real surfaces tests some per triangle: milliseconds).
PIECE_FACES = 4096
#: CPU time (s) of its thread one client's query may take, checked before each call to coal
#: (half a request's ``limits.MAX_REQUEST_SECONDS``: three connections' queries at once hold the
#: others about three times as long): past it, the query stops with an error. A real scene's
#: query takes milliseconds.
MAX_QUERY_SECONDS = 0.25
#: Bytes of meshes' trees kept (coal's ``memUsage``; about 500 bytes a triangle).
MAX_TREE_BYTES = 512 << 20


class Work:
    """A query's bound: the CPU time its thread spent on it, checked before each call to coal.

    Args:
        limit: s at most (None: not bounded, the operator's queries).
        defer: a tree not built yet raises :class:`TreesPending` (a client's query on the
            simulation thread) instead of being built by the caller's thread.
    """

    __slots__ = ("limit", "began", "calls", "defer")

    def __init__(self, limit: float | None = None, defer: bool = False) -> None:
        self.limit, self.began, self.calls, self.defer = limit, 0.0, 0, defer

    @classmethod
    def client(cls, defer: bool = True) -> Work:
        """A client's query's bound.

        Args:
            defer: see the class's.

        Returns:
            A Work bounded by :data:`MAX_QUERY_SECONDS` (read now).
        """
        return cls(MAX_QUERY_SECONDS, defer)

    def spend(self, faces: tuple[int, int]) -> None:
        """Check the bound before a call to coal (the query's first call starts its clock).

        Args:
            faces: the two geoms' triangles (a primitive: 0), for the message.

        Raises:
            ArgumentError: past the limit; the call is not made.
        """
        self.calls += 1
        if self.limit is None:
            return
        now = time.thread_time()
        if self.calls == 1:
            self.began = now
        elif now - self.began > self.limit:
            raise ArgumentError(f"the query took more than {self.limit:g} s (mesh_geometry.MAX_QUERY_SECONDS) "
                                f"after {self.calls - 1:,} calls on meshes of {faces[0]:,} and {faces[1]:,} triangles "
                                "lying within each other's bounds; ask about smaller or farther shapes")


UNBOUNDED = Work()


class TreesPending(RemoteError):
    """A client's query needs meshes' trees that are being built off the simulation thread:
    ``future`` is done once they are (its text: ``server busy``, for a caller that cannot wait)."""

    def __init__(self, future: Future, faces: int) -> None:
        super().__init__(f"{BUSY}: the triangle trees of a mesh of {faces:,} triangles are being built "
                         "off the simulation thread; ask again")
        self.future = future


class Tree:
    """A mesh's pieces (see the module's text): coal's trees, their bounding spheres (mesh frame,
    m) and triangle counts.

    Args:
        vertices: (n, 3) m.
        faces: (t, 3) vertex indices.
    """

    __slots__ = ("pieces", "centres", "radii", "faces", "total", "bytes", "__weakref__")

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.pieces: list[coal.BVHModelOBBRSS] = []
        centres, radii, counts = [], [], []
        for part in _split(vertices, faces):  # each a call to coal: the interpreter is let go between them
            used, local = np.unique(part, return_inverse=True)
            bvh = coal.BVHModelOBBRSS()
            bvh.beginModel(len(part), len(used))
            bvh.addVertices(np.ascontiguousarray(vertices[used], dtype=float))
            bvh.addTriangles(np.ascontiguousarray(local.reshape(-1, 3), dtype=np.int64))
            bvh.endModel()
            bvh.computeLocalAABB()
            self.pieces.append(bvh)
            centres.append(np.array(bvh.aabb_center, dtype=float))
            radii.append(float(bvh.aabb_radius))
            counts.append(len(part))
        self.centres = np.array(centres).reshape(-1, 3)
        self.radii = np.array(radii)
        self.faces: list[int] = counts
        self.total = sum(counts)
        self.bytes = sum(int(p.memUsage(False)) for p in self.pieces)


def _split(vertices: np.ndarray, faces: np.ndarray) -> list[np.ndarray]:
    """``faces`` cut into groups of at most :data:`PIECE_FACES` that lie together: split at the
    median of their centres along the widest axis until small enough."""
    centres = vertices[faces].mean(axis=1)
    out, todo = [], [np.arange(len(faces))]
    while todo:
        idx = todo.pop()
        if len(idx) <= PIECE_FACES:
            out.append(faces[idx])
            continue
        c = centres[idx]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        half = len(idx) // 2
        order = np.argpartition(c[:, axis], half)
        todo += [idx[order[:half]], idx[order[half:]]]
    return out


class _Trees:
    """The trees of every mesh asked about, by content, least recently used first; thread-safe.
    Builds asked for by clients' queries run on one thread of their own."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._kept: collections.OrderedDict[bytes, Tree] = collections.OrderedDict()
        self._bytes = 0
        self._building: dict[bytes, Future] = {}
        self._waiting: queue.SimpleQueue[tuple[bytes, np.ndarray, np.ndarray, Future]] = queue.SimpleQueue()
        self._builder: threading.Thread | None = None

    def get(self, key: bytes) -> Tree | None:
        with self._lock:
            tree = self._kept.get(key)
            if tree is not None:
                self._kept.move_to_end(key)
            return tree

    def put(self, key: bytes, tree: Tree) -> None:
        with self._lock:
            if key in self._kept:
                return
            self._kept[key] = tree
            self._bytes += tree.bytes
            while self._bytes > MAX_TREE_BYTES and len(self._kept) > 1:  # the one just made stays
                _, old = self._kept.popitem(last=False)
                self._bytes -= old.bytes

    def held(self) -> int:
        """Bytes of the trees kept."""
        with self._lock:
            return self._bytes

    def build(self, key: bytes, vertices: np.ndarray, faces: np.ndarray) -> Tree:
        """The tree of ``key``, made now by this thread when not kept (or the builder's, waited for)."""
        tree = self.get(key)
        if tree is not None:
            return tree
        with self._lock:
            running = self._building.get(key)
        if running is not None:
            return running.result()  # type: ignore[no-any-return]
        tree = Tree(vertices, faces)
        self.put(key, tree)
        return tree

    def later(self, key: bytes, vertices: np.ndarray, faces: np.ndarray) -> Future:
        """The future of ``key``'s tree, built by the builder thread (once per key at a time; a
        daemon thread, started at the first build: a server that exits does not wait for it)."""
        with self._lock:
            running = self._building.get(key)
            if running is not None:
                return running
            future: Future = Future()
            self._building[key] = future
            self._waiting.put((key, vertices, faces, future))
            if self._builder is None:
                self._builder = threading.Thread(target=self._build_all, name="simx-mesh-trees", daemon=True)
                self._builder.start()
            return future

    def _build_all(self) -> None:
        while True:
            key, vertices, faces, future = self._waiting.get()
            try:
                tree = Tree(vertices, faces)
                self.put(key, tree)
            except BaseException as exc:  # the queries waiting for it are told
                future.set_exception(exc)
            else:
                future.set_result(tree)
            finally:
                with self._lock:
                    self._building.pop(key, None)
                # what the waiting thread's frame would keep till the next build: the future's
                # callbacks hold the queries waiting for it (and their callers' contexts)
                key = vertices = faces = future = tree = None  # type: ignore[assignment]


TREES = _Trees()


class _ModelShapes:
    """What coal needs of each geom of one model, made when first asked (a model's meshes and
    sizes are not edited in place: a changed scene is a new model): a mesh's content key (its
    tree is in :data:`TREES`) and arrays, a primitive's coal shape."""

    def __init__(self) -> None:
        self.keys: dict[int, tuple[bytes, np.ndarray, np.ndarray]] = {}
        self.primitives: dict[int, Any] = {}
        self.found: dict[int, weakref.ref[Tree]] = {}  # geom -> its tree while TREES keeps it

    def mesh(self, m: mujoco.MjModel, mesh: int) -> tuple[bytes, np.ndarray, np.ndarray]:
        found = self.keys.get(mesh)
        if found is None:
            v0, nv = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
            f0, nf = int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
            v = np.array(m.mesh_vert[v0:v0 + nv], dtype=float)
            f = np.array(m.mesh_face[f0:f0 + nf], dtype=np.int64)
            key = hashlib.blake2b(v.tobytes() + f.tobytes(), digest_size=16).digest()
            found = self.keys[mesh] = (key, v, f)
        return found

    def tree(self, m: mujoco.MjModel, g: int, work: Work) -> Tree:
        """Geom ``g``'s mesh tree; built now unless ``work.defer``.

        Raises:
            TreesPending: not built yet, for a deferring query (its build started).
        """
        ref = self.found.get(g)
        tree = ref() if ref is not None else None
        if tree is not None:
            return tree
        key, v, f = self.mesh(m, int(m.geom_dataid[g]))
        tree = TREES.get(key)
        if tree is not None:
            self.found[g] = weakref.ref(tree)
            return tree
        if work.defer:
            raise TreesPending(TREES.later(key, v, f), len(f))
        return TREES.build(key, v, f)

    def primitive(self, m: mujoco.MjModel, g: int) -> Any:
        found = self.primitives.get(g)
        if found is None:
            kind, size = int(m.geom_type[g]), np.asarray(m.geom_size[g], dtype=float)
            if kind == _SPHERE:
                found = coal.Sphere(float(size[0]))
            elif kind == _CAPSULE:
                found = coal.Capsule(float(size[0]), 2.0 * float(size[1]))
            elif kind == _CYLINDER:
                found = coal.Cylinder(float(size[0]), 2.0 * float(size[1]))
            elif kind == _BOX:
                found = coal.Box(*(2.0 * size).tolist())
            else:
                found = coal.Ellipsoid(*size.tolist())
            self.primitives[g] = found
        return found


def _pose(d: mujoco.MjData, g: int) -> coal.Transform3s:
    """The geom's pose in ``d`` (a new transform per query: a planner's thread and the
    simulation's may ask at once)."""
    return coal.Transform3s(d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g])


_SHAPES: weakref.WeakKeyDictionary[mujoco.MjModel, _ModelShapes] = weakref.WeakKeyDictionary()


def _shapes(m: mujoco.MjModel) -> _ModelShapes:
    found = _SHAPES.get(m)
    if found is None:
        found = _SHAPES[m] = _ModelShapes()
    return found


def handles(m: mujoco.MjModel, g1: int, g2: int) -> bool:
    """Whether coal answers for the geom pair (a mesh with a mesh or a primitive).

    Args:
        m: the model.
        g1: a geom id.
        g2: another geom id.

    Returns:
        True when :class:`Touching` and :func:`distance` take the pair.
    """
    t1, t2 = int(m.geom_type[g1]), int(m.geom_type[g2])
    return (t1 == _MESH or t2 == _MESH) and t1 in _COAL_TYPES and t2 in _COAL_TYPES


def handled(m: mujoco.MjModel, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`handles` for many pairs at once.

    Args:
        m: the model.
        a: (k,) geom ids.
        b: (k,) geom ids, ``b[i]`` paired with ``a[i]``.

    Returns:
        (k,) bool: the pairs coal answers for.
    """
    t1, t2 = m.geom_type[a], m.geom_type[b]
    return ((t1 == _MESH) | (t2 == _MESH)) & np.isin(t1, _COAL_KINDS) & np.isin(t2, _COAL_KINDS)


class _Side:
    """One geom of a pair as coal sees it: its pieces (a primitive: one), their triangle counts
    (a primitive: 0) and bounding spheres in the world (m)."""

    __slots__ = ("shapes", "faces", "total", "pose", "radii", "_d", "_g", "_local", "_centres")

    def __init__(self, shapes: _ModelShapes, m: mujoco.MjModel, d: mujoco.MjData, g: int, pose: coal.Transform3s,
                 work: Work) -> None:
        self.pose, self._d, self._g, self._centres = pose, d, g, None
        if int(m.geom_type[g]) == _MESH:
            tree = shapes.tree(m, g, work)
            self.shapes, self.faces, self.total, self.radii = tree.pieces, tree.faces, tree.total, tree.radii
            self._local: np.ndarray | None = tree.centres
        else:
            self.shapes, self.faces, self.total = [shapes.primitive(m, g)], _ONE_PRIMITIVE, 0
            self.radii, self._local = np.array([float(m.geom_rbound[g])]), None

    @property
    def centres(self) -> np.ndarray:
        """(p, 3): the pieces' sphere centres in the world (m), worked out when first read (only a
        pair with a mesh of several pieces reads them)."""
        if self._centres is None:
            d, g = self._d, self._g
            self._centres = (d.geom_xpos[g][None, :] if self._local is None
                             else self._local @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g])
        return self._centres


_ONE_PRIMITIVE = [0]
_FIRST = ([0], [0], [0.0])


def _candidates(s1: _Side, s2: _Side, within: float) -> tuple[list[int], list[int], list[float]]:
    """The pairs of pieces whose spheres come within ``within`` (m), nearest first, and those
    lower bounds; two sides of one piece each: that pair (the geoms' own spheres were tested)."""
    if len(s1.shapes) == 1 and len(s2.shapes) == 1:
        return _FIRST
    diff = s1.centres[:, None, :] - s2.centres[None, :, :]
    gaps = np.sqrt(np.einsum("ijk,ijk->ij", diff, diff)) - s1.radii[:, None] - s2.radii[None, :]
    i, j = np.nonzero(gaps <= within)
    order = np.argsort(gaps[i, j], kind="stable")
    return i[order].tolist(), j[order].tolist(), gaps[i[order], j[order]].tolist()


class Touching:
    """Whether geom pairs (pairs :func:`handles` takes) come within ``margin`` of touching, at one
    set of poses: the model's shapes, the request and each geom's side (coal transform, pieces in
    the world) made once for all the pairs asked (a planner's state check asks some fifty pairs
    of a few geoms), a result per pair.

    Args:
        m: the model.
        d: whose poses (``geom_xpos``, ``geom_xmat``); not to change while this is used.
        margin: m; touching or overlapping counts whatever it is.
        work: the query's bound (default: none, trees built by the caller).
    """

    __slots__ = ("m", "d", "shapes", "request", "margin", "sides", "work")

    def __init__(self, m: mujoco.MjModel, d: mujoco.MjData, margin: float, work: Work = UNBOUNDED) -> None:
        self.m, self.d, self.shapes, self.work = m, d, _shapes(m), work
        self.request = coal.CollisionRequest()
        self.request.security_margin = self.margin = float(margin)
        self.sides: dict[int, _Side] = {}

    def _side(self, g: int) -> _Side:
        found = self.sides.get(g)
        if found is None:
            found = self.sides[g] = _Side(self.shapes, self.m, self.d, g, _pose(self.d, g), self.work)
        return found

    def __call__(self, g1: int, g2: int) -> bool:
        """True when some triangle of geom ``g1`` or ``g2`` (or the primitive) is closer than the
        margin to the other.

        Raises:
            ArgumentError: the query's work passed its bound (:class:`Work`).
            TreesPending: a tree is being built (a deferring query).
        """
        s1, s2 = self._side(g1), self._side(g2)
        work, request = self.work, self.request
        if len(s1.shapes) == 1 and len(s2.shapes) == 1:  # the geoms' own spheres were tested
            work.spend((s1.total, s2.total))
            return bool(coal.collide(s1.shapes[0], s1.pose, s2.shapes[0], s2.pose, request, coal.CollisionResult()))
        for i, j, _ in zip(*_candidates(s1, s2, self.margin + 1e-9)):
            work.spend((s1.total, s2.total))
            if coal.collide(s1.shapes[i], s1.pose, s2.shapes[j], s2.pose, request, coal.CollisionResult()):
                return True
        return False


def distance(m: mujoco.MjModel, d: mujoco.MjData, g1: int, g2: int, fromto: np.ndarray | None = None,
             work: Work = UNBOUNDED, below: float = np.inf) -> float:
    """Smallest distance between two geoms (a pair :func:`handles` takes): the pieces' pairs
    nearest first, until the next pair's spheres lie farther than the best found.

    Args:
        m: the model.
        d: whose poses.
        g1: a geom id.
        g2: another geom id.
        fromto: (6,) receives the nearest points (m, world), on ``g1`` then on ``g2``, as
            ``mj_geomDistance``'s.
        work: the query's bound (default: none).
        below: m; only a distance below it matters (the caller's best so far): pieces farther
            are not measured (then the answer is ``below`` or more, ``fromto`` untouched).

    Returns:
        The distance in m; 0 (two meshes) or negative (a mesh into a primitive, coal's
        penetration) when they overlap.

    Raises:
        ArgumentError: the query's work passed its bound (:class:`Work`).
        TreesPending: a tree is being built (a deferring query).
    """
    shapes = _shapes(m)
    s1 = _Side(shapes, m, d, g1, _pose(d, g1), work)
    s2 = _Side(shapes, m, d, g2, _pose(d, g2), work)
    best, request = float(below), coal.DistanceRequest()
    for i, j, gap in zip(*_candidates(s1, s2, np.inf)):
        if gap >= best:
            break
        work.spend((s1.total, s2.total))
        result = coal.DistanceResult()
        dist = float(coal.distance(s1.shapes[i], s1.pose, s2.shapes[j], s2.pose, request, result))
        if dist < best:
            best = dist
            if fromto is not None:
                fromto[:3] = result.getNearestPoint1()
                fromto[3:] = result.getNearestPoint2()
    return best
