"""The simulator's global parameters as the legacy remote API numbers them (vrepConst.py's
``sim_intparam_*``, ``sim_floatparam_*``, ``sim_boolparam_*``, ``sim_stringparam_*``,
``sim_arrayparam_*``): what each id means on a headless MuJoCo server.

One implementation for both front doors: the legacy commands (``simxGetIntegerParameter`` ...,
:mod:`simx_server.commands.parameters`) unpack their arguments and call these functions; the ZMQ
``sim`` parameter functions (:mod:`simx_server.api.sim.params`) call them for a remote client's
ids that CoppeliaSim 4.x's own parameters do not answer. An id without a meaning
in simx raises :class:`~simx_wire.protocol.UnsupportedError` naming it.
"""

from __future__ import annotations

import os
import random
import sys
from pathlib import Path
from typing import Any

from simx_wire import constants as C
from simx_wire.protocol import RemoteError, UnsupportedError
from simx_server.sim import physics
from simx_server.sim.state import RunState

INTPARAM_DYNAMIC_STEP_DIVIDER, INTPARAM_PLATFORM, INTPARAM_CORE_COUNT, INTPARAM_STOP_REQUEST_COUNTER = 7, 19, 24, 29
INTPARAM_MOUSE_X, INTPARAM_MOUSE_Y, INTPARAM_MOUSE_BUTTONS = 22, 23, 31

#: The mouse of a headless server: it never moves from the top-left corner of a window nobody
#: sees (x = y = 0 pixels) and no button is ever pressed (bit mask 0). V-REP without a window
#: answered an error; CoppeliaSim's simpleTest.py streams mouse_x, so simx answers this fixed
#: point instead, the same every time (no made-up motion).
HEADLESS_MOUSE = {INTPARAM_MOUSE_X: 0, INTPARAM_MOUSE_Y: 0, INTPARAM_MOUSE_BUTTONS: 0}

_READ_ONLY_INTPARAMS = (INTPARAM_DYNAMIC_STEP_DIVIDER, INTPARAM_PLATFORM, INTPARAM_CORE_COUNT,
                        INTPARAM_STOP_REQUEST_COUNTER, *HEADLESS_MOUSE)

FLOATPARAM_RAND, FLOATPARAM_SIMULATION_TIME_STEP = 0, 1
BOOLPARAM_DYNAMICS_HANDLING, BOOLPARAM_DISPLAY_ENABLED, BOOLPARAM_REALTIME = 6, 16, 25
BOOLPARAM_HEADLESS, BOOLPARAM_WAITING_FOR_TRIGGER = 34, 45
STRINGPARAM_APPLICATION_PATH, STRINGPARAM_SCENE_PATH_AND_NAME = 0, 13
ARRAYPARAM_GRAVITY = 0

#: ``sim_stringparam_application_path``: the folder of the ``simx_server`` package.
APPLICATION_PATH = Path(__file__).resolve().parents[1]


def _param(kind: str, pid: int) -> str:
    """How messages name a global parameter: ``boolean parameter sim_boolparam_fog_enabled (19)``."""
    return f"{kind} parameter {C.describe(pid, C.GLOBAL_PARAM_PREFIXES[kind])}"


def _unsupported_param(kind: str, pid: int) -> UnsupportedError:
    return UnsupportedError(f"{_param(kind, pid)} has no meaning in simx (see docs/API.md for the supported ids)")


def get_integer(sim: Any, pid: int) -> int:
    """An integer parameter (``simxGetIntegerParameter``).

    Args:
        sim: the simulation.
        pid: ``sim_intparam_*`` id: 7 dynamics step divider (MuJoCo substeps per step),
            19 platform (0 Windows, 1 macOS, 2 Linux), 24 core count, 29 stop request counter,
            22/23 mouse x/y (pixels) and 31 mouse buttons (always 0: see HEADLESS_MOUSE).

    Returns:
        The parameter's value.

    Raises:
        UnsupportedError: any other id.
    """
    if pid in HEADLESS_MOUSE:
        return HEADLESS_MOUSE[pid]
    values = {
        INTPARAM_DYNAMIC_STEP_DIVIDER: lambda: sim.world.substeps,
        INTPARAM_PLATFORM: lambda: 0 if sys.platform.startswith("win") else 1 if sys.platform == "darwin" else 2,
        INTPARAM_CORE_COUNT: lambda: os.cpu_count() or 1,
        INTPARAM_STOP_REQUEST_COUNTER: lambda: sim.stop_requests,
    }
    if pid not in values:
        raise _unsupported_param("integer", pid)
    return int(values[pid]())


def set_integer(sim: Any, pid: int, value: int) -> None:
    """Set an integer parameter (``simxSetIntegerParameter``): simx has none to set.

    Args:
        sim: the simulation.
        pid: ``sim_intparam_*`` id.
        value: the value asked for.

    Raises:
        RemoteError: the ids :func:`get_integer` answers are read-only (the mouse says why).
        UnsupportedError: any other id.
    """
    if pid in HEADLESS_MOUSE:
        raise RemoteError(f"{_param('integer', pid)} (the mouse) is read-only: a headless server's mouse "
                          "stays at (0, 0) with no button pressed")
    if pid in _READ_ONLY_INTPARAMS:
        raise RemoteError(f"{_param('integer', pid)} is read-only")
    raise _unsupported_param("integer", pid)


def get_floating(sim: Any, pid: int) -> float:
    """A floating parameter (``simxGetFloatingParameter``).

    Args:
        sim: the simulation.
        pid: 1 ``sim_floatparam_simulation_time_step`` (s) or 0 ``sim_floatparam_rand``
            (uniform in [0, 1)).

    Returns:
        The parameter's value.

    Raises:
        UnsupportedError: any other id.
    """
    if pid == FLOATPARAM_SIMULATION_TIME_STEP:
        return sim.world.dt
    if pid == FLOATPARAM_RAND:
        return random.random()
    raise _unsupported_param("float", pid)


def set_floating(sim: Any, pid: int, value: float) -> None:
    """Set a floating parameter (``simxSetFloatingParameter``): the time step only.

    Args:
        sim: the simulation.
        pid: 1 ``sim_floatparam_simulation_time_step``.
        value: the step in s: 0 < dt <= limits.MAX_DT, at most limits.MAX_SUBSTEPS substeps.

    Raises:
        RemoteError: the simulation is not stopped.
        ArgumentError: ``value`` out of those bounds.
        UnsupportedError: any other id.
    """
    if pid != FLOATPARAM_SIMULATION_TIME_STEP:
        raise _unsupported_param("float", pid)
    if sim.state is not RunState.STOPPED:
        raise RemoteError("the simulation time step can only change while the simulation is stopped")
    sim.world.set_dt(value)


def get_boolean(sim: Any, pid: int) -> bool:
    """A boolean parameter (``simxGetBooleanParameter``).

    Args:
        sim: the simulation.
        pid: 6 dynamics handling (True), 16 display enabled (False), 34 headless (True),
            25 real-time simulation (paced to wall time), 45 waiting for trigger (synchronous
            mode while running).

    Returns:
        The parameter's value.

    Raises:
        UnsupportedError: any other id.
    """
    values = {
        BOOLPARAM_DYNAMICS_HANDLING: True,
        BOOLPARAM_DISPLAY_ENABLED: False,
        BOOLPARAM_HEADLESS: True,
        BOOLPARAM_REALTIME: sim.realtime,
        BOOLPARAM_WAITING_FOR_TRIGGER: sim.synchronous and sim.state is RunState.RUNNING,
    }
    if pid not in values:
        raise _unsupported_param("boolean", pid)
    return values[pid]


def set_boolean(sim: Any, pid: int, value: Any) -> None:
    """Set a boolean parameter (``simxSetBooleanParameter``): real-time pacing only.

    Args:
        sim: the simulation.
        pid: 25 ``sim_boolparam_realtime_simulation``.
        value: truthy to pace the free-running simulation to wall time.

    Raises:
        UnsupportedError: any other id.
    """
    if pid != BOOLPARAM_REALTIME:
        raise _unsupported_param("boolean", pid)
    sim.realtime = bool(value)


def get_string(sim: Any, pid: int) -> str:
    """A string parameter (``simxGetStringParameter``).

    Args:
        sim: the simulation.
        pid: 0 application path (the ``simx_server`` package's folder), 13 scene path and
            name (as clients see it: never a transfer folder's path).

    Returns:
        The parameter's value.

    Raises:
        UnsupportedError: any other id.
    """
    if pid == STRINGPARAM_APPLICATION_PATH:
        return str(APPLICATION_PATH)
    if pid == STRINGPARAM_SCENE_PATH_AND_NAME:
        return sim.editor.public(sim.world.scene_path)  # never the transfer folder's path
    raise _unsupported_param("string", pid)


def set_string(sim: Any, pid: int, value: str) -> None:
    """Set a string parameter: simx has none to set (the legacy API has no such command;
    CoppeliaSim's settable ones are its window's and log's settings).

    Raises:
        UnsupportedError: every id.
    """
    raise _unsupported_param("string", pid)


def get_array(sim: Any, pid: int) -> list[float]:
    """An array parameter (``simxGetArrayParameter``).

    Args:
        sim: the simulation.
        pid: 0 ``sim_arrayparam_gravity``.

    Returns:
        Gravity ``[gx, gy, gz]`` in m/s², the MuJoCo model's.

    Raises:
        UnsupportedError: any other id.
    """
    if pid != ARRAYPARAM_GRAVITY:
        raise _unsupported_param("array", pid)
    return sim.world.model.opt.gravity.tolist()


def set_array(sim: Any, pid: int, values: Any) -> None:
    """Set an array parameter (``simxSetArrayParameter``): gravity only.

    Args:
        sim: the simulation.
        pid: 0 ``sim_arrayparam_gravity``.
        values: 3 numbers, m/s².

    Raises:
        ArgumentError: not 3 finite numbers, or a magnitude above limits.MAX_GRAVITY.
        UnsupportedError: any other id.
    """
    if pid != ARRAYPARAM_GRAVITY:
        raise _unsupported_param("array", pid)
    sim.world.model.opt.gravity[:] = physics.check_gravity(values)
