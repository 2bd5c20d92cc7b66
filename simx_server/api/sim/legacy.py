"""V-REP 3.x script calls with no CoppeliaSim 4.x twin in ``sim``: script parameters, script
attributes and execution counts (custom data blocks, boolean helpers, system time and
``simExtRemoteApiStart``: :mod:`simx_server.api.sim.legacy_data`; collision and distance
objects: :mod:`simx_server.api.sim.legacy_measurements`; Python scripts' thread
calls: :mod:`simx_server.api.sim.threads`).

They are ``sim`` functions like the 4.x ones; the 3.x global names reach them through
:mod:`simx_server.api.legacy_names`. A script is named by
its object's handle in simx (``sim.getScriptHandle()`` is the script's object), so the script
handle arguments are object handles (``sim.handle_self``: this script).
"""

from __future__ import annotations

import logging
from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError
from simx_server.api import script_parameters
from simx_server.api.legacy_names import CONSTANTS as LEGACY_CONSTANTS
from simx_server.api.sim.legacy_data import RemoteApiPorts as RemoteApiPorts
from simx_server.base.arguments import as_integer as _int, as_text as _text

log = logging.getLogger("simx.scripts")

#: Constants this module adds to ``sim.*`` (Lua: also ``sim_*``).
CONSTANTS: dict[str, int] = dict(LEGACY_CONSTANTS)

_ATTR = {name: LEGACY_CONSTANTS[name] for name in LEGACY_CONSTANTS if "attribute" in name}


def name_suffix(name: str) -> tuple[int, str]:
    """V-REP's name suffix: ``("robot#2")`` -> ``(2, "robot")``, ``("robot")`` -> ``(-1, "robot")``.

    Args:
        name: a V-REP object name.

    Returns:
        ``(suffix, base)``: the suffix number (-1: none) and the name without ``#suffix``.
    """
    base, sep, tail = name.rpartition("#")
    return (int(tail), base) if sep and tail.isdigit() else (-1, name)


# V-REP 3.x calls of child and customization scripts.

def _suffix(ctx: CallContext) -> int:
    if ctx.state.name_suffix is None:  # a script's object; none for the world (ZMQ clients)
        ctx.state.name_suffix = name_suffix(ctx.world.get(ctx.owner).name)[0] if ctx.owner > 0 else -1
    return ctx.state.name_suffix


@sim_function("getObjectHandle")
def getObjectHandle(ctx: CallContext, name: Any, options: Any = None) -> int:  # noqa: N802
    """The object ``name`` names, in every form ``sim.getObject`` takes (CoppeliaSim 4.3/4.4's
    ``sim.getObjectHandle``, coppeliaSimLib's ``simGetObjectHandleEx_internal``: a path
    starting with ``/``, ``.`` or ``:`` is looked up as ``sim.getObject`` looks it up, with
    ``options`` ``{index = n, noError = true}``), and V-REP 3.x's names with their automatic
    suffix: in a script whose object is a copy (``robot#0``), ``getObjectHandle("motor")``
    finds ``motor#0``, the motor of the same copy; ``"motor#"`` means the name without a
    suffix, and a name with a suffix is taken as it is. ``sim.setNameSuffix(n)`` changes the
    suffix (-1: none). ``sim.handle_self``: the script's object.

    Args:
        name: a name (``motor``, ``motor#0``, ``motor#``), an alias path (``/robot/motor``,
            ``./motor``, ``:/motor``, ``/joint[2]``), or ``sim.handle_self``.
        options: ``{index = n, noError = true}`` as for ``sim.getObject``, or None.

    Returns:
        The handle, or -1 (``noError``).

    Raises:
        UnknownObjectError: no such object (without ``noError``), as V-REP raised it.
        ArgumentError: ``name`` is neither a string nor ``sim.handle_self``.
    """
    if not isinstance(name, (str, bytes, bytearray)):
        if _int(name, "object name") != C.sim_handle_self:
            raise ArgumentError(f"object name must be a string or sim.handle_self, got {name!r}")
        return ctx.owner
    text = _text(name, "object name")
    suffix = _suffix(ctx)
    if suffix >= 0 and "#" not in text and not text.startswith(("/", ".", ":")):
        text = f"{text}#{suffix}"
    return ctx.sim.getObject(text, options)


@sim_function("getNameSuffix")
def getNameSuffix(ctx: CallContext, name: Any = None) -> tuple[int, str]:  # noqa: N802
    """The suffix number of ``name`` (nil: the script's object) and the name without it.

    Args:
        name: an object name, or None (the script's object's name).

    Returns:
        ``(suffix, base)``: ``simGetNameSuffix``'s suffix number (-1: none) and the name without it.

    Raises:
        ArgumentError: ``name`` is not a string.
        UnknownObjectError: no ``name`` and the script's object is gone.
    """
    text = ctx.world.get(ctx.owner).name if name is None else _text(name, "name")
    return name_suffix(text)


@sim_function("setNameSuffix")
def setNameSuffix(ctx: CallContext, suffix: Any) -> int:  # noqa: N802
    """The suffix later ``getObjectHandle`` calls of this script append (-1: none).

    ``simSetNameSuffix``.

    Args:
        suffix: the suffix number; below -1 counts as -1 (none).

    Returns:
        1.

    Raises:
        ArgumentError: ``suffix`` is not an integer.
    """
    ctx.state.name_suffix = max(-1, _int(suffix, "nameSuffixNumber"))
    return 1


def _own(ctx: CallContext, script: Any, what: str) -> Any:
    h = _int(script, what)
    owner = ctx.owner if h == C.sim_handle_self else h
    me = ctx.script
    if me is not None and owner == me.owner:
        return me
    manager = me.shared.get("manager") if me is not None else None
    other = manager.scripts.get(owner) if manager is not None else None
    if other is None:
        raise ArgumentError(f"{what}: object {owner} has no script")
    return other


@sim_function("getScriptSimulationParameter")
def getScriptSimulationParameter(ctx: CallContext, scriptHandle: Any, parameterName: Any,  # noqa: N802, N803
                                 forceStringReturn: Any = False) -> Any:
    """3.x script simulation parameters (the scene's ``script_parameters=FILE.json``), typed as
    V-REP pushes them (``_simGetScriptSimulationParameter`` and ``pushCorrectTypeOntoLuaStack_old``,
    :mod:`simx_server.api.script_parameters`): nil, a boolean, a number, or the string
    (bytes unchanged); the string always with ``forceStringReturn``; nil when the script has
    no such parameter. ``sim.handle_all`` as the script: a table of the values of every
    script that has it (V-REP 3.x).

    Args:
        scriptHandle: the script's object handle, ``sim.handle_self`` or ``sim.handle_all``.
        parameterName: the parameter's name.
        forceStringReturn: answer the value as a string.

    Returns:
        The value (None, bool, int, float, str, or bytes for binary data), None when the
        script has no such parameter; with ``sim.handle_all``, the list of the values found.

    Raises:
        ArgumentError: a bad argument, or an object that has no script.
    """
    name = _text(parameterName, "parameterName")
    h = _int(scriptHandle, "scriptHandle")
    if h == C.sim_handle_all:
        me = ctx.script
        manager = me.shared.get("manager") if me is not None else None
        scripts = list(manager.scripts.values()) if manager is not None else [me]
        found = [_parameter(s, name, bool(forceStringReturn)) for s in scripts]
        return [v for ok, v in found if ok]
    return _parameter(_own(ctx, h, "scriptHandle"), name, bool(forceStringReturn))[1]


@sim_function("setScriptSimulationParameter")
def setScriptSimulationParameter(ctx: CallContext, scriptHandle: Any, parameterName: Any,  # noqa: N802, N803
                                 parameterValue: Any) -> int:  # noqa: N803
    """Set (or add) a script simulation parameter; the value is kept as its bytes (a number
    as its text), read back typed by :func:`getScriptSimulationParameter`.

    ``simSetScriptSimulationParameter`` (CoppeliaSim's ``_simSetScriptSimulationParameter``):
    ``sim.handle_tree`` sets it in the child scripts of every object below this script's,
    ``sim.handle_chain`` in those above it (``getScriptTree_old`` / ``getScriptChain_old``,
    the calling script left out).

    Args:
        scriptHandle: the script's object handle, ``sim.handle_self``, ``sim.handle_tree``
            or ``sim.handle_chain``.
        parameterName: the parameter's name.
        parameterValue: the new value (string, bytes or number).

    Returns:
        1 for one script; with tree or chain, the number of scripts set.

    Raises:
        ArgumentError: a bad argument, or an object that has no script.
    """
    name = _text(parameterName, "parameterName")
    h = _int(scriptHandle, "scriptHandle")
    if parameterValue is None or isinstance(parameterValue, (dict, list, tuple)):
        raise ArgumentError(f"parameterValue must be a string or a number, got {type(parameterValue).__name__}")
    value = script_parameters.as_bytes(parameterValue)
    if h in (C.sim_handle_tree, C.sim_handle_chain):
        me = ctx.script
        manager = me.shared.get("manager") if me is not None else None
        if me is None or manager is None:
            raise ArgumentError("scriptHandle: sim.handle_tree and sim.handle_chain need a calling script")
        pick = script_parameters.tree if h == C.sim_handle_tree else script_parameters.chain
        targets = [manager.scripts[o] for o in pick(ctx.world, me.owner) if o in manager.scripts]
        for script in targets:
            _store(ctx, script.parameters, name, value)
        return len(targets)
    _store(ctx, _own(ctx, h, "scriptHandle").parameters, name, value)
    return 1


def _user_lists(ctx: CallContext, objectHandle: Any) -> list[list]:
    """The parameter lists of an object's user parameters: those of its scripts (child, then
    customization: V-REP keeps one set per object, which its scripts read), or, for an object
    without a script, a list the scene's scripts keep for it."""
    h = _int(objectHandle, "objectHandle")
    h = ctx.owner if h == C.sim_handle_self else h
    ctx.world.get(h)
    me = ctx.script
    manager = me.shared.get("manager") if me is not None else None
    if manager is None:
        if me is not None and me.owner == h:
            return [me.parameters]
        raise ArgumentError("sim.getUserParameter / sim.setUserParameter need a scene's scripts")
    lists = [s.parameters for s in (manager.scripts.get(h), manager.customization.get(h)) if s is not None]
    if not lists:
        lists = [manager.user_parameters.setdefault(h, [])]
    return lists


@sim_function("getUserParameter")
def getUserParameter(ctx: CallContext, objectHandle: Any, parameterName: Any,  # noqa: N802, N803
                     forceStringReturn: Any = False) -> Any:
    """An object's user parameter (the parameters its scripts read with
    ``getScriptSimulationParameter``), typed as :func:`getScriptSimulationParameter` types them;
    None when it has none of that name.

    ``simGetUserParameter`` / ``sim.getUserParameter`` (deprecated in CoppeliaSim 4.1:
    coppeliaSimLib ``_simGetUserParameter``, ``simGetUserParameter_internal``).

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        parameterName: the parameter's name.
        forceStringReturn: answer the value as a string.

    Returns:
        The value (None, bool, int, float, str or bytes), None when absent.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a bad argument.
    """
    name = _text(parameterName, "parameterName")
    for params in _user_lists(ctx, objectHandle):
        found, value = _parameter(_Params(params), name, bool(forceStringReturn))
        if found:
            return value
    return None


@sim_function("setUserParameter")
def setUserParameter(ctx: CallContext, objectHandle: Any, parameterName: Any,  # noqa: N802, N803
                     parameterValue: Any) -> int:  # noqa: N803
    """Set (or add) an object's user parameter; returns 0. ``"@enable"`` adds
    ``exampleParameter`` = ``"Hello World!"`` (what V-REP's customization scripts call to show the
    parameters' dialog; there is no dialog here).

    ``simSetUserParameter`` / ``sim.setUserParameter`` (deprecated in CoppeliaSim 4.1:
    coppeliaSimLib ``_simSetUserParameter``, ``simSetUserParameter_internal``).

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        parameterName: the parameter's name.
        parameterValue: the new value (string, bytes or number).

    Returns:
        0.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a bad argument.
    """
    name = _text(parameterName, "parameterName")
    if parameterValue is None or isinstance(parameterValue, (dict, list, tuple)):
        raise ArgumentError(f"parameterValue must be a string or a number, got {type(parameterValue).__name__}")
    if name == "@enable":
        name, value = "exampleParameter", b"Hello World!"
    else:
        value = script_parameters.as_bytes(parameterValue)
    for params in _user_lists(ctx, objectHandle):
        _store(ctx, params, name, value)
    return 0


class _Params:
    """A parameter list seen as a script's ``parameters`` (for :func:`_parameter` / :func:`_store`)."""

    __slots__ = ("parameters",)

    def __init__(self, parameters: list):
        self.parameters = parameters


@sim_function("getScriptExecutionCount")
def getScriptExecutionCount(ctx: CallContext) -> int:  # noqa: N802
    """How many times the script's life-cycle functions (or old-style passes) have run since
    the simulation started.

    ``simGetScriptExecutionCount``.

    Returns:
        The count (0 outside a script).
    """
    me = ctx.script
    return me.executions if me is not None else 0


@sim_function("getScriptAssociatedWithObject")
def getScriptAssociatedWithObject(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """The object's child script (its object's handle), -1 when it has none.

    ``simGetScriptAssociatedWithObject``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        The object's handle when it has a child script, else -1.

    Raises:
        ArgumentError: ``objectHandle`` is not an integer.
    """
    h = ctx.h(objectHandle)
    me = ctx.script
    manager = me.shared.get("manager") if me is not None else None
    script = manager.scripts.get(h) if manager is not None else None
    return h if script is not None and script.kind == "child" else -1


@sim_function("getCustomizationScriptAssociatedWithObject")
def getCustomizationScriptAssociatedWithObject(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """The object's customization script (its object's handle), -1 when it has none.

    ``simGetCustomizationScriptAssociatedWithObject``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        The object's handle when it has a customization script, else -1.

    Raises:
        ArgumentError: ``objectHandle`` is not an integer.
    """
    h = ctx.h(objectHandle)
    me = ctx.script
    manager = me.shared.get("manager") if me is not None else None
    script = manager.customization.get(h) if manager is not None else None
    return h if script is not None else -1


@sim_function("setScriptAttribute")
def setScriptAttribute(ctx: CallContext, scriptHandle: Any, attributeID: Any, value: Any) -> int:  # noqa: N802, N803
    """3.x script attributes: ``sim.scriptattribute_executioncount`` sets the script's
    execution count (V-REP 3.1.3's compatibility header of old scripts sets it to 0 at the
    first actuation pass, so that ``simGetScriptExecutionCount()==0`` marks it); the others
    are accepted and logged (simx runs every script every step, in object-tree order).
    Returns 1.

    Args:
        scriptHandle: the script's object handle, or ``sim.handle_self``.
        attributeID: a ``sim.scriptattribute_*`` constant.
        value: the attribute's value (an integer for the execution count).

    Returns:
        1.

    Raises:
        ArgumentError: a bad argument, or an object that has no script.
    """
    script = _own(ctx, scriptHandle, "scriptHandle")
    if _int(attributeID, "attributeID") == _ATTR["scriptattribute_executioncount"]:
        script.executions = _int(value, "value")
        return 1
    log.debug("[%s] setScriptAttribute(%s, %r): no effect in simx", ctx.label, attributeID, value)
    return 1


@sim_function("getScriptAttribute")
def getScriptAttribute(ctx: CallContext, scriptHandle: Any, attributeID: Any) -> Any:  # noqa: N802, N803
    """``sim.scriptattribute_executioncount``, ``_scripttype``, ``_enabled`` (true),
    ``_executionorder`` (normal), ``_debuglevel`` (0).

    ``simGetScriptAttribute``.

    Args:
        scriptHandle: the script's object handle, or ``sim.handle_self``.
        attributeID: a ``sim.scriptattribute_*`` constant.

    Returns:
        The attribute's value (int or bool).

    Raises:
        ArgumentError: an unsupported attribute, a bad argument, or an object without a script.
    """
    script = _own(ctx, scriptHandle, "scriptHandle")
    a = _int(attributeID, "attributeID")
    if a == _ATTR["scriptattribute_executioncount"]:
        return script.executions
    if a == _ATTR["scriptattribute_scripttype"]:
        return C.sim_scripttype_childscript if script.kind == "child" else C.sim_scripttype_customizationscript
    if a == _ATTR["scriptattribute_enabled"]:
        return True
    if a == _ATTR["scriptattribute_executionorder"]:
        return LEGACY_CONSTANTS["scriptexecorder_normal"]
    if a in (_ATTR["scriptattribute_debuglevel"], _ATTR["customizationscriptattribute_activeduringsimulation"]):
        return 0 if a == _ATTR["scriptattribute_debuglevel"] else True
    raise ArgumentError(f"script attribute {a} is not supported")


@sim_function("handleChildScripts", "handleSimulationScripts")
def handleChildScripts(ctx: CallContext, callType: Any, *args: Any) -> int:  # noqa: N802, N803
    """V-REP's cascade of child scripts: simx runs every child script itself at every pass,
    so nothing is left to run here; returns 0 (child scripts run by this call).

    ``simHandleChildScripts``.

    Args:
        callType: a ``sim.syscb_*`` / ``sim_childscriptcall_*`` constant.
        *args: passed on by V-REP to the child scripts; ignored.

    Returns:
        0.

    Raises:
        ArgumentError: ``callType`` is not an integer.
    """
    _int(callType, "callType")
    return 0


@sim_function("delegateChildScriptExecution")
def delegateChildScriptExecution(ctx: CallContext) -> int:  # noqa: N802
    """V-REP 3.0-3.2's ``simDelegateChildScriptExecution()``: a threaded child script hands
    the cascade of its descendants' non-threaded child scripts to the main script (it cannot
    run them from its own loop). simx runs every child script itself at every pass, with no
    cascade, so they already run as delegated: returns 1.

    Returns:
        1.
    """
    return 1


@sim_function("getInt32Parameter")
def getInt32Parameter(ctx: CallContext, parameter: Any) -> int | None:  # noqa: N802
    """V-REP 3.x's ``simGetIntegerParameter`` / ``simGetInt32Parameter``: as
    ``sim.getInt32Param``, except ``sim.intparam_flymode_camera_handle``, which answers nil:
    a headless server has no fly-mode camera, and V-REP's Lua answered nil where the call
    found none (scripts test ``if (flyModeCameraHandle) then``).

    Args:
        parameter: a ``sim.intparam_*`` constant.

    Returns:
        The value, or None for ``sim.intparam_flymode_camera_handle``.

    Raises:
        ArgumentError: an unknown parameter, or not an integer.
    """
    if _int(parameter, "parameter") == C.sim_intparam_flymode_camera_handle:
        return None
    return ctx.sim.getInt32Param(parameter)




def _parameter(script: Any, name: str, as_string: bool) -> tuple[bool, Any]:
    """``(found, value)`` of ``script``'s parameter ``name``, typed (or as a string)."""
    for p in getattr(script, "parameters", ()):
        if p.get("name") == name:
            value = p.get("value")
            if as_string:
                return True, script_parameters.as_string("" if value is None else value)
            return True, script_parameters.typed("" if value is None else value)
    return False, None


def _store(ctx: CallContext, params: list, name: str, value: bytes) -> None:
    """Set ``name`` to ``value`` in ``params``, within the bounds of all the scene's parameters
    (:func:`script_parameters.admit`: as signals, and in the scripts' memory)."""
    me = ctx.script
    manager = me.shared.get("manager") if me is not None else None
    if manager is not None:
        lists, budget = manager.parameter_lists(), manager.budget
        room = budget.memory - sum(s.memory_used() for s in budget.holders())
    else:
        lists, room = [params], None
    script_parameters.admit(lists, params, name, value, room)
    for p in params:
        if p.get("name") == name:
            p["value"] = value
            break
    else:
        params.append({"name": name, "value": value, "unit": ""})
    if manager is not None:
        manager.parameters_changed()
