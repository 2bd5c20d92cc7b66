"""Checks of remote-command arguments, shared by every handler module.

Arguments arrive as msgpack decoded them; a handler states what it expects and gets plain
Python values back, or an ArgumentError (remote error 8) that says which argument is wrong.
"""

from __future__ import annotations

import math
from typing import Any

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
