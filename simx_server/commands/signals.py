"""Signal commands: integer, float and string signals, string streams (``simxSetIntegerSignal``,
``simxAppendStringSignal``, ...), shared by every client and child script. Every handler is
``(simulation, args) -> result``."""

from __future__ import annotations

from typing import Any

from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base.arguments import check_args as _args, quote
from simx_server.commands.handler import Handler
from simx_server.scene.simulation import Simulation

# Signals: one store per server, shared by every client and child script.
_SIGNAL_KINDS = {"Integer": "int", "Float": "float", "String": "string"}


def _set_signal(kind: str) -> Handler:
    def handler(sim: Simulation, args: list) -> None:
        name, value = _args(args, "str", "any")
        sim.signals.set(kind, name, value)

    return handler


def _get_signal(kind: str, clear: bool = False) -> Handler:
    def handler(sim: Simulation, args: list) -> Any:
        (name,) = _args(args, "str")
        value = sim.signals.get(kind, name)
        if value is None:
            raise UnknownObjectError(f"{kind} signal {name!r} does not exist")
        if clear:
            sim.signals.clear(kind, name)
        return value

    return handler


def _clear_signal(kind: str) -> Handler:
    def handler(sim: Simulation, args: list) -> None:
        (name,) = _args(args, "str")
        sim.signals.clear(kind, name or None)  # "" clears every signal of the kind

    return handler


def append_string_signal(sim: Simulation, args: list) -> None:
    name, value = _args(args, "str", "any")
    if not isinstance(value, bytes):
        raise ArgumentError("string signal data must be bytes")
    old = sim.signals.get("string", name, b"")
    if len(old) + len(value) > sim.signals.max_bytes:  # before building old + value: no copy for a refusal
        raise ArgumentError(f"string signal {quote(name)} would hold {len(old) + len(value)} bytes, more than "
                            f"{sim.signals.max_bytes} (simx_server.base.limits.MAX_SIGNAL_BYTES)")
    sim.signals.set("string", name, old + value)


def read_string_stream(sim: Simulation, args: list) -> bytes:
    """What was written to the stream since the last read (empty when nothing was)."""
    (name,) = _args(args, "str")
    value = sim.signals.get("string", name, b"")
    sim.signals.clear("string", name)
    return value


SIGNAL_HANDLERS: dict[str, Handler] = {
    **{f"Set{k}Signal": _set_signal(v) for k, v in _SIGNAL_KINDS.items()},
    **{f"Get{k}Signal": _get_signal(v) for k, v in _SIGNAL_KINDS.items()},
    **{f"Clear{k}Signal": _clear_signal(v) for k, v in _SIGNAL_KINDS.items()},
    "GetAndClearStringSignal": _get_signal("string", clear=True),
    "AppendStringSignal": append_string_signal,
    "WriteStringStream": append_string_signal,
    "ReadStringStream": read_string_stream,
}



