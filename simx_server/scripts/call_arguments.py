"""What a script call's arguments take in a Lua state, bounded before any conversion (both
doors: the legacy simxCallScriptFunction and the ZMQ sim.callScriptFunction)."""

from __future__ import annotations

from simx_wire.protocol import ArgumentError
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
