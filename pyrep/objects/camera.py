"""PyRep's ``Camera``: a view of the scene (a dummy-like frame in simx)."""

from __future__ import annotations

from pyrep.const import ObjectType
from pyrep.objects.object import Object, object_type_to_class


class Camera(Object):
    """A camera (CoppeliaSim's viewing camera, not a vision sensor)."""

    @staticmethod
    def create() -> Camera:
        raise NotImplementedError("API does not support camera creation.")

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.CAMERA

    def _type_ok(self, actual: ObjectType) -> bool:
        return actual in (ObjectType.CAMERA, ObjectType.DUMMY)  # simx makes it a dummy (see docs/PYREP.md)


object_type_to_class[ObjectType.CAMERA] = Camera
