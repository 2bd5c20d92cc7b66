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
and is no larger than the engine's step (CoppeliaSim's 5 ms where the file says none), as
CoppeliaSim steps its engine (``CPhysics::handleDynamics``: ``dt / engine step`` engine passes
per simulation pass), where MuJoCo holds the scene as V-REP's engine does at that step; no
larger than 2 ms (:data:`FALLBACK_TIMESTEP`) where it does not, with the reason in the report
(``Report.physics``, logged at load): :func:`needs_fallback` (rigid contacts, joint limits,
closed mechanisms, motors: MuJoCo makes the constraints two timesteps stiff, and at 5 ms a resting
cube sinks twice as deep, a block on a slope creeps, a gripper's limits and loop closures give
way, a held cube slips; RLBench's demos that stack, screw or push failed) and :func:`stiff_spring` (a joint's own
spring that MuJoCo, integrating it explicitly, would make diverge). The ``simx:scene:simulation``
custom text tells the server the step (``dt=``) and the real-time mode (``real_time=0|1
real_time_factor=F``), which it uses unless ``--dt`` / ``--speed`` say otherwise
(:mod:`simx_server.sim.scene_settings`).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

import mujoco
import numpy as np

from simx_server.scene.ttt.records import Records

#: V-REP's time-step presets (``Spi`` 0-4), s; 5 is "custom".
PRESETS = (0.2, 0.1, 0.05, 0.025, 0.01)
CUSTOM = 5
#: CoppeliaSim's default physics step when a file says none (``CDynamicsContainer``), s.
DEFAULT_PHYSICS_STEP = 0.005
#: The largest MuJoCo timestep of a converted scene that MuJoCo cannot hold at its engine's step
#: (:func:`needs_fallback`, :func:`stiff_spring`), s.
FALLBACK_TIMESTEP = 0.002
#: The most a joint's own spring may turn per MuJoCo step: ``omega * h`` (rad), ``omega`` its
#: natural frequency on the joint's inertia. MuJoCo integrates a spring's force explicitly (only
#: velocity terms are implicit), which diverges past 2; 1 keeps about six steps a period.
MAX_SPRING_PHASE = 1.0
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


def mujoco_timestep(dt: float, physics_step: float | None, cap: float | None = None) -> float:
    """The MuJoCo timestep for a simulation step ``dt`` (s): the largest ``dt / n`` no larger
    than ``physics_step`` (None: :data:`DEFAULT_PHYSICS_STEP`) and ``cap`` (s, None: none) that
    the MJCF keeps exactly (6 significant digits), so that ``dt`` is a whole number of substeps;
    else the largest such ``dt / n``."""
    bound = min(physics_step or DEFAULT_PHYSICS_STEP, cap or math.inf)
    first = max(1, math.ceil(dt / bound - 1e-6))  # a float32 5 ms (0.004999999888) is 5 ms
    for n in range(first, first + 64):
        step = float(f"{dt / n:.6g}")
        if abs(step * n - dt) <= 1e-12:
            return step
    return dt / first


def engine_timestep(scene) -> float:
    """The MuJoCo timestep of the engine's step for a read ``TttScene`` (:func:`mujoco_timestep`
    of its saved steps), s."""
    saved: SavedSettings = scene.saved_settings or SavedSettings()
    return mujoco_timestep(saved.time_step or 0.05, saved.physics_step)


def needs_fallback(scene) -> str | None:
    """Why MuJoCo cannot hold ``scene`` (a read ``TttScene``) as V-REP's engine does at the
    engine's step, or None: a dynamic respondable shape (contacts), a limited joint (its limits),
    a closed mechanism (loop closures, dependent joints) or a motor. MuJoCo makes these
    constraints two timesteps stiff (:func:`simx_server.sim.mechanisms.stiff_solref`: the
    stiffest it keeps stable), so their give under a load grows with the square of the timestep,
    and simx's servo's gain is the joint's inertia over the timestep (:mod:`simx_server.sim.motors`:
    a ROBOTIQ 85's position loop closed its fingers at a third of the speed at 5 ms); V-REP's
    engines keep them rigid at any step.

    Args:
        scene: the file as read.

    Returns:
        One line naming the first such object and what it needs, or None.
    """
    from simx_server.scene.ttt import parts  # the joints' conversion (parts imports what imports this)

    for obj in scene.objects.values():
        d = obj.data
        if obj.kind == "shape" and d is not None and not d.static and d.respondable:
            return (f"shape {obj.name!r} is dynamic and respondable: MuJoCo's contacts, two timesteps "
                    "stiff, hold V-REP's rigid ones (resting, stacked and held bodies) at 2 ms")
        if obj.kind == "joint" and d is not None and d.type != 12 and not (d.type == 10 and d.cyclic) \
                and math.isfinite(d.range) and d.range > 0:
            return (f"joint {obj.name!r} has limits: MuJoCo's limits, two timesteps stiff, hold V-REP's "
                    "hard ones under the motors at 2 ms")
        if obj.kind == "joint" and d is not None and parts.motorised(d):
            return (f"joint {obj.name!r} has a motor: simx's servo (sim/motors.py), its gain the joint's inertia "
                    "over the timestep, follows V-REP's velocity constraint under a load at 2 ms")
        if (obj.kind == "dummy" and d is not None and d.linked >= 0 and d.link_type == 0) \
                or (obj.kind == "joint" and d is not None and d.dependency is not None):
            return (f"{obj.kind} {obj.name!r} closes a mechanism: MuJoCo's loop closures and dependencies, "
                    "two timesteps stiff, hold V-REP's rigid ones at 2 ms")
    return None


def stiff_spring(model: mujoco.MjModel) -> str | None:
    """Why MuJoCo cannot step ``model`` stably at its ``opt.timestep``, or None: the first joint
    whose own spring (``stiffness``, N/m or N·m/rad) turns more than :data:`MAX_SPRING_PHASE` per
    step on the joint's inertia at the initial pose (``1 / dof_invweight0``).

    Args:
        model: the compiled conversion.

    Returns:
        One line naming the joint, its spring and the largest step it takes, or None.
    """
    h = float(model.opt.timestep)
    for j in np.flatnonzero(model.jnt_stiffness > 0):
        kind = int(model.jnt_type[j])
        if kind not in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
            continue
        k = float(model.jnt_stiffness[j])
        omega = math.sqrt(k * float(model.dof_invweight0[model.jnt_dofadr[j]]))
        if omega * h > MAX_SPRING_PHASE:
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(j)) or f"#{j}"
            unit = "N·m/rad" if kind == int(mujoco.mjtJoint.mjJNT_HINGE) else "N/m"
            return (f"joint {name!r}'s spring ({k:g} {unit}, {omega:.4g} rad/s on its inertia) needs MuJoCo "
                    f"steps of at most {MAX_SPRING_PHASE / omega * 1000:.3g} ms")
    return None


def apply(conv, cap: float | None = None) -> None:
    """Set the converted scene's timestep (no larger than ``cap`` s where given) and gravity,
    record ``simx:scene:simulation`` and the report's "taken from the file" lines
    (``conv.report.taken``)."""
    s = conv.scene
    saved: SavedSettings = s.saved_settings or SavedSettings()
    dt = saved.time_step or 0.05
    conv.spec.option.timestep = mujoco_timestep(dt, saved.physics_step, cap)
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
