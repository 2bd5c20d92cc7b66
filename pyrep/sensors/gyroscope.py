"""PyRep's ``Gyroscope``: angular velocity (rad/s) from the change of pose between reads."""

from __future__ import annotations

import numpy as np

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.objects.object import Object


class Gyroscope(Object):
    """The gyroscope model (any object type: its base)."""

    def __init__(self, name: str):
        super().__init__(name)
        self._last_time = float(sim.call("getSimulationTime"))
        self._old = self.get_matrix()

    def _get_requested_type(self) -> ObjectType:
        return self.get_type()

    def _type_ok(self, actual: ObjectType) -> bool:
        return True

    def read(self) -> list[float]:
        """Angular velocity (3, rad/s) about the sensor's axes since the last read (0 when no
        simulation time passed)."""
        now = float(sim.call("getSimulationTime"))
        dt = now - self._last_time
        current = self.get_matrix()
        relative = np.linalg.inv(self._old) @ current
        angles = sim.call("getEulerAnglesFromMatrix", relative[:3].flatten().tolist())
        self._last_time, self._old = now, current
        return [float(a) / dt for a in angles] if dt != 0 else [0.0, 0.0, 0.0]
