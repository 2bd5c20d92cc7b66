"""Physics bounds and blow-ups: what a client may write into MuJoCo, and what happens when
MuJoCo still finds the state unstable.

Bounds (values in :mod:`simx_server.base.limits`, listed in docs/SECURITY.md): every value that sets
the work of a step (``dt``, the substeps it makes, vision-sensor resolutions) and every float a
client writes into ``MjModel``/``MjData`` (gravity, masses, joint positions, targets and forces,
object positions) has a range; a value outside it, NaN and infinities included, raises an
:class:`~simx_wire.protocol.ArgumentError` that names the bound. Scenes are checked when they
load (``<option timestep>`` against dt, camera resolutions).

Blow-ups: MuJoCo resets the state by itself when it finds a NaN, infinite or huge position,
velocity or acceleration, and warns on stdout and in ``MUJOCO_LOG.TXT`` each time; a scene
that stays unstable warns every step and its time goes back to 0 every step. simx installs one
process-wide warning handler (:func:`install_warning_handler`) that keeps MuJoCo's messages for
the log instead, and :class:`~simx_server.sim.world.World` raises :class:`PhysicsError` after a step
that hit one; :class:`~simx_server.scene.simulation.Simulation` then stops the simulation (back to
the scene's initial state, as ``simxStopSimulation``) and logs one line with the reason.
"""

from __future__ import annotations

import logging
import math
import re
import time
from typing import Any, Callable

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, RemoteError
from simx_server.base import limits as L
from simx_server.base.arguments import as_float, quote

log = logging.getLogger("simx.physics")

#: MuJoCo's warnings about a bad state, with what each one is about.
BAD_STATE = {
    int(mujoco.mjtWarning.mjWARN_BADQPOS): "position",
    int(mujoco.mjtWarning.mjWARN_BADQVEL): "velocity",
    int(mujoco.mjtWarning.mjWARN_BADQACC): "acceleration",
}
_BAD_FIRST, _BAD_LAST = min(BAD_STATE), max(BAD_STATE)


class PhysicsError(RemoteError):
    """MuJoCo found the state unstable during a step (NaN, infinite or huge values)."""


# ------------------------------------------------------------------------ bounds
def out_of_range(what: str, value: Any, low: float, high: float, unit: str, bound: str) -> ArgumentError:
    """The ArgumentError for ``value`` outside [low, high] (``bound``: the limits.py names).

    Args:
        what: what the value is, for the message.
        value: the value given.
        low: the smallest allowed.
        high: the largest allowed.
        unit: its unit (``"m"``, ``"kg"`` ...).
        bound: the limits.py name(s) of the bounds.

    Returns:
        The error, to raise.
    """
    return ArgumentError(f"{what} must be finite and within [{low:g}, {high:g}] {unit} "
                         f"(simx_server.base.limits.{bound}), got {quote(value)}")


def check_dt(dt: Any) -> float:
    """``dt`` (s) if 0 < dt <= MAX_DT, else ArgumentError (``--dt``, parameter 1).

    Args:
        dt: the step asked for, s.

    Returns:
        ``dt`` as a float.

    Raises:
        ArgumentError: not a number in (0, MAX_DT].
    """
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not 0 < dt <= L.MAX_DT:
        raise ArgumentError(f"the simulation time step (dt, --dt, sim_floatparam_simulation_time_step) must "
                            f"be > 0 and at most {L.MAX_DT:g} s (simx_server.base.limits.MAX_DT), got {quote(dt)}")
    return float(dt)


def substeps(dt: float, timestep: float) -> int:
    """Number of MuJoCo substeps of ``timestep`` s in a step of ``dt`` s (at least 1).

    Raises:
        ArgumentError: more than MAX_SUBSTEPS, or a timestep that is not > 0 and finite.

    Args:
        dt: the simulation step, s.
        timestep: MuJoCo's ``<option timestep>``, s.

    Returns:
        ``round(dt / timestep)``, at least 1.
    """
    if not (0 < timestep < math.inf):
        raise ArgumentError(f"the scene's <option timestep> must be > 0 and finite, got {quote(timestep)}")
    n = max(1, round(dt / timestep))
    if n > L.MAX_SUBSTEPS:
        raise ArgumentError(f"a step of {dt:g} s is {n} MuJoCo substeps of the scene's timestep {timestep:g} s; "
                            f"the most is {L.MAX_SUBSTEPS} (simx_server.base.limits.MAX_SUBSTEPS): use a smaller dt "
                            "or a larger <option timestep>")
    return n


def check_resolution(width: int, height: int, what: str) -> None:
    """ArgumentError unless both sides are in 1..MAX_RESOLUTION pixels.

    Args:
        width: pixels.
        height: pixels.
        what: what has the resolution, for the message.

    Raises:
        ArgumentError: a side out of bounds.
    """
    if not (0 < width <= L.MAX_RESOLUTION and 0 < height <= L.MAX_RESOLUTION):
        raise ArgumentError(f"{what}: resolution {width}x{height} is outside 1..{L.MAX_RESOLUTION} pixels a "
                            "side (simx_server.base.limits.MAX_RESOLUTION)")


def check_scene(model: mujoco.MjModel, dt: float) -> int:
    """Check a scene's per-step work before it is installed; returns the substeps of ``dt``.

    Raises:
        ArgumentError: too many substeps, or a camera (vision sensor) resolution out of bounds.

    Args:
        model: the compiled scene.
        dt: the simulation step, s.

    Returns:
        MuJoCo substeps per step.
    """
    n = substeps(dt, float(model.opt.timestep))
    for c in range(model.ncam):
        w, h = (int(x) for x in model.cam_resolution[c])
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_CAMERA, c) or f"#{c}"
        check_resolution(w, h, f"camera {quote(name)}")
    return n


def step_work(model: mujoco.MjModel, substeps: int) -> int:
    """The estimated work of one step: ``substeps x solver iterations x geoms``.

    Args:
        model: the compiled scene.
        substeps: MuJoCo substeps per step.

    Returns:
        The product (compared with limits.MAX_STEP_WORK).
    """
    return substeps * max(1, int(model.opt.iterations)) * max(1, int(model.ngeom))


def initial_contacts(model: mujoco.MjModel) -> int:
    """Contacts of the scene as compiled (its initial pose), by MuJoCo's collision detection
    alone on scratch data: no constraint is built and no solver runs, so 300 overlapping spheres
    (24,911 contacts, whose first step takes 30 s) cost about 10 ms. Contacts that overflow the
    arena count as one more than ``limits.MAX_SCENE_CONTACTS``.

    Args:
        model: the compiled scene.

    Returns:
        The number of contacts.
    """
    data = mujoco.MjData(model)  # the arena is allocated, not touched: RSS grows by what is used
    mujoco.mj_kinematics(model, data)
    try:
        mujoco.mj_collision(model, data)
    except mujoco.FatalError:  # the broad phase's pairs overflow the arena
        return L.MAX_SCENE_CONTACTS + 1
    full = data.warning[int(mujoco.mjtWarning.mjWARN_CONTACTFULL)].number
    return int(data.ncon) + (L.MAX_SCENE_CONTACTS + 1 if full else 0)


def check_cost(model: mujoco.MjModel, substeps: int, previous: mujoco.MjModel | None = None,
               previous_substeps: int = 1) -> None:
    """A client's scene or edit, compiled, before its MjData exists and before it replaces the
    current scene: its data arena (MuJoCo sizes it itself when the MJCF does not), the work of
    one step and its contacts as loaded, against MAX_ARENA_BYTES, MAX_STEP_WORK and
    MAX_SCENE_CONTACTS. With ``previous`` (an edit), a model over a bound passes when it is no
    worse than the one it replaces (an operator's big scene may still be edited).

    Raises:
        ArgumentError: naming the bound.

    Args:
        model: the compiled scene or edit.
        substeps: its MuJoCo substeps per step.
        previous: the model it replaces, for an edit; None for a scene load.
        previous_substeps: that model's substeps.
    """
    checks = ((lambda m, n: int(m.narena), L.MAX_ARENA_BYTES, "MAX_ARENA_BYTES", "bytes of MjData arena",
               f" (MuJoCo sizes it from the bodies when the MJCF does not: declare <size memory=\"{L.MAX_ARENA_BYTES >> 20}M\"/> "
               "or less)"),
              (step_work, L.MAX_STEP_WORK, "MAX_STEP_WORK", "substeps x solver iterations x geoms per step", ""),
              (lambda m, n: initial_contacts(m), L.MAX_SCENE_CONTACTS, "MAX_SCENE_CONTACTS", "contacts as loaded",
               " (bodies that overlap or touch where they start)"))
    for measure, bound, name, unit, hint in checks:
        value = measure(model, substeps)
        if value > bound and (previous is None or value > measure(previous, previous_substeps)):
            raise ArgumentError(f"the model needs {value:,} {unit}, more than {bound:,} "
                                f"(simx_server.base.limits.{name}){hint}")


class StepTimeError(PhysicsError):
    """A step of a client's scene took more than limits.MAX_STEP_SECONDS of the simulation thread."""


def timed_step(model: mujoco.MjModel, data: mujoco.MjData, substeps: int, seconds: float,
               one: Callable[[mujoco.MjModel, mujoco.MjData], None] = mujoco.mj_step,
               many: Callable[[mujoco.MjModel, mujoco.MjData, int, Callable[[], None]], None] | None = None) -> None:
    """``substeps`` MuJoCo steps, one at a time, stopping after the first that ends more than
    ``seconds`` after the start (a substep itself cannot be interrupted).

    Raises:
        StepTimeError: the step took too long (cut short, or its last substep ended late); its message gives the scene's contacts,
            constraint rows, solver iterations and substeps at that point.

    Args:
        model: the MuJoCo model.
        data: its data, stepped.
        substeps: MuJoCo steps to make.
        seconds: the time allowed, s (limits.MAX_STEP_SECONDS for a client's scene).
        one: makes one MuJoCo step (``mj_step``; :func:`simx_server.sim.surfaces.substep` while
            a surface moves).
        many: instead of ``one``, makes them all, calling its last argument after each
            (:func:`simx_server.sim.friction.steps`), which raises StepTimeError when late.
    """
    start = time.perf_counter()
    deadline = start + seconds
    done = 0

    def check() -> None:
        nonlocal done
        done += 1
        if time.perf_counter() > deadline:
            raise StepTimeError(
                f"a step of the client's scene took more than MAX_STEP_SECONDS = {seconds:g} s of the "
                f"simulation thread ({time.perf_counter() - start:.2f} s for {done} of its {substeps} substeps, "
                f"at t = {data.time:.3f} s: {data.ncon:,} contacts, {data.nefc:,} constraint rows, solver "
                f"iterations up to {int(model.opt.iterations)}); make the scene lighter (fewer touching bodies, "
                "a larger timestep, fewer iterations)")

    if many is not None:
        many(model, data, substeps, check)
        return
    for _ in range(substeps):
        one(model, data)
        check()


def check_gravity(values: Any) -> list[float]:
    """Gravity (3 floats, m/s²) whose magnitude is at most MAX_GRAVITY, else ArgumentError.

    Checks ``simxSetArrayParameter(sim_arrayparam_gravity)`` and ``sim.setArrayParam``.

    Args:
        values: 3 numbers, m/s².

    Returns:
        The 3 values as floats.

    Raises:
        ArgumentError: not 3 numbers, NaN, infinite, or too large.
    """
    if not isinstance(values, (list, tuple)) or len(values) != 3:
        raise ArgumentError(f"gravity must be a list of 3 numbers (m/s²), got {quote(values)}")
    g = [as_float(v, "gravity") for v in values]
    if not math.hypot(*g) <= L.MAX_GRAVITY:  # NaN and infinities fail too
        raise ArgumentError(f"gravity's magnitude must be finite and at most {L.MAX_GRAVITY:g} m/s² "
                            f"(simx_server.base.limits.MAX_GRAVITY), got {quote(values)}")
    return g


def mass_constants(m: mujoco.MjModel, d: mujoco.MjData) -> None:
    """Recompute what MuJoCo derives from masses and inertias at compile (``mj_setConst``: subtree
    masses, the bodies' and DOFs' inverse weights that scale every constraint), after a mass or an
    inertia was written at run time; the state (positions, velocities, activations, warm start,
    time), which ``mj_setConst`` clobbers, is kept.

    Args:
        m: the model (its derived constants are written).
        d: its data.
    """
    saved = (d.qpos.copy(), d.qvel.copy(), d.act.copy(), d.qacc_warmstart.copy(), d.time)
    mujoco.mj_setConst(m, d)
    d.qpos[:], d.qvel[:], d.act[:], d.qacc_warmstart[:], d.time = saved


def scaled_inertia(mass: float, old_mass: float, inertia: np.ndarray) -> np.ndarray:
    """The principal inertia (3,) in kg·m² of a body given ``mass`` (kg): its ``inertia`` at
    ``old_mass`` scaled by the ratio (same shape, new density, as V-REP keeps it).

    Raises:
        ArgumentError: ``mass`` outside [MIN_MASS, MAX_MASS], or an inertia above MAX_INERTIA.

    Args:
        mass: the new mass, kg.
        old_mass: the body's mass now, kg (0: the inertia is made from its largest axis).
        inertia: its principal inertia (3,), kg·m².

    Returns:
        Array (3,), kg·m².
    """
    if not L.MIN_MASS <= mass <= L.MAX_MASS:
        raise out_of_range("mass", mass, L.MIN_MASS, L.MAX_MASS, "kg", "MIN_MASS and MAX_MASS")
    if old_mass > 0:
        new = np.asarray(inertia, dtype=float) * (mass / old_mass)
    else:
        new = np.full(3, max(float(np.max(inertia)), 1e-9) * mass)
    if not float(np.max(new)) <= L.MAX_INERTIA:  # NaN fails too
        raise ArgumentError(f"a mass of {mass:g} kg makes the body's inertia {float(np.max(new)):g} kg·m², "
                            f"more than {L.MAX_INERTIA:g} (simx_server.base.limits.MAX_INERTIA)")
    return new


def check_position(position: list[float]) -> list[float]:
    """A position (3 floats, m) with every coordinate within ±MAX_POSITION, else ArgumentError.

    Args:
        position: 3 floats, m.

    Returns:
        ``position``.

    Raises:
        ArgumentError: a coordinate beyond ±limits.MAX_POSITION (NaN included).
    """
    for v in position:
        if not -L.MAX_POSITION <= v <= L.MAX_POSITION:
            raise out_of_range("each coordinate of a position", position, -L.MAX_POSITION, L.MAX_POSITION,
                               "m", "MAX_POSITION")
    return position


# --------------------------------------------------------------------- blow-ups
_TIME = re.compile(r"\s*Time = [-+0-9.eEinfa]+\.?\s*$")


class _WarningSink:
    """MuJoCo's warning handler: keeps the first messages of a batch for one log line.

    MuJoCo calls it from inside ``mj_step`` (and model compilation); the simulation thread
    reads the batch with :meth:`take`. Memory is bounded: a few messages and a count.
    """

    KEEP = 4

    def __init__(self) -> None:
        self.messages: list[str] = []
        self.count = 0
        self._reported: set[str] = set()  # texts already logged once (without their time)

    def __call__(self, message: str) -> None:
        self.count += 1
        if len(self.messages) < self.KEEP:
            self.messages.append(str(message).strip())

    def take(self) -> tuple[list[str], int]:
        """The messages kept and the number received since the last take; then empty."""
        messages, count = self.messages, self.count
        self.messages, self.count = [], 0
        return messages, count

    def report(self) -> None:
        """Log what arrived since the last take, once per kind of message (never a flood)."""
        messages, count = self.take()
        fresh = [m for m in messages if _TIME.sub("", m) not in self._reported]
        if not fresh or len(self._reported) >= 64:  # past 64 kinds, nothing more is logged
            return
        self._reported.update(_TIME.sub("", m) for m in fresh)
        more = f" (and {count - 1} more MuJoCo warnings; each kind is logged once)" if count > 1 else ""
        log.warning("MuJoCo: %s%s", quote(fresh[0], 200), more)


SINK = _WarningSink()


def install_warning_handler() -> None:
    """Route MuJoCo's warnings to :data:`SINK` (process-wide; idempotent). Without it MuJoCo
    prints each to stdout and appends it to ``MUJOCO_LOG.TXT`` in the working directory."""
    mujoco.set_mju_user_warning(SINK)


def bad_state_view(data: mujoco.MjData) -> np.ndarray:
    """A view of ``data``'s bad-state warning counters (nonzero after a blow-up).

    Args:
        data: MuJoCo data.

    Returns:
        A view (not a copy) of ``data.warning.number`` over BAD_STATE's warnings.
    """
    return data.warning.number[_BAD_FIRST:_BAD_LAST + 1]


def blow_up(model: mujoco.MjModel, data: mujoco.MjData, time: float) -> PhysicsError:
    """The PhysicsError for a step that started at ``time`` (s) and hit a bad state; clears
    the counters and MuJoCo's messages (the error replaces them).

    Args:
        model: the MuJoCo model.
        data: its data after the step.
        time: the simulation time at the step's start, s.

    Returns:
        The error (naming the quantity and the joint), to raise.
    """
    numbers, infos = data.warning.number, data.warning.lastinfo
    kind = next(k for k in BAD_STATE if numbers[k])
    dof = int(infos[kind])
    where = f"DOF {dof}"
    if 0 <= dof < model.nv:
        joint = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[dof]))
        where += f" (joint {joint!r})" if joint else ""
    _, count = SINK.take()
    for k in BAD_STATE:
        numbers[k] = 0
    return PhysicsError(f"the physics became unstable in the step from t = {time:.3f} s: MuJoCo found a NaN, "
                        f"infinite or huge {BAD_STATE[kind]} at {where} and reset the state "
                        f"({count} warning{'s' if count != 1 else ''} in that step)")
