"""CoppeliaSim 4.x's shapes built from data at run time on the scene's MjSpec:
``sim.createHeightfieldShape`` (a MuJoCo
height field), ``sim.groupShapes`` and ``sim.ungroupShape`` (geoms gathered into one body or
spread over bodies of their own). Each edit recompiles the scene as the scene editor does.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import core as _core
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_server.sim import friction, mechanisms
from simx_server.sim.objects import SHAPE
from simx_server.sim.spec_tools import _names, vrep_suffix

MAX_HEIGHTFIELD_POINTS = 4_000_000

_COPIED = ("name", "material", "meshname", "hfieldname", "rgba", "contype", "conaffinity", "condim", "friction",
           "priority", "margin", "gap", "solref", "solimp", "solmix", "group", "density", "mass")


def _mul(qa: np.ndarray, qb: Any) -> list[float]:
    q = np.empty(4)
    mujoco.mju_mulQuat(q, qa, np.asarray(qb, float))
    return q.tolist()


def _copy_geom(m: mujoco.MjModel, g: int, src: Any, dst_body: Any, rd: np.ndarray, pd: np.ndarray) -> None:
    """Add to ``dst_body`` a copy of geom ``g`` (spec element ``src``), its pose re-expressed by
    the frame change (rd, pd): primitives from the compiled model (``fromto`` resolved), meshes
    from the spec (MuJoCo recentres a mesh when it compiles it)."""
    qd = np.empty(4)
    mujoco.mju_mat2Quat(qd, np.ascontiguousarray(rd).reshape(9))
    if int(m.geom_type[g]) == mujoco.mjtGeom.mjGEOM_MESH:
        pos, quat, size = np.asarray(src.pos, float), np.asarray(src.quat, float), list(src.size)
    else:
        pos, quat, size = m.geom_pos[g].copy(), m.geom_quat[g].copy(), m.geom_size[g].tolist()
    geom = dst_body.add_geom(type=mujoco.mjtGeom(int(m.geom_type[g])), size=size, pos=(rd @ pos + pd).tolist(),
                             quat=_mul(qd, quat / np.linalg.norm(quat)))
    for attr in _COPIED:
        setattr(geom, attr, getattr(src, attr))



# Height fields, grouping and ungrouping of shapes.

@sim_function("createHeightfieldShape")
def createHeightfieldShape(ctx: CallContext, options: Any, shadingAngle: Any, xPointCount: Any, yPointCount: Any,  # noqa: N802, N803
                           xSize: Any, heights: Any) -> int:  # noqa: N803
    """A static height-field shape centred on the world origin; its handle. ``heights``
    (m): ``xPointCount`` x ``yPointCount`` values, x varying fastest, the first row at -y;
    ``xSize`` (m) spans the x points, the y points keep the same spacing. The heights are
    the surface's z in the shape's frame (MuJoCo's height field sits on its lowest point).
    ``options`` and ``shadingAngle`` (display) have no meaning for MuJoCo.

    ``sim.createHeightfieldShape``.

    Args:
        options: checked.
        shadingAngle: checked (rad).
        xPointCount: at least 2.
        yPointCount: at least 2.
        xSize: m.
        heights: xPointCount * yPointCount numbers, m.

    Returns:
        The shape's handle.

    Raises:
        ArgumentError: counts or sizes out of range, or heights of the wrong length.
        UnsupportedError: no simulation behind the script.
    """
    _int(options, "options")
    _num(shadingAngle, "shadingAngle")
    nx, ny, size = _int(xPointCount, "xPointCount"), _int(yPointCount, "yPointCount"), _num(xSize, "xSize")
    if nx < 2 or ny < 2 or nx * ny > MAX_HEIGHTFIELD_POINTS:
        raise ArgumentError(f"xPointCount and yPointCount must be at least 2 (at most {MAX_HEIGHTFIELD_POINTS} points)")
    if not 0 < size <= 1e5:
        raise ArgumentError("xSize must lie in (0, 100000] m")
    if not isinstance(heights, (list, tuple, np.ndarray)) or len(heights) != nx * ny:
        raise ArgumentError(f"heights must hold xPointCount * yPointCount = {nx * ny} numbers")
    z = np.array([_num(v, "heights[i]") for v in heights], dtype=float)
    if not np.isfinite(z).all():
        raise ArgumentError("heights must be finite")
    low, span = float(z.min()), float(z.max() - z.min())
    elevation = span if span > 0 else 1e-6
    data = ((z - low) / elevation).tolist()
    rx, ry = size / 2, size / (nx - 1) * (ny - 1) / 2
    sim = ctx.simulation("createHeightfieldShape")

    def change(spec: mujoco.MjSpec):
        suffix = vrep_suffix({"Heightfield", "Heightfield_data"}, _names(spec) | set(sim.world.by_name))
        field = spec.add_hfield(name=f"Heightfield_data{suffix}", nrow=ny, ncol=nx,
                                size=[rx, ry, elevation, max(elevation, size) * 0.05], userdata=data)
        body = spec.worldbody.add_body(name=f"Heightfield{suffix}")
        geom = body.add_geom(type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname=field.name, pos=[0, 0, low],
                             rgba=[0.8, 0.8, 0.8, 1])
        mechanisms.rigid_contact(geom, spec.option.timestep)  # static: V-REP's rigid contact
        friction.new_shape(spec, geom)  # CoppeliaSim's default material in a V-REP scene
        return lambda: sim.world.resolve(f"Heightfield{suffix}").handle

    return sim.editor._edit(change)


def _loose_shape(ctx: CallContext, handle: Any, what: str) -> Any:
    """A shape (body) that is static or free, with no child body, site or camera."""
    obj = ctx.world.get(ctx.h(handle, what), SHAPE)
    m = ctx.world.model
    b = obj.mj_id
    if int(m.body_jntnum[b]) > 1 or (int(m.body_jntnum[b]) == 1
                                      and int(m.jnt_type[m.body_jntadr[b]]) != mujoco.mjtJoint.mjJNT_FREE):
        raise UnsupportedError(f"{obj.name!r} moves on joints: only static and free shapes are grouped")
    if np.any(m.body_parentid[1:] == b) or np.any(m.site_bodyid == b) or np.any(m.cam_bodyid == b):
        raise UnsupportedError(f"{obj.name!r} carries other objects (bodies, dummies, sensors): detach them first")
    return obj


@sim_function("groupShapes")
def groupShapes(ctx: CallContext, shapeHandles: Any, merge: Any = False) -> int:  # noqa: N802, N803
    """Gather the shapes' geoms into the first shape's body (their world poses kept; the other
    bodies go) and return its handle: CoppeliaSim's compound shape. The compound keeps the
    first shape's frame, joint and name; its inertia is MuJoCo's from the geoms (unless the
    first has explicit inertia). ``merge`` true groups too (MuJoCo keeps each geom; no mesh
    is fused). Shapes on joints other than a free joint, or carrying other objects:
    UnsupportedError.

    ``sim.groupShapes``.

    Args:
        shapeHandles: at least 2 shape handles.
        merge: grouped as well.

    Returns:
        The compound shape's handle.

    Raises:
        ArgumentError: fewer than 2 shapes, or one twice.
        UnknownObjectError: no such object.
        UnsupportedError: as said above, or no simulation behind the script.
    """
    if not isinstance(shapeHandles, (list, tuple)) or len(shapeHandles) < 2:
        raise ArgumentError("shapeHandles must hold at least 2 shape handles")
    objs = [_loose_shape(ctx, h, "shapeHandles[i]") for h in shapeHandles]
    if len({o.handle for o in objs}) != len(objs):
        raise ArgumentError("shapeHandles holds a shape twice")
    m = ctx.world.model
    first = objs[0]
    r_a, p_a = _core.frame_of(ctx, first.handle)
    moves = []
    for o in objs[1:]:
        r_b, p_b = _core.frame_of(ctx, o.handle)
        moves.append((o, r_a.T @ r_b, r_a.T @ (p_b - p_a), np.flatnonzero(m.geom_bodyid == o.mj_id)))
    sim = ctx.simulation("groupShapes")

    def change(spec: mujoco.MjSpec):
        target = spec.body(first.name)
        for o, rd, pd, geoms in moves:
            body = spec.body(o.name)
            sources = list(body.geoms)
            if len(sources) != len(geoms):
                raise ValueError(f"{o.name!r}'s geoms do not match its compiled model")
            for g, src in zip(geoms, sources):
                _copy_geom(m, int(g), src, target, rd, pd)
            spec.delete(body)
        return lambda: sim.world.resolve(first.name).handle

    return sim.editor._edit(change)


@sim_function("ungroupShape")
def ungroupShape(ctx: CallContext, shapeHandle: Any) -> list[int]:  # noqa: N802, N803
    """Spread a compound shape's geoms over shapes of their own: the first geom stays in the
    shape, each other gets a new body (named after the shape) at its world pose, with a free
    joint when the shape had one. Returns the handles, the shape's first; a simple shape:
    ``[shapeHandle]``.

    ``sim.ungroupShape``.

    Args:
        shapeHandle: a shape's handle.

    Returns:
        The shapes' handles.

    Raises:
        UnknownObjectError: no such object.
        UnsupportedError: a shape on a joint other than a free one, or no simulation.
    """
    obj = _loose_shape(ctx, shapeHandle, "shapeHandle")
    m = ctx.world.model
    geoms = np.flatnonzero(m.geom_bodyid == obj.mj_id)
    if len(geoms) < 2:
        return [obj.handle]
    free = int(m.body_jntnum[obj.mj_id]) == 1
    rot, pos = _core.frame_of(ctx, obj.handle)
    sim = ctx.simulation("ungroupShape")

    def change(spec: mujoco.MjSpec):
        body = spec.body(obj.name)
        sources = list(body.geoms)
        if len(sources) != len(geoms):
            raise ValueError(f"{obj.name!r}'s geoms do not match its compiled model")
        taken = _names(spec) | set(sim.world.by_name)
        names = []
        for g, src in zip(geoms[1:], sources[1:]):
            k = 0
            while f"{obj.name}_{k}" in taken:
                k += 1
            name = f"{obj.name}_{k}"
            taken.add(name)
            qd = np.empty(4)
            mujoco.mju_mat2Quat(qd, np.ascontiguousarray(rot).reshape(9))
            part = spec.worldbody.add_body(name=name, pos=pos.tolist(), quat=qd.tolist())
            if free:
                part.add_freejoint()
            _copy_geom(m, int(g), src, part, np.eye(3), np.zeros(3))
            spec.delete(src)
            names.append(name)
        return lambda: [sim.world.resolve(obj.name).handle] + [sim.world.resolve(n).handle for n in names]

    return sim.editor._edit(change)


