"""CoppeliaSim 4.1's mesh decimation and convex decomposition (``sim.getDecimatedMesh``,
``sim.convexDecompose``) on libraries that do the same work: Fast Quadric Mesh Simplification
(the ``fast-simplification`` package) where CoppeliaSim calls OpenMesh's decimator, V-HACD (the
``vhacdx`` package, V-HACD 4, run in a bounded worker process: it holds the GIL for seconds) where
CoppeliaSim calls HACD or V-HACD 2. Both are imported when called; without them the call
answers an UnsupportedError that says what to install (``pip install simx[pyrep]``). Their results are the libraries' own, not CoppeliaSim's: the same kind
of mesh, not the same triangles.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api import long_calls
from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import shapes as _shapes
from simx_server.base import limits as L, vhacd_worker
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.sim.spec_tools import _names, set_mesh_data, solid_mesh, vrep_suffix
from simx_wire.protocol import ArgumentError, UnsupportedError

#: CoppeliaSim's V-HACD defaults (``CSceneObjectOperations::convexDecompose``'s statics): voxel
#: resolution, vertices per hull; and the bounds simx keeps them within (time and memory).
VHACD_RESOLUTION, VHACD_MAX_VERTICES = 100_000, 64
MAX_RESOLUTION, MAX_HULLS = 400_000, 64
#: The parameters of the last decomposition (CoppeliaSim keeps them in statics too: option bit 2
#: "same as last time").
_last: dict[str, int] = {"resolution": VHACD_RESOLUTION, "vertices": VHACD_MAX_VERTICES}


def _need(module: str, package: str, call: str) -> Any:
    try:
        return __import__(module)
    except ImportError:
        raise UnsupportedError(f"{call} needs the {package} package: pip install {package} "
                               "(or simx's pyrep extra)") from None


def _mesh_in(vertices: Any, indices: Any, call: str) -> tuple[np.ndarray, np.ndarray]:
    try:
        v = np.asarray(vertices, dtype=float).reshape(-1, 3)
        f = np.asarray(indices, dtype=np.int64).reshape(-1, 3)
    except (TypeError, ValueError):
        raise ArgumentError(f"{call}: vertices (3 numbers each) and indices (3 per triangle) must fit") from None
    if len(v) < 3 or len(f) < 1 or not np.all(np.isfinite(v)):
        raise ArgumentError(f"{call}: at least 3 finite vertices and one triangle")
    if len(v) > L.MAX_MESH_VERTICES or len(f) > 2 * L.MAX_MESH_VERTICES:
        raise ArgumentError(f"{call}: more than {L.MAX_MESH_VERTICES} vertices (limits.MAX_MESH_VERTICES)")
    if f.min() < 0 or f.max() >= len(v):
        raise ArgumentError(f"{call}: indices must name vertices")
    return v, f


@sim_function("getDecimatedMesh")
def getDecimatedMesh(ctx: CallContext, verticesIn: Any, indicesIn: Any,  # noqa: N802, N803
                     decimationPercentage: Any) -> tuple[list[float], list[int]]:  # noqa: N803
    """``verticesOut, indicesOut``: the mesh with about ``decimationPercentage`` of its
    triangles kept (CoppeliaSim's ``CMeshRoutines::getDecimatedMesh``: ``percentageToKeep``),
    by quadric edge collapse (``fast_simplification.simplify``).

    ``sim.getDecimatedMesh``.

    Args:
        verticesIn: 3n numbers, m.
        indicesIn: 3t integers.
        decimationPercentage: the fraction of triangles kept, in (0, 1].

    Returns:
        ``(vertices, indices)``: 3n' floats (m) and 3t' ints.

    Raises:
        ArgumentError: a bad mesh or fraction.
        UnsupportedError: fast-simplification is not installed.
    """
    v, f = _mesh_in(verticesIn, indicesIn, "getDecimatedMesh")
    keep = _num(decimationPercentage, "decimationPercentage")
    if not 0 < keep <= 1:
        raise ArgumentError("getDecimatedMesh: decimationPercentage is the fraction kept, in (0, 1]")
    fs = _need("fast_simplification", "fast-simplification", "getDecimatedMesh")
    out_v, out_f = fs.simplify(v.astype(np.float32), f.astype(np.int64), target_reduction=1.0 - keep)
    return np.asarray(out_v, float).reshape(-1).tolist(), np.asarray(out_f).reshape(-1).astype(int).tolist()


def _hulls(v: np.ndarray, f: np.ndarray, resolution: int, vertices: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """V-HACD's hulls, computed in a bounded worker process (:mod:`simx_server.base.vhacd_worker`:
    vhacdx holds the GIL for its whole run)."""
    try:
        parts = vhacd_worker.decompose(v, f, resolution, vertices, MAX_HULLS)
    except vhacd_worker.MissingPackageError:
        raise UnsupportedError("convexDecompose needs the vhacdx package: pip install vhacdx "
                               "(or simx's pyrep extra)") from None
    except vhacd_worker.DecompositionError as exc:
        raise UnsupportedError(f"convexDecompose: {exc}") from None
    hulls = [solid_mesh(np.asarray(p, float), np.asarray(t, np.int64)) for p, t in parts if len(t)]
    return [h for h in hulls if h is not None]  # a flat hull gets a back face, a line-like one goes


@sim_function("convexDecompose")
def convexDecompose(ctx: CallContext, shapeHandle: Any, options: Any, intParams: Any,  # noqa: N802, N803
                    floatParams: Any) -> int:  # noqa: N803
    """A shape made of the convex hulls of its mesh's approximate convex decomposition
    (V-HACD); its handle. As CoppeliaSim's ``CSceneObjectOperations::convexDecompose``:
    ``options`` bit 0 morphs the shape itself (its handle, pose, mass and inertia kept), else a
    new static, non-respondable shape at its pose is made (``CShape``'s defaults); bit 2 uses
    the last call's parameters; bit 7 takes V-HACD's parameters from ``intParams[5]``
    (resolution, CoppeliaSim's default 100000) and ``intParams[9]`` (vertices per hull, 64),
    else (HACD's parameters) V-HACD runs at CoppeliaSim's defaults with ``intParams[2]`` (HACD's
    vertices per hull). HACD's other parameters have no V-HACD counterpart.

    ``sim.convexDecompose``. A ZMQ client's V-HACD runs off the simulation thread
    (:mod:`simx_server.api.long_calls`): the simulation goes on, its reply leaves once the shape
    is made.

    Args:
        shapeHandle: a shape of mesh and box geoms.
        options: bits as said.
        intParams: 10 integers (PyRep's order).
        floatParams: 10 numbers (checked).

    Returns:
        The decomposed shape's handle.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: parameters that do not fit.
        UnsupportedError: vhacdx is not installed; a shape with other primitives; no simulation.
    """
    obj = _shapes.shape_of(ctx, shapeHandle)
    opts = _int(options, "options")
    ints = [_int(x, "intParams[i]") for x in (intParams or [])]
    [_num(x, "floatParams[i]") for x in (floatParams or [])]
    if not opts & 4:
        if opts & 128 and len(ints) >= 10:
            _last.update(resolution=ints[5], vertices=ints[9])
        else:
            _last.update(resolution=VHACD_RESOLUTION, vertices=ints[2] if len(ints) >= 3 else VHACD_MAX_VERTICES)
    resolution = min(max(_last["resolution"], 10_000), MAX_RESOLUTION)
    per_hull = min(max(_last["vertices"], 4), 1024)
    verts, idx, _ = _shapes.getShapeMesh(ctx, obj.handle)
    v, f = np.asarray(verts, float).reshape(-1, 3), np.asarray(idx).reshape(-1, 3)
    sim = ctx.simulation("convexDecompose")
    world = sim.world
    m, d, b = world.model, world.data, obj.mj_id
    first = int(np.flatnonzero(m.geom_bodyid == b)[0])
    rgba = m.geom_rgba[first].tolist()
    bits = (int(m.geom_contype[first]), int(m.geom_conaffinity[first]))
    inertial = (float(m.body_mass[b]), m.body_ipos[b].tolist(), m.body_iquat[b].tolist(), m.body_inertia[b].tolist())
    pose = (d.xpos[b].tolist(), d.xquat[b].tolist())

    def work() -> list[tuple[np.ndarray, np.ndarray]]:  # reads only the mesh copied above
        return _hulls(v, f, resolution, per_hull)

    def finish(hulls: list[tuple[np.ndarray, np.ndarray]]) -> int:  # the simulation thread
        if not hulls:
            raise UnsupportedError(f"convexDecompose: V-HACD found no hull in {obj.name!r}'s mesh")
        same = world.by_name.get(obj.name)
        if sim.world is not world or same is None or same.handle != obj.handle:
            raise ArgumentError(f"convexDecompose: {obj.name!r} or its scene changed while V-HACD ran")
        return int(sim.editor._edit(lambda spec: change(spec, hulls)))

    def change(spec: mujoco.MjSpec, hulls: list[tuple[np.ndarray, np.ndarray]]):
        taken = _names(spec) | set(world.by_name)
        if opts & 1:
            _, body, _ = sim.editor._spec_element(spec, obj.handle)
            for geom in list(body.geoms):
                spec.delete(geom)
            body.explicitinertial = True
            body.mass, body.ipos, body.iquat, body.inertia = inertial
            name, contact = obj.name, bits
        else:
            name = "Shape" + vrep_suffix({"Shape"}, taken)
            body = spec.worldbody.add_body(name=name, pos=pose[0], quat=pose[1])
            contact = (0, 0)
        for k, (hv, hf) in enumerate(hulls):
            mesh = spec.add_mesh(name=f"{name}_hull{k}" + vrep_suffix({f"{name}_hull{k}"}, taken))
            set_mesh_data(spec, mesh, hv, hf)
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # thin hulls too (the mass is the shape's)
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh.name, rgba=rgba,
                          contype=contact[0], conaffinity=contact[1])
        return lambda: world.resolve(name).handle

    # a ZMQ client's decomposition runs off the simulation thread, its shape made on it once done
    return long_calls.later(ctx, work, finish)  # type: ignore[no-any-return]
