"""Light parameters of CoppeliaSim's object-parameter API, on MuJoCo's lights.

``sim_lightintparam_pov_casts_shadows`` (8000) is MuJoCo's ``light_castshadow``;
``sim_lightfloatparam_spot_exponent`` (8001) its ``light_exponent``;
``sim_lightfloatparam_spot_cutoff`` (8002, rad, up to pi) its ``light_cutoff`` (degrees);
the constant, linear and quadratic attenuation factors (8003-8005) its ``light_attenuation``,
read only (CoppeliaSim 4.1 does not set them either). Run-time changes are undone when the
simulation stops (the model is reloaded).
"""

from __future__ import annotations

import math

import numpy as np

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.sim.state import SimulationView
from simx_server.sim.world import LIGHT

CASTS_SHADOWS = 8000
SPOT_EXPONENT, SPOT_CUTOFF = 8001, 8002
ATTENUATION = (8003, 8004, 8005)
INT_IDS = (CASTS_SHADOWS,)
FLOAT_IDS = (SPOT_EXPONENT, SPOT_CUTOFF, *ATTENUATION)


def _light(sim: SimulationView, handle: int) -> int:
    return int(sim.world.get(handle, LIGHT).mj_id)


def get_int(sim: SimulationView, handle: int, pid: int) -> int:
    """Whether light ``handle`` casts shadows (8000).

    Args:
        sim: the simulation.
        handle: the light's handle.
        pid: the parameter id.

    Returns:
        The value.
    """
    return int(bool(sim.world.model.light_castshadow[_light(sim, handle)]))


def set_int(sim: SimulationView, handle: int, pid: int, value: int) -> None:
    """Set whether light ``handle`` casts shadows (8000: 0 or 1).

    Args:
        sim: the simulation.
        handle: the light's handle.
        pid: the parameter id.
        value: the new value.

    Raises:
        ArgumentError: not 0 or 1.
    """
    if value not in (0, 1):
        raise ArgumentError(f"sim_lightintparam_pov_casts_shadows (8000): 0 or 1, got {value}")
    sim.world.model.light_castshadow[_light(sim, handle)] = value
    sim.world.version += 1


def get_float(sim: SimulationView, handle: int, pid: int) -> float:
    """Spot exponent, spot cutoff (rad) or an attenuation factor of light ``handle``.

    Args:
        sim: the simulation.
        handle: the light's handle.
        pid: the parameter id.

    Returns:
        The value.
    """
    m, i = sim.world.model, _light(sim, handle)
    if pid == SPOT_EXPONENT:
        return float(m.light_exponent[i])
    if pid == SPOT_CUTOFF:
        kept = getattr(sim.world, "light_cutoffs", {}).get(i)  # the value set, which float32 rounds
        degrees = float(m.light_cutoff[i])
        if kept is not None and float(np.float32(math.degrees(kept))) == degrees:
            return kept
        return math.radians(degrees)
    return float(m.light_attenuation[i][ATTENUATION.index(pid)])


def set_float(sim: SimulationView, handle: int, pid: int, value: float) -> None:
    """Set the spot exponent (>= 0) or cutoff (rad, in (0, pi]) of light ``handle``.

    Args:
        sim: the simulation.
        handle: the light's handle.
        pid: the parameter id.
        value: the new value.

    Raises:
        ArgumentError: a value out of range.
        UnsupportedError: an attenuation factor (read only, as in CoppeliaSim 4.1).
    """
    m, i = sim.world.model, _light(sim, handle)
    if pid in ATTENUATION:
        raise UnsupportedError(f"light parameter {pid}: attenuation factors are read only")
    if not math.isfinite(value):
        raise ArgumentError(f"light parameter {pid}: must be finite, got {value}")
    if pid == SPOT_EXPONENT:
        if value < 0:
            raise ArgumentError(f"sim_lightfloatparam_spot_exponent (8001): must be >= 0, got {value}")
        m.light_exponent[i] = value
    else:
        if not 0 < value <= math.pi:
            raise ArgumentError(f"sim_lightfloatparam_spot_cutoff (8002): must be in (0, pi] rad, got {value}")
        m.light_cutoff[i] = math.degrees(value)
        if not hasattr(sim.world, "light_cutoffs"):
            sim.world.light_cutoffs = {}  # type: ignore[attr-defined]
        sim.world.light_cutoffs[i] = float(value)  # type: ignore[attr-defined]
    sim.world.version += 1
