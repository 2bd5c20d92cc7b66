"""``simx-viewer --images``: the vision sensors' images, each in an OpenCV window.

The images come the way any legacy program gets them: ``simxGetVisionSensorImage`` (or, for a
depth-only sensor, ``simxGetVisionSensorDepthBuffer``) in streaming mode on a connection of
its own, read back with ``simx_opmode_buffer``; each is shown in an OpenCV window named after
its sensor, ``IMAGE_HEIGHT`` pixels high. OpenCV must have a GUI (``opencv-python``; the
``opencv-python-headless`` that simx installs has none): without one, :class:`SensorImages`
raises at once and the viewer goes on without the images. (MuJoCo's ``Handle.set_images``,
which would draw them inside the viewer's window, drew nothing with MuJoCo 3.17 on GLFW/Mesa.)
Without ``--images``, MuJoCo's own viewer shows what a sensor sees too: pick its camera in the
left panel's *Rendering* section (or cycle with ``[`` and ``]``).
"""

from __future__ import annotations

import logging

import cv2
import mujoco
import numpy as np

from simx_client import api

log = logging.getLogger("simx.viewer")

IMAGE_HEIGHT = 160  # px on screen
_STREAMING, _BUFFER, _BLOCKING = 0x020000, 0x060000, 0x010000


class SensorImages:
    """Streams every vision sensor's image of ``model`` from the server at ``host:port``.

    ``gui=False`` skips the check that OpenCV can open windows (reading images needs none).

    Raises:
        RuntimeError: OpenCV has no GUI, or ``simxStart`` failed.
    """

    def __init__(self, host: str, port: int, model: mujoco.MjModel, gui: bool = True):
        self.cid = -1
        self._gui = gui
        try:
            if gui:
                cv2.namedWindow("simx-viewer: probe")
                cv2.destroyWindow("simx-viewer: probe")
        except cv2.error:
            raise RuntimeError("--images needs OpenCV with a GUI: `pip install opencv-python` in place of "
                               "opencv-python-headless; without it, pick a vision sensor's camera in the "
                               "viewer's left panel (Rendering, Camera) to see what it sees") from None
        self.cid = api.simxStart(host, port, True, True, 5000, 5)
        if self.cid < 0:
            raise RuntimeError(f"--images: simxStart({host}, {port}) failed")
        self.sensors: list[tuple[str, int, bool]] = []  # name, handle, depth
        self._shown: dict[int, np.ndarray] = {}
        for i in range(model.ncam):
            if max(int(v) for v in model.cam_resolution[i]) <= 1:
                continue
            name = model.cam(i).name
            rc, handle = api.simxGetObjectHandle(self.cid, name, _BLOCKING)
            if rc != 0:
                continue
            rc, _, _ = api.simxGetVisionSensorImage(self.cid, handle, 0, _BLOCKING)
            depth = rc != 0  # a depth-only sensor answers its depth buffer only
            if depth:
                api.simxGetVisionSensorDepthBuffer(self.cid, handle, _STREAMING)
            else:
                api.simxGetVisionSensorImage(self.cid, handle, 0, _STREAMING)
            self.sensors.append((name, handle, depth))
        log.info("--images: %s", ", ".join(n for n, *_ in self.sensors) or "no vision sensor")

    def read(self, handle: int, depth: bool) -> np.ndarray | None:
        """The sensor's newest image, top row first, as RGB uint8 of shape (height, width, 3)
        (a depth buffer as grey, near = black); None before the first."""
        if depth:
            rc, res, values = api.simxGetVisionSensorDepthBuffer(self.cid, handle, _BUFFER)
            if rc != 0 or not res:
                return None
            grey = (np.asarray(values, np.float64).reshape(res[1], res[0]) * 255).clip(0, 255).astype(np.uint8)
            image = np.repeat(grey[..., None], 3, axis=2)
        else:
            rc, res, values = api.simxGetVisionSensorImage(self.cid, handle, 0, _BUFFER)
            if rc != 0 or not res:
                return None
            image = np.asarray(values, np.uint8).reshape(res[1], res[0], 3)
        return image[::-1]  # V-REP's images start with the bottom row

    def show(self) -> None:
        """Show each sensor's newest image in its window (and let OpenCV draw them)."""
        for name, sensor, depth in self.sensors:
            image = self.read(sensor, depth)
            if image is None:
                continue
            width = max(1, round(image.shape[1] * IMAGE_HEIGHT / image.shape[0]))
            small = cv2.resize(image, (width, IMAGE_HEIGHT), interpolation=cv2.INTER_AREA)
            cv2.imshow(f"simx-viewer: {name}", cv2.cvtColor(small, cv2.COLOR_RGB2BGR))
        cv2.waitKey(1)

    def close(self) -> None:
        """End the connection (its streams go with it); idempotent."""
        if self.cid >= 0:
            api.simxFinish(self.cid)
            self.cid = -1
            if self._gui:
                cv2.destroyAllWindows()
