"""A vision sensor's output after its options and filter chain (a mixin of
:class:`simx_server.sim.vision.VisionSensors`): the image and depth buffer that
``simxGetVisionSensorImage`` / ``simxGetVisionSensorDepthBuffer`` return, and what
``simxReadVisionSensor`` returns (V-REP's default packet, the filters' packets, the trigger).

The order is V-REP's (``CVisionSensor::_computeDefaultReturnValuesAndApplyFilters``): the
sensor renders (its options: "ignore RGB" makes the image the background colour without
rendering it, "ignore depth" the depth buffer all 1), the default packet is computed from that
image and depth, then the filter chain (:mod:`simx_server.sim.vision_filters`) makes the
image and depth that clients read. The chain runs once per world state per sensor, on the
render thread that draws the sensor's frames, and is shared by every command that reads it.
"""

from __future__ import annotations

from concurrent.futures import Future
from typing import TYPE_CHECKING, Callable

import mujoco
import numpy as np

from simx_server.sim import vision_filters as VF
from simx_server.sim.handle_render import BACKGROUND, COLOR_CODED
from simx_server.sim.render_thread import wait_for

if TYPE_CHECKING:
    from simx_server.sim.render_thread import RenderThread
    from simx_server.sim.vision_handled import Handled
    from simx_server.sim.sensor_spec import SensorSpec
    from simx_server.sim.world import World

_THIRD = (np.arange(3 * 255 + 1) // 3).astype(np.uint8)  # (R + G + B) -> (R + G + B) // 3


def grey_of(img: np.ndarray) -> np.ndarray:
    """V-REP's grey image of an (h, w, 3) uint8 RGB image: (R + G + B) // 3, (h, w) uint8 (a sum
    of the planes and a table: 6x faster than numpy's sum over the last axis, 0.07 s at 4096²).

    Args:
        img: (h, w, 3) uint8.

    Returns:
        (h, w) uint8.
    """
    total = img[..., 0].astype(np.uint16)
    total += img[..., 1]
    total += img[..., 2]
    return _THIRD[total]


def handles_of(img: np.ndarray) -> np.ndarray:
    """The handles of a colour-coded image (render mode 2): ``r + 256 g + 65536 b``.

    Args:
        img: (h, w, 3) uint8.

    Returns:
        (h, w) int64 handles; ``handle_render.BACKGROUND`` where no object is.
    """
    c = img.astype(np.int64)
    return c[..., 0] + (c[..., 1] << 8) + (c[..., 2] << 16)


def distinct(values: np.ndarray) -> np.ndarray:
    """``np.unique`` of an image's values, sorted: a pixel equal to the one before it is left out
    first (an image of a few objects holds long runs: a fifth of the time at 128x128).

    Args:
        values: (h, w) array.

    Returns:
        (k,) its distinct values, sorted.
    """
    flat = values.ravel()
    if not flat.size:
        return flat
    first = np.empty(flat.shape, bool)
    first[0] = True
    np.not_equal(flat[1:], flat[:-1], out=first[1:])
    return np.unique(flat[first])


def clip_planes(scene: mujoco.MjvScene, near: float, far: float) -> None:
    """Give the scene's cameras the sensor's own clipping planes (V-REP clips a sensor's image at
    its near and far planes; MuJoCo at the model's ``znear``/``zfar``): objects nearer than
    ``near`` or farther than ``far`` are not drawn. A perspective frustum's sides are given at
    its near plane, so they are scaled with it. Only for images drawn without the sky box (it
    would be cut off too) and never for depth frames (MuJoCo converts their depth with the
    model's planes).

    Args:
        scene: a scene updated for the sensor's camera (``update_scene`` done).
        near: m, > 0.
        far: m, > near.
    """
    for cam in scene.camera:
        if not cam.orthographic and cam.frustum_near > 0:
            k = near / cam.frustum_near
            cam.frustum_bottom, cam.frustum_top = cam.frustum_bottom * k, cam.frustum_top * k
            cam.frustum_width, cam.frustum_center = cam.frustum_width * k, cam.frustum_center * k
        cam.frustum_near, cam.frustum_far = near, far


def default_packet(rgb: np.ndarray, depth: np.ndarray) -> list[float]:
    """V-REP 3.x's default vision packet of an image and depth buffer (``sensorResult``):
    minimum, maximum and average of intensity, red, green, blue (bytes, integer arithmetic:
    intensity (R + G + B) // 3, averages truncated) / 255, and of depth.

    Args:
        rgb: (h, w, 3) uint8.
        depth: (h, w) float32 in 0..1.

    Returns:
        15 floats: the 5 minima, 5 maxima, 5 averages (intensity, red, green, blue, depth).
    """
    # The four planes (intensity, R, G, B) contiguous, one per row: numpy's reductions along a
    # strided axis of the (n, 3) pixels took 9 ms at 256x256, more than the frame's render; the
    # sums exact integers in a 64-bit accumulator (a fourth of four histograms' time).
    n = rgb.shape[0] * rgb.shape[1]
    planes = np.empty((4, n), np.uint8)
    planes[0] = grey_of(rgb).ravel()
    planes[1:] = rgb.reshape(-1, 3).T
    mins = [int(v) for v in planes.min(axis=1)]
    maxs = [int(v) for v in planes.max(axis=1)]
    avgs = [int(v) // n for v in planes.sum(axis=1, dtype=np.uint64)]
    d = depth.ravel()
    depths = float(d.min()), float(d.max()), float(np.float32(d.mean(dtype=np.float64)))
    out = []
    for k, values in enumerate((mins, maxs, avgs)):
        out += [float(np.float32(v / 255.0)) for v in values] + [depths[k]]
    return out


class VisionChain:
    """Images, depth buffers and reads of the vision sensors after their options and filters."""

    def depth_job(self, handle: int) -> Callable[[], np.ndarray]:
        """The sensor's depth buffer of the world's current state (its frames submitted now, on
        the simulation thread); the job returned gives it, run on the render thread after them
        (:meth:`after`): (h, w) float32 in 0..1 between near and far, rows bottom-up; all 1 for
        a sensor that ignores depth; the chain's ``workImgToSensorDepthMap`` where it has one.

        Args:
            handle: a vision sensor's handle.

        Returns:
            The job.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a vision sensor.
        """
        spec, rec = self.spec(handle), self.record(handle)
        if rec is not None:  # handled: its callbacks' and chain's depth
            depth = rec.depth
            return lambda: depth
        if spec.filters and VF.writes_depth(spec.filters):
            filtered = self._filtered(handle)
            return lambda: wait_for(filtered, "vision sensor depth").depth
        return self._raw_depth_job(handle)

    def _raw_depth_job(self, handle: int) -> Callable[[], np.ndarray]:
        """The depth before the filters: rendered, or all 1 (ignore depth; cleared: explicit
        handling, not handled yet)."""
        spec = self.spec(handle)
        if spec.ignore_depth or self.cleared(handle):
            return lambda: np.ones((spec.height, spec.width), np.float32)
        return self._rendered_depth_job(handle)

    def raw_image_job(self, handle: int) -> Callable[[], np.ndarray]:
        """As :meth:`depth_job`, for the image before the filters: the rendering, or for a
        sensor that ignores RGB or shows its cleared buffers (explicit handling, not handled
        yet: ``CVisionSensor::_clearBuffers``) its background colour; (h, w, 3) uint8, rows
        bottom-up.

        Args:
            handle: a vision sensor's handle.

        Returns:
            The job.
        """
        spec = self.spec(handle)
        colour = np.array(spec.background or (0, 0, 0), np.uint8)
        if spec.ignore_rgb or self.cleared(handle):
            return lambda: np.broadcast_to(colour, (spec.height, spec.width, 3))
        image = self._rendered_image_job(handle)
        if not colour.any() or spec.depth_image or spec.render_mode == COLOR_CODED:
            return image  # drawn without a sky box: black where no object is
        # another colour where no object is: the pixels beyond the sensor's far plane in its
        # depth frame (drawn with MuJoCo's planes: see clip_planes)
        depth, far = self._frame(handle, "depth"), np.float32(spec.far)

        def on_background() -> np.ndarray:
            img = image().copy()
            img[wait_for(depth, "vision sensor depth")[::-1] >= far] = colour
            return img

        return on_background

    def image_job(self, handle: int, grey: bool) -> Callable[[], np.ndarray]:
        """As :meth:`depth_job`, for the sensor's image: (h, w, 3) uint8 RGB, or (h, w) uint8
        ``(R + G + B) // 3`` when ``grey``, rows bottom-up; the chain's ``workImgToSensorImg``
        where it has one.

        Args:
            handle: a vision sensor's handle.
            grey: one byte per pixel.

        Returns:
            The job.
        """
        spec, rec = self.spec(handle), self.record(handle)
        if rec is not None:  # handled: its callbacks' and chain's image
            rgb = rec.rgb
            return (lambda: grey_of(rgb)) if grey else (lambda: rgb)
        image = self.raw_image_job(handle)
        if spec.filters and VF.writes_image(spec.filters):
            filtered = self._filtered(handle)

            def from_chain() -> np.ndarray:
                out = wait_for(filtered, "vision sensor image").image
                return out if out is not None else image()

            job = from_chain
        else:
            job = image
        return (lambda: grey_of(job())) if grey else job

    def _filtered(self, handle: int) -> Future:
        """The chain's :class:`~simx_server.sim.vision_filters.Filtered` of the world's current
        state (a future, made once per state on the sensor's render thread)."""
        cached = self._cached((handle, "filtered"))
        if cached is not None:
            return cached[0]
        spec = self.spec(handle)
        image = self.raw_image_job(handle)
        depth = self._raw_depth_job(handle) if VF.uses_depth(spec.filters) else None
        state = self._filter_states.setdefault(handle, VF.FilterState())
        thread = self._target(spec)
        future = thread.executor.submit(
            lambda: VF.apply_chain(spec.filters, np.ascontiguousarray(image()), depth() if depth else None, state))
        self._cache[(handle, "filtered")] = (self.shown(handle), future, thread)
        return future

    def read_job(self, handle: int, image: np.ndarray | None = None,
                 packets: bool = True) -> Callable[[], tuple[bool, list[list[float]]]]:
        """``simxReadVisionSensor``'s result of the world's current state (frames submitted
        now; the job returned computes it on the render thread after them): whether a filter
        triggered, and the packets: V-REP's default packet (:func:`default_packet`, empty when
        the sensor's "compute basic statistics" is off; for a sensor rendering colour-coded
        handles, the handles it sees, each + 0.5, as V-REP 3.x), then each filter step's packet.

        Args:
            handle: a vision sensor's handle.
            image: the image to measure instead of the rendering (a passive sensor's), (h, w, 3)
                uint8 rows bottom-up; its filters are then not applied.
            packets: False: the frames and the filters' trigger only, no packet computed (the
                job still waits for the image, so that a failed render raises).

        Returns:
            The job, giving ``(triggered, [packet, ...])`` (``[]`` without ``packets``).
        """
        rec = self.record(handle)
        if rec is not None:  # handled: the trigger and packets of its callbacks and chain
            trigger, packets = rec.trigger, [list(p) for p in rec.packets]
            return lambda: (trigger, packets)
        spec = self.spec(handle)
        raw = (lambda: image) if image is not None else self.raw_image_job(handle)
        # the default packet reads the depth only for V-REP's statistics: a colour-coded sensor's
        # (RLBench's masks) lists handles, and one without statistics has none: no depth frame
        needs_depth = packets and spec.basic_stats and spec.render_mode != COLOR_CODED
        depth = self._raw_depth_job(handle) if needs_depth else None
        filtered = self._filtered(handle) if spec.filters and image is None else None

        def read() -> tuple[bool, list[list[float]]]:
            img = raw()  # waited for without packets too: a failed render raises here
            out = [self.default_packet_of(spec, img, depth() if depth is not None else None)] if packets else []
            if filtered is None:
                return False, out
            result = wait_for(filtered, "readVisionSensor")
            return result.trigger, (out + [list(p) for p in result.packets]) if packets else out

        return read

    @staticmethod
    def default_packet_of(spec: SensorSpec, rgb: np.ndarray, depth: np.ndarray | None) -> list[float]:
        """The first packet of a sensor's reading: V-REP's default packet (:func:`default_packet`,
        empty when the sensor's "compute basic statistics" is off); for a sensor rendering
        colour-coded handles, the handles it sees, each + 0.5, as V-REP 3.x.

        Args:
            spec: the sensor's properties.
            rgb: its image, (h, w, 3) uint8.
            depth: its depth, (h, w) float32 in 0..1 (None: a colour-coded sensor's, or one
                without statistics: not read).

        Returns:
            The packet.
        """
        if spec.render_mode == COLOR_CODED:  # whatever the statistics setting
            seen = distinct(handles_of(rgb))
            return [float(h) + 0.5 for h in seen[seen < BACKGROUND]]
        return default_packet(rgb, depth) if spec.basic_stats and depth is not None else []

    if TYPE_CHECKING:  # provided by VisionSensors
        world: World
        _cache: dict
        _filter_states: dict

        def spec(self, handle: int) -> SensorSpec: ...

        def _target(self, spec: SensorSpec | None = None) -> RenderThread: ...

        def _cached(self, key: tuple[int, str]) -> tuple[Future, RenderThread] | None: ...

        def _rendered_depth_job(self, handle: int) -> Callable[[], np.ndarray]: ...

        def _rendered_image_job(self, handle: int) -> Callable[[], np.ndarray]: ...

        def _frame(self, handle: int, kind: str) -> Future: ...

        def record(self, handle: int) -> Handled | None: ...

        def shown(self, handle: int) -> int: ...

        def cleared(self, handle: int) -> bool: ...
