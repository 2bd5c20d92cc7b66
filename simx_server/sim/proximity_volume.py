"""The exact detection of a pyramid- or cylinder-type proximity sensor: the point nearest to the
sensor's origin of the detectable triangles inside its volume, as CoppeliaSim computes it for its
volume sensors (coppeliaSimLib ``CProxSensorRoutine::_detectShape``, non-ray branch:
``geomPlugin_volumeSensorDetectMeshIfSmaller`` with the volume's ``planesInside``, built by
``CConvexVolume::computeVolumes``: six planes for a pyramid, two caps and ``faceNumber`` sides
for a cylinder). Casting rays through the volume
misses what crosses it between the rays, and sees nothing of a surface the rays start on or
behind (a floor through the sensor's near face: CoppeliaSim reports the near face's centre).

Each candidate triangle (in the sensor's frame) is clipped by the volume's planes
(Sutherland-Hodgman, all triangles at once in numpy) and the point of the clipped polygon
nearest to the origin is found; the nearest of all is the detection. No triangle hides another:
CoppeliaSim's volume sensors see through everything. Triangles come from mesh geoms (MuJoCo's
``mesh_vert``/``mesh_face``), boxes (12), planes (2, an infinite plane cut to the volume's
reach) and spheres, ellipsoids, capsules and cylinders tessellated as CoppeliaSim meshes its pure
shapes (:func:`primitive_mesh`): a small sphere between the rays of a volume is seen, as RLBench's
pour_from_cup_to_cup needs of its 5 mm drops. Height fields and SDF geoms are left to the rays
(:mod:`simx_server.sim.proximity`). Where a sensor's volume lies along its axis (its offset,
which may be negative, and its far end) is read here too (:func:`axis_offset`,
:func:`volume_span`).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError

_MESH, _BOX, _PLANE = (int(mujoco.mjtGeom.mjGEOM_MESH), int(mujoco.mjtGeom.mjGEOM_BOX),
                       int(mujoco.mjtGeom.mjGEOM_PLANE))
_SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER = (int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_CAPSULE),
                                            int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
                                            int(mujoco.mjtGeom.mjGEOM_CYLINDER))
_HFIELD, _SDF = int(mujoco.mjtGeom.mjGEOM_HFIELD), int(mujoco.mjtGeom.mjGEOM_SDF)
#: a pure shape's subdivisions in CoppeliaSim 4.1 (``simCreatePureShape_internal``: 32 sides, and
#: 16 faces from pole to pole for a sphere, ``CMeshRoutines::createSphere``)
_SIDES, _SPHERE_FACES = 32, 16
_BOX_FACES = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                       [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])
_BOX_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)


def axis_offset(obj: Any) -> float:
    """Where a ray-type proximity sensor's ray starts along its +z, or where a cone-type one's
    apex lies (its ``simx:`` setting ``offset=``, m, may be negative; 0 when not set), as
    CoppeliaSim's: the ray runs from ``(0, 0, offset)`` for ``range`` m (coppeliaSimLib
    ``CProxSensorRoutine::_detectShape``, ray branch, with ``geom_raySensorDetectMeshIfSmaller``),
    the cone volume is translated by it (``CConvexVolume``), and distances are measured from
    the sensor's origin. Raises ArgumentError for a value that is not a
    number within 1000 m (``CConvexVolume::setOffset``'s bounds).

    Args:
        obj: a proximity sensor's scene object.

    Returns:
        The offset, m.
    """
    value = _distance(obj, "offset")
    return 0.0 if value is None else value


def _distance(obj: Any, key: str) -> float | None:
    """The sensor's ``simx:`` setting ``key`` as a distance along its axis (m, within 1000 as
    ``CConvexVolume::setOffset`` takes), None where it has none; ArgumentError for another value."""
    raw = obj.settings.get(key)
    if raw is None:
        return None
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not -1000 <= value <= 1000:
        raise ArgumentError(f"proximity sensor {obj.name!r}: {key}={raw!r} in its simx: settings is not "
                            "a distance in m within 1000")
    return value


def volume_span(obj: Any, cutoff: float) -> tuple[float, float]:
    """Where a volume-type sensor's volume starts and ends along its +z (m): from its
    :func:`axis_offset` (``CConvexVolume``'s offset, which may be negative) to its ``far=``
    setting where it has one (a volume that ends at or behind the sensor's origin, which a
    rangefinder's cutoff cannot hold: RLBench's light_bulb_out's ``success`` sensor, offset
    -0.015 m, range 0.01 m), else to the rangefinder's ``cutoff`` (1 m past the offset when
    unlimited). Raises ArgumentError for a bad ``offset=`` or ``far=``.

    Args:
        obj: a proximity sensor's scene object.
        cutoff: its rangefinder's cutoff, m (``math.inf``: unlimited).

    Returns:
        ``(offset, far)``, m.
    """
    offset, far = axis_offset(obj), _distance(obj, "far")
    if far is not None:
        return offset, far
    return offset, cutoff if math.isfinite(cutoff) else offset + 1.0


def triangle_geoms(m: mujoco.MjModel) -> np.ndarray:
    """Mask (ngeom,) of the geoms whose triangles this module reads: every type but height
    fields and SDF geoms (a mesh's own, a box's 12, a plane's 2, and the tessellation of
    :func:`primitive_mesh` for spheres, capsules, ellipsoids and cylinders).

    Args:
        m: the model.

    Returns:
        Boolean array.
    """
    t = m.geom_type
    return (t != _HFIELD) & (t != _SDF)  # two compares: np.isin costs ten times more


def _lathe(profile: np.ndarray, sides: int) -> tuple[np.ndarray, np.ndarray]:
    """The surface of revolution about z of ``profile`` (k, 2) of (radius, z) points, from a
    pole (radius 0) at the top to one at the bottom, with ``sides`` sides: vertices (v, 3) and
    triangles (t, 3) of vertex indices, each facing outwards."""
    angle = 2.0 * np.pi * np.arange(sides) / sides
    rings = profile[1:-1]
    ring_v = np.stack([rings[:, :1] * np.cos(angle), rings[:, :1] * np.sin(angle),
                       np.repeat(rings[:, 1:], sides, axis=1)], axis=-1).reshape(-1, 3)
    v = np.vstack([[0.0, 0.0, profile[0, 1]], ring_v, [0.0, 0.0, profile[-1, 1]]])
    i = np.arange(sides)
    j = (i + 1) % sides
    faces = [np.column_stack([np.zeros(sides, int), 1 + i, 1 + j])]
    for r in range(len(rings) - 1):
        a, b = 1 + r * sides, 1 + (r + 1) * sides
        faces += [np.column_stack([a + i, b + i, b + j]), np.column_stack([a + i, b + j, a + j])]
    last = 1 + (len(rings) - 1) * sides
    faces.append(np.column_stack([last + i, np.full(sides, len(v) - 1), last + j]))
    return v, np.vstack(faces)


@functools.lru_cache(maxsize=1024)
def primitive_mesh(kind: int, size: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """The triangle mesh CoppeliaSim gives a pure shape of MuJoCo geom type ``kind`` and
    ``geom_size`` ``size`` (m), in the geom's frame: a sphere or an ellipsoid of 32 sides and 16
    faces (``CMeshRoutines::createSphere``: vertices on the surface), a cylinder of 32 sides
    with its caps, a capsule as a sphere's halves joined by a cylinder (MuJoCo's own type).

    Args:
        kind: ``mjGEOM_SPHERE``, ``_ELLIPSOID``, ``_CAPSULE`` or ``_CYLINDER``.
        size: the geom's ``geom_size`` (3,), m.

    Returns:
        Vertices (v, 3) m and triangles (t, 3) of vertex indices, read-only.

    Raises:
        ValueError: another type.
    """
    theta = np.pi * np.arange(_SPHERE_FACES + 1) / _SPHERE_FACES
    arc = np.column_stack([np.sin(theta), np.cos(theta)])
    r, h = size[0], size[1]
    if kind in (_SPHERE, _ELLIPSOID):
        v, f = _lathe(arc, _SIDES)
        v = v * (np.array(size) if kind == _ELLIPSOID else r)
    elif kind == _CAPSULE:
        half = _SPHERE_FACES // 2
        v, f = _lathe(np.vstack([arc[:half + 1] * r + [0.0, h], arc[half:] * r - [0.0, h]]), _SIDES)
    elif kind == _CYLINDER:
        v, f = _lathe(np.array([[0.0, h], [r, h], [r, -h], [0.0, -h]]), _SIDES)
    else:
        raise ValueError(f"geom type {kind} is not a primitive with a tessellation")
    v.setflags(write=False)
    f.setflags(write=False)
    return v, f


def pyramid(offset: float, far: float, size: tuple[float, float],
            size_far: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A pyramid volume's planes and corners in the sensor frame: a frustum from an ``size``
    (x, y; m) rectangle at ``offset`` to a ``size_far`` one at ``far`` along +z
    (``CConvexVolume::computeVolumes``, PYRAMID_TYPE_CONVEX_VOLUME).

    Args:
        offset: m.
        far: m, more than ``offset``.
        size: full widths at ``offset``, m.
        size_far: full widths at ``far``, m.

    Returns:
        ``(normals (6, 3), offsets (6,), corners (8, 3))``: a point p is inside where
        ``normals @ p <= offsets`` for every plane.
    """
    length = far - offset
    kx, ky = (size_far[0] - size[0]) / (2 * length), (size_far[1] - size[1]) / (2 * length)
    normals = np.array([[0, 0, -1], [0, 0, 1], [1, 0, -kx], [-1, 0, -kx], [0, 1, -ky], [0, -1, -ky]], dtype=float)
    offsets = np.array([-offset, far, size[0] / 2 - kx * offset, size[0] / 2 - kx * offset,
                        size[1] / 2 - ky * offset, size[1] / 2 - ky * offset])
    corners = np.array([[sx * w / 2, sy * h / 2, z] for z, (w, h) in ((offset, size), (far, size_far))
                        for sx in (-1, 1) for sy in (-1, 1)])
    return normals, offsets, corners


#: The sides a cylinder volume may have (``CConvexVolume::setFaceNumber``'s bounds for a cylinder).
CYLINDER_FACES = (3, 1024)


def cylinder(offset: float, far: float, radius: float, radius_far: float,
             faces: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A cylinder volume's planes and corners in the sensor frame, as CoppeliaSim builds it
    (``CConvexVolume::computeVolumes``, CYLINDER_TYPE_CONVEX_VOLUME): a prism (a frustum where
    the radii differ) of ``faces`` sides inscribed in circles of ``radius`` at ``offset`` and
    ``radius_far`` at ``far`` along +z, the first side's normal along +x.

    Args:
        offset: m.
        far: m, more than ``offset``.
        radius: m, at ``offset``.
        radius_far: m, at ``far``.
        faces: sides, 3 to 1024.

    Returns:
        ``(normals (faces + 2, 3), offsets (faces + 2,), corners (2 faces, 3))``, as
        :func:`pyramid`.
    """
    alpha = math.pi / faces
    k = math.cos(alpha) * (radius_far - radius) / (far - offset)  # the apothem's growth along z
    phi = 2 * alpha * np.arange(faces)
    sides = np.column_stack([np.cos(phi), np.sin(phi), np.full(faces, -k)])
    normals = np.vstack([[[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]], sides])
    offsets = np.concatenate([[-offset, far], np.full(faces, math.cos(alpha) * radius - k * offset)])
    corner = phi + alpha
    corners = np.vstack([np.column_stack([r * np.cos(corner), r * np.sin(corner), np.full(faces, z)])
                         for z, r in ((offset, radius), (far, radius_far))])
    return normals, offsets, corners


def _geom_mesh(m: mujoco.MjModel, d: mujoco.MjData, g: int, centre: np.ndarray,
               reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (v, 3) of geom ``g`` in the world frame and its triangles (t, 3) of vertex
    indices; an infinite plane cut to a square of ``reach`` around ``centre``'s foot."""
    kind = int(m.geom_type[g])
    if kind == _MESH:
        mid = int(m.geom_dataid[g])
        v = m.mesh_vert[m.mesh_vertadr[mid]:m.mesh_vertadr[mid] + m.mesh_vertnum[mid]].astype(float)
        f = m.mesh_face[m.mesh_faceadr[mid]:m.mesh_faceadr[mid] + m.mesh_facenum[mid]]
    elif kind == _BOX:
        v, f = _BOX_CORNERS * m.geom_size[g], _BOX_FACES
    elif kind != _PLANE:
        v, f = primitive_mesh(kind, tuple(float(x) for x in m.geom_size[g]))
    else:
        rot = d.geom_xmat[g].reshape(3, 3)
        foot = rot.T @ (centre - d.geom_xpos[g])
        hx = m.geom_size[g, 0] if m.geom_size[g, 0] > 0 else reach
        hy = m.geom_size[g, 1] if m.geom_size[g, 1] > 0 else reach
        cx = float(np.clip(foot[0], -hx, hx)) if m.geom_size[g, 0] > 0 else float(foot[0])
        cy = float(np.clip(foot[1], -hy, hy)) if m.geom_size[g, 1] > 0 else float(foot[1])
        lx, ly = (min(hx, reach), min(hy, reach))
        x0, x1 = max(-hx, cx - lx), min(hx, cx + lx)
        y0, y1 = max(-hy, cy - ly), min(hy, cy + ly)
        v = np.array([[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0]], dtype=float)
        f = np.array([[0, 1, 2], [0, 2, 3]])
    return v @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g], f


def _clip(poly: np.ndarray, count: np.ndarray, normal: np.ndarray, offset: float) -> tuple[np.ndarray, np.ndarray]:
    """Clip every convex polygon (N, K, 3) of ``count`` (N,) corners by ``normal @ p <= offset``."""
    n, k = poly.shape[:2]
    idx = np.arange(k)[None, :]
    valid = idx < count[:, None]
    s = poly @ normal - offset
    nxt = np.where(idx + 1 < count[:, None], idx + 1, 0)
    pn, sn = np.take_along_axis(poly, nxt[:, :, None], axis=1), np.take_along_axis(s, nxt, axis=1)
    cin, nin = s <= 0, sn <= 0
    denom = s - sn
    t = s / np.where(denom == 0, 1.0, denom)
    inter = poly + t[:, :, None] * (pn - poly)
    cand = np.stack([poly, inter], axis=2).reshape(n, 2 * k, 3)
    keep = np.stack([cin & valid, (cin != nin) & valid], axis=2).reshape(n, 2 * k)
    order = np.argsort(~keep, axis=1, kind="stable")[:, :k]
    return np.take_along_axis(cand, order[:, :, None], axis=1), keep.sum(axis=1)


def _nearest(poly: np.ndarray, count: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The point (N, 3) of each planar convex polygon nearest to the origin."""
    n, k = poly.shape[:2]
    idx = np.arange(k)[None, :]
    valid = idx < count[:, None]
    foot = np.einsum("nj,nj->n", poly[:, 0], normal)[:, None] * normal  # the origin projected on the plane
    nxt = np.where(idx + 1 < count[:, None], idx + 1, 0)
    a = poly
    e = np.take_along_axis(poly, nxt[:, :, None], axis=1) - a
    side = np.einsum("nkj,nj->nk", np.cross(e, foot[:, None, :] - a), normal)
    inside = (count >= 3) & np.all((side >= -1e-12) | ~valid, axis=1)
    t = np.clip(np.einsum("nkj,nkj->nk", -a, e) / np.maximum(np.einsum("nkj,nkj->nk", e, e), 1e-300), 0.0, 1.0)
    q = a + t[:, :, None] * e
    dist = np.where(valid, np.linalg.norm(q, axis=2), np.inf)
    best = np.take_along_axis(q, np.argmin(dist, axis=1)[:, None, None], axis=1)[:, 0]
    return np.where(inside[:, None], foot, best)


def within_reach(m: mujoco.MjModel, d: mujoco.MjData, geoms: np.ndarray, centre: np.ndarray,
                 reach: float) -> np.ndarray:
    """Of ``geoms`` (indices), those whose bounding sphere (MuJoCo's ``geom_rbound`` about
    ``geom_xpos``) comes within ``reach`` (m) of ``centre`` (3,) world, and every plane (unbounded):
    what a sensor volume inside that sphere can meet at all.

    Args:
        m: the model.
        d: its data (after kinematics).
        geoms: geom indices (k,).
        centre: the centre of a sphere holding the volume, world (3,), m.
        reach: that sphere's radius, m.

    Returns:
        The geoms that may meet the sphere, indices (<= k,).
    """
    gaps = np.linalg.norm(d.geom_xpos[geoms] - centre, axis=1) - m.geom_rbound[geoms]
    return geoms[(gaps <= reach) | (m.geom_type[geoms] == _PLANE)]


def ball(points: np.ndarray) -> tuple[np.ndarray, float]:
    """A sphere holding ``points`` (k, 3) and so their convex hull: (centre (3,), radius m).

    Args:
        points: (k, 3) points, m.

    Returns:
        ``(centre, radius)``: their mean and the largest distance from it.
    """
    centre = points.mean(axis=0)
    return centre, float(np.linalg.norm(points - centre, axis=1).max())


def may_meet(m: mujoco.MjModel, d: mujoco.MjData, seen: np.ndarray, rot: np.ndarray, origin: np.ndarray,
             centre: np.ndarray, reach: float) -> bool:
    """Whether any ``seen`` geom may meet a sensor volume held by the sphere of ``centre`` (3,)
    in the sensor frame and radius ``reach``: False when every seen geom's bounding sphere lies
    beyond it, so that no ray inside it can reach a seen geom (a cheap test before casting them;
    a geom checked alone, ``simCheckProximitySensor``, is usually far from the volume).

    Args:
        m: the model.
        d: its data (after kinematics).
        seen: (ngeom,) the geoms that may be detected.
        rot: the sensor's frame (3, 3), world.
        origin: the sensor's origin (3,), world.
        centre: the sphere's centre in the sensor frame (3,), m (:func:`ball` of the volume's points).
        reach: its radius, m.

    Returns:
        False where no seen geom can meet the volume.
    """
    return bool(within_reach(m, d, np.flatnonzero(seen), origin + rot @ centre, reach + 1e-9).size)


def nearest_inside(m: mujoco.MjModel, d: mujoco.MjData, rot: np.ndarray, origin: np.ndarray, exclude: int,
                   seen: np.ndarray, planes: tuple[np.ndarray, np.ndarray, np.ndarray],
                   max_angle: float = math.pi / 2) -> tuple[float, int, np.ndarray, np.ndarray] | None:
    """The detection of a convex volume: the point nearest to the sensor's origin of the
    triangles of the ``seen`` geoms (:func:`triangle_geoms`; not of body ``exclude``) inside it.

    Args:
        m: the model.
        d: its data (after kinematics).
        rot: the sensor's frame (3, 3), world.
        origin: the sensor's origin (3,), world.
        exclude: the sensor's own body.
        seen: (ngeom,) the geoms that may be detected.
        planes: what :func:`pyramid` or :func:`cylinder` returned (sensor frame).
        max_angle: rad; a triangle is seen only where the line from the origin meets it at most
            this far from its normal (V-REP's "limited angle detection"); pi/2: every triangle.

    Returns:
        ``(distance m, geom, point (3,) sensor frame, surface normal (3,) world, facing the
        sensor)``, or None.
    """
    normals, offsets, corners = planes
    centre_local, reach = ball(corners)
    centre = origin + rot @ centre_local
    candidates = within_reach(m, d, np.flatnonzero(seen & triangle_geoms(m) & (m.geom_bodyid != exclude)),
                              centre, reach)
    if not candidates.size:
        return None
    tris, owner, crossings = [], [], []
    above = math.inf  # the distance of a vertex inside the volume: the answer is no farther
    for g in candidates:
        v, f = _geom_mesh(m, d, int(g), centre, reach)
        v = (v - origin) @ rot  # sensor frame
        side = v @ normals.T - offsets  # (v, planes): > 0 beyond that plane
        out = side > 0
        corner_out = out[f]  # (t, 3, planes)
        # a triangle whose three corners lie beyond one plane is outside
        keep = ~np.any(corner_out[:, 0] & corner_out[:, 1] & corner_out[:, 2], axis=1)
        if not keep.any():
            continue
        f = f[keep]
        inside = ~np.any(out, axis=1)[f]  # (t, 3) corners inside the volume
        if inside.any():
            above = min(above, float(np.linalg.norm(v, axis=1)[f][inside].min()))
        tris.append(v[f])
        crossings.append(np.any(corner_out[keep].reshape(len(f), -1), axis=1))
        owner.append(np.full(len(f), g))
    if not tris:
        return None
    tri, geom, crossing = np.concatenate(tris), np.concatenate(owner), np.concatenate(crossings)
    if max_angle >= math.pi / 2 and math.isfinite(above):
        # a triangle's points lie within its longest edge of each corner: leave those that cannot
        # come nearer than a vertex inside (most of a mesh or a tessellated sphere wholly inside)
        edge = np.linalg.norm(tri - tri[:, [1, 2, 0]], axis=2).max(axis=1)
        near = np.linalg.norm(tri, axis=2).max(axis=1) - edge <= above + 1e-9
        tri, geom, crossing = tri[near], geom[near], crossing[near]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(normal, axis=1)
    keep = area > 1e-18
    tri, geom, crossing, normal = tri[keep], geom[keep], crossing[keep], normal[keep] / area[keep, None]
    poly = np.zeros((len(tri), 3 + len(offsets), 3))
    poly[:, :3] = tri
    count = np.full(len(tri), 3)
    cut = np.flatnonzero(crossing)  # only the triangles with a corner beyond a plane are clipped
    if cut.size:
        part, part_count = poly[cut], count[cut]
        for n, off in zip(normals, offsets):
            part, part_count = _clip(part, part_count, n, float(off))
        poly[cut], count[cut] = part, part_count
    hit = count > 0
    if not hit.any():
        return None
    poly, count, normal, geom = poly[hit], count[hit], normal[hit], geom[hit]
    point = _nearest(poly[:, :int(count.max())], count, normal)  # no wider than the largest polygon
    dist = np.linalg.norm(point, axis=1)
    if max_angle < math.pi / 2:
        facing = np.abs(np.einsum("nj,nj->n", point, normal)) / np.maximum(dist, 1e-300)
        dist = np.where(facing >= math.cos(max_angle) - 1e-9, dist, np.inf)
    if not np.isfinite(dist.min()):
        return None
    # an edge or corner nearest: of the triangles that share it, the one that faces the origin most
    ties = np.flatnonzero(dist <= dist.min() + 1e-9)
    i = int(ties[np.argmax(np.abs(np.einsum("nj,nj->n", point[ties], normal[ties])))])
    n = normal[i] if float(point[i] @ normal[i]) <= 0 else -normal[i]
    return float(dist[i]), int(geom[i]), point[i], rot @ n
