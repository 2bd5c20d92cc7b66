"""The scripts' own services: messages between scripts, a script's variables, its last error's
traceback and its auto-yield delay (``sim.broadcastMsg``, ``sim.getUserVariables``,
``sim.getStackTraceback``, ``sim.getAutoYieldDelay`` / ``sim.setAutoYieldDelay``).

As CoppeliaSim 4.6+ does them (coppeliaSimLib: ``_simBroadcastMsg``, ``_simGetStackTraceback``,
``_simGetAutoYieldDelay`` / ``_simSetAutoYieldDelay`` in ``sourceCode/interfaces/luaScriptFunctions.cpp``,
``CSceneContainer::broadcastMsg`` and ``CDetachedScript`` in ``sourceCode/scripting/detachedScript.cpp``;
``sim.getUserVariables`` in its ``lua/sim.lua``). A script's handle is, in simx, the handle of the
object it is attached to (``sim.getScript``).
"""

from __future__ import annotations

import copy
import logging
from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.base.arguments import as_integer as _int, as_number as _num
from simx_wire import constants
from simx_wire.protocol import ArgumentError, ScriptError, UnsupportedError

log = logging.getLogger("simx.scripts")
_HANDLE_SELF: int = constants.VREP_CONSTANTS["sim_handle_self"]
#: ``sim.broadcastMsg`` calls nested in receivers' ``sysCall_msg`` (a receiver that broadcasts
#: back): past this depth the call is refused rather than recursing without end.
MAX_BROADCAST_DEPTH = 16
#: ``sim.setAutoYieldDelay``'s bounds, in ms (``CDetachedScript::setDelayForAutoYielding``).
MAX_AUTO_YIELD_DELAY_MS = 10_000


def _manager(ctx: CallContext) -> Any:
    """The scene's scripts (:class:`~simx_server.scripts.scene_scripts.Scripts`), or None."""
    view = ctx.view
    scripts = getattr(view, "scripts", None) if view is not None else None
    if scripts is not None:
        return scripts
    me = ctx.script
    return me.shared.get("manager") if me is not None else None


def _script_of(ctx: CallContext, handle: int) -> Any:
    """The script of object ``handle`` (the caller's own first, then a child script, then a
    customization script), or None."""
    me = ctx.script
    if me is not None and handle == me.owner:
        return me
    manager = _manager(ctx)
    if manager is None:
        return None
    return manager.scripts.get(handle) or manager.customization.get(handle)


@sim_function("broadcastMsg")
def broadcastMsg(ctx: CallContext, message: Any, options: Any = 0) -> None:  # noqa: N802
    """Send ``message`` to every other script: each running child and customization script that
    defines ``sysCall_msg`` has it called as ``sysCall_msg(message, origin)``.

    ``sim.broadcastMsg`` (CoppeliaSim 4.6+). As ``CSceneContainer::broadcastMsg``: the receivers
    run in the scene's script order (child scripts, then customization scripts), at once, before
    the call returns; the sender is left out; ``origin`` is the sender's script handle (in simx
    its object's handle), -1 when a remote client sends; what the receivers return is dropped and
    their errors go to the log (each the receiver's own, as a life-cycle function's). Child
    scripts receive only while the simulation runs (they exist only then). ``options`` is
    reserved (CoppeliaSim reads it and uses none of its bits).

    Args:
        message: a table (a map, or a list): each receiver gets its own copy.
        options: an integer, reserved (default 0).

    Raises:
        ArgumentError: ``message`` is not a table, ``options`` not an integer, or broadcasts
            nested deeper than :data:`MAX_BROADCAST_DEPTH` (receivers broadcasting back).
    """
    if not isinstance(message, (dict, list, tuple)):
        raise ArgumentError(f"sim.broadcastMsg: message must be a table (a map), got {type(message).__name__}")
    _int(options, "options")
    manager = _manager(ctx)
    if manager is None:
        return
    origin = -1 if ctx.remote else ctx.owner
    depth = manager.shared.get("broadcast_depth", 0)
    if depth >= MAX_BROADCAST_DEPTH:
        raise ArgumentError(f"sim.broadcastMsg: broadcasts nested {depth} deep (receivers' sysCall_msg "
                            f"broadcasting again): at most {MAX_BROADCAST_DEPTH}")
    sender = ctx.script
    receivers = [s for s in (*manager.scripts.values(), *manager.customization.values()) if s is not sender]
    editor = getattr(ctx.view, "editor", None) if ctx.remote else None
    manager.shared["broadcast_depth"] = depth + 1
    try:
        if editor is not None:  # the scripts' file calls act as this client (as sim.callScriptFunction)
            with editor.files.on_behalf():
                _deliver(receivers, message, origin)
        else:
            _deliver(receivers, message, origin)
    finally:
        manager.shared["broadcast_depth"] = depth


def _deliver(receivers: list[Any], message: Any, origin: int) -> None:
    for script in receivers:
        script.system_call("sysCall_msg", (copy.deepcopy(message), origin))


@sim_function("getUserVariables")
def getUserVariables(ctx: CallContext) -> Any:  # noqa: N802
    """The global variables the calling script made itself, name -> value.

    ``sim.getUserVariables``. As CoppeliaSim's ``sim.lua``: the globals that were not there when
    the script's state was made and the API registered (``_S.initGlobals``), so neither ``sim``,
    ``simIK``, ``print`` nor the language's builtins; its functions (``sysCall_init``...) are
    among them. A Lua script gets a table (``for name, value in pairs(...)``: answered by the
    script's own Lua, :mod:`simx_server.scripts.lua`), a Python script a dict (iterating it
    gives the names). A remote client is no script: it has no user variables, an empty list
    (CoppeliaSim evaluates the call in its remote API add-on's own state, nothing of the client).

    Returns:
        ``{name: value}`` for a script; ``[]`` for a remote client.

    Raises:
        UnsupportedError: a script of a language without such a list.
    """
    script = ctx.script
    if script is None:
        return []
    variables = getattr(script, "user_variables", None)
    if variables is None:
        raise UnsupportedError(f"sim.getUserVariables: not available to {script.language} scripts here "
                               "(Lua scripts answer it themselves)")
    return variables()


@sim_function("getStackTraceback")
def getStackTraceback(ctx: CallContext, scriptHandle: Any = _HANDLE_SELF) -> str:  # noqa: N802, N803
    """The message and stack traceback of the last error raised in a script, then forgotten.

    ``sim.getStackTraceback``. As ``_simGetStackTraceback`` (``getAndClearLastStackTraceback``):
    each error that leaves a script (a life-cycle function's, its thread's, a function another
    script or a client called) is kept, the last one only, until this call reads it; a second
    call answers ``""``. The text is simx's error line (the script, the function, ``file:line:
    message``) followed by the language's traceback: Lua's ``stack traceback:`` (as
    ``debug.traceback``), Python's ``Traceback (most recent call last):`` with the script's own
    frames. ``""`` where there was no error since, or no such script (as CoppeliaSim).

    Args:
        scriptHandle: a script handle (in simx the handle of its object, ``sim.getScript``), or
            ``sim.handle_self`` (default): the calling script's (a remote client has none).

    Returns:
        The text, or ``""``.

    Raises:
        ArgumentError: ``scriptHandle`` is not an integer (nor an object path).
        UnknownObjectError: a path that names no object.
    """
    handle = _HANDLE_SELF if scriptHandle is None else scriptHandle
    script = _script_of(ctx, ctx.h(handle, "scriptHandle"))
    if script is None:
        return ""
    text: str = script.last_traceback
    script.last_traceback = ""
    return text


@sim_function("setAutoYieldDelay")
def setAutoYieldDelay(ctx: CallContext, dt: Any) -> None:  # noqa: N802
    """Set the calling script's auto-yield delay: how long its thread runs before it yields by itself.

    ``sim.setAutoYieldDelay`` (CoppeliaSim 4.5+). Stored per caller (a script's for its run: a
    restart begins again at 2 ms, as ``CDetachedScript::_initInterpreterState``; the ZMQ door's
    for its clients) in whole ms, truncated and bounded to 0..10 s as
    ``CDetachedScript::setDelayForAutoYielding``. simx's script threads never yield by
    themselves: a Python or Lua thread yields only where it calls ``sim.step`` /
    ``sim.switchThread`` / ``sim.wait`` (see ``sim.setThreadAutomaticSwitch``); the value is
    kept and read back, and changes nothing else.

    Args:
        dt: the delay in s.

    Raises:
        ArgumentError: ``dt`` is not a finite number.
    """
    ms = int(_num(dt, "dt") * 1000.0)
    ctx.state.auto_yield_delay_ms = min(max(ms, 0), MAX_AUTO_YIELD_DELAY_MS)


@sim_function("getAutoYieldDelay")
def getAutoYieldDelay(ctx: CallContext) -> float:  # noqa: N802
    """The calling script's auto-yield delay, in s (default 0.002).

    ``sim.getAutoYieldDelay`` (CoppeliaSim 4.5+): what :func:`setAutoYieldDelay` set, in whole
    ms. In s as CoppeliaSim's API reference (``float dt``) and ``sim.lua``'s
    ``sim.getThreadSwitchTiming`` (``sim.getAutoYieldDelay() * 1000``) read it. simx's threads
    yield only where they call ``sim.step`` / ``sim.switchThread``: the value changes nothing.

    Returns:
        The delay in s.
    """
    return ctx.state.auto_yield_delay_ms / 1000.0


#: ``sim.scriptintparam_*`` (CoppeliaSim 4.x's values; ``simSetScriptInt32Param_internal`` also
#: takes the older 0-9, offset by 10100).
_EXECORDER, _EXECCOUNT, _TYPE, _HANDLE, _ENABLED, _OBJECTHANDLE, _LANG, _AUTORESTART = range(10100, 10108)


def _script_param(ctx: CallContext, scriptHandle: Any, parameterID: Any) -> tuple[Any, int]:  # noqa: N803
    h = _int(scriptHandle, "scriptHandle")
    h = ctx.owner if h == _HANDLE_SELF else h
    script = _script_of(ctx, h)
    if script is None:
        raise ArgumentError(f"scriptHandle: object {h} has no script")
    p = _int(parameterID, "parameterID")
    return script, p + 10100 if 0 <= p < 10 else p


@sim_function("setScriptInt32Param")
def setScriptInt32Param(ctx: CallContext, scriptHandle: Any, parameterID: Any, parameter: Any) -> int:  # noqa: N802, N803
    """``sim.scriptintparam_enabled``: 0 disables the script (its system callbacks no more run;
    its functions can still be called), 1 enables it again (a script saved disabled starts then:
    top level and ``sysCall_init``); ``sim.scriptintparam_execcount`` sets
    its execution count. Other parameters: ArgumentError (simx runs scripts in tree order).

    coppeliaSimLib ``simSetScriptInt32Param_internal`` (``CDetachedScript::setScriptIsDisabled``,
    ``setNumberOfPasses``).

    Args:
        scriptHandle: the script's handle (its object's), or ``sim.handle_self``.
        parameterID: a ``sim.scriptintparam_*`` constant.
        parameter: the value.

    Returns:
        1.

    Raises:
        ArgumentError: no such script, or a parameter simx does not set.
    """
    script, p = _script_param(ctx, scriptHandle, parameterID)
    value = _int(parameter, "parameter")
    if p == _ENABLED:
        script.disabled = value == 0
        if value and script.pending_start:  # saved disabled: it starts now (CoppeliaSim: at its first pass)
            script.pending_start = False
            try:
                script.start()
            except ScriptError as exc:
                log.error("%s", exc)
    elif p == _EXECCOUNT:
        script.executions = value
    else:
        raise ArgumentError(f"setScriptInt32Param: parameter {p} is not one simx sets "
                            f"(sim.scriptintparam_enabled, sim.scriptintparam_execcount)")
    return 1


@sim_function("getScriptInt32Param")
def getScriptInt32Param(ctx: CallContext, scriptHandle: Any, parameterID: Any) -> int:  # noqa: N802, N803
    """``sim.scriptintparam_enabled`` (1/0), ``_execcount``, ``_type`` (``sim.scripttype_*``),
    ``_handle`` and ``_objecthandle`` (in simx both the object's handle), ``_lang`` (0 Lua,
    1 Python), ``_execorder`` (0, normal), ``_autorestartonerror`` (0).

    coppeliaSimLib ``simGetScriptInt32Param_internal``.

    Args:
        scriptHandle: the script's handle (its object's), or ``sim.handle_self``.
        parameterID: a ``sim.scriptintparam_*`` constant.

    Returns:
        The value.

    Raises:
        ArgumentError: no such script or parameter.
    """
    script, p = _script_param(ctx, scriptHandle, parameterID)
    values = {_ENABLED: int(not script.disabled), _EXECCOUNT: script.executions,
              _TYPE: 1 if script.kind == "child" else 6, _HANDLE: script.owner, _OBJECTHANDLE: script.owner,
              _LANG: int(type(script).__name__ == "PythonScript"), _EXECORDER: 0, _AUTORESTART: 0}
    if p not in values:
        raise ArgumentError(f"getScriptInt32Param: no script parameter {p}")
    return values[p]
