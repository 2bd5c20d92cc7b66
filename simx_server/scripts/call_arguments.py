"""What a script call's arguments take in a Lua state, bounded before any conversion (both
doors: the legacy simxCallScriptFunction and the ZMQ sim.callScriptFunction), and a script
function's results as the legacy call's four lists (:func:`legacy_outputs`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_wire.protocol import ArgumentError, ScriptError
from simx_server.base import limits as L

#: Bytes a converted value may take in a Lua state at most (a table slot as the table grows,
#: a string's header): a call's arguments are converted only when this estimate fits.
_LUA_BYTES_PER_VALUE = 64
_MAX_DEPTH = 32  # nesting of tables converted between Lua and Python (as lua.py's)
_LUA_BYTES_PER_TABLE = 128  # a table's header and its slot in its parent, about


def script_argument_bytes(args: tuple) -> int:
    """Bytes ``args`` take in a Lua state, about, walked without recursion before any conversion.

    Raises ArgumentError past limits.MAX_SCRIPT_CALL_VALUES values (numbers, booleans, strings),
    MAX_SCRIPT_CALL_TABLES tables (lists and dicts: a million empty tables in a 1 MiB request
    took 13 s to convert) or MAX_SCRIPT_CALL_BYTES bytes of strings and buffers, or nested deeper
    than the conversion goes."""
    values = tables = size = 0
    stack = [(args, 0)]
    while stack:
        items, depth = stack.pop()
        for v in (items.items() if isinstance(items, dict) else items):
            for w in (v if isinstance(items, dict) else (v,)):
                if isinstance(w, str):
                    values += 1
                    size += len(w)
                elif isinstance(w, (bytes, bytearray, memoryview)):  # buffers: counted by their bytes
                    size += len(w) + _LUA_BYTES_PER_VALUE
                elif not isinstance(w, (list, tuple, dict)):
                    values += 1
                else:
                    tables += 1
                    if tables > L.MAX_SCRIPT_CALL_TABLES:
                        raise ArgumentError(f"more than {L.MAX_SCRIPT_CALL_TABLES} tables passed to a script "
                                            "function (limits.MAX_SCRIPT_CALL_TABLES)")
                    if depth >= _MAX_DEPTH:
                        raise ArgumentError(f"tables nested deeper than {_MAX_DEPTH} passed to a script function")
                    stack.append((w, depth + 1))
            if values > L.MAX_SCRIPT_CALL_VALUES:
                raise ArgumentError(f"more than {L.MAX_SCRIPT_CALL_VALUES} values passed to a script function "
                                    "(limits.MAX_SCRIPT_CALL_VALUES)")
    if size > L.MAX_SCRIPT_CALL_BYTES:
        raise ArgumentError(f"{size} bytes of strings passed to a script function: at most "
                            f"{L.MAX_SCRIPT_CALL_BYTES} (limits.MAX_SCRIPT_CALL_BYTES)")
    return _LUA_BYTES_PER_VALUE * values + _LUA_BYTES_PER_TABLE * tables + size


def legacy_outputs(out: Any) -> list:
    """A script function's return value as the legacy ``[ints, floats, strings, buffer]``.

    Accepts None, one value, or a tuple/list of up to four; missing values are empty. Numbers
    in the ints list are truncated to integers (as V-REP's C side did), strings may be bytes
    (decoded as UTF-8), the buffer bytes or str. Raises ScriptError for anything else."""
    if out is None:
        values: list = []
    elif isinstance(out, tuple):
        values = list(out)
    else:
        values = [out]
    if len(values) > 4:
        raise ScriptError(f"returned {len(values)} values; at most 4 (ints, floats, strings, buffer)")
    values += [None] * (4 - len(values))
    ints, floats, strings, buf = values
    try:
        ints = [_as_int(v) for v in _seq(ints, "ints")]
        floats = [_as_float(v) for v in _seq(floats, "floats")]
        strings = [_as_str(v) for v in _seq(strings, "strings")]
        if buf is None:
            buf = b""
        elif isinstance(buf, str):
            buf = buf.encode("utf-8")
        elif isinstance(buf, (bytes, bytearray, memoryview)):
            buf = bytes(buf)
        else:
            raise TypeError(f"the buffer must be a string (bytes), got {type(buf).__name__}")
    except (TypeError, ValueError, OverflowError) as exc:
        raise ScriptError(f"returned values of the wrong types: {exc}") from None
    return [ints, floats, strings, buf]


def _seq(value: Any, what: str) -> list:
    if value is None:
        return []
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return list(value)
    raise TypeError(f"{what} must be a list (a Lua table), got {type(value).__name__}")


def _as_int(v: Any) -> int:
    if isinstance(v, (str, bytes)) or v is None:
        raise TypeError(f"ints must be numbers, got {v!r}")
    return int(v)


def _as_float(v: Any) -> float:
    if isinstance(v, (str, bytes)) or v is None:
        raise TypeError(f"floats must be numbers, got {v!r}")
    return float(v)


def _as_str(v: Any) -> str:
    if isinstance(v, (bytes, bytearray)):
        return bytes(v).decode("utf-8", errors="replace")
    if isinstance(v, str):
        return v
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return str(v)
    raise TypeError(f"strings must be strings, got {v!r}")


_WRONG_TYPES = "script arguments must be lists of ints, floats and strings, and bytes"


def check_call_arguments(ints: Any, floats: Any, strings: Any, buffer: Any) -> None:
    """Types and bounds of simxCallScriptFunction's arguments, the bounds first (before any
    per-value work): at most limits.MAX_SCRIPT_CALL_VALUES values and MAX_SCRIPT_CALL_BYTES
    bytes of strings and buffer.

    Raises:
        ArgumentError: naming the bound that was passed, or the types expected.
    """
    if not (type(ints) is list and type(floats) is list and type(strings) is list
            and isinstance(buffer, (bytes, bytearray))):
        raise ArgumentError(_WRONG_TYPES)
    count = len(ints) + len(floats) + len(strings)
    if count > L.MAX_SCRIPT_CALL_VALUES:
        raise ArgumentError(f"{count} values passed to a script function: at most {L.MAX_SCRIPT_CALL_VALUES} "
                            "(limits.MAX_SCRIPT_CALL_VALUES)")
    if not all(type(v) is str for v in strings):
        raise ArgumentError(_WRONG_TYPES)
    size = len(buffer) + sum(map(len, strings))
    if size > L.MAX_SCRIPT_CALL_BYTES:
        raise ArgumentError(f"{size} bytes of strings and buffer passed to a script function: at most "
                            f"{L.MAX_SCRIPT_CALL_BYTES} (limits.MAX_SCRIPT_CALL_BYTES)")
    if not (all(type(v) is int for v in ints) and all(type(v) in (int, float) for v in floats)):
        raise ArgumentError(_WRONG_TYPES)
