"""PyRep's ``Dummy``: a reference frame."""

from __future__ import annotations

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.objects.object import Object, object_type_to_class


class Dummy(Object):
    """A dummy (a frame with no geometry)."""

    @staticmethod
    def create(size: float = 0.01) -> Dummy:
        """A new dummy of ``size`` (m) at the world's origin."""
        return Dummy(int(sim.call("createDummy", float(size))))

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.DUMMY


object_type_to_class[ObjectType.DUMMY] = Dummy
