"""The simulation settings a ``.ttt`` saves, and how the conversion applies them.

Read (records of the top-level ``SIM`` and ``DYN`` lists):

* the simulation step, as CoppeliaSim's ``CSimulation::serialize`` loads it: ``_t3`` (f64) or
  ``St3`` (f32) is the step itself; older files give ``Sts`` (f32 s) or ``St2`` (u64 µs) and the
  time-step preset ``Spi``: 0-4 are V-REP's presets 200, 100, 50, 25 and 10 ms (whatever value
  was stored beside them), 5 is "custom" (the stored value);
* real-time mode (``Ss2``, or the old ``Sst``, bit 0) and its multiplier (``Rt2`` f64, ``Rtc`` f32);
* gravity and the engine (``_n3``/``En3``/``En2``/``Eng``, read by the reader) and the physics
  engine's own step, as ``CDynamicsContainer::serialize`` loads it: ``_tp``/``Stp``, else the first
  float of the selected engine's parameter array (``_uN``/``BuN``/``Bul`` Bullet, ``_dN``/``OdN``/
  ``Ode`` ODE, ``_o5``/``Vo5`` Vortex, ``_w1``/``Nw1`` Newton, ``_j1``/``Mj1`` MuJoCo), else 5 ms.

Applied (:func:`apply`): MuJoCo's ``timestep`` is the largest that divides the simulation step
and is no larger than the engine's step or 2 ms (so that contacts stay stable in MuJoCo), and
the ``simx:scene:simulation`` custom text tells the server the step (``dt=``) and the real-time
mode (``real_time=0|1 real_time_factor=F``), which it uses unless ``--dt`` / ``--speed`` say
otherwise (:mod:`simx_server.sim.scene_settings`).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

from simx_server.scene.ttt.records import Records

#: V-REP's time-step presets (``Spi`` 0-4), s; 5 is "custom".
PRESETS = (0.2, 0.1, 0.05, 0.025, 0.01)
CUSTOM = 5
#: CoppeliaSim's default physics step when a file says none (``CDynamicsContainer``), s.
DEFAULT_PHYSICS_STEP = 0.005
#: The largest MuJoCo timestep a conversion uses, s (MuJoCo's contacts need small steps).
MAX_MUJOCO_TIMESTEP = 0.002
#: The engines' parameter arrays, in the order of ``CDynamicsContainer::serialize``'s engines
#: (0 Bullet, 1 ODE, 2 Vortex, 3 Newton, 4 MuJoCo): (f64 array, f32 array, older f32 pair).
_ENGINE_ARRAYS = (("_uN", "BuN", "Bul"), ("_dN", "OdN", "Ode"), ("_o5", "Vo5", None), ("_w1", "Nw1", None),
                  ("_j1", "Mj1", None))
_MAX_STEP = 10.0  # s: larger saved values are taken as damage, not settings


@dataclass
class SavedSettings:
    """What a file's ``SIM``/``DYN`` records say; None where the file says nothing usable.

    Attributes:
        time_step: the simulation step, s; ``preset`` the ``Spi`` index (5: custom, None: absent).
        real_time: real-time mode; ``real_time_factor`` its multiplier.
        physics_step: the physics engine's step, s.
        gravity_saved: whether the file has a ``DYN`` engine record (its gravity is in
            ``TttScene.gravity``).
    """

    time_step: float | None = None
    preset: int | None = None
    real_time: bool | None = None
    real_time_factor: float | None = None
    physics_step: float | None = None
    gravity_saved: bool = False
    notes: list[str] = field(default_factory=list)


def _finite(value: float, low: float = 0.0, high: float = _MAX_STEP) -> bool:
    return math.isfinite(value) and low < value <= high


def read_simulation(r: Records, saved: SavedSettings) -> None:
    """The ``SIM`` records into ``saved`` (``CSimulation::serialize``, loading)."""
    value, exact = None, False
    for tag, fmt, scale, new in (("Sts", "<f", 1.0, False), ("St2", "<Q", 1e-6, False), ("St3", "<f", 1.0, True),
                                 ("_t3", "<d", 1.0, True)):
        payload = r.get(tag)
        if payload is not None and len(payload) >= struct.calcsize(fmt):
            v = struct.unpack_from(fmt, payload, 0)[0] * scale
            if _finite(v):
                value, exact = float(v), exact or new
    spi = r.get("Spi")
    preset = struct.unpack_from("<i", spi, 0)[0] if spi is not None and len(spi) >= 4 else None
    flags = r.get("Ss2")
    if flags is None:
        flags = r.get("Sst")
        if flags is not None and len(flags) >= 1 and preset is None:  # bit 5: the default step
            preset = 2 if flags[0] & 32 else CUSTOM
    if flags is not None and len(flags) >= 1:
        saved.real_time = bool(flags[0] & 1)
    saved.preset = preset
    if not exact and preset is not None and 0 <= preset < len(PRESETS):
        value = PRESETS[preset]  # a preset: V-REP's value, not the one stored beside it
    saved.time_step = value
    for tag, fmt in (("Rt2", "<d"), ("Rtc", "<f")):
        payload = r.get(tag)
        if payload is not None and len(payload) >= struct.calcsize(fmt):
            factor = struct.unpack_from(fmt, payload, 0)[0]
            if _finite(factor, 0.0, 1e6):
                saved.real_time_factor = float(factor)
            break


def read_dynamics(r: Records, engine: int, saved: SavedSettings) -> None:
    """The physics step of the ``DYN`` records into ``saved`` (``CDynamicsContainer::serialize``,
    loading: the common step record, else the selected engine's own, else the default)."""
    for tag, fmt in (("_tp", "<d"), ("Stp", "<f")):
        payload = r.get(tag)
        if payload is not None and len(payload) >= struct.calcsize(fmt):
            step = struct.unpack_from(fmt, payload, 0)[0]
            saved.physics_step = float(step) if _finite(step, 0.0, 1.0) else None
            return
    if 0 <= engine < len(_ENGINE_ARRAYS):
        new, old, pair = _ENGINE_ARRAYS[engine]
        for tag, fmt, offset in ((new, "<d", 8), (old, "<f", 8), (pair, "<f", 0)):
            payload = r.get(tag) if tag else None
            if payload is not None and len(payload) >= offset + struct.calcsize(fmt):
                count = struct.unpack_from("<i", payload, 0)[0] if offset else 1
                step = struct.unpack_from(fmt, payload, offset)[0]
                if count >= 1 and _finite(step, 0.0, 1.0):
                    saved.physics_step = float(step)
                    return
    saved.physics_step = DEFAULT_PHYSICS_STEP


def mujoco_timestep(dt: float, physics_step: float | None) -> float:
    """The MuJoCo timestep for a simulation step ``dt`` (s): the largest ``dt / n`` no larger
    than ``physics_step`` and MAX_MUJOCO_TIMESTEP that the MJCF keeps exactly (6 significant
    digits), so that ``dt`` is a whole number of substeps; else the largest such ``dt / n``."""
    bound = min(MAX_MUJOCO_TIMESTEP, physics_step or MAX_MUJOCO_TIMESTEP)
    first = max(1, math.ceil(dt / bound - 1e-9))
    for n in range(first, first + 64):
        step = float(f"{dt / n:.6g}")
        if abs(step * n - dt) <= 1e-12:
            return step
    return dt / first


def apply(conv) -> None:
    """Set the converted scene's timestep and gravity, record ``simx:scene:simulation`` and the
    report's "taken from the file" lines (``conv.report.taken``)."""
    s = conv.scene
    saved: SavedSettings = s.saved_settings or SavedSettings()
    dt = saved.time_step or 0.05
    conv.spec.option.timestep = mujoco_timestep(dt, saved.physics_step)
    conv.spec.option.gravity = s.gravity
    items, taken = [], conv.report.taken
    if saved.time_step is not None:
        items.append(f"dt={dt:.9g}")
        kind = "custom" if saved.preset in (None, CUSTOM) else "preset"
        taken.append(f"simulation time step {dt * 1000:g} ms ({kind})")
    if saved.real_time is not None:
        factor = saved.real_time_factor if saved.real_time_factor is not None else 1.0
        items += [f"real_time={int(saved.real_time)}", f"real_time_factor={factor:.9g}"]
        taken.append(f"real-time mode x{factor:g}" if saved.real_time else
                     "real-time mode off (a pass per display frame, as CoppeliaSim's window)")
    if saved.gravity_saved:
        g = ", ".join(f"{v:g}" for v in s.gravity)
        taken.append(f"gravity ({g}) m/s²")
    if saved.physics_step is not None:
        taken.append(f"physics step {saved.physics_step * 1000:g} ms (MuJoCo substeps of "
                     f"{conv.spec.option.timestep * 1000:.4g} ms)")
    if items:
        conv.setting("scene:simulation", *items)
