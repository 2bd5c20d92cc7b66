"""CoppeliaSim 4.x's mass and inertia functions of shapes: ``sim.getShapeMass``, ``sim.setShapeMass``,
``sim.getShapeInertia``, ``sim.setShapeInertia``, ``sim.computeMassAndInertia``, on the MuJoCo
body of the shape (its ``body_mass``, ``body_inertia``, ``body_iquat``, ``body_ipos``), written
into the scene's MjSpec as well so that later edits keep them.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import shapes as _shapes
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base import limits as L
from simx_server.base.arguments import as_number as _num, as_vector as _vector
from simx_server.api.sim.shapes import _geoms
from simx_server.sim import physics


# Mass and inertia of shapes (``_shape`` comes from :mod:`simx_server.api.sim.shapes`).

@sim_function("getShapeMass")
def getShapeMass(ctx: CallContext, shapeHandle: Any) -> float:  # noqa: N802, N803
    """Mass of the shape's body (kg).

    ``sim.getShapeMass``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.

    Returns:
        kg.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
    """
    return float(ctx.world.model.body_mass[_shapes.shape_of(ctx, shapeHandle).mj_id])


@sim_function("setShapeMass")
def setShapeMass(ctx: CallContext, shapeHandle: Any, mass: Any) -> None:  # noqa: N802, N803
    """Set the body's mass (kg, within limits.MIN_MASS..MAX_MASS); its inertia scales with it,
    as CoppeliaSim keeps the mass-divided inertia.

    ``sim.setShapeMass``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        mass: kg.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: a mass out of range, or not a number.
    """
    obj = _shapes.shape_of(ctx, shapeHandle)
    new = _num(mass, "mass")
    if not L.MIN_MASS <= new <= L.MAX_MASS:
        raise ArgumentError(f"mass must lie in [{L.MIN_MASS}, {L.MAX_MASS}] kg, got {new}")
    m = ctx.world.model
    old = float(m.body_mass[obj.mj_id])
    m.body_inertia[obj.mj_id] *= new / old if old > 0 else 1.0
    m.body_mass[obj.mj_id] = new
    _spec_inertial(ctx, obj)


@sim_function("getShapeInertia")
def getShapeInertia(ctx: CallContext, shapeHandle: Any) -> tuple[list[float], list[float]]:  # noqa: N802, N803
    """``inertiaMatrix, transformationMatrix``: the 3x3 inertia tensor (kg·m², 9 numbers row
    by row) about the centre of mass, in the frame whose pose relative to the shape's frame
    the 12-number matrix gives (MuJoCo's principal frame: the tensor is diagonal).

    ``sim.getShapeInertia``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.

    Returns:
        ``(inertiaMatrix, transformationMatrix)``: 9 floats (kg·m²) and 12 floats (m).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
    """
    obj = _shapes.shape_of(ctx, shapeHandle)
    m = ctx.world.model
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, m.body_iquat[obj.mj_id])
    pose = np.hstack([rot.reshape(3, 3), m.body_ipos[obj.mj_id].reshape(3, 1)])
    return np.diag(m.body_inertia[obj.mj_id]).reshape(9).tolist(), pose.reshape(12).tolist()


@sim_function("setShapeInertia")
def setShapeInertia(ctx: CallContext, shapeHandle: Any, inertiaMatrix: Any, transformationMatrix: Any) -> None:  # noqa: N802, N803
    """Set the inertia tensor (9 numbers, kg·m², symmetric positive definite) about the centre
    of mass placed by ``transformationMatrix`` (12 numbers, relative to the shape's frame).

    ``sim.setShapeInertia``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        inertiaMatrix: 9 numbers, kg·m², row by row.
        transformationMatrix: 12 numbers (3x4 row-major, m).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: a tensor that is not symmetric positive definite, or wrong lengths.
    """
    obj = _shapes.shape_of(ctx, shapeHandle)
    tensor = np.array(_vector(inertiaMatrix, 9, "inertiaMatrix")).reshape(3, 3)
    pose = np.array(_vector(transformationMatrix, 12, "transformationMatrix")).reshape(3, 4)
    if not np.allclose(tensor, tensor.T, atol=1e-9):
        raise ArgumentError("inertiaMatrix must be symmetric")
    values, axes = np.linalg.eigh(pose[:, :3] @ tensor @ pose[:, :3].T)
    if values.min() <= 0:
        raise ArgumentError("inertiaMatrix must be positive definite")
    if np.linalg.det(axes) < 0:
        axes[:, 0] *= -1
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, axes.reshape(9).copy())
    m = ctx.world.model
    m.body_inertia[obj.mj_id], m.body_iquat[obj.mj_id], m.body_ipos[obj.mj_id] = values, quat, pose[:, 3]
    _spec_inertial(ctx, obj)


def _spec_inertial(ctx: CallContext, obj: Any) -> None:
    """Write the body's inertial values into the scene's MjSpec (they survive later edits) and
    recompute MuJoCo's constants derived from them."""
    sim = ctx.view
    try:
        body = sim.editor._live_spec().body(obj.name) if sim is not None else None
    except UnsupportedError:
        body = None
    m = ctx.world.model
    if body is not None:
        body.explicitinertial = True
        body.mass, body.ipos = float(m.body_mass[obj.mj_id]), m.body_ipos[obj.mj_id].copy()
        body.iquat, body.inertia = m.body_iquat[obj.mj_id].copy(), m.body_inertia[obj.mj_id].copy()
    physics.mass_constants(m, ctx.world.data)  # subtree masses, constraint weights: stale otherwise
    ctx.world.changed()


@sim_function("computeMassAndInertia")
def computeMassAndInertia(ctx: CallContext, shapeHandle: Any, density: Any) -> int:  # noqa: N802, N803
    """The body's mass from its geoms' volumes at ``density`` (kg/m³) (boxes, spheres,
    ellipsoids, cylinders, capsules; mesh geoms count no volume: MuJoCo's model keeps none); the inertia scales with the mass. Returns 1 (0: no volume, unchanged).

    ``sim.computeMassAndInertia``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        density: kg/m³, in (0, 1e5].

    Returns:
        1, or 0.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: a density out of range.
    """
    obj = _shapes.shape_of(ctx, shapeHandle)
    rho = _num(density, "density")
    if not 0 < rho <= 1e5:
        raise ArgumentError("density must lie in (0, 1e5] kg/m³")
    m = ctx.world.model
    old = float(m.body_mass[obj.mj_id])
    volume = sum(_volume(m, int(g)) for g in _geoms(ctx.world, obj.mj_id))
    if volume <= 0 or old <= 0:
        return 0
    setShapeMass(ctx, shapeHandle, min(max(rho * volume, L.MIN_MASS), L.MAX_MASS))
    return 1




def _volume(m: mujoco.MjModel, g: int) -> float:
    """Volume of geom ``g`` (m³) as MuJoCo measured it: its mass at its density."""
    s = m.geom_size[g]
    kind = int(m.geom_type[g])
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return float(8 * s[0] * s[1] * s[2])
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return float(4 / 3 * np.pi * s[0] ** 3)
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return float(4 / 3 * np.pi * s[0] * s[1] * s[2])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return float(np.pi * s[0] ** 2 * 2 * s[1])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return float(np.pi * s[0] ** 2 * 2 * s[1] + 4 / 3 * np.pi * s[0] ** 3)
    return 0.0  # meshes: MuJoCo 3.x's model keeps no mesh volume
