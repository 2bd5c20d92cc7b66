"""Exact collision and distance of geoms on their triangle meshes, with coal (FCL's successor).

MuJoCo's narrow phase (``mj_geomDistance``) sees a mesh geom as its convex hull; CoppeliaSim's
``sim.checkCollision`` / ``sim.checkDistance`` (coppeliaSimLib ``CCollisionRoutine``,
``CDistanceRoutine``, on the geometric plugin's OBB trees) test the triangles themselves. Here a
pair with a mesh geom is answered by coal on the mesh's triangles: a bounding volume hierarchy
(``coal.BVHModelOBBRSS``) per mesh of the model (``mesh_vert`` / ``mesh_face`` as MuJoCo compiled
them: scaled, in the geom's frame), built the first time the mesh is asked about and cached per
model; the other geom as coal's primitive (sphere, capsule, cylinder, box, ellipsoid). The poses are MuJoCo's (``geom_xpos`` / ``geom_xmat`` of the data
asked about: the live simulation or a planner's scratch copy); physics stays MuJoCo's.

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

import weakref
from typing import Any

import coal
import mujoco
import numpy as np

_MESH = int(mujoco.mjtGeom.mjGEOM_MESH)
_SPHERE = int(mujoco.mjtGeom.mjGEOM_SPHERE)
_CAPSULE = int(mujoco.mjtGeom.mjGEOM_CAPSULE)
_ELLIPSOID = int(mujoco.mjtGeom.mjGEOM_ELLIPSOID)
_CYLINDER = int(mujoco.mjtGeom.mjGEOM_CYLINDER)
_BOX = int(mujoco.mjtGeom.mjGEOM_BOX)
#: geom types coal answers for when the pair has a mesh (a plane, a height field, an SDF: MuJoCo)
_COAL_TYPES = frozenset({_MESH, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX})
_COAL_KINDS = np.array(sorted(_COAL_TYPES))  # the same, for :func:`handled`


class _ModelShapes:
    """coal's geometry of each geom of one model, built when first asked (a model's meshes and
    sizes are not edited in place: a changed scene is a new model, with a new cache)."""

    def __init__(self) -> None:
        self.meshes: dict[int, coal.BVHModelOBBRSS] = {}
        self.geoms: dict[int, Any] = {}

    def shape(self, m: mujoco.MjModel, g: int) -> Any:
        found = self.geoms.get(g)
        if found is None:
            found = self.geoms[g] = self._build(m, g)
        return found

    def _build(self, m: mujoco.MjModel, g: int) -> Any:
        kind, size = int(m.geom_type[g]), np.asarray(m.geom_size[g], dtype=float)
        if kind == _MESH:
            mesh = int(m.geom_dataid[g])
            bvh = self.meshes.get(mesh)
            if bvh is None:
                v0, nv = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
                f0, nf = int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
                bvh = coal.BVHModelOBBRSS()
                bvh.beginModel(nf, nv)
                bvh.addVertices(np.ascontiguousarray(m.mesh_vert[v0:v0 + nv], dtype=float))
                bvh.addTriangles(np.ascontiguousarray(m.mesh_face[f0:f0 + nf], dtype=np.int64))
                bvh.endModel()
                self.meshes[mesh] = bvh
            return bvh
        if kind == _SPHERE:
            return coal.Sphere(float(size[0]))
        if kind == _CAPSULE:
            return coal.Capsule(float(size[0]), 2.0 * float(size[1]))
        if kind == _CYLINDER:
            return coal.Cylinder(float(size[0]), 2.0 * float(size[1]))
        if kind == _BOX:
            return coal.Box(*(2.0 * size).tolist())
        return coal.Ellipsoid(*size.tolist())



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


class Touching:
    """Whether geom pairs (pairs :func:`handles` takes) come within ``margin`` of touching, at one
    set of poses: the model's shapes, the request and each geom's coal transform made once for
    all the pairs asked (a planner's state check asks some fifty pairs of a few geoms), a result
    per pair.

    Args:
        m: the model.
        d: whose poses (``geom_xpos``, ``geom_xmat``); not to change while this is used.
        margin: m; touching or overlapping counts whatever it is.
    """

    __slots__ = ("m", "d", "shapes", "request", "poses")

    def __init__(self, m: mujoco.MjModel, d: mujoco.MjData, margin: float) -> None:
        self.m, self.d, self.shapes = m, d, _shapes(m)
        self.request = coal.CollisionRequest()
        self.request.security_margin = float(margin)
        self.poses: dict[int, coal.Transform3s] = {}

    def _pose(self, g: int) -> coal.Transform3s:
        found = self.poses.get(g)
        if found is None:
            found = self.poses[g] = _pose(self.d, g)
        return found

    def __call__(self, g1: int, g2: int) -> bool:
        """True when some triangle of geom ``g1`` or ``g2`` (or the primitive) is closer than the
        margin to the other."""
        shape = self.shapes.shape
        return bool(coal.collide(shape(self.m, g1), self._pose(g1), shape(self.m, g2), self._pose(g2),
                                 self.request, coal.CollisionResult()))


def distance(m: mujoco.MjModel, d: mujoco.MjData, g1: int, g2: int, fromto: np.ndarray | None = None) -> float:
    """Smallest distance between two geoms (a pair :func:`handles` takes).

    Args:
        m: the model.
        d: whose poses.
        g1: a geom id.
        g2: another geom id.
        fromto: (6,) receives the nearest points (m, world), on ``g1`` then on ``g2``, as
            ``mj_geomDistance``'s.

    Returns:
        The distance in m; 0 (two meshes) or negative (a mesh into a primitive, coal's
        penetration) when they overlap.
    """
    shapes = _shapes(m)
    result = coal.DistanceResult()
    dist = float(coal.distance(shapes.shape(m, g1), _pose(d, g1), shapes.shape(m, g2), _pose(d, g2),
                               coal.DistanceRequest(), result))
    if fromto is not None:
        fromto[:3] = result.getNearestPoint1()
        fromto[3:] = result.getNearestPoint2()
    return dist
