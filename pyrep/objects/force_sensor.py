"""PyRep's ``ForceSensor``: force in N, torque in N·m, in the sensor's frame."""

from __future__ import annotations

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.objects.object import Object, object_type_to_class


class ForceSensor(Object):
    """A force sensor."""

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.FORCE_SENSOR

    @classmethod
    def create(cls, sensor_size: float = 0.01) -> ForceSensor:
        """A new force sensor of ``sensor_size`` (m) at the world's origin (``sim.createForceSensor``)."""
        handle = sim.call("createForceSensor", 0, [0, 1, 5, 0, 0], [sensor_size, 0, 0, 0, 0], None)
        return cls(int(handle))

    def read(self) -> tuple[list[float], list[float]]:
        """``(force, torque)``: 3 N, 3 N·m."""
        _, force, torque = sim.call("readForceSensor", self._handle)
        return [float(v) for v in force], [float(v) for v in torque]


object_type_to_class[ObjectType.FORCE_SENSOR] = ForceSensor
