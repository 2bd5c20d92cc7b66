"""CoppeliaSim 4.x's simulator parameters, the random generator and the run flags, for scripts and
ZMQ clients alike (``sim.getInt32Param`` and the other typed and named parameter functions,
``sim.getRandom``, ``sim.getIsRealTimeSimulation``, ``sim.quitSimulator``).

Parameter ids are CoppeliaSim's (``sim.intparam_program_version`` ...). Each id with a meaning
on a headless MuJoCo server answers it; the rest raise UnsupportedError naming the id (for a ZMQ
client, :func:`_legacy_param` first tries the legacy API's parameters, which know the mouse and
the stop counter, :mod:`simx_server.scene.parameters`).

``sim.intparam_program_version`` answers **40800**, CoppeliaSim 4.8.0 (major·10000 + minor·100
+ patch): the release whose API simx's ZMQ table and ``sim`` functions follow (docs/ZMQ.md), so a program
that checks ``>= 40300`` before using 4.3's paths takes the 4.x branch.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
import random
import sys
from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import RemoteError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector
from simx_server.sim import physics
from simx_server.sim.state import RunState

log = logging.getLogger("simx.scripts")

#: CoppeliaSim release simx answers for (``sim.intparam_program_version``): 4.8.0.
PROGRAM_VERSION, PROGRAM_REVISION = 40800, 0
#: CoppeliaSim's ``sim.physics_mujoco`` (``sim.intparam_dynamic_engine``).
PHYSICS_MUJOCO = 4
_INT, _FLOAT, _BOOL, _STRING, _ARRAY = "integer", "float", "boolean", "string", "array"


# ``sim.get/setInt32Param``, ``Float``, ``Bool``, ``String``, ``Array`` and named parameters,
# ``getRandom``, ``getIsRealTimeSimulation``, ``quitSimulator``.

#: CoppeliaSim 4.x string parameters simx answers besides the legacy ones (simConst.h's numbering).
STRINGPARAM_SCENE_PATH, STRINGPARAM_SCENE_NAME, STRINGPARAM_SCENEDEFAULTDIR = 14, 15, 132


def _legacy_param(ctx: CallContext, kind: str, pid: int, *value: Any) -> Any:
    """An id this module does not know: for a remote client, the legacy API's parameters
    (``simxGetIntegerParameter``...: the headless mouse, the stop counter; the simulation's
    :meth:`~simx_server.scene.simulation.Simulation.legacy_parameter`); for a script,
    UnsupportedError."""
    if ctx.remote:
        return ctx.simulation("get" if not value else "set").legacy_parameter(kind, pid, *value)
    raise UnsupportedError(f"{kind} parameter {pid} has no meaning in simx (docs/COVERAGE.md)")


def _int_params(ctx: CallContext) -> dict[int, Any]:
    sim = ctx.simulation("getInt32Param")
    return {1: lambda: PROGRAM_VERSION, 30: lambda: PROGRAM_REVISION,  # program_version, revision
            39: lambda: PROGRAM_VERSION * 100 + PROGRAM_REVISION,  # program_full_version
            4: lambda: 0,  # compilation_version: 0, no Edu/Pro/Player flavour
            7: lambda: sim.world.substeps,  # dynamic_step_divider: MuJoCo substeps per step
            8: lambda: PHYSICS_MUJOCO,  # dynamic_engine
            19: lambda: 0 if sys.platform.startswith("win") else 1 if sys.platform == "darwin" else 2,
            24: lambda: os.cpu_count() or 1,  # core_count
            52: os.getpid,  # processid
            }


@sim_function("getInt32Param")
def getInt32Param(ctx: CallContext, parameter: Any) -> int:  # noqa: N802 (CoppeliaSim's names)
    """An integer parameter: ``sim.intparam_program_version`` 40800 (CoppeliaSim 4.8.0),
    ``program_revision`` 0, ``program_full_version`` 4080000, ``dynamic_step_divider`` (MuJoCo
    substeps per step), ``dynamic_engine`` (``sim.physics_mujoco``), ``platform`` (0 Windows,
    1 macOS, 2 Linux), ``core_count``, ``processid``. Others: UnsupportedError naming it.

    Args:
        parameter: a ``sim.intparam_*`` id.

    Returns:
        The value.
    """
    pid = _int(parameter, "parameter")
    known = _int_params(ctx).get(pid)
    return int(known()) if known is not None else _legacy_param(ctx, _INT, pid)


@sim_function("setInt32Param")
def setInt32Param(ctx: CallContext, parameter: Any, value: Any) -> None:  # noqa: N802
    """Integer parameters are read-only in simx (the engine's step divider follows dt).

    Args:
        parameter: a ``sim.intparam_*`` id.
        value: an integer.

    Raises:
        RemoteError: an id this module answers (read-only).
        UnsupportedError: any other id.
    """
    pid, v = _int(parameter, "parameter"), _int(value, "intState")
    if pid in _int_params(ctx):
        raise RemoteError(f"integer parameter {pid} is read-only in simx")
    _legacy_param(ctx, _INT, pid, v)


@sim_function("getFloatParam")
def getFloatParam(ctx: CallContext, parameter: Any) -> float:  # noqa: N802
    """``sim.floatparam_simulation_time_step`` (s), ``floatparam_physicstimestep`` (MuJoCo's
    timestep, s), ``floatparam_rand`` (uniform in [0, 1)).

    Args:
        parameter: a ``sim.floatparam_*`` id.

    Returns:
        The value.

    Raises:
        UnsupportedError: an id simx does not answer.
    """
    pid = _int(parameter, "parameter")
    world = ctx.simulation("getFloatParam").world
    if pid == 1:
        return world.dt
    if pid == 5:
        return float(world.model.opt.timestep)
    if pid == 0:
        return random.random()
    return _legacy_param(ctx, _FLOAT, pid)


@sim_function("setFloatParam")
def setFloatParam(ctx: CallContext, parameter: Any, value: Any) -> None:  # noqa: N802
    """``sim.floatparam_simulation_time_step`` (s, simulation stopped, as CoppeliaSim).

    Args:
        parameter: 1 (``sim.floatparam_simulation_time_step``).
        value: the step, s.

    Raises:
        RemoteError: the simulation is not stopped.
        ArgumentError: a step out of bounds (limits.MAX_DT, MAX_SUBSTEPS).
        UnsupportedError: any other id.
    """
    pid, v = _int(parameter, "parameter"), _num(value, "floatState")
    sim = ctx.simulation("setFloatParam")
    if pid != 1:
        _legacy_param(ctx, _FLOAT, pid, v)
        return
    if sim.state is not RunState.STOPPED:
        raise RemoteError("sim.floatparam_simulation_time_step can change only while the simulation is stopped")
    sim.world.set_dt(v)


@sim_function("getBoolParam")
def getBoolParam(ctx: CallContext, parameter: Any) -> bool:  # noqa: N802
    """``headless`` true, ``display_enabled`` false, ``realtime_simulation`` (paced to wall
    time), ``dynamics_handling_enabled`` true, ``ik_handling_enabled`` true (the scene's IK
    groups are solved each step), ``scene_closing`` false.

    Args:
        parameter: a ``sim.boolparam_*`` id.

    Returns:
        The value.

    Raises:
        UnsupportedError: an id simx does not answer.
    """
    pid = _int(parameter, "parameter")
    sim = ctx.simulation("getBoolParam")
    known = {34: True, 16: False, 6: True, 4: True, 52: False, 25: bool(getattr(sim, "realtime", False))}
    return known[pid] if pid in known else _legacy_param(ctx, _BOOL, pid)


@sim_function("setBoolParam")
def setBoolParam(ctx: CallContext, parameter: Any, value: Any) -> None:  # noqa: N802
    """``sim.boolparam_realtime_simulation``: pace the free-running simulation to wall time;
    ``display_enabled`` false is accepted (there is no display).

    Args:
        parameter: a ``sim.boolparam_*`` id.
        value: truthy or not.

    Raises:
        UnsupportedError: any other id (or ``display_enabled`` true).
    """
    pid = _int(parameter, "parameter")
    sim = ctx.simulation("setBoolParam")
    if pid == 25:
        sim.realtime = bool(value)
    elif pid == 16 and not value:
        return
    else:
        _legacy_param(ctx, _BOOL, pid, bool(value))


@sim_function("getStringParam")
def getStringParam(ctx: CallContext, parameter: Any) -> str:  # noqa: N802
    """``sim.stringparam_scene_name``, ``application_path`` (the simx_server package's folder),
    ``stringparam_scene_path`` (the loaded scene's folder), ``stringparam_scenedefaultdir`` (the
    server's scene folder: the first ``--scene-path``, else the folder of the scene it started
    with); for remote clients the legacy ones as ``simxGetStringParameter``.

    Args:
        parameter: a ``sim.stringparam_*`` id.

    Returns:
        The value.

    Raises:
        UnsupportedError: an id simx does not answer.
    """
    pid = _int(parameter, "parameter")
    sim = ctx.simulation("getStringParam")
    if pid == STRINGPARAM_SCENE_NAME:
        return sim.world.scene_name
    if pid == 0:
        return str(Path(__file__).resolve().parents[2])
    if pid == STRINGPARAM_SCENEDEFAULTDIR:  # the first --scene-path, else the first scene's folder
        roots = sim.editor.files.roots
        return str(roots[1] if len(roots) > 1 else roots[0])
    if pid == STRINGPARAM_SCENE_PATH:
        return sim.editor.public(sim.world.scene_path.parent)
    return _legacy_param(ctx, _STRING, pid)


@sim_function("setStringParam")
def setStringParam(ctx: CallContext, parameter: Any, value: Any) -> None:  # noqa: N802
    """CoppeliaSim's settable string parameters (video file name, verbosities) belong to its
    window and log settings: an UnsupportedError names the id.

    Args:
        parameter: a ``sim.stringparam_*`` id.
        value: text.

    Raises:
        UnsupportedError: every id.
    """
    pid = _int(parameter, "parameter")
    _legacy_param(ctx, _STRING, pid, _text(value, "stringState"))


@sim_function("getArrayParam")
def getArrayParam(ctx: CallContext, parameter: Any) -> list[float]:  # noqa: N802
    """``sim.arrayparam_gravity`` (m/s², the MuJoCo model's).

    Args:
        parameter: a ``sim.arrayparam_*`` id.

    Returns:
        ``[gx, gy, gz]``.

    Raises:
        UnsupportedError: any other id.
    """
    pid = _int(parameter, "parameter")
    if pid == 0:
        return ctx.simulation("getArrayParam").world.model.opt.gravity.tolist()
    return _legacy_param(ctx, _ARRAY, pid)


@sim_function("setArrayParam")
def setArrayParam(ctx: CallContext, parameter: Any, value: Any) -> None:  # noqa: N802
    """``sim.arrayparam_gravity`` (3 numbers, m/s², bounded as ``simxSetArrayParameter``).

    Args:
        parameter: 0 (``sim.arrayparam_gravity``).
        value: 3 numbers.

    Raises:
        ArgumentError: not 3 finite numbers, or a magnitude above limits.MAX_GRAVITY.
        UnsupportedError: any other id.
    """
    pid = _int(parameter, "parameter")
    v = _vector(value, 3, "arrayOfValues")
    if pid != 0:
        _legacy_param(ctx, _ARRAY, pid, v)
        return
    ctx.simulation("setArrayParam").world.model.opt.gravity[:] = physics.check_gravity(v)


def _named(ctx: CallContext) -> dict[str, str]:
    sim = ctx.simulation("getNamedStringParam")
    store = getattr(sim, "named_params", None)
    if store is None:
        store = sim.named_params = {}
    return store


@sim_function("setNamedStringParam")
def setNamedStringParam(ctx: CallContext, paramName: Any, stringParam: Any) -> None:  # noqa: N802, N803
    """Store a named parameter (text) for the server's lifetime (at most 1,000 names).

    Args:
        paramName: the name.
        stringParam: the value (cut at 100,000 characters).

    Raises:
        RemoteError: 1,000 names are stored already.
    """
    store, key = _named(ctx), _text(paramName, "paramName")
    if key not in store and len(store) >= 1000:
        raise RemoteError("the named parameters hold 1,000 names already")
    store[key] = _text(stringParam, "stringParam")[:100_000]


@sim_function("getNamedStringParam")
def getNamedStringParam(ctx: CallContext, paramName: Any) -> str | None:  # noqa: N802, N803
    """A named parameter, nil (None) when not set.

    Args:
        paramName: the name.

    Returns:
        The value, or None.
    """
    return _named(ctx).get(_text(paramName, "paramName"))


@sim_function("setNamedInt32Param")
def setNamedInt32Param(ctx: CallContext, paramName: Any, value: Any) -> None:  # noqa: N802, N803
    """Store a named parameter as the text of an integer (:func:`setNamedStringParam`).

    Args:
        paramName: the name.
        value: an integer.
    """
    setNamedStringParam(ctx, paramName, str(_int(value, "value")))


@sim_function("getNamedInt32Param")
def getNamedInt32Param(ctx: CallContext, paramName: Any) -> int | None:  # noqa: N802, N803
    """A named parameter read as an integer.

    Args:
        paramName: the name.

    Returns:
        The integer, or None when not set or not an integer's text.
    """
    v = getNamedStringParam(ctx, paramName)
    try:
        return None if v is None else int(v)
    except ValueError:
        return None


@sim_function("setNamedFloatParam")
def setNamedFloatParam(ctx: CallContext, paramName: Any, value: Any) -> None:  # noqa: N802, N803
    """Store a named parameter as the text of a number (:func:`setNamedStringParam`).

    Args:
        paramName: the name.
        value: a number.
    """
    setNamedStringParam(ctx, paramName, repr(_num(value, "value")))


@sim_function("getNamedFloatParam")
def getNamedFloatParam(ctx: CallContext, paramName: Any) -> float | None:  # noqa: N802, N803
    """A named parameter read as a number.

    Args:
        paramName: the name.

    Returns:
        The number, or None when not set or not a number's text.
    """
    v = getNamedStringParam(ctx, paramName)
    try:
        return None if v is None else float(v)
    except ValueError:
        return None


@sim_function("setNamedBoolParam")
def setNamedBoolParam(ctx: CallContext, paramName: Any, value: Any) -> None:  # noqa: N802, N803
    """Store a named parameter as ``"true"`` or ``"false"``.

    Args:
        paramName: the name.
        value: truthy or not.
    """
    setNamedStringParam(ctx, paramName, "true" if value else "false")


@sim_function("getNamedBoolParam")
def getNamedBoolParam(ctx: CallContext, paramName: Any) -> bool | None:  # noqa: N802, N803
    """A named parameter read as a boolean (``true``, ``1``, ``on``: True).

    Args:
        paramName: the name.

    Returns:
        The boolean, or None when not set.
    """
    v = getNamedStringParam(ctx, paramName)
    return None if v is None else v.lower() in ("true", "1", "on")


@sim_function("getRandom")
def getRandom(ctx: CallContext, seed: Any = None) -> float:  # noqa: N802
    """A uniform number in [0, 1); ``seed`` (an integer) reseeds the generator first.

    Args:
        seed: an integer, or None.

    Returns:
        The number.
    """
    rng = ctx.state.rng
    if rng is None or seed is not None:
        rng = ctx.state.rng = random.Random(None if seed is None else _int(seed, "seed"))
    return rng.random()


@sim_function("getIsRealTimeSimulation")
def getIsRealTimeSimulation(ctx: CallContext) -> int:  # noqa: N802
    """1 when the free-running simulation is paced to wall time (``--speed``), else 0.

    Returns:
        1 or 0.
    """
    return int(bool(getattr(ctx.simulation("getIsRealTimeSimulation"), "realtime", False)))


@sim_function("getRealTimeSimulation")
def getRealTimeSimulation(ctx: CallContext) -> bool:  # noqa: N802
    """Whether the free-running simulation is paced to wall time (:func:`getIsRealTimeSimulation`).

    Returns:
        True or False.
    """
    return bool(getIsRealTimeSimulation(ctx))


@sim_function("getSimulationStopping")
def getSimulationStopping(ctx: CallContext) -> bool:  # noqa: N802
    """Whether the simulation is stopping (the scripts' ``sysCall_cleanup`` runs).

    Returns:
        True while stopping.
    """
    return bool(getattr(ctx.simulation("getSimulationStopping").scripts, "stopping", False))


@sim_function("quitSimulator")
def quitSimulator(ctx: CallContext, doNotDisplayMessages: Any = False) -> None:  # noqa: N802, N803
    """Refused: a script or client cannot end the server other clients share (stop it with
    SIGTERM / Ctrl-C, docs/SECURITY.md).

    Args:
        doNotDisplayMessages: ignored.

    Raises:
        RemoteError: always.
    """
    raise RemoteError("sim.quitSimulator is refused: the server is shared by its clients and scripts; "
                      "stop simx-server itself (SIGTERM or Ctrl-C)")


