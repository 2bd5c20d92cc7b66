"""CoppeliaSim 4.x's engine parameters where MuJoCo has them, and application queries answered
from simx's own state (``sim.getEngineFloatParam`` and its kin, ``sim.getObjectsWithTag``,
``sim.getApiInfo``, ``sim.getSettingBool`` ...).

Engine parameters: CoppeliaSim's ``sim.mujoco_global_*`` ids map onto the model's ``mjOption``
(``impratio``, ``wind``, ``density``, ``viscosity``, ``iterations``, ``integrator``, ``solver``,
``cone``, the multi-CCD flag); the Bullet, ODE, Vortex and Newton ids answer an error naming
them, except the per-shape friction coefficients (Bullet's ``bullet_body_friction``, ODE's
``ode_body_friction``, Newton's static and kinetic friction), which map onto MuJoCo's sliding
friction of the shape's geoms (``geom_friction[:, 0]``; in a scene with Bullet's rule, every
converted ``.ttt``, the coefficient squared: :mod:`simx_server.sim.friction`). Set values are written to the model and to the scene's MjSpec (kept by later edits).
"""

from __future__ import annotations

import math
from typing import Any

import mujoco

from simx_server.api.context import CallContext
from simx_server.api.registry import SIM, sim_function
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text
from simx_server.sim import friction
from simx_server.sim.objects import JOINT, SHAPE
from simx_server.sim.state import RunState
from simx_wire.protocol import ObjectTypeError

#: ``sim.mujoco_global_*`` id -> (mjOption field, index or None, kind).
ENGINE_PARAMS: dict[int, tuple[str, int | None, str]] = {
    37002: ("impratio", None, "float"), 37003: ("wind", 0, "float"), 37004: ("wind", 1, "float"),
    37005: ("wind", 2, "float"), 37006: ("density", None, "float"), 37007: ("viscosity", None, "float"),
    38002: ("iterations", None, "int"), 38003: ("integrator", None, "int"), 38004: ("solver", None, "int"),
    38007: ("cone", None, "int"), 39003: ("multiccd", None, "bool"),
}
_LIMITS = {"impratio": (1e-6, 1e3), "wind": (-1e3, 1e3), "density": (0.0, 1e4), "viscosity": (0.0, 1e3),
           "iterations": (1, 1000), "integrator": (0, 3), "solver": (0, 2), "cone": (0, 1)}


#: Per-shape friction ids of CoppeliaSim's engines (simConst: sim_bullet_body_friction...).
BODY_FRICTION = {6003: "bullet_body_friction", 15001: "ode_body_friction", 33001: "newton_body_staticfriction",
                 33002: "newton_body_kineticfriction"}


def _friction_geoms(ctx: CallContext, what: str, pid: int, objectHandle: Any) -> Any:  # noqa: N803
    """The geoms of the shape ``objectHandle`` whose friction ``pid`` reads or sets."""
    obj = ctx.world.get(ctx.h(objectHandle, "objectHandle"))
    if obj.type != SHAPE:
        raise ObjectTypeError(f"sim.{what}: {BODY_FRICTION[pid]} applies to shapes; {obj.name!r} is not one")
    m = ctx.world.model
    geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == obj.mj_id]
    if not geoms:
        raise ObjectTypeError(f"sim.{what}: shape {obj.name!r} has no geometry")
    return geoms


# ``sim.get/setEngine*Param``, ``isDynamicallyEnabled``, object tags and order, API info.

def _engine(ctx: CallContext, what: str, paramId: Any, objectHandle: Any, kind: str) -> tuple[str, int | None]:  # noqa: N803
    pid, h = _int(paramId, "paramId"), ctx.h(objectHandle, "objectHandle")
    entry = ENGINE_PARAMS.get(pid)
    if entry is None or entry[2] != kind:
        raise UnsupportedError(f"sim.{what}: engine parameter {pid} has no MuJoCo counterpart in simx "
                               "(sim.mujoco_global_* ids of mjOption do)")
    if h != -1:
        raise UnsupportedError(f"sim.{what}: per-object engine parameters: MuJoCo's are in the MJCF")
    return entry[0], entry[1]


def _opt(ctx: CallContext, field: str, index: int | None) -> Any:
    opt = ctx.world.model.opt
    if field == "multiccd":  # MuJoCo 3.x: on unless disabled
        return not opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
    value = getattr(opt, field)
    return value[index] if index is not None else value


def _set_opt(ctx: CallContext, field: str, index: int | None, value: Any) -> None:
    lo, hi = _LIMITS.get(field, (None, None))
    if lo is not None and not lo <= value <= hi:
        raise ArgumentError(f"{field} must lie in [{lo}, {hi}]")
    targets = [ctx.world.model.opt]
    sim = ctx.view
    try:
        targets.append(sim.editor._live_spec().option if sim is not None else None)
    except UnsupportedError:
        pass
    for opt in (t for t in targets if t is not None):
        if field == "multiccd":
            bit = int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
            opt.disableflags = (opt.disableflags & ~bit) if value else (opt.disableflags | bit)
        elif index is not None:
            getattr(opt, field)[index] = value
        else:
            setattr(opt, field, value)


@sim_function("getEngineFloatParam")
def getEngineFloatParam(ctx: CallContext, paramId: Any, objectHandle: Any) -> float:  # noqa: N802, N803
    """``sim.mujoco_global_impratio``, ``wind1..3`` (m/s), ``density`` (kg/m³), ``viscosity``.

    ``sim.getEngineFloatParam``.

    Args:
        paramId: a ``sim.mujoco_global_*`` float parameter, or a body friction id (BODY_FRICTION).
        objectHandle: -1 (global parameters), a shape for a body friction.

    Returns:
        The value (MuJoCo's ``opt`` field).

    Raises:
        UnsupportedError: a parameter with no MuJoCo counterpart, or a per-object one.
    """
    if isinstance(paramId, int) and paramId in BODY_FRICTION:
        geoms = _friction_geoms(ctx, "getEngineFloatParam", paramId, objectHandle)
        value = float(ctx.world.model.geom_friction[geoms[0], 0])
        return math.sqrt(value) if friction.declared(ctx.world.model) else value  # stored squared there
    return float(_opt(ctx, *_engine(ctx, "getEngineFloatParam", paramId, objectHandle, "float")))


@sim_function("setEngineFloatParam")
def setEngineFloatParam(ctx: CallContext, paramId: Any, objectHandle: Any, floatParam: Any) -> None:  # noqa: N802, N803
    """``sim.setEngineFloatParam``: set a MuJoCo ``opt`` field (see :func:`getEngineFloatParam`).

    Args:
        paramId: a ``sim.mujoco_global_*`` float parameter, or a body friction id (BODY_FRICTION).
        objectHandle: -1 (global parameters), a shape for a body friction.
        floatParam: the value, in the field's range.

    Raises:
        UnsupportedError: a parameter with no MuJoCo counterpart, or a per-object one.
        ArgumentError: a value out of range, or not a number.

    """
    if isinstance(paramId, int) and paramId in BODY_FRICTION:
        value = _num(floatParam, "floatParam")
        if not 0.0 <= value <= 1e3:
            raise ArgumentError(f"{BODY_FRICTION[paramId]} must lie in [0, 1000]")
        if friction.declared(ctx.world.model):  # Bullet's rule: the coefficient squared (sim/friction.py)
            value = min(value * value, friction.BULLET_MAX_FRICTION)
        for g in _friction_geoms(ctx, "setEngineFloatParam", paramId, objectHandle):
            ctx.world.model.geom_friction[g, 0] = value
        return
    _set_opt(ctx, *_engine(ctx, "setEngineFloatParam", paramId, objectHandle, "float"), _num(floatParam, "floatParam"))


@sim_function("getEngineInt32Param")
def getEngineInt32Param(ctx: CallContext, paramId: Any, objectHandle: Any) -> int:  # noqa: N802, N803
    """``sim.mujoco_global_iterations``, ``integrator``, ``solver``, ``cone`` (MuJoCo's enums).

    ``sim.getEngineInt32Param``.

    Args:
        paramId: a ``sim.mujoco_global_*`` integer parameter.
        objectHandle: -1 (global parameters only).

    Returns:
        The value.

    Raises:
        UnsupportedError: a parameter with no MuJoCo counterpart, or a per-object one.
    """
    return int(_opt(ctx, *_engine(ctx, "getEngineInt32Param", paramId, objectHandle, "int")))


@sim_function("setEngineInt32Param")
def setEngineInt32Param(ctx: CallContext, paramId: Any, objectHandle: Any, int32Param: Any) -> None:  # noqa: N802, N803
    """``sim.setEngineInt32Param``: set a MuJoCo ``opt`` field (see :func:`getEngineInt32Param`).

    Args:
        paramId: a ``sim.mujoco_global_*`` integer parameter.
        objectHandle: -1 (global parameters only).
        int32Param: the value, in the field's range.

    Raises:
        UnsupportedError: a parameter with no MuJoCo counterpart, or a per-object one.
        ArgumentError: a value out of range, or not an integer.

    """
    _set_opt(ctx, *_engine(ctx, "setEngineInt32Param", paramId, objectHandle, "int"), _int(int32Param, "int32Param"))


@sim_function("getEngineBoolParam")
def getEngineBoolParam(ctx: CallContext, paramId: Any, objectHandle: Any) -> bool:  # noqa: N802, N803
    """``sim.mujoco_global_multiccd``.

    ``sim.getEngineBoolParam``.

    Args:
        paramId: a ``sim.mujoco_global_*`` boolean parameter.
        objectHandle: -1 (global parameters only).

    Returns:
        The value.

    Raises:
        UnsupportedError: a parameter with no MuJoCo counterpart, or a per-object one.
    """
    return bool(_opt(ctx, *_engine(ctx, "getEngineBoolParam", paramId, objectHandle, "bool")))


@sim_function("setEngineBoolParam")
def setEngineBoolParam(ctx: CallContext, paramId: Any, objectHandle: Any, boolParam: Any) -> None:  # noqa: N802, N803
    """``sim.setEngineBoolParam``: set a MuJoCo flag (see :func:`getEngineBoolParam`).

    Args:
        paramId: a ``sim.mujoco_global_*`` boolean parameter.
        objectHandle: -1 (global parameters only).
        boolParam: the value (truthiness).

    Raises:
        UnsupportedError: a parameter with no MuJoCo counterpart, or a per-object one.

    """
    _set_opt(ctx, *_engine(ctx, "setEngineBoolParam", paramId, objectHandle, "bool"), bool(boolParam))


def dynamics_running(ctx: CallContext) -> bool:
    """Whether the physics engine simulates the scene now: the simulation runs (or is paused)
    and its first step is done (True for a script without a simulation). CoppeliaSim's objects
    are marked dynamically simulated by the engine's first ``sim.handleDynamics`` of a run
    (simDyn ``CRigidBodyContainerDyn_base``, after the first pass's actuation scripts) and
    unmarked when it ends (``CSceneObject::simulationEnded``)."""
    view = ctx.view
    if view is None:
        return True
    return view.state is not RunState.STOPPED and ctx.world.data.time > 0


@sim_function("isDynamicallyEnabled")
def isDynamicallyEnabled(ctx: CallContext, objectHandle: Any) -> bool:  # noqa: N802, N803
    """Whether MuJoCo simulates the object's dynamics now (:func:`dynamics_running`): a shape
    not welded to the world, a joint in dynamic mode (one with a motor); other objects follow
    their body. False while the simulation is stopped, as CoppeliaSim's
    ``simIsDynamicallyEnabled_internal``.

    ``sim.isDynamicallyEnabled``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        True or False.

    Raises:
        UnknownObjectError: no such object.
    """
    obj = ctx.world.get(ctx.h(objectHandle))
    if not dynamics_running(ctx):
        return False
    if obj.type == JOINT:
        return obj.handle in ctx.world.motor_index
    return obj.type == SHAPE and int(ctx.world.model.body_weldid[obj.mj_id]) != 0


@sim_function("getObjectsWithTag")
def getObjectsWithTag(ctx: CallContext, tagName: Any, justModels: Any = False) -> list[int]:  # noqa: N802, N803
    """The objects that carry custom data ``tagName`` (``writeCustomDataBlockEx``).

    ``sim.getObjectsWithTag``.

    Args:
        tagName: the custom data tag.
        justModels: ignored.

    Returns:
        The handles, sorted.

    Raises:
        ArgumentError: ``tagName`` is not a string.
    """
    tag = _text(tagName, "tagName")
    holder = ctx.holder
    store = getattr(holder, "custom_data", {})
    return sorted(h for h, block in store.items() if tag in block and h in ctx.world.objects)


@sim_function("getObjectHierarchyOrder")
def getObjectHierarchyOrder(ctx: CallContext, objectHandle: Any) -> tuple[int, int]:  # noqa: N802, N803
    """``order, totalSiblings``: the object's place among its parent's children (tree order).

    ``sim.getObjectHierarchyOrder``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        ``(order, totalSiblings)``: 0-based index and count.

    Raises:
        UnknownObjectError: no such object.
    """
    obj = ctx.world.get(ctx.h(objectHandle))
    siblings = [o.handle for o in ctx.world.objects.values() if o.parent == obj.parent]
    return siblings.index(obj.handle), len(siblings)


@sim_function("getObjectSizeFactor")
def getObjectSizeFactor(ctx: CallContext, objectHandle: Any) -> float:  # noqa: N802, N803
    """1: simx never scales objects (``scaleObject`` is not implemented).

    ``sim.getObjectSizeFactor``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        1.0.

    Raises:
        UnknownObjectError: no such object.
    """
    ctx.world.get(ctx.h(objectHandle))
    return 1.0


@sim_function("getApiFunc")
def getApiFunc(ctx: CallContext, scriptHandle: Any, apiWord: Any) -> list[str]:  # noqa: N802, N803
    """Names of the ``sim`` functions that start with ``apiWord`` (``sim.`` prefix optional).

    ``sim.getApiFunc``.

    Args:
        scriptHandle: ignored.
        apiWord: the prefix.

    Returns:
        ``sim.NAME`` strings, sorted.

    Raises:
        ArgumentError: ``apiWord`` is not a string.
    """
    word = _text(apiWord, "apiWord").removeprefix("sim.")
    return [f"sim.{n}" for n in SIM.names(ctx.caller) if n.startswith(word)]


@sim_function("getApiInfo")
def getApiInfo(ctx: CallContext, scriptHandle: Any, apiWord: Any) -> str:  # noqa: N802, N803
    """The documentation of ``sim.apiWord`` (its docstring), ``""`` when it has none.

    ``sim.getApiInfo``.

    Args:
        scriptHandle: ignored.
        apiWord: the function's name.

    Returns:
        The text.

    Raises:
        ArgumentError: ``apiWord`` is not a string.
    """
    entry = SIM.get(_text(apiWord, "apiWord").removeprefix("sim."))
    return (entry.function.__doc__ or "").strip() if entry is not None else ""


@sim_function("getSettingString", "getSettingBool", "getSettingInt32", "getSettingFloat")
def getSettingString(ctx: CallContext, key: Any) -> str | None:  # noqa: N802
    """simx has no user settings file: nil for every key.

    ``sim.getSettingString``.

    Args:
        key: the setting's name.

    Returns:
        None.

    Raises:
        ArgumentError: ``key`` is not a string.
    """
    _text(key, "key")
    return None


@sim_function("getSimulatorMessage")
def getSimulatorMessage(ctx: CallContext) -> tuple[int, list[int], list[int]]:  # noqa: N802
    """``-1``: no message queue (no window events), as CoppeliaSim with an empty queue.

    ``sim.getSimulatorMessage``.

    Returns:
        ``(-1, [0, 0, 0, 0], [0, 0, 0, 0])``: message, auxiliary data, auxiliary data 2.
    """
    return -1, [0, 0, 0, 0], [0, 0, 0, 0]


@sim_function("getLastInfo")
def getLastInfo(ctx: CallContext) -> str:  # noqa: N802
    """``""``: simx reports information in its log, not through this call.

    ``sim.getLastInfo``.

    Returns:
        ``""``.
    """
    return ""


