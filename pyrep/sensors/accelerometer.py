"""PyRep's ``Accelerometer``: acceleration (m/s²) from the force on a known mass."""

from __future__ import annotations

from pyrep.const import ObjectType
from pyrep.objects.force_sensor import ForceSensor
from pyrep.objects.object import Object
from pyrep.objects.shape import Shape


class Accelerometer(Object):
    """The accelerometer model: ``<name>_mass`` on ``<name>_force_sensor``."""

    def __init__(self, name: str):
        super().__init__(name)
        self._mass_object = Shape(f"{self.get_name()}_mass")
        self._sensor = ForceSensor(f"{self.get_name()}_force_sensor")

    def _get_requested_type(self) -> ObjectType:
        return self.get_type()

    def _type_ok(self, actual: ObjectType) -> bool:
        return True

    def read(self) -> list[float]:
        """Acceleration (3, m/s²) along the sensor's axes."""
        forces, _ = self._sensor.read()
        mass = self._mass_object.get_mass()
        return [f / mass for f in forces]
