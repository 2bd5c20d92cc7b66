"""PyRep's ``SphericalVisionSensor``: a 360° image composed from six 90° vision sensors.

The model (PyRep's) has six sub-sensors ``<name>_front/top/back/bottom/left/right`` and two
output sensors ``<name>_sensorRGB`` / ``_sensorDepth`` that give the equirectangular image's
resolution (width = 2 height). CoppeliaSim composes the image in an add-on script with its
``simVision`` plugin; here each pixel's direction (longitude 0..2π along the width, polar angle
0..π from the output sensor's +z down the height) is looked up in the sub-sensor that faces it
most, by nearest pixel (numpy). Depth is radial: the planar depth of the sub-sensor divided by
the cosine to its axis.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from pyrep.const import ObjectType, RenderMode
from pyrep.objects.object import Object
from pyrep.objects.vision_sensor import VisionSensor

_FACES = ("front", "top", "back", "bottom", "left", "right")


class SphericalVisionSensor(Object):
    """A spherical vision sensor model, by its base's name."""

    def __init__(self, name: str):
        super().__init__(name)
        base = self.get_name()
        self._sensor_depth = VisionSensor(f"{base}_sensorDepth")
        self._sensor_rgb = VisionSensor(f"{base}_sensorRGB")
        self._six_sensors = [VisionSensor(f"{base}_{n}") for n in _FACES]
        self._front = self._six_sensors[0]
        for sensor in [self._sensor_depth, self._sensor_rgb, *self._six_sensors]:
            sensor.set_explicit_handling(1)

    def _get_requested_type(self) -> ObjectType:
        return self.get_type()

    def _type_ok(self, actual: ObjectType) -> bool:
        return True

    def _lookup(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per output pixel: the face index, its pixel row and column, and the cosine to its axis."""
        w, h = self._sensor_rgb.get_resolution()
        phi = (np.arange(w) + 0.5) / w * 2 * np.pi
        theta = (np.arange(h) + 0.5) / h * np.pi
        ph, th = np.meshgrid(phi, theta)
        local = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)
        world = local @ self._sensor_rgb.get_matrix()[:3, :3].T
        forward = np.stack([s.get_matrix()[:3, :3] for s in self._six_sensors])  # (6, 3, 3)
        cam = np.einsum("hwk,fkj->fhwj", world, forward)  # directions in each face's frame
        face = np.argmax(cam[..., 2], axis=0)
        pick = np.take_along_axis(cam, face[None, ..., None], axis=0)[0]
        fw, fh = self._front.get_resolution()
        cos = np.clip(pick[..., 2], 1e-6, None)
        col = np.clip(((0.5 - 0.5 * pick[..., 0] / cos) * fw).astype(int), 0, fw - 1)  # image right: -x
        row = np.clip(((0.5 - 0.5 * pick[..., 1] / cos) * fh).astype(int), 0, fh - 1)  # image up: +y
        return face, row, col, cos

    def handle_explicitly(self) -> None:
        """Renders the six sub-sensors now."""
        for sensor in self._six_sensors:
            sensor.handle_explicitly()

    def _sensed(self) -> None:
        """The six sub-sensors as the model's script leaves them each pass: its ``sysCall_sensing``
        calls ``simVision.handleSpherical``, which handles them (explicit sensors) and composes
        the image. simx has no such plug-in function: they are handled when read, so the image
        is the state now (the last pass's while nothing moved since the step)."""
        self.handle_explicitly()

    def capture_rgb(self) -> np.ndarray:
        """The 360° RGB image, float32 (h, w, 3) in 0..1."""
        self._sensed()
        face, row, col, _ = self._lookup()
        images = np.stack([s.capture_rgb() for s in self._six_sensors])
        return images[face, row, col]

    def capture_depth(self, in_meters: bool = False) -> np.ndarray:
        """The 360° radial depth, float32 (h, w): 0..1 between the clipping planes, or m."""
        self._sensed()
        face, row, col, cos = self._lookup()
        planar = np.stack([s.capture_depth(in_meters=True) for s in self._six_sensors])[face, row, col]
        radial = (planar / cos).astype(np.float32)
        if in_meters:
            return radial
        near, far = self.get_near_clipping_plane(), self.get_far_clipping_plane()
        return np.clip((radial - near) / (far - near), 0.0, 1.0).astype(np.float32)

    def get_resolution(self) -> list[int]:
        return self._sensor_depth.get_resolution()

    def set_resolution(self, resolution: list[int]) -> None:
        """Sets ``[w, h]`` (w = 2 h, h even); the sub-sensors get ``h/2`` square.

        Raises:
            Exception: other proportions (PyRep's error).
        """
        if resolution[0] != 2 * resolution[1]:
            raise Exception("Spherical vision sensors must have an X resolution 2x the Y resolution")
        if resolution[1] % 2 != 0:
            raise Exception("Spherical vision sensors must have an even Y resolution")
        for sensor in self._six_sensors:
            sensor.set_resolution([resolution[1] // 2, resolution[1] // 2])
        self._sensor_depth.set_resolution(resolution)
        self._sensor_rgb.set_resolution(resolution)

    def get_render_mode(self) -> RenderMode:
        return self._sensor_depth.get_render_mode()

    def set_render_mode(self, render_mode: RenderMode) -> None:
        for sensor in [self._sensor_depth, self._sensor_rgb, *self._six_sensors]:
            sensor.set_render_mode(render_mode)

    def get_windowed_size(self) -> Sequence[int]:
        return self._sensor_depth.get_windowed_size()

    def set_windowed_size(self, resolution: Sequence[int] = (0, 0)) -> None:
        self._sensor_depth.set_windowed_size(resolution)
        self._sensor_rgb.set_windowed_size(resolution)

    def get_near_clipping_plane(self) -> float:
        return self._front.get_near_clipping_plane()

    def set_near_clipping_plane(self, near_clipping: float) -> None:
        for sensor in self._six_sensors:
            sensor.set_near_clipping_plane(near_clipping)

    def get_far_clipping_plane(self) -> float:
        return self._front.get_far_clipping_plane()

    def set_far_clipping_plane(self, far_clipping: float) -> None:
        for sensor in self._six_sensors:
            sensor.set_far_clipping_plane(far_clipping)

    def get_entity_to_render(self) -> int:
        return self._front.get_entity_to_render()

    def set_entity_to_render(self, entity_to_render: int) -> None:
        for sensor in [self._sensor_depth, self._sensor_rgb, *self._six_sensors]:
            sensor.set_entity_to_render(entity_to_render)
