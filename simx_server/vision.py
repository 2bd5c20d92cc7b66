"""Vision sensors: MuJoCo cameras rendered offscreen, in V-REP's image and depth formats.

A vision sensor is a MuJoCo camera. Its resolution is the camera's ``resolution`` attribute
(256x256 when the MJCF leaves it at 1x1), its field of view the camera's ``fovy``, and its
near/far clipping planes and image kind come from the ``simx:NAME`` custom text
(``near=0.01 far=10 image=rgb|depth``). A sensor with ``image=depth`` shows its depth as grey
in all three channels (near dark, far bright), as a V-REP depth sensor with a
"depth to image" filter does.

Frames are rendered on demand and cached until the world changes (one render per
simulation step per sensor, however many clients ask). Images leave here as ``bytes`` in
V-REP's layout: rows bottom-up, RGB, 8 bits; depth as float32 in 0..1 (linear between near
and far).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from simx_client.protocol import ArgumentError
from simx_server.world import VISION_SENSOR, World

DEFAULT_RESOLUTION = (256, 256)
DEFAULT_NEAR, DEFAULT_FAR = 0.01, 10.0


@dataclasses.dataclass
class SensorSpec:
    """Static properties of one vision sensor."""

    camera: int
    width: int
    height: int
    near: float  # m
    far: float  # m
    depth_image: bool


class VisionSensors:
    """Renders the scene's vision sensors. Owns GL contexts: use from one thread, then close()."""

    def __init__(self, world: World):
        self.world = world
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self._cache: dict[tuple[int, str], tuple[int, np.ndarray]] = {}
        self.renders = 0  # number of frames actually rendered (for tests and benchmarks)
        self.reset()

    def reset(self) -> None:
        """(Re)read every sensor's properties from the scene (undoing run-time changes)."""
        world = self.world
        self.specs: dict[int, SensorSpec] = {}
        self._cache.clear()
        m = world.model
        for obj in world.objects.values():
            if obj.type != VISION_SENSOR:
                continue
            w, h = (int(x) for x in m.cam_resolution[obj.mj_id])
            if (w, h) == (1, 1):
                w, h = DEFAULT_RESOLUTION
            s = obj.settings
            self.specs[obj.handle] = SensorSpec(
                obj.mj_id, w, h, float(s.get("near", DEFAULT_NEAR)), float(s.get("far", DEFAULT_FAR)),
                s.get("image", "rgb") == "depth")
        if self.specs:
            m.vis.global_.offwidth = max(m.vis.global_.offwidth, *(s.width for s in self.specs.values()))
            m.vis.global_.offheight = max(m.vis.global_.offheight, *(s.height for s in self.specs.values()))

    def spec(self, handle: int) -> SensorSpec:
        """The sensor's properties; raises UnknownObjectError/ObjectTypeError for other handles."""
        self.world.get(handle, VISION_SENSOR)
        return self.specs[handle]

    def _renderer(self, spec: SensorSpec) -> mujoco.Renderer:
        key = (spec.width, spec.height)
        if key not in self._renderers:
            self._renderers[key] = mujoco.Renderer(self.world.model, spec.height, spec.width)
        return self._renderers[key]

    def _render(self, handle: int, kind: str) -> np.ndarray:
        """Rendered frame, top-down rows: RGB (h, w, 3) uint8, or depth (h, w) float32 in m."""
        cached = self._cache.get((handle, kind))
        if cached is not None and cached[0] == self.world.version:
            return cached[1]
        spec = self.spec(handle)
        r = self._renderer(spec)
        if kind == "depth":
            r.enable_depth_rendering()
        try:
            r.update_scene(self.world.data, camera=spec.camera)
            frame = r.render()
        finally:
            if kind == "depth":
                r.disable_depth_rendering()
        self.renders += 1
        self._cache[(handle, kind)] = (self.world.version, frame)
        return frame

    def depth(self, handle: int) -> np.ndarray:
        """Depth normalised to 0..1 between near and far, (h, w) float32, rows bottom-up."""
        spec = self.spec(handle)
        d = self._render(handle, "depth")
        norm = (d - spec.near) / (spec.far - spec.near)
        return np.clip(norm, 0.0, 1.0, out=norm).astype(np.float32, copy=False)[::-1]

    def image(self, handle: int, grey: bool) -> np.ndarray:
        """The sensor's image, rows bottom-up: (h, w, 3) uint8 RGB, or (h, w) uint8 when ``grey``.

        ``grey`` is V-REP's options bit 0: one byte per pixel, (R + G + B) / 3.
        """
        spec = self.spec(handle)
        if spec.depth_image:
            g = np.rint(self.depth(handle) * 255.0).astype(np.uint8)
            return g if grey else np.repeat(g[:, :, None], 3, axis=2)
        rgb = self._render(handle, "rgb")[::-1]
        if grey:
            return (rgb.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8)
        return rgb

    def image_bytes(self, handle: int, options: int) -> tuple[list[int], bytes]:
        """``simxGetVisionSensorImage``: ``([resX, resY], bytes)`` for options bit 0 (grey)."""
        if not isinstance(options, int):
            raise ArgumentError(f"options must be an int, got {type(options).__name__}")
        spec = self.spec(handle)
        img = self.image(handle, bool(options & 1))
        return [spec.width, spec.height], np.ascontiguousarray(img).tobytes()

    def depth_bytes(self, handle: int) -> tuple[list[int], bytes]:
        """``simxGetVisionSensorDepthBuffer``: ``([resX, resY], float32 bytes)``."""
        spec = self.spec(handle)
        return [spec.width, spec.height], np.ascontiguousarray(self.depth(handle)).tobytes()

    def close(self) -> None:
        """Free every GL context; idempotent."""
        for r in self._renderers.values():
            try:
                r.close()
            except Exception:  # a context already torn down by the driver
                pass
        self._renderers.clear()
        self._cache.clear()
