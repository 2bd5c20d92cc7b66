"""CoppeliaSim 4.x's data functions of ``sim``: table
packing, buffer signals, custom data on objects and the scene, the 4.8+ properties API over
them (rotation arithmetic: :mod:`simx_server.api.sim.rotations`).

* ``packTable`` / ``unpackTable`` use CBOR (RFC 8949, the ``cbor2`` library): CoppeliaSim 4.x's
  ``packTable(t, 1)`` format, which its ``unpackTable`` reads back; a buffer packed by simx is
  unpacked by simx and by CoppeliaSim, and ``unpackTable`` also reads CoppeliaSim's own binary
  format (scheme 0, its default: the custom data of the scenes it saved,
  :mod:`simx_server.api.stack_tables`).
* Custom data (``writeCustomDataBlockEx`` and the typed ``writeCustom*Data``) is kept per object
  (``sim.handle_scene`` for the scene) for the server's lifetime, bounded like signals.
* Properties: ``customData.NAME`` and ``signal.NAME`` on any handle map onto the two stores,
  plus read-only object properties (``alias``, ``objectType``, ``parentHandle``, ``mass`` of a
  shape...); typed getters/setters check the value's type.
"""

from __future__ import annotations

from typing import Any

import cbor2
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base.arguments import quote
from simx_server.api.signals import Signals
from simx_server.api.stack_tables import is_stack_buffer, unpack_stack_table
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_text as _text
from simx_server.sim import properties
from simx_server.sim.objects import SHAPE

HANDLE_SCENE, HANDLE_APP = -12, -13
_MAX_CUSTOM_BYTES = 16 << 20  # all custom data of a server
_CBOR_FIRST = set(range(0x80, 0xC0)) | {0xF6}  # CBOR arrays, maps, null
#: CoppeliaSim 4.8's boolean object properties over V-REP's special property bits (detectable: all kinds).
_SPECIAL = {"collidable": properties.COLLIDABLE, "measurable": properties.MEASURABLE,
            "detectable": properties.DETECTABLE_ALL}


def _plain(value: Any, depth: int = 0) -> Any:
    """A value CBOR can carry (lists for tuples and numpy arrays); bounded nesting."""
    if depth > 64:
        raise ArgumentError("packTable: table nested more than 64 levels")
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v, depth + 1) for v in value]
    if isinstance(value, dict):
        return {_plain(k, depth + 1): _plain(v, depth + 1) for k, v in value.items()}
    if isinstance(value, np.generic):
        return value.item()
    return value


# Packing, buffer signals, custom data, properties.

@sim_function("packTable")
def packTable(ctx: CallContext, aTable: Any, scheme: Any = 0) -> bytes:  # noqa: N802, N803
    """A table (list or dict, nested) as a CBOR buffer (``scheme`` 0 or 1: simx writes CBOR
    for both; CoppeliaSim reads it with ``unpackTable``).

    Args:
        aTable: a list, tuple, dict or numpy array (nested at most 64 levels).
        scheme: 0 or 1 (both give CBOR).

    Returns:
        The CBOR bytes.

    Raises:
        ArgumentError: not a table, nested too deep, or a value CBOR cannot carry.
    """
    if not isinstance(aTable, (list, tuple, dict, np.ndarray)):
        raise ArgumentError(f"packTable needs a table, got {type(aTable).__name__}")
    _int(scheme, "scheme")
    try:
        return cbor2.dumps(_plain(aTable))
    except (TypeError, ValueError, cbor2.CBOREncodeError) as exc:
        raise ArgumentError(f"packTable: {exc}") from None


@sim_function("unpackTable")
def unpackTable(ctx: CallContext, buffer: Any) -> Any:  # noqa: N802
    """The table of a buffer :func:`packTable` wrote (CBOR), or of one CoppeliaSim's
    ``sim.packTable`` wrote in its own binary format (scheme 0: custom data of the scenes it
    saved, :mod:`simx_server.api.stack_tables`).

    ``sim.unpackTable``.

    Args:
        buffer: bytes of a CBOR array or map (or CBOR null), or of a binary packed table.

    Returns:
        The list or dict.

    Raises:
        ArgumentError: neither, or a malformed one.
    """
    raw = _bytes(buffer, "buffer")
    if is_stack_buffer(raw):  # CoppeliaSim's own scheme-0 format, as scenes it saved keep
        return unpack_stack_table(raw)
    if not raw or raw[0] not in _CBOR_FIRST:
        raise ArgumentError("unpackTable reads CBOR buffers (packTable's) and CoppeliaSim's binary packed "
                            "tables; this buffer is neither")
    try:
        return cbor2.loads(raw, max_depth=65, allow_indefinite=False)
    except (cbor2.CBORDecodeError, ValueError, RecursionError) as exc:
        raise ArgumentError(f"unpackTable: not a CBOR table ({exc})") from None


@sim_function("copyTable")
def copyTable(ctx: CallContext, original: Any) -> Any:  # noqa: N802
    """A deep copy of a table.

    ``sim.copyTable``.

    Args:
        original: a list, dict or numpy array.

    Returns:
        The copy (lists for tuples and arrays).

    Raises:
        ArgumentError: nested more than 64 levels.
    """
    return _plain(original)


@sim_function("setBufferSignal")
def setBufferSignal(ctx: CallContext, signalName: Any, signalValue: Any) -> None:  # noqa: N802, N803
    """A buffer signal (CoppeliaSim 4: the string signals of V-REP, one store).

    ``sim.setBufferSignal``.

    Args:
        signalName: the signal's name.
        signalValue: bytes (or a string).

    Raises:
        ArgumentError: a bad name or value, or the signal store is full.
    """
    ctx.signals.set(Signals.STRING, _text(signalName, "signalName"), _bytes(signalValue, "signalValue"),
                      by_script=True)


@sim_function("getBufferSignal")
def getBufferSignal(ctx: CallContext, signalName: Any) -> bytes | None:  # noqa: N802, N803
    """``sim.getBufferSignal``: the buffer (string) signal ``signalName``.

    Args:
        signalName: the signal's name.

    Returns:
        The bytes, or None when there is no such signal.

    Raises:
        ArgumentError: ``signalName`` is not a string.

    """
    return ctx.signals.get(Signals.STRING, _text(signalName, "signalName"))


@sim_function("clearBufferSignal")
def clearBufferSignal(ctx: CallContext, signalName: Any = None) -> None:  # noqa: N802, N803
    """``sim.clearBufferSignal``: remove a buffer signal, or all of them.

    Args:
        signalName: the signal's name, or None (all buffer signals).

    Raises:
        ArgumentError: ``signalName`` is not a string.

    """
    ctx.signals.clear(Signals.STRING, None if signalName is None else _text(signalName, "signalName"))


@sim_function("getSignalName")
def getSignalName(ctx: CallContext, signalIndex: Any, signalType: Any) -> str | None:  # noqa: N802, N803
    """Name of the ``signalIndex``-th signal of ``signalType`` (0 int, 1 float, 2 string /
    buffer), in name order; nil past the last.

    ``sim.getSignalName``.

    Args:
        signalIndex: 0-based.
        signalType: 0, 1 or 2.

    Returns:
        The name, or None.

    Raises:
        ArgumentError: an unknown ``signalType``, or not integers.
    """
    kind = {0: Signals.INT, 1: Signals.FLOAT, 2: Signals.STRING}.get(_int(signalType, "signalType"))
    if kind is None:
        raise ArgumentError("signalType: 0 (integer), 1 (float) or 2 (string/buffer)")
    names = ctx.signals.names(kind)
    i = _int(signalIndex, "signalIndex")
    return names[i] if 0 <= i < len(names) else None


def _custom(ctx: CallContext, handle: Any) -> dict[str, bytes]:
    h = ctx.h(handle, "objectHandle")
    if h not in (HANDLE_SCENE, HANDLE_APP):
        h = ctx.world.get(ctx.h(h)).handle
    holder = ctx.holder
    store = getattr(holder, "custom_data", None)
    if store is None:
        store = holder.custom_data = {}
    if h in store and h >= 0 and h not in ctx.world.objects:
        del store[h]
    return store.setdefault(h, {})


@sim_function("writeCustomDataBlockEx", "writeCustomBufferData")
def writeCustomDataBlockEx(ctx: CallContext, objectHandle: Any, tagName: Any, data: Any, options: Any = None) -> None:  # noqa: N802, N803
    """Store ``data`` (bytes) under ``tagName`` on an object (``sim.handle_scene``: the
    scene); empty data removes the tag. At most 16 MiB of custom data in all.

    ``sim.writeCustomDataBlockEx`` (``sim.writeCustomBufferData``).

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.
        data: bytes (or a string); None or empty: remove the tag.
        options: ignored.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: over 16 MiB of custom data in all, or a bad argument.
    """
    block, tag = _custom(ctx, objectHandle), _text(tagName, "tagName")
    raw = b"" if data is None else _bytes(data, "data")
    total = sum(len(v) for store in getattr(ctx.holder, "custom_data", {}).values()
                for v in store.values())
    if total - len(block.get(tag, b"")) + len(raw) > _MAX_CUSTOM_BYTES:
        raise ArgumentError(f"custom data would exceed {_MAX_CUSTOM_BYTES} bytes in all")
    if raw:
        block[tag] = raw
    else:
        block.pop(tag, None)


@sim_function("readCustomDataBlockEx", "readCustomBufferData")
def readCustomDataBlockEx(ctx: CallContext, objectHandle: Any, tagName: Any, options: Any = None) -> bytes | None:  # noqa: N802, N803
    """The data stored under ``tagName``; nil when none.

    ``sim.readCustomDataBlockEx`` (``sim.readCustomBufferData``).

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.
        options: ignored.

    Returns:
        The bytes, or None.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a bad argument.
    """
    return _custom(ctx, objectHandle).get(_text(tagName, "tagName"))


@sim_function("readCustomDataTags")
def readCustomDataTags(ctx: CallContext, objectHandle: Any) -> list[str]:  # noqa: N802, N803
    """The tags with data on an object, sorted.

    ``sim.readCustomDataTags``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.

    Returns:
        The tags.

    Raises:
        UnknownObjectError: no such object.
    """
    return sorted(_custom(ctx, objectHandle))


@sim_function("writeCustomStringData")
def writeCustomStringData(ctx: CallContext, objectHandle: Any, tagName: Any, data: Any) -> None:  # noqa: N802, N803
    """``sim.writeCustomStringData``: store text (UTF-8) under ``tagName``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.
        data: the text; empty: remove the tag.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: over 16 MiB of custom data in all, or a bad argument.

    """
    writeCustomDataBlockEx(ctx, objectHandle, tagName, _text(data, "data").encode("utf-8"))


@sim_function("readCustomStringData")
def readCustomStringData(ctx: CallContext, objectHandle: Any, tagName: Any) -> str | None:  # noqa: N802, N803
    """``sim.readCustomStringData``: the text stored under ``tagName``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.

    Returns:
        The text (bad UTF-8 replaced), or None.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a bad argument.

    """
    raw = readCustomDataBlockEx(ctx, objectHandle, tagName)
    return None if raw is None else raw.decode("utf-8", "replace")


@sim_function("writeCustomTableData")
def writeCustomTableData(ctx: CallContext, objectHandle: Any, tagName: Any, data: Any, options: Any = None) -> None:  # noqa: N802, N803
    """Store a table (packed as :func:`packTable`).

    ``sim.writeCustomTableData``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.
        data: a list or dict; empty or None: remove the tag.
        options: ignored.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not a table, over 16 MiB of custom data in all, or a bad argument.
    """
    writeCustomDataBlockEx(ctx, objectHandle, tagName, packTable(ctx, data) if data else b"")


@sim_function("readCustomTableData")
def readCustomTableData(ctx: CallContext, objectHandle: Any, tagName: Any, options: Any = None) -> Any:  # noqa: N802, N803
    """The stored table; an empty table when none.

    ``sim.readCustomTableData``.

    Args:
        objectHandle: an object handle, ``sim.handle_self`` or ``sim.handle_scene``.
        tagName: the tag.
        options: ignored.

    Returns:
        The list or dict.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: the data stored is no packed table.
    """
    raw = readCustomDataBlockEx(ctx, objectHandle, tagName)
    return {} if raw is None else unpackTable(ctx, raw)


def _object_property(ctx: CallContext, handle: int, name: str) -> Any:
    obj = ctx.world.get(handle)
    values = {"alias": lambda: obj.name.split("#")[0], "objectType": lambda: obj.type,
              "parentHandle": lambda: obj.parent, "handle": lambda: obj.handle, "objectUid": lambda: obj.handle,
              "pose": lambda: ctx.world.position(handle, -1) + ctx.world.quaternion(handle, -1)}
    if obj.type == SHAPE:
        values["mass"] = lambda: float(ctx.world.model.body_mass[obj.mj_id])
    for key, bits in _SPECIAL.items():  # CoppeliaSim 4.8's names of the special properties
        values[key] = lambda bits=bits: properties.special(ctx.world, handle) & bits == bits
    if name not in values:
        raise UnknownObjectError(f"object {obj.name!r} has no property {quote(name)} in simx "
                                 f"(it has customData.*, signal.* on the scene, {', '.join(sorted(values))})")
    return values[name]()


@sim_function("getProperty")
def getProperty(ctx: CallContext, target: Any, pName: Any, options: Any = None) -> Any:  # noqa: N802, N803
    """A property of an object or of the scene (``sim.handle_scene``): ``customData.TAG``
    (the custom data block, unpacked when it is a packed table), ``signal.NAME`` (a signal of
    any kind), ``alias``, ``objectType``, ``parentHandle``, ``pose``, ``mass`` (shapes),
    ``collidable``, ``measurable``, ``detectable`` (V-REP's special properties, booleans).
    Errors: no such property (``{noError = true}``: nil).

    ``sim.getProperty`` (CoppeliaSim 4.8).

    Args:
        target: an object handle, ``sim.handle_scene`` or ``sim.handle_app``.
        pName: the property's name.
        options: ``{noError = true}``, or None.

    Returns:
        The value (pose: 7 numbers, m and a quaternion; mass: kg), or None with ``noError``.

    Raises:
        UnknownObjectError: no such object or property (without ``noError``).
        ArgumentError: a bad argument.
    """
    name, h = _text(pName, "pName"), ctx.h(target, "target")
    try:
        if name.startswith("customData."):
            raw = readCustomDataBlockEx(ctx, h, name[11:])
            if raw is None:
                raise UnknownObjectError(f"no property {quote(name)}")
            if (h, name) in getattr(ctx.holder, "custom_types", {}):
                return cbor2.loads(raw)  # written by a typed setter (simx_server.api.sim.props)
            return unpackTable(ctx, raw) if raw[:1] and raw[0] in _CBOR_FIRST else raw
        if name.startswith("signal.") and h == HANDLE_SCENE:
            for kind in Signals.KINDS:
                v = ctx.signals.get(kind, name[7:])
                if v is not None:
                    return v
            raise UnknownObjectError(f"no property {quote(name)}")
        if h in (HANDLE_SCENE, HANDLE_APP):
            raise UnknownObjectError(f"the scene has no property {quote(name)} in simx")
        return _object_property(ctx, ctx.h(h), name)
    except UnknownObjectError:
        if isinstance(options, dict) and options.get("noError"):
            return None
        raise


@sim_function("setProperty")
def setProperty(ctx: CallContext, target: Any, pName: Any, pValue: Any, pType: Any = None) -> None:  # noqa: N802, N803
    """Set ``customData.TAG`` (tables packed, bytes and text as they are), an object's
    ``collidable``, ``measurable`` or ``detectable`` (its special property bits, as
    ``sim.setObjectSpecialProperty``) or, on the scene, ``signal.NAME`` (an integer, float or
    buffer signal by the value's type).

    ``sim.setProperty`` (CoppeliaSim 4.8).

    Args:
        target: an object handle or ``sim.handle_scene``.
        pName: ``customData.TAG`` or (scene) ``signal.NAME``.
        pValue: the value.
        pType: ignored (the value's type decides).

    Raises:
        ArgumentError: a property simx cannot set, or a bad value.
        UnknownObjectError: no such object.
    """
    name, h = _text(pName, "pName"), ctx.h(target, "target")
    if name.startswith("customData."):
        value = pValue if isinstance(pValue, (bytes, bytearray)) else (
            pValue.encode() if isinstance(pValue, str) else cbor2.dumps(_plain(pValue)))
        writeCustomDataBlockEx(ctx, h, name[11:], value)
    elif name in _SPECIAL and h >= 0:  # sceneObject.collidable / measurable / detectable
        handle = ctx.h(h)
        bits = properties.special(ctx.world, handle)
        want = _SPECIAL[name]
        properties.set_special(ctx.world, handle, bits | want if bool(pValue) else bits & ~want)
    elif name.startswith("signal.") and h == HANDLE_SCENE:
        kind = Signals.INT if isinstance(pValue, int) and not isinstance(pValue, bool) else (
            Signals.FLOAT if isinstance(pValue, float) else Signals.STRING)
        ctx.signals.set(kind, name[7:], pValue, by_script=True)
    else:
        raise ArgumentError(f"property {quote(name)} cannot be set in simx (customData.*, an object's "
                            "collidable, measurable and detectable, and the scene's signal.* can)")


@sim_function("removeProperty")
def removeProperty(ctx: CallContext, target: Any, pName: Any, options: Any = None) -> None:  # noqa: N802, N803
    """``sim.removeProperty`` (CoppeliaSim 4.8): remove ``customData.TAG`` or, on the scene,
    ``signal.NAME`` (of every kind).

    Args:
        target: an object handle or ``sim.handle_scene``.
        pName: the property's name.
        options: ignored.

    Raises:
        ArgumentError: any other property.
        UnknownObjectError: no such object.

    """
    name, h = _text(pName, "pName"), ctx.h(target, "target")
    if name.startswith("customData."):
        writeCustomDataBlockEx(ctx, h, name[11:], b"")
    elif name.startswith("signal.") and h == HANDLE_SCENE:
        for kind in Signals.KINDS:
            ctx.signals.clear(kind, name[7:])
    else:
        raise ArgumentError(f"property {quote(name)} cannot be removed")


