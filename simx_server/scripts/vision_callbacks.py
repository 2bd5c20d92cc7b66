"""Vision sensors' script callbacks, called where CoppeliaSim 4.2+ calls them
(``CVisionSensor::_computeDefaultReturnValuesAndApplyFilters`` in coppeliaSimLib).

A vision sensor whose child or customization script defines ``sysCall_vision`` (when the
simulation starts) is *handled*: rendered, measured, and its scripts' ``sysCall_vision(inData)``
called, child script first, with ``inData`` = ``{visionSensor, handle (the same, deprecated),
resolution = {x, y}, clippingPlanes = {near, far}, viewAngle (rad), orthoSize (m),
perspectiveOperation (bool)}``. A callback processes the sensor's image with ``simVision``
(:mod:`simx_server.api.simvision`) and returns nil or ``{trigger = bool, packedPackets = {packed
floats, ...}}``: a boolean ``trigger`` replaces the sensor's, and each packet (a string of
float32 values) is added after V-REP's default packet. When the sensor triggered, the scripts'
``sysCall_trigger({visionSensor, handle, packedPackets})`` follow (their ``trigger`` replaces
it). What the handling leaves is what clients then read (:mod:`simx_server.sim.vision_handled`).

A sensor is handled

* once each simulation pass, after the step and before the scripts' ``sysCall_sensing`` (the main
  script's ``sim.handleVisionSensor(sim.handle_all_except_explicit)``), unless it is passive
  (``image=external``) or has explicit handling (``sim.setExplicitHandling``);
* by ``sim.handleVisionSensor`` (a script or a client);
* when a passive sensor gets an image (``simxSetVisionSensorImage``, ``sim.setVisionSensorImg``,
  ``simVision.workImgToSensorImg`` outside its callbacks).

Scenes without such callbacks pay nothing: their sensors are rendered when read, as before.
Every callback is charged to the scripts' time like the others (:func:`~.dynamics.call_back`,
:mod:`simx_server.scripts.budget`); errors are logged and the handling goes on.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from simx_wire.protocol import RemoteError
from simx_server.scripts.dynamics import call_back
from simx_server.sim import sensors, vision_params
from simx_server.sim.objects import VISION_SENSOR
from simx_server.sim.vision_handled import Handled

log = logging.getLogger("simx.scripts")

VISION, TRIGGER = "sysCall_vision", "sysCall_trigger"


def unpack(packet: Any) -> list[float] | None:
    """A packed packet (float32 values) as floats; None for anything but bytes."""
    if not isinstance(packet, (bytes, bytearray)):
        return None
    data = bytes(packet)
    return np.frombuffer(data[:len(data) // 4 * 4], "<f4").astype(float).tolist()


class VisionCallbacks:
    """The scene's sensors whose scripts have vision callbacks, and those callbacks (the
    :class:`~simx_server.sim.vision_handled.VisionHooks` of their handling).

    Args:
        scripts: the scene's :class:`~simx_server.scripts.scene_scripts.Scripts`.
    """

    def __init__(self, scripts: Any):
        self._scripts = scripts
        self._attached: dict[int, list[Any]] = {}  # sensor -> its running scripts (child first)
        self._failed: set[int] = set()  # sensors whose handling failed (logged once)

    @property
    def sensors(self) -> list[int]:
        """The sensors handled with callbacks, by handle."""
        return sorted(self._attached)

    def install(self) -> None:
        """The simulation starts (its scripts have run their top level and ``sysCall_init``):
        find the sensors whose scripts define ``sysCall_vision``."""
        self._attached, self._failed = {}, set()
        sim = self._scripts.simulation
        if sim is None:
            return
        for h in sim.world.objects_of_type(VISION_SENSOR):
            attached = [s for s in (self._scripts.scripts.get(h), self._scripts.customization.get(h))
                        if s is not None and s.running and not s.load_error]
            if any(s._defines(VISION) for s in attached):
                self._attached[h] = attached

    def remove(self) -> None:
        """The simulation stops: no more callbacks."""
        self._attached = {}

    def hook(self, handle: int) -> VisionCallbacks | None:
        """Self when sensor ``handle`` has vision callbacks, else None."""
        return self if handle in self._attached else None

    def handle_pass(self) -> None:
        """Handle every sensor with callbacks, but passive ones and those with explicit handling
        (a simulation pass, after the step)."""
        sim = self._scripts.simulation
        for h in list(self._attached):
            try:
                if h in sim.vision.explicit or sensors.is_passive(sim, h):
                    continue
                sim.vision.handle(h, self)
                self._failed.discard(h)
            except Exception as exc:  # no frame (a renderer's failure), an edit removed it: said once
                if h not in self._failed:
                    self._failed.add(h)
                    log.error("vision sensor %d not handled with its vision callbacks: %s: %s", h,
                              type(exc).__name__, exc, exc_info=not isinstance(exc, RemoteError))

    def vision(self, handle: int, record: Handled) -> None:
        """The ``sysCall_vision`` callbacks of the sensor's scripts, on ``record``."""
        sim = self._scripts.simulation
        spec = sim.vision.spec(handle)
        perspective, angle, size = vision_params.view(sim, handle)
        in_data = {"visionSensor": handle, "handle": handle, "resolution": [spec.width, spec.height],
                   "clippingPlanes": [spec.near, spec.far], "viewAngle": angle, "orthoSize": size,
                   "perspectiveOperation": perspective}
        for script in self._attached.get(handle, ()):
            if not script._defines(VISION):
                continue
            out = call_back(script, VISION, dict(in_data))
            if not isinstance(out, dict):
                continue
            if isinstance(out.get("trigger"), bool):
                record.trigger = out["trigger"]
            packets = out.get("packedPackets")
            if isinstance(packets, list):
                record.packets += [p for p in map(unpack, packets) if p is not None]

    def trigger(self, handle: int, record: Handled) -> None:
        """The ``sysCall_trigger`` callbacks of a triggered sensor's scripts."""
        in_data = {"visionSensor": handle, "handle": handle,
                   "packedPackets": [np.asarray(p, "<f4").tobytes() for p in record.packets]}
        for script in self._attached.get(handle, ()):
            if not script._defines(TRIGGER):
                continue
            out = call_back(script, TRIGGER, dict(in_data))
            if isinstance(out, dict) and isinstance(out.get("trigger"), bool):
                record.trigger = out["trigger"]
