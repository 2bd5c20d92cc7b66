"""PyRep's ``ProximitySensor``: distances in m."""

from __future__ import annotations

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.objects.object import Object, object_type_to_class


class ProximitySensor(Object):
    """A proximity sensor."""

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.PROXIMITY_SENSOR

    def read(self) -> float:
        """Distance (m) to the detected point, -1.0 when nothing is detected."""
        state, distance, _, _, _ = sim.call("readProximitySensor", self._handle)
        return float(distance) if state else -1.0

    def is_detected(self, obj: Object) -> bool:
        """Whether the sensor detects ``obj`` now."""
        return bool(sim.call("checkProximitySensor", self._handle, obj.get_handle())[0] == 1)


object_type_to_class[ObjectType.PROXIMITY_SENSOR] = ProximitySensor
