"""Values a script passes to the ``sim`` facade, checked and converted: strings, buffers,
integers, finite numbers and fixed-length vectors. Each raises
:class:`simx_wire.protocol.ArgumentError` naming the argument (``what``) when the value does not fit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from simx_wire.protocol import ArgumentError


def _text(value: Any, what: str) -> str:
    if isinstance(value, (bytes, bytearray)):
        return bytes(value).decode("utf-8", errors="replace")
    if not isinstance(value, str):
        raise ArgumentError(f"{what} must be a string, got {type(value).__name__}")
    return value


def _bytes(value: Any, what: str) -> bytes:
    if isinstance(value, str):
        return value.encode("utf-8")
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    raise ArgumentError(f"{what} must be a string (bytes), got {type(value).__name__}")


def _int(value: Any, what: str) -> int:
    if isinstance(value, (np.integer, np.floating)):
        value = value.item()
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ArgumentError(f"{what} must be an integer, got {value!r}")
    return value


def _num(value: Any, what: str) -> float:
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ArgumentError(f"{what} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ArgumentError(f"{what} must be finite, got {value!r}")
    return v


def _vector(value: Any, n: int, what: str) -> list[float]:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ArgumentError(f"{what} must be a table of {n} numbers, got {value!r}")
    return [_num(v, f"{what}[{i + 1}]") for i, v in enumerate(value)]
