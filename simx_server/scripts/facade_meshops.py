"""CoppeliaSim 4.x's shape frame and size edits on the scene's MjSpec (mixin of
:class:`simx_server.scripts.facade.ScriptSim`): ``sim.relocateShapeFrame`` (the body's frame
moves, its geoms, sites, cameras, lights, inertia and child bodies stay where they are in the
world), ``sim.setShapeBB`` and ``sim.scaleObjects`` (through ``sim.scaleObject``'s geom
scaling). Each edit recompiles the scene as the scene editor does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_vector as _vector
from simx_server.sim.objects import SHAPE, WORLD
from simx_server.sim.rotations import matrix_from_quaternion
from simx_server.sim.state import SimulationView


def _quat(rot: np.ndarray) -> np.ndarray:
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot).reshape(9))
    return q


def _moved(pos: Any, quat: Any, rd: np.ndarray, pd: np.ndarray) -> tuple[list[float], list[float]]:
    """A local pose (MuJoCo pos, quat w-first) re-expressed after the frame change (rd, pd)."""
    q = np.empty(4)
    mujoco.mju_mulQuat(q, _quat(rd), np.asarray(quat, float) / np.linalg.norm(quat))
    return (rd @ np.asarray(pos, float) + pd).tolist(), q.tolist()


class MeshOpCalls:
    """Shape frame relocation and bounding-box sizing (facade mixin)."""

    def _shape_frame(self, handle: int) -> tuple[np.ndarray, np.ndarray]:
        m = np.array(self.getObjectMatrix(handle, -1), dtype=float).reshape(3, 4)
        return m[:, :3], m[:, 3]

    def relocateShapeFrame(self, shapeHandle: Any, pose: Any) -> int:  # noqa: N802, N803
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
        obj = self._world.get(self._h(shapeHandle, "shapeHandle"), SHAPE)
        v = _vector(pose, 7, "pose")
        m = self._world.model
        b = obj.mj_id
        free = int(m.body_jntnum[b]) == 1 and int(m.jnt_type[m.body_jntadr[b]]) == mujoco.mjtJoint.mjJNT_FREE
        if int(m.body_jntnum[b]) and not free:
            raise UnsupportedError(f"relocateShapeFrame: {obj.name!r} moves on joints placed in its frame "
                                   "(only static and free shapes)")
        r_old, p_old = self._shape_frame(obj.handle)
        if not any(v):
            c = self._corners(b)
            r_new, p_new = r_old, r_old @ ((c.max(axis=0) + c.min(axis=0)) / 2) + p_old
        else:
            if not np.linalg.norm(v[3:]) > 0:
                raise ArgumentError("pose's quaternion must not be zero")
            r_new, p_new = np.asarray(matrix_from_quaternion(*v[3:]), float), np.array(v[:3])
        rd, pd = r_new.T @ r_old, r_new.T @ (p_old - p_new)  # old frame in the new one
        parent = self._world.objects[obj.handle].parent
        if parent == WORLD:
            r_par, p_par = np.eye(3), np.zeros(3)
        else:
            r_par, p_par = self._shape_frame(parent)
        local_p, local_r = r_par.T @ (p_new - p_par), r_par.T @ r_new
        sim = self._simulation("relocateShapeFrame")

        def change(spec: mujoco.MjSpec) -> None:
            body = spec.body(obj.name)
            for items in (body.geoms, body.sites, body.cameras, body.lights, body.bodies, body.frames):
                for el in items:
                    if getattr(el, "frame", None) is None:  # in a frame: moves with it
                        el.pos, el.quat = _moved(el.pos, el.quat, rd, pd)
            if body.explicitinertial:
                body.ipos, body.iquat = _moved(body.ipos, body.iquat, rd, pd)
            body.pos, body.quat = local_p.tolist(), _quat(local_r).tolist()

        sim.editor._edit(change)
        if free or m.body_mocapid[b] >= 0:  # the compiled pose is the start; the state keeps the old place
            self._set_pose(obj.handle, WORLD, position=p_new.tolist(), rotation=r_new)
        return 1

    def setShapeBB(self, shapeHandle: Any, size: Any) -> None:  # noqa: N802, N803
        """Scale a shape so that its bounding box (its frame) measures ``size`` x, y, z (m), as
        :meth:`scaleObject` scales it (each axis by new size / current size).

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
        h = self._h(shapeHandle, "shapeHandle")
        new = np.array(_vector(size, 3, "size"))
        old = np.array(self.getShapeBB(h))
        if not np.all(new > 0):
            raise ArgumentError("size must be positive")
        f = np.where(old > 1e-12, new / np.maximum(old, 1e-12), 1.0)
        self.scaleObject(h, *f.tolist())

    def scaleObjects(self, objectHandles: Any, scalingFactor: Any, scalePositionsToo: Any) -> None:  # noqa: N802, N803
        """Scale shapes by ``scalingFactor`` (0.001..1000, as :meth:`scaleObject`); with
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
        handles = [self._world.get(self._h(x, "objectHandles[i]")).handle for x in objectHandles]
        local = {h: self.getObjectPosition(h, self._world.objects[h].parent) for h in handles}
        for h in handles:
            if self._world.objects[h].type == SHAPE:
                self.scaleObject(h, f, f, f)
        if move:
            for h in handles:
                parent = self._world.objects[h].parent
                self.setObjectPosition(h, parent, [c * f for c in local[h]])

    if TYPE_CHECKING:  # provided by the facade
        _world: Any

        def _h(self, handle: Any, what: str = "object handle") -> int: ...

        def _simulation(self, what: str) -> SimulationView: ...

        def _corners(self, body: int) -> np.ndarray: ...

        def _set_pose(self, handle: Any, relative_to: Any, position: list[float] | None = None,
                      rotation: np.ndarray | None = None) -> None: ...

        def getObjectMatrix(self, handle: Any, relative_to: Any = -1) -> list[float]: ...

        def getObjectPosition(self, handle: Any, relative_to: Any = -1) -> list[float]: ...

        def setObjectPosition(self, handle: Any, relative_to: Any, position: Any = None) -> None: ...

        def getShapeBB(self, shapeHandle: Any) -> list[float]: ...

        def scaleObject(self, objectHandle: Any, xScale: Any, yScale: Any, zScale: Any, options: Any = 0) -> None: ...
