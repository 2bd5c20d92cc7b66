"""PyRep's ``SuctionCup``: grasps by attaching a detected object to its connection point."""

from __future__ import annotations

from pyrep.objects.force_sensor import ForceSensor
from pyrep.objects.object import Object
from pyrep.objects.proximity_sensor import ProximitySensor
from pyrep.objects.shape import Shape


class SuctionCup(Shape):
    """A suction cup ``name`` with ``<name>_sensor`` and ``<name>_connection``."""

    def __init__(self, count: int, name: str, base_name: str | None = None):
        suffix = "" if count == 0 else f"#{count - 1}"
        super().__init__((name if base_name is None else base_name) + suffix)
        self._proximity_sensor = ProximitySensor(f"{name}_sensor{suffix}")
        self._attach_point = ForceSensor(f"{name}_connection{suffix}")
        self._old_parents: list[Object | None] = []
        self._grasped_objects: list[Object] = []

    def grasp(self, obj: Object) -> bool:
        """Attaches ``obj`` if detected; whether it is."""
        detected = self._proximity_sensor.is_detected(obj)
        if detected and obj not in self._grasped_objects:
            self._grasped_objects.append(obj)
            self._old_parents.append(obj.get_parent())
            obj.set_parent(self._attach_point, keep_in_place=True)
        return detected

    def release(self) -> None:
        """Detaches every attached object."""
        for obj, parent in zip(self._grasped_objects, self._old_parents):
            if obj.still_exists():
                obj.set_parent(parent, keep_in_place=True)
        self._grasped_objects = []
        self._old_parents = []

    def get_grasped_objects(self) -> list[Object]:
        return self._grasped_objects
