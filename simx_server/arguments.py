"""Checks of remote-command arguments, shared by every handler module.

Arguments arrive as msgpack decoded them; a handler states what it expects and gets plain
Python values back, or an ArgumentError (remote error 8) that says which argument is wrong.
"""

from __future__ import annotations

import math
import reprlib
from typing import Any

from simx_client.protocol import ArgumentError


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


QUOTE_LIMIT = 60  # characters of a client's value quoted in an error or a log line


def quote(value: Any, limit: int = QUOTE_LIMIT) -> str:
    """``repr(value)`` cut to ``limit`` characters (with ``...`` and the full length), for error
    messages and log lines that name a client's input: an attacker's 10 MB name must not come
    back as a 10 MB reply, and a value nested 1,000 deep must not overflow the stack."""
    r = reprlib.Repr()
    r.maxstring = r.maxother = limit
    r.maxlevel, r.maxlist, r.maxtuple, r.maxdict = 3, 8, 8, 8
    try:
        text = r.repr(value)
    except Exception:  # a value whose repr fails is named by its type
        text = f"<{type(value).__name__}>"
    if len(text) > limit:
        size = len(value) if isinstance(value, (str, bytes, list, dict)) else None
        text = text[:limit] + "..." + (f" ({size} long)" if size is not None else "")
    return text
