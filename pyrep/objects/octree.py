"""PyRep's ``Octree``: voxels (m) of a given size."""

from __future__ import annotations

from typing import Any

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.objects.object import Object, object_type_to_class


def _points(points: Any, what: str) -> list[float]:
    if not isinstance(points, list):
        raise ValueError(f"Octree.{what}: points parameter is not a list.")
    if len(points) % 3 != 0:
        raise ValueError(f"Octree.{what}: points parameter length not a multiple of 3.")
    return [float(v) for v in points]


def _color(color: Any, what: str) -> Any:
    if color is not None and (not isinstance(color, list) or len(color) != 3):
        raise ValueError(f"Octree.{what}: color parameter not an RGB list.")
    return color


class Octree(Object):
    """An octree."""

    @staticmethod
    def create(voxel_size: float, point_size: float | None = None, options: int = 0) -> Octree:
        """A new empty octree of ``voxel_size`` (m)."""
        size = voxel_size if point_size is None else point_size
        return Octree(int(sim.call("createOctree", float(voxel_size), int(options), float(size))))

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.OCTREE

    def _type_ok(self, actual: ObjectType) -> bool:
        return actual in (ObjectType.OCTREE, ObjectType.DUMMY)  # simx makes it a dummy (see docs/PYREP.md)

    def insert_voxels(self, points: list[float], color: Any = None, options: int = 0) -> None:
        """Adds the voxels holding ``points`` (3n, m).

        Raises:
            ValueError: points not a list of 3n numbers, or a bad colour.
        """
        sim.call("insertVoxelsIntoOctree", self._handle, options, _points(points, "insert_voxels"),
                 _color(color, "insert_voxels"), None)

    def remove_voxels(self, points: list[float] | None, options: int = 0) -> None:
        """Removes the voxels holding ``points`` (None: all)."""
        pts = None if points is None else _points(points, "remove_voxels")
        sim.call("removeVoxelsFromOctree", self._handle, options, pts)

    def get_voxels(self) -> list:
        """The voxels' centres, 3n floats (m)."""
        return list(sim.call("getOctreeVoxels", self._handle))

    def insert_object(self, obj: Object, color: Any = None, options: int = 0) -> None:
        """Adds the voxels ``obj`` occupies."""
        sim.call("insertObjectIntoOctree", self._handle, obj.get_handle(), options,
                 _color(color, "insert_object"), 0)

    def subtract_object(self, obj: Object, options: int = 0) -> None:
        """Removes the voxels ``obj`` occupies."""
        sim.call("subtractObjectFromOctree", self._handle, obj.get_handle(), options)

    def check_point_occupancy(self, points: list[float], options: int = 0) -> bool:
        """Whether a voxel holds one of ``points``."""
        result = sim.call("checkOctreePointOccupancy", self._handle, options, _points(points, "check_point_occupancy"))
        return bool(result[0] if isinstance(result, (list, tuple)) else result)

    def clear_voxels(self) -> None:
        """Removes every voxel."""
        sim.call("removeVoxelsFromOctree", self._handle, 0, None)


object_type_to_class[ObjectType.OCTREE] = Octree
