"""Argument coercion of the legacy ``simx*`` functions (see :mod:`simx_client.api`).

Each coercion turns what a legacy program passes (Python values, numpy scalars, 1-element
arrays) into a plain Python value, or raises (:class:`~simx_wire.protocol.LocalError`,
``OverflowError``...): the functions then answer ``simx_return_local_error_flag``. Values that
the legacy binding carried as ``c_float`` are rounded to float32 as it did.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

from simx_wire import protocol as P

_INT_MIN, _INT_MAX = -2**31, 2**31 - 1  # simxInt: every integer argument of the C API is an int32


# ------------------------------------------------------------------ coercion
# Each coercion tests the exact plain type first: the facade runs them on every call.
def _scalar(value: Any) -> Any:
    """A Python scalar from a Python/numpy scalar or a 1-element array."""
    if isinstance(value, (int, float, bool, str, bytes)):
        return value
    array = np.asarray(value)
    if array.size != 1:
        raise P.LocalError(f"expected a single value, got an array of shape {array.shape}")
    return array.reshape(()).item()


def _int(value: Any) -> int:
    """An int32 (the C API's simxInt), else LocalError."""
    if type(value) is int and -2147483648 <= value <= 2147483647:  # _INT_MIN, _INT_MAX as constants
        return value
    v = _scalar(value)
    if isinstance(v, bool) or not isinstance(v, int):
        raise P.LocalError(f"expected an integer, got {type(v).__name__} {P.quote(v)}")
    if not _INT_MIN <= v <= _INT_MAX:
        raise P.LocalError(f"integer {P.quote(v)} out of the int32 range")
    return int(v)


def _bool(value: Any) -> bool:
    """A truth value from a bool or a number (not NaN), as the legacy ``c_ubyte`` took them."""
    if type(value) is bool:
        return value
    v = _scalar(value)
    if not isinstance(v, (bool, int, float)) or v != v:
        raise P.LocalError(f"expected a truth value, got {type(v).__name__} {P.quote(v)}")
    return bool(v)


def _float(value: Any) -> float:
    if type(value) is float:
        return value
    v = _scalar(value)
    if isinstance(v, (bool, str, bytes)) or not isinstance(v, (int, float)):
        raise P.LocalError(f"expected a number, got {type(v).__name__} {P.quote(v)}")
    return float(v)


def _str(value: Any) -> str:
    if type(value) is str:
        return value
    v = _scalar(value)
    if isinstance(v, (bytes, bytearray)):
        return bytes(v).decode("utf-8")
    if not isinstance(v, str):
        raise P.LocalError(f"expected a string, got {type(v).__name__}")
    return v


def _bytes(value: Any) -> bytes:
    """Bytes of a str (UTF-8), a bytes-like object or integers (-128..255, as c_ubyte took them)."""
    if isinstance(value, str):
        return value.encode("utf-8")
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    data = np.asarray(value)
    if data.dtype.kind not in "iub":
        raise P.LocalError(f"expected bytes, a str or integers, got {P.quote(value)}")
    return data.astype(np.int64).astype(np.uint8).tobytes()


_F32 = struct.Struct("<f")


def _f32(value: float) -> float:
    """``value`` rounded to float32, as the legacy binding's c_float did; OverflowError beyond
    float32 (ctypes made such a value inf without a word): the facade answers a local error."""
    return _F32.unpack(_F32.pack(value))[0]


def _f32_input(values: Any) -> list[float]:
    """A list of numbers rounded to float32 (FloatingPointError beyond float32)."""
    with np.errstate(over="raise"):
        return np.asarray([_float(v) for v in values], dtype=np.float32).tolist()


def _f32_list(values: list) -> list[float]:
    return np.asarray(values, dtype=np.float32).tolist()


def _floats(values: Any, n: int) -> list[float]:
    out = [_f32(_float(v)) for v in np.asarray(values, dtype=object).reshape(-1)]
    if len(out) != n:
        raise P.LocalError(f"expected {n} values, got {len(out)}")
    return out
