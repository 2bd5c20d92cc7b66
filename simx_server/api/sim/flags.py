"""CoppeliaSim 4.x's object and model property flags (``sim.getObjectProperty``,
``sim.setModelProperty`` ...) and ``sim.convertPropertyValue``.

The object property flags are kept per object in the simulation's store (they change nothing
else). Until set, an object answers ``getObjectProperty`` ``sim.objectproperty_selectable``
(CoppeliaSim's default). Model properties are :mod:`simx_server.sim.properties`': a model base's
``not_*`` bits override the special properties (collidable, measurable, detectable, renderable:
:mod:`simx_server.api.sim.legacy_objects`) below it, as in V-REP; ``getModelProperty`` answers
``sim.modelproperty_not_model`` for an object that is no model base.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import paths as _paths
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_integer as _int
from simx_server.api.sim.props import TYPES
from simx_server.sim import properties

OBJECTPROPERTY_SELECTABLE = 32
_SCALARS = {0, 1, 2, 16}                                  # bool, int, float, long
_LENGTHS = {5: 3, 6: 4, 7: 7, 8: 9, 9: 16, 10: 3, 14: 2, 15: 2}  # fixed-size numeric types
_ARRAYS = {11, 13}                                         # floatarray, intarray


def _quat_to_mat(q: list[float]) -> list[float]:
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.array([q[3], q[0], q[1], q[2]]) / np.linalg.norm(q))
    return out.tolist()


def _mat_to_quat(m: list[float]) -> list[float]:
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.array(m, dtype=float))
    return [float(q[1]), float(q[2]), float(q[3]), float(q[0])]


# Property flags of objects and models; property value conversion.

def _flags(ctx: CallContext, kind: str) -> dict:
    return _paths.store_of(ctx, f"flags_{kind}")


def _flag_target(ctx: CallContext, handle: Any) -> int:
    return ctx.world.get(ctx.h(handle, "objectHandle")).handle


@sim_function("getObjectProperty")
def getObjectProperty(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """The object's ``sim.objectproperty_*`` bits (window behaviour: selectable, collapsed...).

    ``sim.getObjectProperty``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        The bits.

    Raises:
        UnknownObjectError: no such object.
    """
    h = _flag_target(ctx, objectHandle)
    return int(_flags(ctx, "object").get(h, OBJECTPROPERTY_SELECTABLE))


@sim_function("setObjectProperty")
def setObjectProperty(ctx: CallContext, objectHandle: Any, property: Any) -> None:  # noqa: N802, N803, A002
    """Keep the object's ``sim.objectproperty_*`` bits (no window: nothing else changes).

    ``sim.setObjectProperty``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        property: the bits.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not an integer.
    """
    _flags(ctx, "object")[_flag_target(ctx, objectHandle)] = _int(property, "property")


@sim_function("getModelProperty")
def getModelProperty(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """The ``sim.modelproperty_*`` bits of a model base (a ``.ttt``'s, or set by
    ``setModelProperty``); ``sim.modelproperty_not_model`` for an object that is none.

    ``sim.getModelProperty``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        The bits.

    Raises:
        UnknownObjectError: no such object.
    """
    return properties.model_property(ctx.world, _flag_target(ctx, objectHandle))


@sim_function("setModelProperty")
def setModelProperty(ctx: CallContext, objectHandle: Any, property: Any) -> None:  # noqa: N802, N803, A002
    """Set the ``sim.modelproperty_*`` bits; bits without ``sim.modelproperty_not_model``
    make the object a model base (CoppeliaSim's rule) whose ``not_collidable``,
    ``not_measurable``, ``not_detectable``, ``not_renderable`` and ``not_visible`` bits
    override the special properties of everything at and below it
    (:func:`simx_server.sim.properties.cumulative`); the other bits are kept.

    ``sim.setModelProperty``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        property: the bits.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not an integer.
    """
    properties.set_model_property(ctx.world, _flag_target(ctx, objectHandle), _int(property, "property"))


@sim_function("convertPropertyValue")
def convertPropertyValue(ctx: CallContext, value: Any, fromType: Any, toType: Any) -> Any:  # noqa: N802, N803
    """``value`` of ``sim.propertytype_*`` ``fromType`` as ``toType``: between numbers (bool,
    int, long, float), string and buffer (UTF-8), numeric vectors of one length (vector2/3,
    color, quaternion, pose, matrices, float and int arrays), quaternion and matrix3x3,
    pose and matrix4x4 (16 numbers, row-major). ArgumentError for any other pair.

    ``sim.convertPropertyValue`` (CoppeliaSim 4.8).

    Args:
        value: the value.
        fromType: a ``sim.propertytype_*``.
        toType: a ``sim.propertytype_*``.

    Returns:
        The converted value.

    Raises:
        ArgumentError: an unknown type, a pair with no conversion, or a value of the wrong kind.
    """
    src, dst = _int(fromType, "fromType"), _int(toType, "toType")
    if src not in TYPES or dst not in TYPES:
        raise ArgumentError(f"unknown property type {src if src not in TYPES else dst}")
    v = TYPES[src][1](list(value) if isinstance(value, tuple) else value)
    if src == dst:
        return v
    if src in _SCALARS and dst in _SCALARS:
        return bool(v) if dst == 0 else float(v) if dst == 2 else int(v)
    if (src, dst) == (3, 4):
        return v.encode("utf-8")
    if (src, dst) == (4, 3):
        try:
            return v.decode("utf-8")
        except UnicodeDecodeError:
            raise ArgumentError("the buffer is not UTF-8 text") from None
    if (src, dst) == (6, 8):
        return _quat_to_mat(v)
    if (src, dst) == (8, 6):
        return _mat_to_quat(v)
    if (src, dst) == (7, 9):
        rot = np.array(_quat_to_mat(v[3:])).reshape(3, 3)
        return np.vstack([np.hstack([rot, np.array(v[:3])[:, None]]), [0, 0, 0, 1]]).reshape(-1).tolist()
    if (src, dst) == (9, 7):
        m = np.array(v).reshape(4, 4)
        return [*m[:3, 3].tolist(), *_mat_to_quat(m[:3, :3].reshape(-1).tolist())]
    numeric = _LENGTHS.keys() | _ARRAYS
    if src in numeric and dst in numeric:
        n = _LENGTHS.get(dst, len(v))
        if len(v) != n:
            raise ArgumentError(f"a {TYPES[dst][0]} holds {n} numbers, the value {len(v)}")
        return TYPES[dst][1]([int(x) for x in v] if dst in (13, 15) else v)
    raise ArgumentError(f"no conversion from a {TYPES[src][0]} to a {TYPES[dst][0]}")


