"""CoppeliaSim 4.8+'s typed property getters and setters (``sim.getIntProperty``,
``sim.setFloatProperty`` ...), over :func:`~simx_server.api.sim.data.getProperty` /
:func:`~simx_server.api.sim.data.setProperty`.

A typed setter (``sim.setIntProperty(h, 'customData.count', 3)``) stores the value as a custom
data block (CBOR) and remembers its ``sim.propertytype_*``; a typed getter reads any property
and checks that its value has the type asked for (an ArgumentError names both otherwise).
``getPropertyName`` / ``getPropertyInfo`` / ``getProperties`` enumerate a target's custom data and
its read-only object properties.
"""

from __future__ import annotations

from typing import Any

import cbor2

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import quote
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector

#: ``sim.propertytype_*`` -> (name, checker of a value).
TYPES: dict[int, tuple[str, Any]] = {
    0: ("bool", lambda v: bool(v)),
    1: ("int", lambda v: _int(v, "value")),
    2: ("float", lambda v: _num(v, "value")),
    3: ("string", lambda v: _text(v, "value")),
    4: ("buffer", lambda v: _bytes(v, "value")),
    5: ("vector3", lambda v: _vector(v, 3, "value")),
    6: ("quaternion", lambda v: _vector(v, 4, "value")),
    7: ("pose", lambda v: _vector(v, 7, "value")),
    8: ("matrix3x3", lambda v: _vector(v, 9, "value")),
    9: ("matrix4x4", lambda v: _vector(v, 16, "value")),
    10: ("color", lambda v: _vector(v, 3, "value")),
    11: ("floatarray", lambda v: [_num(x, "value[i]") for x in v]),
    12: ("table", lambda v: v if isinstance(v, (list, dict)) else _table_error(v)),
    13: ("intarray", lambda v: [_int(x, "value[i]") for x in v]),
    14: ("vector2", lambda v: _vector(v, 2, "value")),
    15: ("intarray2", lambda v: [_int(x, "value[i]") for x in _vector(v, 2, "value")]),
    16: ("long", lambda v: _int(v, "value")),
}
_OBJECT_TYPES = {"alias": 3, "objectType": 1, "parentHandle": 1, "handle": 1, "objectUid": 16, "pose": 7, "mass": 2,
                 "collidable": 0, "measurable": 0, "detectable": 0}


def _table_error(v: Any) -> Any:
    raise ArgumentError(f"a table property needs a table, got {type(v).__name__}")


def _get(ptype: int):
    def getter(ctx: CallContext, target: Any, pName: Any, options: Any = None) -> Any:  # noqa: N803
        value = ctx.sim.getProperty(target, pName, options)
        if value is None:
            return None
        try:
            return TYPES[ptype][1](list(value) if isinstance(value, tuple) else value)
        except (ArgumentError, TypeError) as exc:
            raise ArgumentError(f"property {quote(_text(pName, 'pName'))} is not a {TYPES[ptype][0]}: {exc}") from None
    getter.__doc__ = f"Property ``pName`` of ``target`` as a {TYPES[ptype][0]} (``sim.propertytype_{TYPES[ptype][0]}``)."
    return getter


def _set(ptype: int):
    def setter(ctx: CallContext, target: Any, pName: Any, pValue: Any) -> None:  # noqa: N803
        _set_typed(ctx, target, pName, TYPES[ptype][1](pValue), ptype)
    setter.__doc__ = (f"Set ``customData.NAME`` (or the scene's ``signal.NAME``) to a {TYPES[ptype][0]} "
                      f"(``sim.propertytype_{TYPES[ptype][0]}``).")
    return setter


# ``sim.get/set<Type>Property``, ``getPropertyName``, ``getPropertyInfo``, ``getProperties``...

def _types(ctx: CallContext) -> dict:
    holder = ctx.holder
    types = getattr(holder, "custom_types", None)
    if types is None:
        types = holder.custom_types = {}
    return types


def _set_typed(ctx: CallContext, target: Any, pName: Any, value: Any, ptype: int) -> None:
    name, h = _text(pName, "pName"), ctx.h(target, "target")
    if name.startswith("customData."):
        ctx.sim.writeCustomDataBlockEx(h, name[11:], cbor2.dumps(value))
        _types(ctx)[(h, name)] = ptype
    else:
        ctx.sim.setProperty(h, name, value)


def _names(ctx: CallContext, target: int) -> list[str]:
    out = [f"customData.{t}" for t in ctx.sim.readCustomDataTags(target)]
    if target >= 0:
        ctx.world.get(ctx.h(target))
        out += sorted(_OBJECT_TYPES)
    return out


@sim_function("getPropertyName")
def getPropertyName(ctx: CallContext, target: Any, index: Any, options: Any = None) -> tuple[str, str] | None:  # noqa: N802
    """``name, class`` of the ``index``-th property of ``target``; nil past the last.

    ``sim.getPropertyName`` (CoppeliaSim 4.8).

    Args:
        target: an object handle or ``sim.handle_scene``.
        index: 0-based.
        options: ignored.

    Returns:
        ``(name, class)``, or None.

    Raises:
        UnknownObjectError: no such object.
    """
    names = _names(ctx, ctx.h(target, "target"))
    i = _int(index, "index")
    return (names[i], "customData" if names[i].startswith("customData.") else "object") if 0 <= i < len(names) else None


@sim_function("getPropertyInfo")
def getPropertyInfo(ctx: CallContext, target: Any, pName: Any, options: Any = None) -> tuple[int, int, str] | None:  # noqa: N802, N803
    """``type, flags, description`` of a property (flags bit 0: read-only); nil when none.

    ``sim.getPropertyInfo`` (CoppeliaSim 4.8).

    Args:
        target: an object handle or ``sim.handle_scene``.
        pName: the property's name.
        options: ignored.

    Returns:
        ``(type, flags, description)``, or None.

    Raises:
        UnknownObjectError: no such object.
    """
    h, name = ctx.h(target, "target"), _text(pName, "pName")
    if name.startswith("customData."):
        if ctx.sim.readCustomDataBlockEx(h, name[11:]) is None:
            return None
        return _types(ctx).get((h, name), 4), 0, "custom data"
    if name in _OBJECT_TYPES and h >= 0:
        ctx.world.get(ctx.h(h))
        return _OBJECT_TYPES[name], 1, "object property (read-only in simx)"
    return None


@sim_function("getPropertyTypeString")
def getPropertyTypeString(ctx: CallContext, pType: Any) -> str:  # noqa: N802, N803
    """``"int"``, ``"float"``... of a ``sim.propertytype_*``.

    ``sim.getPropertyTypeString``.

    Args:
        pType: a ``sim.propertytype_*``.

    Returns:
        The type's name.

    Raises:
        ArgumentError: an unknown type.
    """
    t = _int(pType, "pType")
    if t not in TYPES:
        raise ArgumentError(f"no property type {t}")
    return TYPES[t][0]


@sim_function("getProperties")
def getProperties(ctx: CallContext, target: Any, options: Any = None) -> dict[str, Any]:  # noqa: N802
    """Every property of ``target`` and its value.

    ``sim.getProperties`` (CoppeliaSim 4.8).

    Args:
        target: an object handle or ``sim.handle_scene``.
        options: ignored.

    Returns:
        ``{name: value}``.

    Raises:
        UnknownObjectError: no such object.
    """
    h = ctx.h(target, "target")
    return {n: ctx.sim.getProperty(h, n, {"noError": True}) for n in _names(ctx, h)}


@sim_function("setProperties")
def setProperties(ctx: CallContext, target: Any, props: Any) -> None:  # noqa: N802
    """``setProperty`` for each ``name = value`` of a table.

    ``sim.setProperties`` (CoppeliaSim 4.8).

    Args:
        target: an object handle or ``sim.handle_scene``.
        props: ``{name: value}``.

    Raises:
        ArgumentError: not a table, or a property simx cannot set.
        UnknownObjectError: no such object.
    """
    if not isinstance(props, dict):
        raise ArgumentError("props must be a table of name = value")
    for name, value in props.items():
        ctx.sim.setProperty(target, name, value)


@sim_function("getPropertiesInfos")
def getPropertiesInfos(ctx: CallContext, target: Any, options: Any = None) -> dict[str, dict]:  # noqa: N802
    """``{name = {type, flags, descr}}`` for every property of ``target``.

    ``sim.getPropertiesInfos`` (CoppeliaSim 4.8).

    Args:
        target: an object handle or ``sim.handle_scene``.
        options: ignored.

    Returns:
        ``{name: {type, flags, descr}}``.

    Raises:
        UnknownObjectError: no such object.
    """
    h = ctx.h(target, "target")
    out = {}
    for n in _names(ctx, h):
        info = getPropertyInfo(ctx, h, n)
        if info is not None:
            out[n] = {"type": info[0], "flags": info[1], "descr": info[2]}
    return out




for _t, (_name, _) in TYPES.items():
    if _t in (8, 9):  # matrices: no typed function of their own in CoppeliaSim's table
        continue
    _cap = {"intarray2": "IntArray2", "floatarray": "FloatArray", "intarray": "IntArray", "vector2": "Vector2",
            "vector3": "Vector3"}.get(_name, _name.capitalize())
    sim_function(f"get{_cap}Property")(_get(_t))
    sim_function(f"set{_cap}Property")(_set(_t))
