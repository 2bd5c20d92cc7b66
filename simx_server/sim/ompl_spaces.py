"""simOMPL's state space types on OMPL's spaces, and what puts a state into a scratch copy of
the scene for the collision checks of :mod:`simx_server.sim.motion_planning`.

A simOMPL task's state is its state spaces' values in order (CoppeliaRobotics/simOMPL,
``sourceCode/plugin.cpp``, class ``StateSpace``): ``joint_position`` a joint's position
(OMPL's ``RealVectorStateSpace(1)``), ``cyclic_joint_position`` a cyclic joint's (``SO2``),
``position2d`` an object's x, y (``RealVectorStateSpace(2)``), ``position3d`` its x, y, z,
``pose2d`` its x, y and yaw (``SE2``), ``dubins`` the same under a car's turning radius
(``DubinsStateSpace``), ``pose3d`` its position and quaternion x, y, z, w (``SE3``); positions
and angles relative to the space's reference object (-1: the world). Writing a state moves the
objects as the plug-in's ``writeState`` does: a 2-D position keeps the object's z, a 2-D pose its
z and its first two Euler angles (V-REP's, R = Rx(a) Ry(b) Rz(g)), the yaw replacing the third.

:class:`Space` is OMPL's space of a task: the space itself when the task has one, else a
``CompoundStateSpace`` of them, each of weight 1, as the plug-in's ``StateSpace`` (so a distance is
the sum of the spaces' distances: for an arm's joints the L1 norm, in rad or m, and the space's
extent the sum of the joints' ranges; OMPL's checking resolution and its planners' ranges are
fractions of that extent); its default projection the first space marked for projection, OMPL's
``SubspaceProjectionEvaluator`` (the plug-in's ``ProjectionEvaluator`` also has the first marked
space's dimension).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import mujoco
import numpy as np

from simx_server.sim import grasps
from simx_server.sim.objects import JOINT, SHAPE
from simx_server.sim.rotations import euler_from_matrix, matrix_from_euler, matrix_from_quaternion
from simx_server.sim.world import World

#: OMPL's ``ompl.base`` once :func:`load` has imported it; None before.
ob: Any = None
#: OMPL's modules ``(base, geometric, util)``, or why they cannot be imported; None: not tried yet.
_loaded: tuple[Any, Any, Any] | str | None = None


def load() -> tuple[Any, Any, Any]:
    """OMPL's Python bindings, imported when a planning call first needs them (the pyrep extra
    installs them): a server that never plans neither pays their import (0.1-0.2 s) nor holds
    their types.

    Returns:
        The modules ``(ompl.base, ompl.geometric, ompl.util)``; OMPL's own log is silenced (the
        calls report what failed).

    Raises:
        RuntimeError: the bindings are not installed (:func:`import_error` says so).
    """
    global ob, _loaded
    if _loaded is None:
        try:
            from ompl import base, geometric, util

            util.setLogLevel(util.LOG_NONE)
            _loaded = (base, geometric, util)
        except ImportError as exc:  # pragma: no cover - the test environment has ompl
            _loaded = f"motion planning needs OMPL's Python bindings: pip install ompl ({exc})"
    if isinstance(_loaded, str):
        raise RuntimeError(_loaded)
    ob = _loaded[0]
    return _loaded


def import_error() -> str | None:
    """Whether OMPL's bindings can be imported (the import tried now if not yet).

    Returns:
        Why not (a line for the caller's error), or None when they are there.
    """
    try:
        load()
    except RuntimeError as exc:
        return str(exc)
    return None

#: simOMPL's ``StateSpaceType`` names (callbacks.xml, from 50001, in this order).
TYPES = ("position2d", "pose2d", "position3d", "pose3d", "joint_position", "dubins", "cyclic_joint_position")
#: Values of one state of each type.
DIMENSION = {"position2d": 2, "pose2d": 3, "position3d": 3, "pose3d": 7, "joint_position": 1, "dubins": 3,
             "cyclic_joint_position": 1}
#: Bounds of each type: the position's (m) or the joint's (rad or m); a cyclic joint has none.
BOUNDS = {"position2d": 2, "pose2d": 2, "position3d": 3, "pose3d": 3, "joint_position": 1, "dubins": 2,
          "cyclic_joint_position": 0}
JOINT_TYPES = ("joint_position", "cyclic_joint_position")


@dataclasses.dataclass(frozen=True)
class Subspace:
    """One simOMPL state space, as OMPL builds it.

    Attributes:
        kind: a name of :data:`TYPES`.
        low, high: its bounds (:data:`BOUNDS` values each).
        projection: projection-based planners project onto it (simOMPL's ``useForProjection``).
        turning_radius: a ``dubins`` space's turning radius (m; simOMPL's default 0.05).
        symmetric: a ``dubins`` space's symmetric distance (simOMPL's default False).
    """

    kind: str
    low: tuple[float, ...]
    high: tuple[float, ...]
    projection: bool = False
    turning_radius: float = 0.05
    symmetric: bool = False


def _bounds(low: tuple[float, ...], high: tuple[float, ...]) -> Any:
    b = ob.RealVectorBounds(len(low))
    b.low, b.high = list(low), list(high)
    return b


def _make(s: Subspace) -> Any:
    """OMPL's space of one simOMPL state space, bounded."""
    if s.kind in ("joint_position", "position2d", "position3d"):
        space = ob.RealVectorStateSpace(len(s.low))
    elif s.kind == "cyclic_joint_position":
        return ob.SO2StateSpace()
    elif s.kind == "pose2d":
        space = ob.SE2StateSpace()
    elif s.kind == "dubins":
        space = ob.DubinsStateSpace(float(s.turning_radius), bool(s.symmetric))
    else:
        space = ob.SE3StateSpace()
    space.setBounds(_bounds(s.low, s.high))
    return space


def _get(kind: str, s: Any) -> list[float]:
    """The values of one OMPL (sub)state of a simOMPL type."""
    if kind in ("pose2d", "dubins"):
        return [s.getX(), s.getY(), s.getYaw()]
    if kind == "cyclic_joint_position":
        return [s.value]
    if kind == "pose3d":
        r = s.rotation()
        return [s.getX(), s.getY(), s.getZ(), r.x, r.y, r.z, r.w]
    return [s[i] for i in range(DIMENSION[kind])]


def _set(kind: str, s: Any, v: Any) -> None:
    """Writes values into one OMPL (sub)state of a simOMPL type (a quaternion normalised)."""
    if kind in ("pose2d", "dubins"):
        s.setXY(float(v[0]), float(v[1]))
        s.setYaw(float(v[2]))
    elif kind == "cyclic_joint_position":
        s.value = math.remainder(float(v[0]), 2 * math.pi)
    elif kind == "pose3d":
        s.setXYZ(float(v[0]), float(v[1]), float(v[2]))
        q = np.asarray(v[3:7], dtype=float)
        q = q / n if (n := float(np.linalg.norm(q))) > 1e-12 else np.array([0.0, 0.0, 0.0, 1.0])
        r = s.rotation()
        r.x, r.y, r.z, r.w = (float(c) for c in q)
    else:
        for i in range(DIMENSION[kind]):
            s[i] = float(v[i])


class Space:
    """OMPL's state space of a task's simOMPL state spaces (see the module's text).

    Args:
        subspaces: the task's state spaces, in order (at least one).

    Raises:
        RuntimeError: OMPL's bindings are not installed.
    """

    def __init__(self, subspaces: list[Subspace]):
        load()
        self.subspaces = subspaces
        self.dim = sum(DIMENSION[s.kind] for s in subspaces)
        self._offsets = np.cumsum([0] + [DIMENSION[s.kind] for s in subspaces]).tolist()
        flagged = [i for i, s in enumerate(subspaces) if s.projection]
        if len(subspaces) == 1:  # its own space, with its own default projection (SE2's: x, y)
            self.space = _make(subspaces[0])
        else:
            self.space = ob.CompoundStateSpace()
            for s in subspaces:
                self.space.addSubspace(_make(s), 1.0)
            self.space.registerDefaultProjection(ob.SubspaceProjectionEvaluator(self.space, (flagged or [0])[0]))

    def values(self, state: Any) -> np.ndarray:
        """A state's values, the spaces' in order.

        Args:
            state: an OMPL state of :attr:`space`.

        Returns:
            (:attr:`dim`,) floats (m, rad, quaternion components as the space has them).
        """
        if len(self.subspaces) == 1:
            return np.array(_get(self.subspaces[0].kind, state), dtype=float)
        return np.array([v for i, s in enumerate(self.subspaces) for v in _get(s.kind, state[i])], dtype=float)

    def write(self, state: Any, values: Any) -> None:
        """Set a state to values.

        Args:
            state: an OMPL state of :attr:`space`, written in place.
            values: (:attr:`dim`,) floats, the spaces' in order.
        """
        if len(self.subspaces) == 1:
            _set(self.subspaces[0].kind, state, values)
        else:
            for i, s in enumerate(self.subspaces):
                _set(s.kind, state[i], values[self._offsets[i]:self._offsets[i + 1]])

    def state(self, values: Any) -> Any:
        """A new OMPL state of these values.

        Args:
            values: (:attr:`dim`,) floats, the spaces' in order.

        Returns:
            The state, allocated by :attr:`space`.
        """
        s = self.space.allocState()
        self.write(s, values)
        return s

    def within_bounds(self, values: Any) -> bool:
        """Whether the values lie within the spaces' bounds (OMPL's ``satisfiesBounds``).

        Args:
            values: (:attr:`dim`,) floats.

        Returns:
            True when every value is within its bounds.
        """
        return bool(self.space.satisfiesBounds(self.state(values)))

    def enforce_bounds(self, values: Any) -> np.ndarray:
        """The values brought within the bounds (OMPL's ``enforceBounds``: positions clipped,
        angles wrapped).

        Args:
            values: (:attr:`dim`,) floats.

        Returns:
            (:attr:`dim`,) the values within the bounds.
        """
        s = self.state(values)
        self.space.enforceBounds(s)
        return self.values(s)

    def distance(self, a: Any, b: Any) -> float:
        """OMPL's distance of the space between two states' values.

        Args:
            a: (:attr:`dim`,) floats.
            b: (:attr:`dim`,) floats.

        Returns:
            The space's distance (m and rad as the space weighs them).
        """
        return float(self.space.distance(self.state(a), self.state(b)))


class Placement:
    """Puts one state space's values into a scratch ``MjData`` (as the plug-in's ``writeState``
    puts them into the scene), for :class:`~simx_server.sim.motion_planning.ScratchCollisions`.

    Args:
        world: the scene.
        kind: a name of :data:`TYPES`.
        handle: a joint (joint types) or a shape that moves freely (a free joint or a mocap
            body: a dynamic shape, a model's base) for the others.
        ref: the reference object of positions and angles (-1: the world).

    Raises:
        UnknownObjectError, ObjectTypeError: no such object, or a joint type's object is not a joint.
        ValueError: a pose type's object cannot be placed in a copy of the state (a static or
            jointed shape, a dummy...).
    """

    def __init__(self, world: World, kind: str, handle: int, ref: int = -1):
        self.kind, self.handle, self.ref, self.width = kind, handle, ref, DIMENSION[kind]
        m = world.model
        if kind in JOINT_TYPES:
            self.address = int(m.jnt_qposadr[world.get(handle, JOINT).mj_id])
            return
        obj = world.get(handle)
        b = obj.mj_id if obj.type == SHAPE else -1
        self.mocap = int(m.body_mocapid[b]) if b >= 0 else -1
        free = b >= 0 and grasps.is_free(m, b)
        if self.mocap < 0 and not free:
            raise ValueError(f"{obj.name!r} does not move freely (a dynamic shape or a model base with a free "
                             f"joint): simx cannot place it for a {kind} state space")
        self.address = int(m.jnt_qposadr[m.body_jntadr[b]]) if free else -1

    def refresh(self, world: World) -> None:
        """Read the object's and the reference's poses now (what a state leaves unchanged); before
        the first :meth:`write` (:class:`~simx_server.sim.motion_planning.ScratchCollisions` does).

        Args:
            world: the scene.
        """
        if self.kind in JOINT_TYPES:
            return
        self.p0, self.r0 = world.frame(self.ref)
        p, r = world.frame(self.handle)
        self.rel_p, self.rel_r = self.r0.T @ (p - self.p0), self.r0.T @ r
        self.euler = euler_from_matrix(self.rel_r)

    def write(self, data: mujoco.MjData, v: np.ndarray) -> None:
        """Put a state's values into a copy of the state.

        Args:
            data: the scratch ``MjData`` (its ``qpos`` or mocap pose is written).
            v: (:attr:`width`,) the values (m, rad, quaternion x, y, z, w).
        """
        if self.kind in JOINT_TYPES:
            data.qpos[self.address] = v[0]
            return
        p, r = self.rel_p.copy(), self.rel_r
        if self.kind == "position2d":
            p[:2] = v
        elif self.kind in ("pose2d", "dubins"):
            p[:2] = v[:2]
            r = matrix_from_euler(self.euler[0], self.euler[1], float(v[2]))
        elif self.kind == "position3d":
            p = np.asarray(v, dtype=float)
        else:
            p, r = np.asarray(v[:3], dtype=float), matrix_from_quaternion(*(float(c) for c in v[3:7]))
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(self.r0 @ r).reshape(9))
        pos = self.p0 + self.r0 @ p
        if self.address >= 0:
            data.qpos[self.address:self.address + 7] = np.concatenate([pos, quat])
        else:
            data.mocap_pos[self.mocap], data.mocap_quat[self.mocap] = pos, quat
