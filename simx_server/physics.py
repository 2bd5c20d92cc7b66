"""Physics bounds: what a client may write into MuJoCo.

Bounds (values in :mod:`simx_server.limits`, listed in docs/SECURITY.md): every value that sets
the work of a step (``dt``, the substeps it makes, vision-sensor resolutions) and every float a
client writes into ``MjModel``/``MjData`` (gravity, masses, joint positions, targets and forces,
object positions) has a range; a value outside it, NaN and infinities included, raises an
:class:`~simx_client.protocol.ArgumentError` that names the bound. Scenes are checked when they
load (``<option timestep>`` against dt, camera resolutions).
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np

from simx_client.protocol import ArgumentError
from simx_server import limits as L
from simx_server.arguments import as_float, quote


# ------------------------------------------------------------------------ bounds
def out_of_range(what: str, value: Any, low: float, high: float, unit: str, bound: str) -> ArgumentError:
    """The ArgumentError for ``value`` outside [low, high] (``bound``: the limits.py names)."""
    return ArgumentError(f"{what} must be finite and within [{low:g}, {high:g}] {unit} "
                         f"(simx_server.limits.{bound}), got {quote(value)}")


def check_dt(dt: Any) -> float:
    """``dt`` (s) if 0 < dt <= MAX_DT, else ArgumentError (``--dt``, parameter 1)."""
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not 0 < dt <= L.MAX_DT:
        raise ArgumentError(f"the simulation time step (dt, --dt, sim_floatparam_simulation_time_step) must "
                            f"be > 0 and at most {L.MAX_DT:g} s (simx_server.limits.MAX_DT), got {quote(dt)}")
    return float(dt)


def substeps(dt: float, timestep: float) -> int:
    """Number of MuJoCo substeps of ``timestep`` s in a step of ``dt`` s (at least 1).

    Raises:
        ArgumentError: more than MAX_SUBSTEPS, or a timestep that is not > 0 and finite.
    """
    if not (0 < timestep < math.inf):
        raise ArgumentError(f"the scene's <option timestep> must be > 0 and finite, got {quote(timestep)}")
    n = max(1, round(dt / timestep))
    if n > L.MAX_SUBSTEPS:
        raise ArgumentError(f"a step of {dt:g} s is {n} MuJoCo substeps of the scene's timestep {timestep:g} s; "
                            f"the most is {L.MAX_SUBSTEPS} (simx_server.limits.MAX_SUBSTEPS): use a smaller dt "
                            "or a larger <option timestep>")
    return n


def check_resolution(width: int, height: int, what: str) -> None:
    """ArgumentError unless both sides are in 1..MAX_RESOLUTION pixels."""
    if not (0 < width <= L.MAX_RESOLUTION and 0 < height <= L.MAX_RESOLUTION):
        raise ArgumentError(f"{what}: resolution {width}x{height} is outside 1..{L.MAX_RESOLUTION} pixels a "
                            "side (simx_server.limits.MAX_RESOLUTION)")


def check_scene(model: mujoco.MjModel, dt: float) -> int:
    """Check a scene's per-step work before it is installed; returns the substeps of ``dt``.

    Raises:
        ArgumentError: too many substeps, or a camera (vision sensor) resolution out of bounds.
    """
    n = substeps(dt, float(model.opt.timestep))
    for c in range(model.ncam):
        w, h = (int(x) for x in model.cam_resolution[c])
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, c) or f"#{c}"
        check_resolution(w, h, f"camera {quote(name)}")
    return n


def check_gravity(values: Any) -> list[float]:
    """Gravity (3 floats, m/s²) whose magnitude is at most MAX_GRAVITY, else ArgumentError."""
    if not isinstance(values, (list, tuple)) or len(values) != 3:
        raise ArgumentError(f"gravity must be a list of 3 numbers (m/s²), got {quote(values)}")
    g = [as_float(v, "gravity") for v in values]
    if not math.hypot(*g) <= L.MAX_GRAVITY:  # NaN and infinities fail too
        raise ArgumentError(f"gravity's magnitude must be finite and at most {L.MAX_GRAVITY:g} m/s² "
                            f"(simx_server.limits.MAX_GRAVITY), got {quote(values)}")
    return g


def scaled_inertia(mass: float, old_mass: float, inertia: np.ndarray) -> np.ndarray:
    """The principal inertia (3,) in kg·m² of a body given ``mass`` (kg): its ``inertia`` at
    ``old_mass`` scaled by the ratio (same shape, new density, as V-REP keeps it).

    Raises:
        ArgumentError: ``mass`` outside [MIN_MASS, MAX_MASS], or an inertia above MAX_INERTIA.
    """
    if not L.MIN_MASS <= mass <= L.MAX_MASS:
        raise out_of_range("mass", mass, L.MIN_MASS, L.MAX_MASS, "kg", "MIN_MASS and MAX_MASS")
    if old_mass > 0:
        new = np.asarray(inertia, dtype=float) * (mass / old_mass)
    else:
        new = np.full(3, max(float(np.max(inertia)), 1e-9) * mass)
    if not float(np.max(new)) <= L.MAX_INERTIA:  # NaN fails too
        raise ArgumentError(f"a mass of {mass:g} kg makes the body's inertia {float(np.max(new)):g} kg·m², "
                            f"more than {L.MAX_INERTIA:g} (simx_server.limits.MAX_INERTIA)")
    return new


def check_position(position: list[float]) -> list[float]:
    """A position (3 floats, m) with every coordinate within ±MAX_POSITION, else ArgumentError."""
    for v in position:
        if not -L.MAX_POSITION <= v <= L.MAX_POSITION:
            raise out_of_range("each coordinate of a position", position, -L.MAX_POSITION, L.MAX_POSITION,
                               "m", "MAX_POSITION")
    return position
