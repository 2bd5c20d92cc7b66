"""Geometry for point clouds and octrees kept as data (:mod:`simx_server.api.sim.clouds`):
signed distances (m) from world points to a shape's MuJoCo geoms, the points nearest within a
tolerance (cell hashing, numpy), and the world points near a shape's surface on a grid.

MuJoCo collides with primitives and with the convex hull of meshes, so a shape's volume here is
the union of its geoms' primitives and mesh hulls: the same solid its contacts see.
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, UnsupportedError

#: At most this many grid cells scanned or point pairs compared in one call.
MAX_CELLS = 4_000_000


def _hull_planes(m: mujoco.MjModel, mesh: int) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normals (K, 3) and offsets (K,) of a mesh's convex hull faces, mesh frame."""
    vadr, vnum = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
    verts = m.mesh_vert[vadr:vadr + vnum].astype(float)
    gadr = int(m.mesh_graphadr[mesh])
    if gadr >= 0:  # MuJoCo's hull: numvert, numface, vert_edgeadr, vert_globalid, edge_localid, face_globalid
        g = m.mesh_graph[gadr:]
        nv, nf = int(g[0]), int(g[1])
        start = 2 + 2 * nv + 3 * nf + nv  # edge_localid holds 3 * numface + numvert entries
        faces = np.asarray(g[start:start + 3 * nf]).reshape(nf, 3)
    else:  # no hull computed: the mesh's own faces (MuJoCo then collides with them as a convex body)
        fadr, fnum = int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
        faces = m.mesh_face[fadr:fadr + fnum]
    tri = verts[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    centre = verts.mean(axis=0)
    d = np.einsum("ij,ij->i", n, tri[:, 0])
    flip = np.einsum("ij,j->i", n, centre) > d  # orient every normal away from the centre
    n[flip], d[flip] = -n[flip], -d[flip]
    return n, d


def geom_sdf(m: mujoco.MjModel, d: mujoco.MjData, g: int, pts: np.ndarray) -> np.ndarray:
    """Signed distance (m, negative inside) of world points ``pts`` (N, 3) to geom ``g``;
    ellipsoids and mesh hulls: a bound exact on the surface (0) and of the right sign."""
    p = (pts - d.geom_xpos[g]) @ d.geom_xmat[g].reshape(3, 3)  # into the geom's frame
    s, kind = m.geom_size[g], int(m.geom_type[g])
    G = mujoco.mjtGeom
    if kind == G.mjGEOM_SPHERE:
        return np.linalg.norm(p, axis=1) - s[0]
    if kind == G.mjGEOM_BOX:
        q = np.abs(p) - s
        return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)
    if kind == G.mjGEOM_CAPSULE:
        c = p.copy()
        c[:, :2] = 0
        c[:, 2] = np.clip(p[:, 2], -s[1], s[1])
        return np.linalg.norm(p - c, axis=1) - s[0]
    if kind == G.mjGEOM_CYLINDER:
        q = np.stack([np.linalg.norm(p[:, :2], axis=1) - s[0], np.abs(p[:, 2]) - s[1]], axis=1)
        return np.minimum(q.max(axis=1), 0) + np.linalg.norm(np.maximum(q, 0), axis=1)
    if kind == G.mjGEOM_ELLIPSOID:
        k0 = np.linalg.norm(p / s, axis=1)
        k1 = np.maximum(np.linalg.norm(p / s ** 2, axis=1), 1e-12)
        return k0 * (k0 - 1) / k1
    if kind == G.mjGEOM_PLANE:
        return p[:, 2]
    if kind == G.mjGEOM_MESH:
        n, off = _hull_planes(m, int(m.geom_dataid[g]))
        return (p @ n.T - off).max(axis=1)
    raise UnsupportedError(f"geom {g} is a MuJoCo {G(kind).name}: no distance for it")


def shape_sdf(m: mujoco.MjModel, d: mujoco.MjData, geoms: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Signed distance of world points to the union of ``geoms`` (one shape)."""
    if not len(geoms):
        raise UnsupportedError("the shape has no geom")
    return np.min([geom_sdf(m, d, int(g), pts) for g in geoms], axis=0)


def shape_bounds(m: mujoco.MjModel, d: mujoco.MjData, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World axis-aligned bounds (low, high) of the geoms, from MuJoCo's geom boxes."""
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
    corners = []
    for g in geoms:
        if int(m.geom_type[g]) == mujoco.mjtGeom.mjGEOM_PLANE:
            raise UnsupportedError("the shape holds a plane (unbounded): it cannot be sampled")
        centre, half = m.geom_aabb[g][:3], m.geom_aabb[g][3:]
        corners.append((centre + signs * half) @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g])
    c = np.vstack(corners)
    return c.min(axis=0), c.max(axis=0)


def _triangle_samples(m: mujoco.MjModel, d: mujoco.MjData, g: int, spacing: float) -> np.ndarray:
    """World points on the triangles of mesh geom ``g``, at most about ``spacing`` m apart along
    each triangle's edges (a barycentric grid per triangle, built once per grid size).

    Raises:
        ArgumentError: more than MAX_CELLS points.
    """
    mesh = int(m.geom_dataid[g])
    vadr, fadr, fnum = int(m.mesh_vertadr[mesh]), int(m.mesh_faceadr[mesh]), int(m.mesh_facenum[mesh])
    tri = m.mesh_vert[vadr:][m.mesh_face[fadr:fadr + fnum]].astype(float)  # (t, 3, 3), mesh frame
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - a, axis=1), np.linalg.norm(c - b, axis=1)], axis=0)
    divisions = np.maximum(1, np.ceil(longest / spacing)).astype(int)
    if int(((divisions + 1) * (divisions + 2) // 2).sum()) > MAX_CELLS:
        raise ArgumentError(f"grid size {spacing} m is too fine for this mesh (over {MAX_CELLS} points)")
    pts = []
    for n in np.unique(divisions):
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        keep = i + j <= n
        u, v = i[keep] / n, j[keep] / n  # (k,)
        sel = divisions == n
        aa, ba, ca = a[sel][:, None], (b - a)[sel][:, None], (c - a)[sel][:, None]
        pts.append((aa + u[None, :, None] * ba + v[None, :, None] * ca).reshape(-1, 3))
    local = np.vstack(pts) if pts else np.zeros((0, 3))
    return local @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]


def surface_points(m: mujoco.MjModel, d: mujoco.MjData, geoms: np.ndarray, spacing: float) -> np.ndarray:
    """World points on the shape's surface, about ``spacing`` m apart: the cells of a grid of that
    pitch the surface crosses, each cell centre moved onto the surface along the distance's
    gradient (a few near sharp edges, which do not get there within 1/1000 of the pitch, are
    left out). A visual-only mesh, which MuJoCo gives no convex hull (no distance field here),
    is sampled on its triangles instead."""
    if not spacing > 0:
        raise ArgumentError("the grid size must be positive")
    hull_less = [int(g) for g in geoms if int(m.geom_type[g]) == mujoco.mjtGeom.mjGEOM_MESH
                 and int(m.mesh_graphadr[int(m.geom_dataid[g])]) < 0]
    if hull_less:
        others = np.array([g for g in geoms if int(g) not in hull_less], dtype=int)
        sampled = [_triangle_samples(m, d, g, spacing) for g in hull_less]
        return np.vstack(sampled + ([surface_points(m, d, others, spacing)] if len(others) else []))
    lo, hi = shape_bounds(m, d, geoms)
    lo, hi = lo - spacing, hi + spacing
    counts = np.ceil((hi - lo) / spacing).astype(int)
    if int(np.prod(counts)) > MAX_CELLS:
        raise ArgumentError(f"grid size {spacing} m is too fine for this shape (over {MAX_CELLS} cells)")
    axes = [lo[i] + spacing * (np.arange(counts[i]) + 0.5) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    dist = shape_sdf(m, d, geoms, grid)
    near = grid[np.abs(dist) <= spacing * 0.5]
    h = spacing * 1e-3
    for _ in range(8):  # Newton steps onto the zero level, the gradient by central differences
        grad = np.stack([shape_sdf(m, d, geoms, near + h * e) - shape_sdf(m, d, geoms, near - h * e)
                         for e in np.eye(3)], axis=1)
        grad /= np.maximum(np.linalg.norm(grad, axis=1, keepdims=True), 1e-12)
        near = near - shape_sdf(m, d, geoms, near)[:, None] * grad
    return near[np.abs(shape_sdf(m, d, geoms, near)) <= spacing * 1e-3]  # those that got there (not all at edges)


def near_mask(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """For each point of ``a`` (N, 3): whether some point of ``b`` (M, 3) lies within ``tol`` m.
    Cell hashing at pitch ``tol``: each point of ``a`` is compared with ``b``'s 27 nearby cells."""
    out = np.zeros(len(a), dtype=bool)
    if not len(a) or not len(b):
        return out
    tol = max(float(tol), 1e-9)
    cb = np.floor(b / tol).astype(np.int64)
    ca = np.floor(a / tol).astype(np.int64)
    base = np.minimum(ca.min(axis=0), cb.min(axis=0)) - 1
    span = np.maximum(ca.max(axis=0), cb.max(axis=0)) - base + 2
    if float(np.prod(span.astype(float))) > 2.0 ** 62:
        raise ArgumentError("the points spread too far for this tolerance")

    def key(c: np.ndarray) -> np.ndarray:
        c = c - base
        return (c[:, 0] * span[1] + c[:, 1]) * span[2] + c[:, 2]
    kb = key(cb)
    order = np.argsort(kb, kind="stable")
    kb, bs = kb[order], b[order]
    for off in np.array([[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)]):
        todo = np.flatnonzero(~out)
        if not len(todo):
            break
        k = key(ca[todo] + off)
        lo, hi = np.searchsorted(kb, k, "left"), np.searchsorted(kb, k, "right")
        counts = hi - lo
        total = int(counts.sum())
        if not total:
            continue
        if total > MAX_CELLS:
            raise ArgumentError(f"over {MAX_CELLS} point pairs to compare: use a smaller tolerance or fewer points")
        ia = np.repeat(np.arange(len(todo)), counts)
        ib = np.repeat(lo, counts) + np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
        hit = np.linalg.norm(a[todo[ia]] - bs[ib], axis=1) <= tol
        out[todo[np.unique(ia[hit])]] = True
    return out


def dedupe(pts: np.ndarray, tol: float, existing: np.ndarray) -> np.ndarray:
    """Indices of ``pts`` to insert with a duplicate tolerance: a point goes in unless one
    already there (``existing``) or one inserted before it lies within ``tol`` m."""
    fresh = np.flatnonzero(~near_mask(pts, existing, tol))
    cells: dict[tuple[int, int, int], list[np.ndarray]] = {}
    offsets = [(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)]
    keep = []
    for i in fresh:
        p = pts[i]
        c = tuple(int(v) for v in np.floor(p / tol))
        if any(np.linalg.norm(q - p) <= tol for o in offsets
               for q in cells.get((c[0] + o[0], c[1] + o[1], c[2] + o[2]), ())):
            continue
        cells.setdefault(c, []).append(p)
        keep.append(int(i))
    return np.array(keep, dtype=int)
