"""PyRep's signals: named values shared with the scene's scripts (``sim.setInt32Signal``...)."""

from __future__ import annotations

from typing import Any

from pyrep.backend import sim
from pyrep.errors import PyRepError


class Signal:
    """A named signal of one type."""

    _kind = ""

    def __init__(self, name: str):
        self._name = name

    def set(self, value: Any) -> None:
        """Sets the signal."""
        sim.call(f"set{self._kind}Signal", self._name, value)

    def get(self) -> Any:
        """The signal's value.

        Raises:
            PyRepError: the signal is not set.
        """
        value = sim.call(f"get{self._kind}Signal", self._name)
        if value is None:
            raise PyRepError(f"Signal {self._name} of type {self._kind.lower()} does not exist.")
        return value

    def clear(self) -> int:
        """Clears the signal; the number of signals cleared."""
        result = sim.call(f"clear{self._kind}Signal", self._name)
        return 1 if result is None else int(result)


class IntegerSignal(Signal):
    _kind = "Int32"

    def set(self, value: Any) -> None:
        super().set(int(value))


class FloatSignal(Signal):
    _kind = "Float"

    def set(self, value: Any) -> None:
        super().set(float(value))


class DoubleSignal(Signal):
    _kind = "Double"

    def set(self, value: Any) -> None:
        super().set(float(value))


class StringSignal(Signal):
    _kind = "String"

    def set(self, value: Any) -> None:
        super().set(str(value))

    def get(self) -> str:
        value = super().get()
        return value.decode() if isinstance(value, (bytes, bytearray)) else str(value)
