"""V-REP's core ``sim`` calls on top of the world: object names, types and parents, poses,
simulation time, signals, the status bar, packing tables (V-REP's names and units).

The signals they read and write are the server's store, :class:`simx_server.api.signals.Signals`.
"""

from __future__ import annotations

import logging
import struct
from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError
from simx_server.api.signals import Signals
from simx_server.api.sim.stepped import strings_as_text
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num  # noqa: F401
from simx_server.base.arguments import as_text as _text, as_vector as _vector  # noqa: F401 (api.sim modules use them)

log = logging.getLogger("simx.scripts")


def script_constants() -> dict[str, int]:
    """The ``sim.*`` constants of child scripts: every ``sim_X`` constant of vrepConst.py,
    simConst.py and the Lua API's extras (:data:`simx_wire.constants.SCRIPT_ONLY`) as
    ``sim.X`` (Lua also reads it as ``sim_X``), plus ``handle_world`` (-1).

    Returns:
        Name (without ``sim.``) -> value.
    """
    table = {**C.SIM_CONSTANTS, **C.VREP_CONSTANTS, **C.SCRIPT_ONLY}
    out = {name[4:]: value for name, value in table.items() if name.startswith("sim_")}
    out["handle_world"] = -1
    return out


SCRIPT_CONSTANTS: dict[str, int] = script_constants()


#: pack/unpack formats: struct code and item size of each V-REP pack*Table function.
_PACK_FORMATS = {"Int32": "i", "UInt32": "I", "Float": "f", "Double": "d", "UInt8": "B", "UInt16": "H"}


# V-REP's core ``sim`` functions, on top of the world (V-REP's names and units).
#
# Python scripts call them directly and Lua scripts through :mod:`simx_server.scripts.lua`
# (every registered function is ``sim.NAME`` there, every constant of :func:`script_constants`
# ``sim.CONSTANT``). Vectors are lists (Lua tables), strings may be ``str`` or ``bytes``, buffers
# are ``bytes``. Errors raise the simx exceptions (UnknownObjectError, ObjectTypeError,
# ArgumentError); Lua sees them as Lua errors.

@sim_function("getObjectName")
def getObjectName(ctx: CallContext, handle: Any) -> str:  # noqa: N802
    """Name of the object ``handle``.

    Args:
        handle: the object's handle (``sim.handle_self``: the script's object).

    Returns:
        The V-REP name.

    Raises:
        UnknownObjectError: no such object.
    """
    return ctx.world.get(ctx.h(handle)).name


@sim_function("getObjectType")
def getObjectType(ctx: CallContext, handle: Any) -> int:  # noqa: N802
    """Type of the object (``sim.object_joint_type`` ...).

    Args:
        handle: the object's handle.

    Returns:
        A ``sim.object_*_type`` value.

    Raises:
        UnknownObjectError: no such object.
    """
    return ctx.world.get(ctx.h(handle)).type


@sim_function("getObjectParent")
def getObjectParent(ctx: CallContext, handle: Any) -> int:  # noqa: N802
    """Handle of the object's parent, -1 for the world.

    Args:
        handle: the object's handle.

    Returns:
        The parent's handle, or -1.

    Raises:
        UnknownObjectError: no such object.
    """
    return ctx.world.get(ctx.h(handle)).parent


@sim_function("getObjectAssociatedWithScript")
def getObjectAssociatedWithScript(ctx: CallContext, script: Any) -> int:  # noqa: N802
    """The script's object (only ``sim.handle_self`` is a script handle in simx).

    Args:
        script: ``sim.handle_self``.

    Returns:
        The script's object's handle.

    Raises:
        ArgumentError: any other script handle.
    """
    if _int(script, "script handle") != C.sim_handle_self:
        raise ArgumentError("simx knows only sim.handle_self as a script handle")
    return ctx.owner


@sim_function("getObjects")
def getObjects(ctx: CallContext, index: Any, object_type: Any) -> int:  # noqa: N802
    """The ``index``-th object (0-based) of ``object_type`` (``sim.handle_all``: any), or -1.

    Args:
        index: 0-based.
        object_type: a ``sim.object_*_type`` value, or ``sim.handle_all``.

    Returns:
        A handle, or -1 past the last.
    """
    handles = ctx.world.objects_of_type(_int(object_type, "objectType"))
    i = _int(index, "index")
    return handles[i] if 0 <= i < len(handles) else -1


#: Bits of an object handle that are flags (coppeliaSimLib ``sim_handleflag_flagmask``), the
#: handle proper (``sim_handleflag_handlemask``), and the pose calls' flags.
HANDLE_FLAGS, HANDLE_MASK = 0x0FF00000, 0x000FFFFF
HANDLEFLAG_RELJOINTBASEFRAME, HANDLEFLAG_WXYZQUAT = 0x400000, 0x1000000
#: Scripts written before this version (CoppeliaSim 4.0.1) count a joint they are relative to by
#: its base frame (coppeliaSimLib ``CDetachedScript::_adjustScriptText11_old``).
_JOINT_BASE_BEFORE = 40001


def pose_handles(ctx: CallContext, handle: Any, relative_to: Any) -> tuple[int, int, bool, int]:
    """The object and reference of a pose call, as coppeliaSimLib ``simGetObjectPosition_internal``
    & co. read them: the object handle less its flags (``handle + sim.handleflag_reljointbaseframe``,
    ``+ sim.handleflag_wxyzquat``), the reference (-1, ``sim.handle_parent`` or an object),
    whether a joint as reference counts by its base frame (the flag, or a script saved before
    CoppeliaSim 4.0.1, for which CoppeliaSim adds the flag to its pose calls:
    ``_adjustScriptText11_old``), and the flags.

    Raises:
        UnknownObjectError: no such object as reference.
    """
    h = ctx.h(handle)
    flags = h & HANDLE_FLAGS if h >= 0 else 0
    h = h & HANDLE_MASK if flags else h
    version = getattr(ctx.script, "version", None)
    old = isinstance(version, int) and version < _JOINT_BASE_BEFORE
    return h, ctx.rel(relative_to), bool(flags & HANDLEFLAG_RELJOINTBASEFRAME) or old, flags


def set_pose(ctx: CallContext, handle: Any, relative_to: Any, position: list[float] | None = None,
             rotation: np.ndarray | None = None) -> None:
    """Place an object (:meth:`simx_server.sim.world.World.set_pose`), its handle's flags read
    as :func:`pose_handles` reads them."""
    h, rel, base, _ = pose_handles(ctx, handle, relative_to)
    ctx.world.set_pose(h, rel, position=position, rotation=rotation, reference_base=base)


def frame_of(ctx: CallContext, handle: int) -> tuple[np.ndarray, np.ndarray]:
    """The object's rotation (3x3) and position (3, m) in the world (point clouds, octrees, shapes built)."""
    mat = np.array(ctx.sim.getObjectMatrix(handle, -1), dtype=float).reshape(3, 4)
    return mat[:, :3], mat[:, 3]


@sim_function("getSimulationTime")
def getSimulationTime(ctx: CallContext) -> float:  # noqa: N802
    """Simulation time (s).

    Returns:
        s.
    """
    return ctx.world.time


@sim_function("getSimulationTimeStep")
def getSimulationTimeStep(ctx: CallContext) -> float:  # noqa: N802
    """Simulation step dt (s).

    Returns:
        s.
    """
    return ctx.world.dt


@sim_function("setIntegerSignal")
def setIntegerSignal(ctx: CallContext, name: Any, value: Any) -> None:  # noqa: N802
    """Set integer signal ``name``.

    Args:
        name: the signal's name.
        value: an integer (64 bits).

    Raises:
        ArgumentError: a bad name or value, or the store's bounds.
    """
    ctx.signals.set(Signals.INT, _text(name, "signal name"), value, by_script=True)


@sim_function("getIntegerSignal")
def getIntegerSignal(ctx: CallContext, name: Any) -> int | None:  # noqa: N802
    """Integer signal ``name``; None (Lua nil) when not set.

    Args:
        name: the signal's name.

    Returns:
        The value, or None.
    """
    return ctx.signals.get(Signals.INT, _text(name, "signal name"))


@sim_function("clearIntegerSignal")
def clearIntegerSignal(ctx: CallContext, name: Any = None) -> None:  # noqa: N802
    """Clear integer signal ``name`` (every integer signal when None).

    Args:
        name: the signal's name, or None.
    """
    ctx.signals.clear(Signals.INT, None if name is None else _text(name, "signal name"))


@sim_function("setFloatSignal", "setDoubleSignal")
def setFloatSignal(ctx: CallContext, name: Any, value: Any) -> None:  # noqa: N802
    """Set float signal ``name``.

    Args:
        name: the signal's name.
        value: a number.

    Raises:
        ArgumentError: a bad name or value, or the store's bounds.
    """
    ctx.signals.set(Signals.FLOAT, _text(name, "signal name"), _num(value, "value"), by_script=True)


@sim_function("getFloatSignal", "getDoubleSignal")
def getFloatSignal(ctx: CallContext, name: Any) -> float | None:  # noqa: N802
    """Float signal ``name``; None (Lua nil) when not set.

    Args:
        name: the signal's name.

    Returns:
        The value, or None.
    """
    return ctx.signals.get(Signals.FLOAT, _text(name, "signal name"))


@sim_function("clearFloatSignal", "clearDoubleSignal")
def clearFloatSignal(ctx: CallContext, name: Any = None) -> None:  # noqa: N802
    """Clear float signal ``name`` (every float signal when None).

    Args:
        name: the signal's name, or None.
    """
    ctx.signals.clear(Signals.FLOAT, None if name is None else _text(name, "signal name"))


@sim_function("setStringSignal")
def setStringSignal(ctx: CallContext, name: Any, value: Any) -> None:  # noqa: N802
    """Set string signal ``name`` (a byte string).

    Args:
        name: the signal's name.
        value: bytes or text (stored as bytes).

    Raises:
        ArgumentError: a bad name or value, or the store's bounds (limits.MAX_SIGNAL_BYTES ...).
    """
    ctx.signals.set(Signals.STRING, _text(name, "signal name"), _bytes(value, "value"), by_script=True)


@sim_function("getStringSignal")
def getStringSignal(ctx: CallContext, name: Any) -> bytes | None:  # noqa: N802
    """String signal ``name`` as bytes; None (Lua nil) when not set. A remote client gets text
    where the bytes are UTF-8 (CoppeliaSim's ZMQ server sends Lua strings so, and its example
    programs compare the value with a str); ``getBufferSignal`` answers the same store as bytes.

    Args:
        name: the signal's name.

    Returns:
        The bytes (or text), or None.
    """
    value = ctx.signals.get(Signals.STRING, _text(name, "signal name"))
    return strings_as_text(value) if ctx.remote else value


@sim_function("clearStringSignal")
def clearStringSignal(ctx: CallContext, name: Any = None) -> None:  # noqa: N802
    """Clear string signal ``name`` (every string signal when None).

    Args:
        name: the signal's name, or None.
    """
    ctx.signals.clear(Signals.STRING, None if name is None else _text(name, "signal name"))


@sim_function("addStatusbarMessage")
def addStatusbarMessage(ctx: CallContext, message: Any) -> None:  # noqa: N802
    """Write ``message`` to the server log (there is no status bar).

    Args:
        message: text, or None for an empty line.
    """
    log.info("[%s] %s", ctx.label, _text(message, "message") if message is not None else "")


def _pack(ctx: CallContext, kind: str, values: Any, start: Any, count: Any) -> bytes:
    if isinstance(values, np.ndarray):
        values = values.tolist()
    if not isinstance(values, (list, tuple)):
        raise ArgumentError(f"pack{kind}Table needs a table of numbers, got {values!r}")
    s, n = _int(start, "startIndex"), _int(count, "count")
    if s < 0 or n < 0:
        raise ArgumentError("startIndex and count must not be negative")
    items = values[s:] if n == 0 else values[s:s + n]
    code = _PACK_FORMATS[kind]
    conv = (lambda v: _num(v, "value")) if code in "fd" else (lambda v: _int(v, "value"))
    try:
        return struct.pack(f"<{len(items)}{code}", *(conv(v) for v in items))
    except struct.error as exc:
        raise ArgumentError(f"pack{kind}Table: {exc}") from None


def _unpack(ctx: CallContext, kind: str, data: Any, start: Any, count: Any, offset: Any) -> list:
    raw = _bytes(data, "data")
    s, n, off = _int(start, "startIndex"), _int(count, "count"), _int(offset, "additionalByteOffset")
    if s < 0 or n < 0 or off < 0:
        raise ArgumentError("startIndex, count and additionalByteOffset must not be negative")
    code = _PACK_FORMATS[kind]
    size = struct.calcsize(code)
    raw = raw[off + s * size:]
    available = len(raw) // size
    n = available if n == 0 else min(n, available)
    return list(struct.unpack(f"<{n}{code}", raw[:n * size]))


def _table_functions(kind: str) -> tuple[Any, Any]:
    """``sim.pack<kind>Table`` and ``sim.unpack<kind>Table`` (little endian, V-REP's arguments)."""

    def pack(ctx: CallContext, values: Any, startIndex: Any = 0, count: Any = 0) -> bytes:  # noqa: N803
        return _pack(ctx, kind, values, startIndex, count)

    def unpack(ctx: CallContext, data: Any, startIndex: Any = 0, count: Any = 0,  # noqa: N803
               additionalByteOffset: Any = 0) -> list:  # noqa: N803
        return _unpack(ctx, kind, data, startIndex, count, additionalByteOffset)

    pack.__doc__ = f"Pack ``values[startIndex:][:count]`` (count 0: all) as little-endian {kind} items."
    unpack.__doc__ = (f"{kind} items of a little-endian buffer, from item ``startIndex`` "
                      f"(after ``additionalByteOffset`` bytes), ``count`` of them (0: all).")
    pack.__name__, unpack.__name__ = f"pack{kind}Table", f"unpack{kind}Table"
    return pack, unpack


for _kind in _PACK_FORMATS:  # packInt32Table, unpackFloatTable, ... as V-REP names them
    _pack_fn, _unpack_fn = _table_functions(_kind)
    sim_function(f"pack{_kind}Table")(_pack_fn)
    sim_function(f"unpack{_kind}Table")(_unpack_fn)
