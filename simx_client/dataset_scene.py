"""The scene as ``simx-dataset`` (:mod:`simx_client.dataset`) sees it: one legacy-API connection
(``simx*`` calls only) that reads handles, poses, parameters and the two images of a view, sets
the state of a view, and raises :class:`~simx_client.dataset_labels.DatasetError` naming the
call that failed.
"""

from __future__ import annotations

import numpy as np

import simx_client as vrep
from simx_client.dataset_labels import DatasetError
from simx_client.images import decode_handles, set_lazy_image_lists

B = vrep.simx_opmode_blocking
ONESHOT = vrep.simx_opmode_oneshot
RENDER_MODE = 1017  # sim_visionintparam_render_mode
RESOLUTION_X, RESOLUTION_Y = 1002, 1003  # sim_visionintparam_resolution_x / _y
PERSPECTIVE_ANGLE = 1004  # sim_visionfloatparam_perspective_angle (rad)
COLOR_CODED = 2  # sim_rendermode_colorcoded
BACKGROUND = 0xFFFFFF  # what a colour-coded pixel with no object decodes to


class Scene:
    """The calls the generator makes on one connection; every failure is a DatasetError."""

    def __init__(self, host: str, port: int, timeout_ms: int = 5000):
        self.cid = vrep.simxStart(host, port, True, True, timeout_ms, 5)
        if self.cid < 0:
            raise DatasetError(f"no simx server answers at {host}:{port}")
        set_lazy_image_lists(self.cid)  # images only become arrays here: no legacy list needed

    def close(self) -> None:
        vrep.simxFinish(self.cid)

    def _ok(self, rc: int, call: str):
        if rc != vrep.simx_return_ok:
            raise DatasetError(f"{call} failed (return code {rc})")

    def handle(self, name: str) -> int:
        """The handle of the object called ``name`` (``simxGetObjectHandle``).

        Args:
            name: the object's name.

        Returns:
            The handle.

        Raises:
            DatasetError: no such object.

        """
        rc, h = vrep.simxGetObjectHandle(self.cid, name, B)
        if rc != vrep.simx_return_ok:
            raise DatasetError(f"the scene has no object {name!r} (simxGetObjectHandle rc {rc})")
        return h

    def joint_position(self, h: int) -> float:
        """A joint's position (``simxGetJointPosition``).

        Args:
            h: the joint's handle.

        Returns:
            rad or m.

        Raises:
            DatasetError: the call failed (not a joint, no such object).

        """
        rc, q = vrep.simxGetJointPosition(self.cid, h, B)
        self._ok(rc, "simxGetJointPosition")
        return q

    def position(self, h: int, rel: int = -1) -> list[float]:
        """An object's position (``simxGetObjectPosition``).

        Args:
            h: the object's handle.
            rel: -1 (world) or an object's handle.

        Returns:
            ``[x, y, z]``, m.

        Raises:
            DatasetError: the call failed.

        """
        rc, p = vrep.simxGetObjectPosition(self.cid, h, rel, B)
        self._ok(rc, "simxGetObjectPosition")
        return list(p)

    def orientation(self, h: int) -> list[float]:
        """An object's Euler angles in the world frame (``simxGetObjectOrientation``).

        Args:
            h: the object's handle.

        Returns:
            ``[alpha, beta, gamma]``, rad.

        Raises:
            DatasetError: the call failed.

        """
        rc, e = vrep.simxGetObjectOrientation(self.cid, h, -1, B)
        self._ok(rc, "simxGetObjectOrientation")
        return list(e)

    def quaternion(self, h: int) -> list[float]:
        """An object's orientation in the world frame (``simxGetObjectQuaternion``).

        Args:
            h: the object's handle.

        Returns:
            ``[qx, qy, qz, qw]``.

        Raises:
            DatasetError: the call failed.

        """
        rc, q = vrep.simxGetObjectQuaternion(self.cid, h, -1, B)
        self._ok(rc, "simxGetObjectQuaternion")
        return list(q)

    def bbox(self, h: int) -> tuple[np.ndarray, np.ndarray]:
        """The object's bounding box in its own frame (params 15..20): (min xyz, max xyz).

        Args:
            h: the object's handle.

        Returns:
            Two float arrays of shape (3,), m.

        Raises:
            DatasetError: a call failed.
        """
        vals = []
        for pid in range(15, 21):
            rc, v = vrep.simxGetObjectFloatParameter(self.cid, h, pid, B)
            self._ok(rc, f"simxGetObjectFloatParameter({pid})")
            vals.append(v)
        return np.array(vals[:3]), np.array(vals[3:])

    def float_param(self, h: int, pid: int) -> float:
        """A float parameter of an object (``simxGetObjectFloatParameter``).

        Args:
            h: the object's handle.
            pid: a ``sim_*floatparam_*`` id.

        Returns:
            The value (in the parameter's unit).

        Raises:
            DatasetError: the call failed.

        """
        rc, v = vrep.simxGetObjectFloatParameter(self.cid, h, pid, B)
        self._ok(rc, f"simxGetObjectFloatParameter({pid})")
        return float(v)

    def int_param(self, h: int, pid: int) -> int:
        """An integer parameter of an object (``simxGetObjectIntParameter``).

        Args:
            h: the object's handle.
            pid: a ``sim_*intparam_*`` id.

        Returns:
            The value.

        Raises:
            DatasetError: the call failed.

        """
        rc, v = vrep.simxGetObjectIntParameter(self.cid, h, pid, B)
        self._ok(rc, f"simxGetObjectIntParameter({pid})")
        return v

    def set_int_param(self, h: int, pid: int, value: int) -> None:
        """Set an integer parameter of an object (``simxSetObjectIntParameter``).

        Args:
            h: the object's handle.
            pid: a ``sim_*intparam_*`` id.
            value: the value.

        Raises:
            DatasetError: the call failed.

        """
        self._ok(vrep.simxSetObjectIntParameter(self.cid, h, pid, value, B),
                 f"simxSetObjectIntParameter({pid}, {value})")

    def set_state(self, joints: dict[int, float], places: dict[int, list[float]],
                  orientations: dict[int, list[float]] | None = None) -> None:
        """Joints teleported and objects moved in one batch (applied before the next read).

        Args:
            joints: joint handle -> position (rad or m).
            places: object handle -> ``[x, y, z]`` (m, world frame).
            orientations: object handle -> ``[alpha, beta, gamma]`` (rad, world frame), or None.
        """
        vrep.simxPauseCommunication(self.cid, True)
        for h, q in joints.items():
            vrep.simxSetJointPosition(self.cid, h, q, ONESHOT)
        for h, p in places.items():
            vrep.simxSetObjectPosition(self.cid, h, -1, p, ONESHOT)
        for h, e in (orientations or {}).items():
            vrep.simxSetObjectOrientation(self.cid, h, -1, e, ONESHOT)
        vrep.simxPauseCommunication(self.cid, False)

    def image(self, sensor: int) -> np.ndarray:
        """(h, w, 3) uint8 RGB, rows top-down.

        Args:
            sensor: the vision sensor's handle.

        Returns:
            The image (``simxGetVisionSensorImage``).

        Raises:
            DatasetError: the call failed.
        """
        rc, res, raw = vrep.simxGetVisionSensorImage(self.cid, sensor, 0, B)
        self._ok(rc, "simxGetVisionSensorImage")
        return np.asarray(raw, dtype=np.uint8).reshape(res[1], res[0], 3)[::-1]

    def coded(self, sensor: int) -> np.ndarray:
        """Handles (h, w) int32 seen by ``sensor`` now, rows top-down (the sensor is switched to
        colour-coded handles for this one image).

        Args:
            sensor: the vision sensor's handle.

        Returns:
            The (h, w) int32 array of handles (0xFFFFFF: background).

        Raises:
            DatasetError: the image could not be read.
        """
        vrep.simxSetObjectIntParameter(self.cid, sensor, RENDER_MODE, COLOR_CODED, ONESHOT)
        try:
            img = self.image(sensor)
        finally:
            vrep.simxSetObjectIntParameter(self.cid, sensor, RENDER_MODE, 0, ONESHOT)
        return decode_handles(img)

    def check_errors(self) -> None:
        """A oneshot command that failed (a joint without a motor, a bad position) shows here."""
        rc, errors = vrep.simxGetLastErrors(self.cid, B)
        if rc == vrep.simx_return_ok and errors:
            raise DatasetError("the server refused a command: " + "; ".join(errors))
