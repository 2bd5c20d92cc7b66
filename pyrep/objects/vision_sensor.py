"""PyRep's ``VisionSensor``: a camera rendered by MuJoCo (EGL/OSMesa), images top-down.

RGB as float32 (h, w, 3) in 0..1, depth as float32 (h, w) in 0..1 between the clipping planes
(or m), as PyRep returns them. As in CoppeliaSim, a sensor made by :meth:`VisionSensor.create`
shows a blank image until it is handled (the next ``step()``, or ``handle_explicitly()``).
CoppeliaSim's main script handles every sensor not tagged for explicit handling at each step
(coppeliaSimLib ``simHandleVisionSensor_internal`` with ``sim_handle_all_except_explicit``, the
sensing phase), and ``capture_rgb`` reads the image of that handling: simx renders a handled
sensor when it is read, the same image while nothing has moved since the step (RLBench's gym
``render()`` after ``step()``). A sensor with explicit handling (RLBench's cameras) shows the
state of its last ``handle_explicitly()`` until the next, however the world moved since, as
CoppeliaSim's sensor buffers (``simx_server.sim.vision_handled``).
"""

from __future__ import annotations

import math
from typing import Any, Sequence, Union

import numpy as np

from pyrep.backend import sim
from pyrep.const import ObjectType, PerspectiveMode, RenderMode
from pyrep.objects.object import Object, object_type_to_class

_RES_X, _RES_Y = 1002, 1003  # sim_visionintparam_resolution_x/y
_WIN_X, _WIN_Y = 1004, 1005  # sim_visionintparam_windowed_size_x/y
_ENTITY = 1008  # sim_visionintparam_entity_to_render
_RENDER_MODE = 1017  # sim_visionintparam_render_mode
_PERSPECTIVE = 1018  # sim_visionintparam_perspective_operation
_NEAR, _FAR, _ANGLE, _ORTHO = 1000, 1001, 1004, 1005  # sim_visionfloatparam_*


def unhandled() -> set[int]:
    """The sensors of the current PyRep made by ``create`` and not handled yet (blank images)."""
    state: Any = sim.context().state
    if not hasattr(state, "pyrep_unhandled"):
        state.pyrep_unhandled = set()
    found: set[int] = state.pyrep_unhandled
    return found


class VisionSensor(Object):
    """A vision sensor."""

    def __init__(self, name_or_handle: Union[str, int]):
        super().__init__(name_or_handle)
        self.resolution = self.get_resolution()

    @staticmethod
    def create(resolution: Sequence[int], explicit_handling: bool = False, perspective_mode: bool = True,
               show_volume_not_detecting: bool = True, show_volume_detecting: bool = True,
               passive: bool = False, use_local_lights: bool = False, show_fog: bool = True,
               near_clipping_plane: float = 1e-2, far_clipping_plane: float = 10.0, view_angle: float = 60.0,
               ortho_size: float = 1.0, sensor_size: Any = None, render_mode: RenderMode = RenderMode.OPENGL3,
               position: Any = None, orientation: Any = None) -> VisionSensor:
        """A new vision sensor of ``resolution`` [w, h] px; ``view_angle`` in degrees, clipping
        planes and ``ortho_size`` in m."""
        size = [0.01, 0.01, 0.03] if sensor_size is None else list(sensor_size)
        angle = math.radians(view_angle) if perspective_mode else ortho_size
        handle = int(sim.call("createVisionSensor", 1 if perspective_mode else 0,
                              [int(resolution[0]), int(resolution[1]), 0, 0],
                              [float(near_clipping_plane), float(far_clipping_plane), float(angle), *size,
                               0.0, 0.0, 0.0, 0.0, 0.0]))
        sensor = VisionSensor(handle)
        unhandled().add(handle)
        if explicit_handling:
            sensor.set_explicit_handling(1)
        sensor.set_render_mode(render_mode)
        if position is not None:
            sensor.set_position(position)
        if orientation is not None:
            sensor.set_orientation(orientation)
        return sensor

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.VISION_SENSOR

    def handle_explicitly(self) -> None:
        """Renders the sensor now: its images show the scene as it is now until it is handled
        again. PyRep reads none of ``sim.handleVisionSensor``'s packets: none is computed
        (simx's ``packets`` false)."""
        unhandled().discard(self._handle)
        sim.call("handleVisionSensor", self._handle, False)

    def capture_rgb(self) -> np.ndarray:
        """The RGB image, float32 (h, w, 3) in 0..1, top row first."""
        w, h = self.resolution
        if self._handle in unhandled():
            return np.zeros((h, w, 3), dtype=np.float32)
        data, (w, h) = sim.call("getVisionSensorImg", self._handle)
        img = np.frombuffer(bytes(data), dtype=np.uint8).reshape(h, w, 3)
        return np.flipud(img).astype(np.float32) / 255.0

    def capture_depth(self, in_meters: bool = False) -> np.ndarray:
        """The depth image, float32 (h, w): 0..1 from the near to the far plane, or m."""
        w, h = self.resolution
        if self._handle in unhandled():
            return np.full((h, w), 0.0 if in_meters else 1.0, dtype=np.float32)
        data, (w, h) = sim.call("getVisionSensorDepth", self._handle, 1 if in_meters else 0)
        return np.flipud(np.frombuffer(bytes(data), dtype=np.float32).reshape(h, w)).copy()

    def capture_pointcloud(self) -> np.ndarray:
        """The points seen, (h, w, 3) in m, world frame."""
        return self.pointcloud_from_depth(self.capture_depth(in_meters=True))

    def pointcloud_from_depth(self, depth: np.ndarray) -> np.ndarray:
        """Points (h, w, 3) in the world frame from a depth image in m."""
        return VisionSensor.pointcloud_from_depth_and_camera_params(depth, self.get_matrix(),
                                                                    self.get_intrinsic_matrix())

    @staticmethod
    def pointcloud_from_depth_and_camera_params(depth: np.ndarray, extrinsics: np.ndarray,
                                                intrinsics: np.ndarray) -> np.ndarray:
        """Points (h, w, 3) in the world frame from a depth image (m), the camera's (4, 4) pose
        and its (3, 3) intrinsic matrix (PyRep's convention: negative focal lengths, the
        sensor looking along its +z)."""
        h, w = depth.shape
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        fx, fy, cx, cy = intrinsics[0, 0], intrinsics[1, 1], intrinsics[0, 2], intrinsics[1, 2]
        z = depth.astype(np.float64)
        local = np.stack([(u - cx) * z / fx, (v - cy) * z / fy, z], axis=-1)
        return local @ extrinsics[:3, :3].T + extrinsics[:3, 3]

    def get_intrinsic_matrix(self) -> np.ndarray:
        """The (3, 3) intrinsic matrix (focal lengths negative, as PyRep's)."""
        res = np.array(self.get_resolution(), dtype=np.float64)
        angle = math.radians(self.get_perspective_angle())
        ratio = res[0] / res[1]
        ax = ay = angle
        if ratio > 1:
            ay = 2 * np.arctan(np.tan(angle / 2) / ratio)
        elif ratio < 1:
            ax = 2 * np.arctan(np.tan(angle / 2) * ratio)
        f = -res / (2 * np.tan(np.array([ax, ay]) / 2))
        return np.array([[f[0], 0.0, res[0] / 2], [0.0, f[1], res[1] / 2], [0.0, 0.0, 1.0]])

    def _int(self, param: int) -> int:
        return int(sim.call("getObjectInt32Param", self._handle, param))

    def _set_int(self, param: int, value: int) -> None:
        sim.call("setObjectInt32Param", self._handle, param, int(value))

    def _float(self, param: int) -> float:
        return float(sim.call("getObjectFloatParam", self._handle, param))

    def _set_float(self, param: int, value: float) -> None:
        sim.call("setObjectFloatParam", self._handle, param, float(value))

    def get_resolution(self) -> list[int]:
        """``[width, height]`` in pixels."""
        return [self._int(_RES_X), self._int(_RES_Y)]

    def set_resolution(self, resolution: Sequence[int]) -> None:
        """Sets ``[width, height]`` in pixels."""
        self._set_int(_RES_X, int(resolution[0]))
        self._set_int(_RES_Y, int(resolution[1]))
        self.resolution = [int(resolution[0]), int(resolution[1])]

    def get_perspective_mode(self) -> PerspectiveMode:
        return PerspectiveMode(self._int(_PERSPECTIVE))

    def set_perspective_mode(self, perspective_mode: PerspectiveMode) -> None:
        self._set_int(_PERSPECTIVE, perspective_mode.value)

    def get_render_mode(self) -> RenderMode:
        return RenderMode(self._int(_RENDER_MODE))

    def set_render_mode(self, render_mode: RenderMode) -> None:
        """Sets the render mode (every mode renders with MuJoCo's OpenGL renderer)."""
        self._set_int(_RENDER_MODE, render_mode.value)

    def get_windowed_size(self) -> Sequence[int]:
        return self._int(_WIN_X), self._int(_WIN_Y)

    def set_windowed_size(self, resolution: Sequence[int] = (0, 0)) -> None:
        self._set_int(_WIN_X, int(resolution[0]))
        self._set_int(_WIN_Y, int(resolution[1]))

    def get_perspective_angle(self) -> float:
        """The view angle in degrees."""
        return math.degrees(self._float(_ANGLE))

    def set_perspective_angle(self, angle: float) -> None:
        """Sets the view angle in degrees."""
        self._set_float(_ANGLE, math.radians(angle))

    def get_orthographic_size(self) -> float:
        """The orthographic view's size (m)."""
        return self._float(_ORTHO)

    def set_orthographic_size(self, ortho_size: float) -> None:
        self._set_float(_ORTHO, ortho_size)

    def get_near_clipping_plane(self) -> float:
        """The near clipping plane (m)."""
        return self._float(_NEAR)

    def set_near_clipping_plane(self, near_clipping: float) -> None:
        self._set_float(_NEAR, near_clipping)

    def get_far_clipping_plane(self) -> float:
        """The far clipping plane (m)."""
        return self._float(_FAR)

    def set_far_clipping_plane(self, far_clipping: float) -> None:
        self._set_float(_FAR, far_clipping)

    def set_entity_to_render(self, entity_to_render: int) -> None:
        """Renders only that object or collection (-1: everything)."""
        self._set_int(_ENTITY, entity_to_render)

    def get_entity_to_render(self) -> int:
        return self._int(_ENTITY)


object_type_to_class[ObjectType.VISION_SENSOR] = VisionSensor
