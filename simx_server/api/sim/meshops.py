"""CoppeliaSim 4.x's shape frame and size edits on the scene's MjSpec: ``sim.relocateShapeFrame`` (the body's frame
moves, its geoms, sites, cameras, lights, inertia and child bodies stay where they are in the
world), ``sim.alignShapeBB`` (the same, turning the frame), ``sim.setShapeBB`` and ``sim.scaleObjects`` (through ``sim.scaleObject``'s geom
scaling). Each edit recompiles the scene as the scene editor does.
"""

from __future__ import annotations

from typing import Any

import cv2
import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import core as _core
from simx_server.api.sim import shapes as _shapes
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_vector as _vector
from simx_server.sim.objects import SHAPE, WORLD
from simx_server.sim.old_paths import matrix_to_quat
from simx_server.sim.rotations import matrix_from_quaternion, quaternion_from_matrix


def _moved(pos: Any, quat: Any, rd: np.ndarray, pd: np.ndarray) -> tuple[list[float], list[float]]:
    """A local pose (MuJoCo pos, quat w-first) re-expressed after the frame change (rd, pd)."""
    q = np.empty(4)
    mujoco.mju_mulQuat(q, matrix_to_quat(rd), np.asarray(quat, float) / np.linalg.norm(quat))
    return (rd @ np.asarray(pos, float) + pd).tolist(), q.tolist()


# Shape frame relocation and bounding-box sizing.

def _shape_frame(ctx: CallContext, handle: int) -> tuple[np.ndarray, np.ndarray]:
    m = np.array(ctx.sim.getObjectMatrix(handle, -1), dtype=float).reshape(3, 4)
    return m[:, :3], m[:, 3]


@sim_function("relocateShapeFrame")
def relocateShapeFrame(ctx: CallContext, shapeHandle: Any, pose: Any) -> int:  # noqa: N802, N803
    """Move a shape's reference frame to ``pose`` (x, y, z, qx, qy, qz, qw; world) without
    moving its geometry; seven zeros: to the centre of its bounding box, axes kept. Shapes
    moved by joints other than a free joint: UnsupportedError (their joints are placed in
    the frame). Returns 1.

    ``sim.relocateShapeFrame``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        pose: 7 numbers (m and a quaternion), or seven zeros.

    Returns:
        1.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: not 7 numbers.
        UnsupportedError: as said above, or no simulation behind the script.
    """
    obj = ctx.world.get(ctx.h(shapeHandle, "shapeHandle"), SHAPE)
    v = _vector(pose, 7, "pose")
    m = ctx.world.model
    b = obj.mj_id
    free = int(m.body_jntnum[b]) == 1 and int(m.jnt_type[m.body_jntadr[b]]) == mujoco.mjtJoint.mjJNT_FREE
    if int(m.body_jntnum[b]) and not free:
        raise UnsupportedError(f"relocateShapeFrame: {obj.name!r} moves on joints placed in its frame "
                               "(only static and free shapes)")
    r_old, p_old = _shape_frame(ctx, obj.handle)
    if not any(v):
        c = _shapes.corners(ctx, b)
        r_new, p_new = r_old, r_old @ ((c.max(axis=0) + c.min(axis=0)) / 2) + p_old
    else:
        if not np.linalg.norm(v[3:]) > 0:
            raise ArgumentError("pose's quaternion must not be zero")
        r_new, p_new = np.asarray(matrix_from_quaternion(*v[3:]), float), np.array(v[:3])
    rd, pd = r_new.T @ r_old, r_new.T @ (p_old - p_new)  # old frame in the new one
    parent = ctx.world.objects[obj.handle].parent
    if parent == WORLD:
        r_par, p_par = np.eye(3), np.zeros(3)
    else:
        r_par, p_par = _shape_frame(ctx, parent)
    local_p, local_r = r_par.T @ (p_new - p_par), r_par.T @ r_new
    sim = ctx.simulation("relocateShapeFrame")

    def change(spec: mujoco.MjSpec) -> None:
        body = spec.body(obj.name)
        for items in (body.geoms, body.sites, body.cameras, body.lights, body.bodies, body.frames):
            for el in items:
                if getattr(el, "frame", None) is None:  # in a frame: moves with it
                    el.pos, el.quat = _moved(el.pos, el.quat, rd, pd)
        if body.explicitinertial:
            body.ipos, body.iquat = _moved(body.ipos, body.iquat, rd, pd)
        body.pos, body.quat = local_p.tolist(), matrix_to_quat(local_r).tolist()

    sim.editor._edit(change)
    # the compiled pose is the start; an edit keeps where a free, mocap or static body is now (the
    # state, or a static body's pose set at run time): put the new frame there
    _core.set_pose(ctx, obj.handle, WORLD, position=p_new.tolist(), rotation=r_new)
    return 1


@sim_function("setShapeBB")
def setShapeBB(ctx: CallContext, shapeHandle: Any, size: Any) -> None:  # noqa: N802, N803
    """Scale a shape so that its bounding box (its frame) measures ``size`` x, y, z (m), as
    :func:`~simx_server.api.sim.mesh.scaleObject` scales it (each axis by new size / current size).

    ``sim.setShapeBB``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        size: 3 positive numbers, m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: sizes that are not positive, or factors out of range.
        UnsupportedError: a geom that cannot take the factors, or no simulation.
    """
    h = ctx.h(shapeHandle, "shapeHandle")
    new = np.array(_vector(size, 3, "size"))
    old = np.array(ctx.sim.getShapeBB(h))
    if not np.all(new > 0):
        raise ArgumentError("size must be positive")
    f = np.where(old > 1e-12, new / np.maximum(old, 1e-12), 1.0)
    ctx.sim.scaleObject(h, *f.tolist())


@sim_function("scaleObjects")
def scaleObjects(ctx: CallContext, objectHandles: Any, scalingFactor: Any, scalePositionsToo: Any) -> None:  # noqa: N802, N803
    """Scale shapes by ``scalingFactor`` (0.001..1000, as :func:`~simx_server.api.sim.mesh.scaleObject`); with
    ``scalePositionsToo``, each object's position relative to its parent scales too (other
    objects than shapes only move).

    ``sim.scaleObjects``.

    Args:
        objectHandles: list of handles.
        scalingFactor: 0.001..1000.
        scalePositionsToo: bool or 0/1.

    Raises:
        ArgumentError: an empty or bad list, or a factor out of range.
        UnknownObjectError: no such object.
        UnsupportedError: a geom that cannot be scaled, or no simulation behind the script.
    """
    if not isinstance(objectHandles, (list, tuple)) or not objectHandles:
        raise ArgumentError("objectHandles must be a table of handles")
    f = _num(scalingFactor, "scalingFactor")
    if not 1e-3 <= f <= 1e3:
        raise ArgumentError("scalingFactor must lie in [0.001, 1000]")
    move = bool(scalePositionsToo) if isinstance(scalePositionsToo, bool) else bool(_int(scalePositionsToo, "x"))
    handles = [ctx.world.get(ctx.h(x, "objectHandles[i]")).handle for x in objectHandles]
    local = {h: ctx.sim.getObjectPosition(h, ctx.world.objects[h].parent) for h in handles}
    for h in handles:
        if ctx.world.objects[h].type == SHAPE:
            ctx.sim.scaleObject(h, f, f, f)
    if move:
        for h in handles:
            parent = ctx.world.objects[h].parent
            ctx.sim.setObjectPosition(h, parent, [c * f for c in local[h]])




def box_axes(points: np.ndarray) -> np.ndarray:
    """Axes (3, 3), columns x, y, z, of a small box around ``points`` (n, 3), as CoppeliaSim's
    ``CAlgos::getMainAxis`` searches for them: among the points' principal axes, and about each
    the rectangle of least area around the points projected across it (OpenCV's
    ``minAreaRect``), the box of least volume; x its shortest side, z its longest
    (``getMainAxis``'s order), right-handed.

    Args:
        points: (n, 3), n >= 1.

    Returns:
        A rotation matrix (3, 3).
    """
    centred = points - points.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    pca = np.eye(3) if vt.shape[0] < 3 else vt.T
    best, best_volume = pca, np.inf
    for k in range(3):
        axis = pca[:, k]
        a, b = pca[:, (k + 1) % 3], pca[:, (k + 2) % 3]
        flat = np.column_stack([centred @ a, centred @ b]).astype(np.float32)
        (_, _), (_, _), angle = cv2.minAreaRect(flat)
        c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
        u, w = c * a + s * b, -s * a + c * b
        axes = np.column_stack([u, w, axis])
        extent = np.ptp(centred @ axes, axis=0)
        if float(np.prod(extent)) < best_volume - 1e-15:
            best, best_volume = axes, float(np.prod(extent))
    order = np.argsort(np.ptp(centred @ best, axis=0))  # x shortest, z longest
    best = best[:, order]
    if np.linalg.det(best) < 0:
        best[:, 0] = -best[:, 0]
    return best


@sim_function("alignShapeBB")
def alignShapeBB(ctx: CallContext, shapeHandle: Any, pose: Any) -> int:  # noqa: N802, N803
    """Align a shape's bounding box with ``pose``'s orientation (world), or with its mesh
    (seven zeros, or a zero quaternion: the smallest box, :func:`box_axes`); 1, or 0 for a
    shape of one primitive (coppeliaSimLib ``simAlignShapeBB_internal``: pure shapes keep
    theirs). simx's bounding box lies along the shape's frame (``sim.getShapeBB``), so the
    frame turns there about its origin (:func:`relocateShapeFrame`: the geometry stays where it
    is); CoppeliaSim keeps a bounding-box frame apart from the shape's.

    ``sim.alignShapeBB`` (4.1's ``simReorientShapeBoundingBox``).

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        pose: 7 numbers (x, y, z ignored; qx, qy, qz, qw in the world frame), or seven zeros.

    Returns:
        1, or 0 for a shape of one primitive.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: not 7 numbers.
        UnsupportedError: as :func:`relocateShapeFrame`, or no simulation behind the caller.
    """
    obj = ctx.world.get(ctx.h(shapeHandle, "shapeHandle"), SHAPE)
    v = _vector(pose, 7, "pose")
    m = ctx.world.model
    geoms = np.flatnonzero(m.geom_bodyid == obj.mj_id)
    if len(geoms) == 1 and int(m.geom_type[geoms[0]]) != int(mujoco.mjtGeom.mjGEOM_MESH):
        return 0
    r_old, p_old = _shape_frame(ctx, obj.handle)
    if not np.linalg.norm(v[3:]) > 0:
        r_new = r_old @ box_axes(_shapes.corners(ctx, obj.mj_id))
    else:
        r_new = np.asarray(matrix_from_quaternion(*v[3:]), float)
    relocateShapeFrame(ctx, obj.handle, [*p_old.tolist(), *quaternion_from_matrix(r_new)])
    return 1
