"""PyRep's ``Distance``: a distance object of the scene (m)."""

from __future__ import annotations

from typing import Union

from pyrep.backend import sim
from pyrep.errors import PyRepError


class Distance(sim.OnItsWorld):
    """A distance object, by name or handle, of the PyRep current when it is made
    (:class:`pyrep.backend.sim.OnItsWorld`)."""

    def __init__(self, name_or_handle: Union[str, int]):
        self._bind_world()
        self._handle = name_or_handle if isinstance(name_or_handle, int) else \
            int(sim.call("getDistanceHandle", name_or_handle))

    def read(self) -> float | None:
        """The distance (m) last measured.

        Raises:
            PyRepError: the distance could not be measured.
        """
        result = sim.call("handleDistance", self._handle)
        if not result or result[0] < 0:
            raise PyRepError("Cannot read the distance: the objects may not be measurable.")
        return float(result[1])
