"""The server's one vocabulary of argument checks, for every handler, script and ZMQ call.

Arguments arrive as msgpack (legacy calls), CBOR (ZMQ calls) or Lua / Python (child scripts)
made them; the code that takes one states what it expects and gets a plain Python value back, or
an :class:`~simx_wire.protocol.ArgumentError` (legacy remote error 8) naming the argument
(``what``) and what is wrong with it.

* exact wire values, for legacy handlers (msgpack gives plain int, float and str):
  :func:`check_args`, :func:`as_int`, :func:`as_float`, :func:`as_floats`;
* a script's or a ZMQ client's values, which may be integral floats (Lua 5.3 numbers, JSON) or
  numpy scalars and arrays: :func:`as_integer`, :func:`as_number`, :func:`as_vector`,
  :func:`as_text`;
* byte strings, for both: :func:`as_bytes`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from simx_wire.protocol import ArgumentError, quote  # noqa: F401  (quote: for every handler module)


def as_int(value: Any, what: str) -> int:
    """``value`` if it is an int (not a bool), else ArgumentError."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ArgumentError(f"{what} must be an int, got {type(value).__name__}")
    return value


def as_float(value: Any, what: str) -> float:
    """``value`` as a float if it is a number (not a bool), else ArgumentError."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ArgumentError(f"{what} must be a number, got {type(value).__name__}")
    return float(value)


def as_floats(value: Any, n: int, what: str) -> list[float]:
    """A list of exactly ``n`` finite numbers as floats, else ArgumentError."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        got = f"{len(value)} values" if isinstance(value, (list, tuple)) else type(value).__name__
        raise ArgumentError(f"{what} must be a list of {n} numbers, got {got}")
    out = [as_float(v, what) for v in value]
    if not all(math.isfinite(v) for v in out):
        raise ArgumentError(f"{what} must be finite, got {quote(value)}")
    return out


def check_args(args: list, *kinds: str) -> list:
    """Check arity and convert each argument: kinds are "int", "float", "str", "any".

    Hot path (every command): exact type tests (msgpack gives plain int, float, str), and the
    error message is built only when an argument is wrong.
    """
    if len(args) != len(kinds):
        raise ArgumentError(f"expected {len(kinds)} arguments, got {len(args)}")
    out = list(args)
    for i, k in enumerate(kinds):
        t = type(out[i])
        if k == "int":
            if t is not int:
                as_int(out[i], f"argument {i + 1}")  # raises with the message
        elif k == "float":
            if t is int:
                out[i] = float(out[i])
            elif t is not float:
                out[i] = as_float(out[i], f"argument {i + 1}")
        elif k == "str" and t is not str:
            raise ArgumentError(f"argument {i + 1} must be a string, got {t.__name__}")
    return out


def as_text(value: Any, what: str) -> str:
    """A string; bytes are decoded as UTF-8 (invalid sequences replaced). Else ArgumentError."""
    if isinstance(value, (bytes, bytearray)):
        return bytes(value).decode("utf-8", errors="replace")
    if not isinstance(value, str):
        raise ArgumentError(f"{what} must be a string, got {type(value).__name__}")
    return value


def as_bytes(value: Any, what: str, *, byte_values: bool = False) -> bytes:
    """A byte string: a bytes-like object as it is, and a str as UTF-8 (a script's or ZMQ
    client's buffer); with ``byte_values`` instead of a str a flat list of ints in -128..255
    (signed or unsigned bytes, as V-REP's remote API took image buffers), each taken modulo
    256. Anything else -> ArgumentError naming ``what``."""
    if isinstance(value, (bytes, bytearray, memoryview)):
        return bytes(value)
    if isinstance(value, str) and not byte_values:
        return value.encode("utf-8")
    if byte_values and isinstance(value, (list, tuple)):
        arr = np.asarray(value) if value else np.zeros(0, dtype=np.int64)
        if arr.ndim != 1 or arr.dtype.kind not in "iu" or (arr.size and (arr.min() < -128 or arr.max() > 255)):
            raise ArgumentError(f"{what} as a list must hold ints in -128..255 (signed or unsigned bytes)")
        return (arr.astype(np.int64) & 0xFF).astype(np.uint8).tobytes()
    if byte_values:
        raise ArgumentError(f"{what} must be bytes or a list of byte values, got {type(value).__name__}")
    raise ArgumentError(f"{what} must be a string (bytes), got {type(value).__name__}")


def as_integer(value: Any, what: str) -> int:
    """An int from a script or ZMQ value: an int, an integral float (Lua 5.3 and JSON numbers) or
    a numpy integer; not a bool. Else ArgumentError."""
    if type(value) is int:  # the usual case, first
        return value
    if isinstance(value, (np.integer, np.floating)):
        value = value.item()
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ArgumentError(f"{what} must be an integer, got {value!r}")
    return value


def as_number(value: Any, what: str) -> float:
    """A finite float from an int, a float or a numpy scalar; not a bool. Else ArgumentError."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ArgumentError(f"{what} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise ArgumentError(f"{what} must be finite, got {value!r}")
    return v


def as_vector(value: Any, n: int, what: str) -> list[float]:
    """Exactly ``n`` finite numbers (a list, tuple or 1-D numpy array) as floats, each checked by
    :func:`as_number` (an error names the element, ``what[i]``, 1-based as in Lua)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise ArgumentError(f"{what} must be a table of {n} numbers, got {value!r}")
    return [as_number(v, f"{what}[{i + 1}]") for i, v in enumerate(value)]
