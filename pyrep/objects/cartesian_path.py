"""PyRep's ``CartesianPath``: poses along control points (m, rad).

A path of a ``.ttt`` / ``.ttm`` saved by CoppeliaSim 4.1 (PyRep's) is V-REP's old path object:
poses along it are ``sim.getPositionOnPath`` / ``sim.getOrientationOnPath`` on its Bezier curve,
as PyRep reads them, and control points are inserted with ``sim.insertPathCtrlPoints`` as
PyRep's add-on script does. A path :meth:`CartesianPath.create` makes is kept as CoppeliaSim
4.3+ keeps one, a dummy carrying its control poses as custom data ``PATHCTRLPT``; the pose at a
relative distance is then interpolated linearly between control points.
"""

from __future__ import annotations

import struct
from typing import Any, Union

import numpy as np

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.objects.object import Object, object_type_to_class

_PATHCTRLPT = "PATHCTRLPT"


def _euler_to_quat(a: float, b: float, g: float) -> list[float]:
    """CoppeliaSim's alpha, beta, gamma (R = Rx(a) Ry(b) Rz(g)) as a quaternion [x, y, z, w]."""
    m = np.array(sim.call("buildMatrix", [0.0, 0.0, 0.0], [a, b, g]))
    return [float(v) for v in sim.call("getQuaternionFromMatrix", m.tolist())]


class CartesianPath(Object):
    """A path: control poses and the poses between them."""

    def __init__(self, name_or_handle: Union[str, int]):
        super().__init__(name_or_handle)

    @staticmethod
    def create(show_line: bool = True, show_orientation: bool = True, show_position: bool = True,
               closed_path: bool = False, automatic_orientation: bool = True, flat_path: bool = False,
               keep_x_up: bool = False, line_size: int = 1, length_calculation_method: int = 0,
               control_point_size: float = 0.01, ang_to_lin_conv_coeff: float = 1.0,
               virt_dist_scale_factor: float = 1.0, path_color: tuple = (0.1, 0.75, 1.0)) -> CartesianPath:
        """A new path with no control point (the display options have no effect headless)."""
        return CartesianPath(int(sim.call("createDummy", float(control_point_size))))

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.PATH

    def _type_ok(self, actual: ObjectType) -> bool:
        return actual in (ObjectType.PATH, ObjectType.DUMMY)

    def _control_points(self) -> np.ndarray:
        """The control poses (n, 7): x y z qx qy qz qw in the path's frame."""
        tags = sim.call("readCustomDataTags", self._handle) or []
        if _PATHCTRLPT not in tags:
            return np.zeros((0, 7))
        data = bytes(sim.call("readCustomDataBlockEx", self._handle, _PATHCTRLPT))
        return np.array(struct.unpack(f"<{len(data) // 8}d", data)).reshape(-1, 7)

    def get_pose_on_path(self, relative_distance: float) -> tuple[list[float], list[float]]:
        """Position (m) and Euler angles (rad), world frame, at ``relative_distance`` (0..1)
        along the path (its own pose when it has no control point). An old path (4.1's): PyRep's
        ``simGetPositionOnPath`` and ``simGetOrientationOnPath``."""
        if self._is_old_path():
            return ([float(v) for v in sim.call("getPositionOnPath", self._handle, float(relative_distance))],
                    [float(v) for v in sim.call("getOrientationOnPath", self._handle, float(relative_distance))])
        pts = self._control_points()
        if len(pts) == 0:
            return self.get_position().tolist(), self.get_orientation().tolist()
        lengths = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts[:, :3], axis=0), axis=1))])
        t = min(max(float(relative_distance), 0.0), 1.0) * lengths[-1]
        i = min(int(np.searchsorted(lengths, t, side="right")) - 1, len(pts) - 1)
        if i < len(pts) - 1 and lengths[i + 1] > lengths[i]:
            f = (t - lengths[i]) / (lengths[i + 1] - lengths[i])
            pose = sim.call("interpolatePoses", pts[i].tolist(), pts[i + 1].tolist(), f)
        else:
            pose = pts[i].tolist()
        world = sim.call("multiplyPoses", sim.call("getObjectPose", self._handle, -1), list(pose))
        m = sim.call("poseToMatrix", world)
        return [float(v) for v in world[:3]], [float(v) for v in sim.call("getEulerAnglesFromMatrix", m)]

    def insert_control_points(self, poses: list[list[float]]) -> None:
        """Appends control points: each ``[x, y, z, alpha, beta, gamma]`` (m, rad), path frame
        (an old path: at its start, with PyRep's Bezier settings, as its ``insertPathControlPoint``)."""
        if self._is_old_path():
            data = [v for p in poses for v in (*[float(x) for x in p[:6]], 0.0, 0.0, 20, 0.99, 0.99)]
            sim.call("insertPathCtrlPoints", self._handle, 0, 0, len(poses), data)
            return
        new = [list(p[:3]) + _euler_to_quat(*p[3:6]) for p in poses]
        pts = np.vstack([self._control_points(), np.array(new, dtype=np.float64).reshape(-1, 7)])
        sim.call("writeCustomDataBlockEx", self._handle, _PATHCTRLPT,
                 struct.pack(f"<{pts.size}d", *pts.reshape(-1)))

    def _is_old_path(self) -> bool:
        return int(sim.call("getObjectType", self._handle)) == int(ObjectType.PATH.value)

    def _script_call(self, func: str, ints: Any = (), floats: Any = (), strings: Any = (), bytes: str = "") -> Any:
        raise NotImplementedError("simx has no PyRep add-on script")


object_type_to_class[ObjectType.PATH] = CartesianPath
