"""Joint motors as V-REP's, realised on whatever actuator an MJCF gives a joint.

V-REP (3.x) joints in force/torque mode have one motor with two stored targets, a target
position and a target velocity, whatever the mode; two flags decide which acts:

* ``sim_jointintparam_motor_enabled`` (2000) off: a free joint (no motor force);
* motor on, ``sim_jointintparam_ctrl_enabled`` (2001) on: position control toward the target
  position, no faster than the upper velocity (2017, ``simx:`` ``max_velocity``) and with at most
  the maximum force/torque (``simxSetJointForce``); the loop's proportional gain is V-REP's
  ``sim_jointfloatparam_pid_p`` (2002, ``simx:`` ``pid_p``, default 0.1: a velocity of P/5 ms
  per unit of error);
* motor on, loop off: velocity control at the target velocity with at most the maximum force
  (so ``simxSetJointForce`` + a large target velocity is torque control);
* motor and loop on in the spring-damper mode (``simx:`` ``mode=spring``): the velocity motor
  :mod:`simx_server.sim.joint_springs` gives.

The targets start at the joint's rest position and 0, or where the scene says (``simx:``
``target_position``, ``target_velocity``), and return there when the simulation stops.

A joint's motor is the first actuator whose transmission is that joint, whatever its type
(``<velocity>``, ``<position>``, ``<motor>`` with ``gear``, ``<general>``). At load
:func:`prepare` makes it an affine actuator without activation dynamics, control limits or
``ctrlrange`` clamping, and :meth:`Motors.apply` rewrites its gain and bias once per simulation
step so that the substeps run in C:

* velocity law: joint force ``tau = ff + kv * (v - qdot)``;
* position law: far from the target (more than vmax / Kp away) ``v = +-vmax`` for the whole
  step; near it the linear law ``tau = ff + kv * (Kp * (target - q) - qdot)``, which never asks
  more than vmax from there on;
* a velocity motor told to stop (target 0) is V-REP's velocity constraint bounded by the maximum
  force (:mod:`simx_server.sim.motor_hold`: its joint's friction loss, no actuator force), which
  holds the joint against any load up to that force and brakes it without reversing it; a locked
  one (below) keeps its servo at HOLD_KV_FACTOR times the usual gain beside its lock;
* ``ff`` is the joint's load at the start of the step (MuJoCo's ``qfrc_bias``: gravity and
  Coriolis forces, minus ``qfrc_passive``: the joint's spring, damper and gravity compensation),
  so a joint holds its target under gravity, and its velocity against its damping, as V-REP's
  constraint-based motors do; everything is clipped to the maximum force. A motor in position
  control also bears what the constraints put on its joint (``qfrc_constraint``: contacts, limits,
  equalities, a grasped part's weld): V-REP's position loop is a velocity constraint towards
  ``P e / 5 ms`` bounded by the maximum force (``CJoint::handleDynJointControl``, then the engine's
  motor), so a joint pushed by a contact stays at its target until the push exceeds that force,
  where a servo alone would yield by the push over its gain (an arm closed on a door handle gave
  way, and the handle slipped out of the fingers);
* "lock motor when target velocity is zero" (``sim_jointintparam_velocity_lock``, 2030, off by
  default; ``simx:`` ``velocity_lock=1``): a velocity motor told to stop holds the position where
  it stopped with no force limit (CoppeliaSim's ``CJoint::handleDynJoint``, ``_motorLock``):
  pinned by a joint equality (``simx_lock:<joint>``, :func:`~simx_server.sim.motor_spec.add_locks`)
  as Bullet 2.78 sets both limits there; one locked at run time without one, by the position law
  at gain 1/dt with force range limits.MAX_JOINT_FORCE;
* a joint in a kinematic mode (:attr:`Motors.joint_mode` 0 passive or 2 IK,
  :mod:`simx_server.sim.kinematic`) has no motor force: it is held where it is put.

``kv`` is the servo gain: a ``<velocity>`` actuator keeps its own ``kv`` (the author's choice);
any other gets ``f * M / h`` with ``M`` the joint's effective inertia now, with the scene's
equality constraints held (:mod:`simx_server.sim.mechanisms`: a motor that closes a linkage moves
all of it; without equalities ``M = 1 / (M^-1)_ii``; recomputed each step), ``h`` the model's
timestep and ``f`` IMPLICIT_KV_FRACTION, the velocity term being integrated implicitly: a model
using the Euler integrator is switched to ``implicitfast`` (which differs from Euler only in
treating actuators' and fluid forces' velocity terms implicitly too); under RK4 ``f`` is
KV_FRACTION, which keeps the explicit servo stable. The force limit (joint
units) comes from the actuator's ``forcerange`` (if ``forcelimited``) x |gear|, else from its
``ctrlrange`` x gain x |gear| when the control is a force (``<motor>``-like), else from the
joint's ``actuatorfrcrange``, else it is unlimited (limits.MAX_JOINT_FORCE).

A hinge or slide joint without an actuator gets one (``simx_motor:<joint>``) through ``MjSpec``
at load, disabled: physics are unchanged until a program enables it. A joint moved only through
a tendon that an actuator drives gets none, and motor calls answer an error naming the tendon.
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

from simx_server.base import limits as L
from simx_server.sim import dyn_ctrl, mechanisms
from simx_server.sim.joint_springs import Springs
from simx_server.sim.motor_hold import Holds
from simx_server.sim.motor_stall import Stalls
from simx_server.sim.motor_views import Views, select as _select, slice_or
from simx_server.sim.motor_spec import (joint_setting, lock_name, max_force, own_kv, ADDED_PREFIX, JOINT_TRNS,
                                        SCALAR, tendon_driven)

log = logging.getLogger("simx.world")

#: V-REP's default proportional gain of the joint position loop (sim_jointfloatparam_pid_p).
DEFAULT_PID_P = 0.1
#: V-REP's default dynamics step (s): its position loop asks a velocity of P * error / step.
VREP_DYN_STEP = 0.005
#: Servo gain as a fraction of M/h (effective inertia over timestep) under the RK4 integrator,
#: where the servo is explicit: below 2 for stability, 0.5 leaves margin for coupled joints.
KV_FRACTION = 0.5
#: The same under the implicit integrators, which integrate the servo's velocity term
#: implicitly and coupled through the mass matrix (stable at any gain): stiff tracking.
IMPLICIT_KV_FRACTION = 0.9
#: Servo gain of a locked velocity-mode motor told to stop (target 0), as a multiple of the usual
#: one, under the implicit integrators, beside its lock (the others are held by motor_hold).
HOLD_KV_FACTOR = 300.0
#: CoppeliaSim's ``sim_jointmode_force`` (4.3+: ``sim.jointmode_dynamic``): a joint driven by physics.
JOINTMODE_FORCE = 5

def _name(m: mujoco.MjModel, joint: int) -> str:
    return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, joint) or f"#{joint}"


class Motors:
    """The motors of a model's joints: per-motor arrays, indexed by motor number.

    Args:
        model: the compiled model (its motor actuators are rewritten in place: affine gain and
            bias, no activation dynamics, no control clamping, force limited).
        joints: ``(handle, joint id, settings)`` of each registered joint, in handle order.
    """

    def __init__(self, model: mujoco.MjModel, joints: list[tuple[int, int, dict[str, str]]]):
        m = model
        motor_of_joint: dict[int, int] = {}
        for a in range(m.nu):
            if m.actuator_trntype[a] in JOINT_TRNS:
                motor_of_joint.setdefault(int(m.actuator_trnid[a, 0]), a)
        self.tendon_of_joint = tendon_driven(m)  # joint id -> tendon name (no motor of their own)
        mine = [(h, j, s) for h, j, s in joints if j in motor_of_joint and int(m.jnt_type[j]) in SCALAR]
        self.index = {h: i for i, (h, _, _) in enumerate(mine)}
        act = np.array([motor_of_joint[j] for _, j, _ in mine], dtype=int)
        self.act = act
        self.qadr = np.array([m.jnt_qposadr[j] for _, j, _ in mine], dtype=int)
        self.dadr = np.array([m.jnt_dofadr[j] for _, j, _ in mine], dtype=int)
        self.jnt, self._hinge = dyn_ctrl.joints(m, [j for _, j, _ in mine])  # joint ids, hinges
        self.gear = np.array([float(m.actuator_gear[a, 0]) or 1.0 for a in act])
        self.own_kv = np.array([own_kv(m, a) for a in act])
        self.initial_max_force = np.array([max_force(m, a, j) for a, (_, j, _) in zip(act, mine)])
        added = [(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or "").startswith(ADDED_PREFIX) for a in act]
        modes = [s.get("mode", "passive" if new else "position") for (_, _, s), new in zip(mine, added)]
        self.initial_enabled = np.array([mode != "passive" for mode in modes], dtype=bool)
        self.initial_loop = np.array([mode not in ("velocity", "force") for mode in modes], dtype=bool)
        self.initial_force_mode, self.initial_callback_mode = (np.array(modes) == "force", np.array(modes) == "callback")
        # None: no spring-damper; every motor's K and C
        self.springs, self._spring_parameters = Springs.read([(s, _name(m, j)) for _, j, s in mine], joint_setting)
        self.initial_max_velocity = np.array([joint_setting(s, "max_velocity", np.pi, _name(m, j)) for _, j, s in mine])
        self.initial_pid_p = np.array([joint_setting(s, "pid_p", DEFAULT_PID_P, _name(m, j)) for _, j, s in mine])
        # targets the scene starts with (V-REP saves them with the joint): NaN = the joint's rest
        self.initial_target_position = np.array([joint_setting(s, "target_position", np.nan, _name(m, j), signed=True)
                                                 for _, j, s in mine])
        self.initial_target_velocity = np.array([joint_setting(s, "target_velocity", 0.0, _name(m, j), signed=True)
                                                 for _, j, s in mine])
        # "lock motor when target velocity is zero" as the scene saved it (simx: velocity_lock=1)
        self.initial_locked = np.array([joint_setting(s, "velocity_lock", 0.0, _name(m, j)) != 0 for _, j, s in mine],
                                       dtype=bool)
        self.names = {h: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for (h, _, _), a in zip(mine, act)}
        # each motor's lock (motor_spec.add_locks: a joint equality, -1 where the joint has none)
        self.lock_eq = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, lock_name(_name(m, j)))
                                 for _, j, _ in mine], dtype=int)
        self._pinned = self.lock_eq >= 0
        self._lock_eqs = self.lock_eq[self._pinned]
        self._lock_rows = slice_or(self._lock_eqs)  # a slice where they are consecutive (faster writes)
        for a in act:  # one actuator realises both laws; ctrl is a velocity or a position
            m.actuator_gaintype[a] = mujoco.mjtGain.mjGAIN_FIXED
            m.actuator_biastype[a] = mujoco.mjtBias.mjBIAS_AFFINE
            if m.actuator_dyntype[a] != mujoco.mjtDyn.mjDYN_NONE:  # activation follows ctrl at once
                m.actuator_dyntype[a] = mujoco.mjtDyn.mjDYN_FILTEREXACT
                m.actuator_dynprm[a, :] = 0.0
                m.actuator_dynprm[a, 0] = m.opt.timestep
                m.actuator_actlimited[a] = 0
            m.actuator_ctrllimited[a] = 0
            m.actuator_forcelimited[a] = 1
            m.actuator_gainprm[a, :] = 0.0
            m.actuator_biasprm[a, :] = 0.0
        self.kv_fraction = KV_FRACTION
        if len(act) and m.opt.integrator != mujoco.mjtIntegrator.mjINT_RK4:
            # Euler treats joint damping implicitly, implicitfast also actuators' velocity terms:
            # the same physics for passive joints, and a servo stable at any gain.
            if m.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER:
                m.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
            self.kv_fraction = IMPLICIT_KV_FRACTION
        if any(added) or self.tendon_of_joint:
            new = [(self.names[h][len(ADDED_PREFIX):], on)
                   for (h, _, _), is_new, on in zip(mine, added, self.initial_enabled) if is_new]
            passive = [name for name, on in new if not on]
            enabled = [name for name, on in new if on]  # by a simx: mode (a URDF's joints: position)
            tendons = sorted(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) or f"#{j}"
                             for j in self.tendon_of_joint)
            log.debug("joint motors: %d from the scene's actuators; added, disabled: %s;%s joints moved only through "
                     "tendons (no motor of their own): %s", len(act) - len(new), ", ".join(passive) or "none",
                     f" added, enabled by simx: texts: {', '.join(enabled)};" if enabled else "",
                     ", ".join(tendons) or "none")
        n = len(act)
        # per model, for apply(): the gears squared, which motors keep their own kv, and a slice
        # for the actuators when they are consecutive
        self._gear2 = self.gear ** 2
        self._own_kv_set, self._no_own_kv = self.own_kv > 0, self.own_kv == 0
        self._any_own_kv = bool(self._own_kv_set.any())
        self._unit_gear = bool((self.gear == 1.0).all())  # apply() divides by no gear
        self._act_index = slice_or(act)
        self.stalls = Stalls(n)  # velocity motors held back (sim/motor_stall.py)
        self._none, self._zeros = np.zeros(n, dtype=bool), np.zeros(n)  # no motor (spring, hold masks); 0.0s
        self._rows = np.arange(n)
        self._unit = np.zeros((n, m.nv))
        self._unit[np.arange(n), self.dadr] = 1.0
        self._minv = np.zeros((n, m.nv))
        self._diagonal = self._rows * m.nv + self.dadr  # (M^-1)_ii's places in _minv, flat
        self._views: Views | None = None
        #: dyn_ctrl.position_error's cyclic joints: (the model's jnt_limited as bytes, mask, any).
        self.cyclic_kept: tuple[bytes | None, np.ndarray, bool] = (None, self._none, False)
        self._gain_kept: tuple[tuple | None, np.ndarray] = (None, np.zeros(0))  # _gain's
        self._modes_kept: tuple[bytes | None, tuple] = (None, ())  # _modes'
        self.holds = Holds(m, self.dadr)  # stopped velocity motors (motor_hold)
        self._limits_key: bytes | None = None  # what _lock last wrote into the force ranges (None: unknown)
        self._law_locked = True  # some motor locked by the position law (_lock, with _limits_key)
        self.reset(m, None)

    @property
    def stalled(self) -> bool:
        """Some motor is held back, or a spring acts (:mod:`simx_server.sim.motor_stall`): the world
        applies the motors at every substep."""
        return self.stalls.stalled

    def __len__(self) -> int:
        return len(self.act)

    def reset(self, m: mujoco.MjModel, qpos: np.ndarray | None) -> None:
        """Initial state (``simxStopSimulation``): flags and limits of the scene, targets at rest.

        Args:
            m: the MuJoCo model (its actuators' force ranges are written).
            qpos: the initial joint positions (nq,), the rest the targets start at; None: 0.
        """
        self.enabled = self.initial_enabled.copy()
        self.loop = self.initial_loop.copy()  # control loop on = position control
        self.max_velocity = self.initial_max_velocity.copy()
        self.max_force = self.initial_max_force.copy()
        self.pid_p = self.initial_pid_p.copy()
        rest = np.zeros(len(self.act)) if qpos is None else qpos[self.qadr]
        self.target_position = np.where(np.isnan(self.initial_target_position), rest, self.initial_target_position)
        self.target_velocity = self.initial_target_velocity.copy()
        dyn_ctrl.reset(self)  # the target force's sign, force and callback modes, the callbacks' answers
        #: CoppeliaSim's joint mode per motor (JOINTMODE_FORCE, or a kinematic mode: 0 or 2).
        self.joint_mode = np.full(len(self.act), JOINTMODE_FORCE, dtype=int)
        #: ``sim_jointintparam_velocity_lock`` per motor; where each locked motor stopped (NaN: not now).
        self.locked = self.initial_locked.copy()
        self._lock_q = np.full(len(self.act), np.nan)
        self._lock_kept: tuple | None = None  # _lock's, for the motors locked last
        self.refresh_flags()
        self.stalls.reset(len(self.act))
        self._inertia_at: tuple[float, np.ndarray] = (0.0, np.zeros(0))  # (time, inertia) of this step
        #: Motors a script's joint callback drives (scripts/dynamics.py): its own law, no stall force.
        self.scripted = np.zeros(len(self.act), dtype=bool)
        if self.springs is not None:
            self.springs.reset()
        self.holds.write(m, self._none, self.max_force)
        self.write_force_limits(m)

    def refresh_flags(self) -> None:
        """Note whether any motor is kinematic, locked or forcing (read at every step: plain attributes)."""
        #: Some joint is in a kinematic mode (:mod:`simx_server.sim.kinematic`).
        self.kinematic = bool((self.joint_mode != JOINTMODE_FORCE).any())
        self._locking = bool(self.locked.any()) or not bool(np.isnan(self._lock_q).all())
        #: Some motor is in CoppeliaSim 4.x's force or callback mode (read at every step).
        self.forcing = bool(self.force_mode.any() or self.callback_mode.any())

    def set_joint_mode(self, i: int, mode: int) -> None:
        """Motor ``i``'s joint in CoppeliaSim's mode ``mode`` (JOINTMODE_FORCE, 0 or 2).

        Args:
            i: a motor number.
            mode: the mode.
        """
        self.joint_mode[i] = mode
        self.refresh_flags()

    def set_locked(self, i: int, locked: bool) -> None:
        """``sim_jointintparam_velocity_lock`` of motor ``i``.

        Args:
            i: a motor number.
            locked: lock a stopped velocity motor where it stopped.
        """
        self.locked[i] = locked
        self.refresh_flags()

    def write_force_limits(self, m: mujoco.MjModel) -> None:
        """Maximum forces (joint units) into the actuators' forcerange (actuator units).

        Args:
            m: the MuJoCo model written to.
        """
        self._limits_key = None  # _lock writes its own again
        if len(self.act):
            f = self.max_force / np.abs(self.gear)
            m.actuator_forcerange[self.act, 0] = -f
            m.actuator_forcerange[self.act, 1] = f

    def apply(self, m: mujoco.MjModel, d: mujoco.MjData, dt: float) -> None:
        """Write gains, biases and controls of every motor for the next step of ``dt`` s.

        V-REP's joint modes on MuJoCo actuators: motor off (no force), velocity control (target
        velocity, m/s or rad/s), or position control (a proportional loop towards the target
        position, at most the upper velocity), each bounded by the maximum force (N or N·m).

        Args:
            m: the MuJoCo model (gains and biases of the motors' actuators are written).
            d: its data (``ctrl`` is written).
            dt: the simulation step, s.
        """
        if not len(self.act):
            return
        views = self._views
        if views is None or views.model is not m or views.data is not d:
            views = self._views = Views(m, d, self._lock_eqs, self.qadr, self.dadr)
            self._limits_key = self._lock_kept = None
            self.cyclic_kept = (None, self._none, False)  # dyn_ctrl.position_error's, per model
            self.holds.forget()
        act, g, g2 = self._act_index, self.gear, self._gear2
        q = views.qpos[views.qadr]
        timestep = m.opt.timestep
        inertia = self._inertia(views, dt, timestep)
        kv = self.kv_fraction * inertia / timestep
        if self._any_own_kv:
            kv = np.where(self._own_kv_set, self.own_kv, kv)
        dof = views.dadr
        ff = views.qfrc_bias[dof] - views.qfrc_passive[dof]  # static load, joint springs and dampers
        kp = self._gain(dt)
        goal, err = dyn_ctrl.position_error(self, views.jnt_limited, q)  # cyclic joints: the shortest way
        kept_on, kept_position, velocity_mode, off_loop, positioned, loaded, unlocked, locking, all_on = self._modes()
        on, position = kept_on, kept_position
        forced = scripted = self._none
        if self.forcing:  # CoppeliaSim 4.x's force and callback modes (dyn_ctrl.py)
            on, forced, scripted = dyn_ctrl.split(self, on)
            position, velocity_mode, off_loop = position & on & ~scripted, velocity_mode & on, off_loop & on
            positioned = bool(position.any())
        springs = self.springs
        if springs is not None:  # spring-damper motors are velocity motors (joint_springs.py)
            spring, spring_v = springs.law(err, float(d.time), self.loop, self.target_velocity, self.max_force)
            position = position & ~spring
            velocity_mode = velocity_mode | (on & spring & self._no_own_kv & ~self.scripted)
            positioned = True
        if positioned:
            linear = position & (np.abs(err) * kp <= self.max_velocity)
            v = _select(position, np.sign(err) * self.max_velocity, self.target_velocity)
        else:  # no motor in position control: every law a velocity
            linear, v = self._none, self.target_velocity
        if springs is not None:
            v = np.where(spring, spring_v, v)
        if scripted is not self._none:
            v = np.where(scripted, self.callback_velocity, v)
        held_back = self.stalls.force(q, views.qvel[dof], v, velocity_mode, float(d.time), self.max_force)
        if held_back is not self.stalls.no_force:  # (adding zeros changes nothing)
            ff = ff + held_back
        if positioned:  # position control bears its joint's constraint load
            if position is not kept_position:  # forcing or springs changed the position motors
                loaded = position & ~self.scripted
            if np.count_nonzero(loaded):
                np.subtract(ff, views.qfrc_constraint[dof], out=ff, where=loaded)  # ff is this step's own
        if springs is not None:  # a spring's force follows it at every substep
            self.stalls.stalled = self.stalls.stalled or bool((spring & on).any())
            stopped = velocity_mode & (v == 0) & ~spring  # told to stop (a spring: its force)
        else:
            stopped = velocity_mode & (v == 0)
        hold = stopped & unlocked if self.holds.usable else self._none
        self.holds.write(m, hold, self.max_force)
        if self.kv_fraction == IMPLICIT_KV_FRACTION:  # locked (or no friction rows): a stiff servo
            np.multiply(kv, HOLD_KV_FACTOR, out=kv, where=stopped & ~hold)  # kv is this step's own
        if np.count_nonzero(hold):  # held by its joint's friction row, no actuator force
            on = on & ~hold
            off_loop = off_loop & ~hold
        target = goal
        if self._locking:
            target, kp, linear = self._lock(views, q, off_loop & (v == 0), dt, kp, linear, goal, locking)
        # tau = g * F, F = gain * ctrl + b0 + b1 * (g q) + b2 * (g qdot); a gear of 1 (the usual
        # case) divides nothing: x / 1.0 is x
        kv_kp = kv * kp
        gain, bias, damping, linear_kv = _select(linear, kv_kp, kv), ff, -kv, -kv_kp
        if not self._unit_gear:
            gain, bias, damping, linear_kv = gain / g, ff / g, damping / g2, linear_kv / g2
        gains, biases = views.gainprm, views.biasprm
        if on is kept_on and all_on or on is not kept_on and np.count_nonzero(on) == len(on):  # every motor on
            gains[act, 0] = gain
            biases[act, 0] = bias
            biases[act, 2] = damping
            moving = v
        else:
            gains[act, 0] = np.where(on, gain, 0.0)
            biases[act, 0] = np.where(on, bias, 0.0)
            biases[act, 2] = np.where(on, damping, 0.0)
            moving = np.where(on, v, 0.0)
        biases[act, 1] = _select(linear, linear_kv, self._zeros)
        views.ctrl[act] = _select(linear, target, moving)
        if springs is not None:  # after _lock, which writes every motor's force range
            springs.write_limits(m, self.act, g, self.max_force)
        if self.forcing:
            dyn_ctrl.apply_forced(self, views, forced, scripted)

    def _gain(self, dt: float) -> np.ndarray:
        """The position loops' gain (n,) 1/s: V-REP's ``P / 5 ms``, at most ``1 / dt`` (no overshoot
        in a step); kept while the gains and the step are the same."""
        key = (self.pid_p.tobytes(), dt)
        if self._gain_kept[0] != key:
            self._gain_kept = (key, np.minimum(self.pid_p / VREP_DYN_STEP, 1.0 / dt))
        return self._gain_kept[1]

    def _modes(self) -> tuple:
        """``(on, position, velocity, loop off, any position, loaded, unlocked, any locked, all on)``:
        the motors that act (enabled, their joint not kinematic), those in position control (loop
        on), those in V-REP's velocity law (loop off, not a ``<velocity>`` actuator's own gain, not
        driven by a script's joint callback), those on with their loop off; whether any is in
        position control; those in it that bear their joint's constraint load (no script drives
        them); those not locked; whether any is locked; whether all are on ((n,) bool arrays, bools).
        Spring-damper motors are told apart per step (:meth:`apply`). Kept while the flags are the
        same (byte copies instead of a dozen array operations); never written in place."""
        key = (self.enabled.tobytes() + self.loop.tobytes() + self.scripted.tobytes() + self.locked.tobytes()
               + (self.joint_mode.tobytes() if self.kinematic else b""))
        kept = self._modes_kept
        if kept[0] != key:
            on = self.enabled if not self.kinematic else self.enabled & (self.joint_mode == JOINTMODE_FORCE)
            on = on.copy()  # not the flags themselves, which calls write in place
            loop = self.loop
            position = on & loop
            velocity = on & ~loop & self._no_own_kv & ~self.scripted
            kept = self._modes_kept = (key, (on, position, velocity, on & ~loop, bool(position.any()),
                                             position & ~self.scripted, ~self.locked, bool(self.locked.any()),
                                             bool(on.all())))
        return kept[1]

    def _lock(self, views: Views, q: np.ndarray, stopped: np.ndarray, dt: float, kp: np.ndarray,
              linear: np.ndarray, goal: np.ndarray, locking: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The locked motors (velocity lock on, velocity mode, target 0) hold where they stopped (or
        were put, :meth:`teleported`) with no force limit (``CJoint::handleDynJoint``: "motor locked"):
        pinned by their lock equality (:func:`~simx_server.sim.motor_spec.add_locks`; ``eq_active``,
        ``eq_data``) as Bullet 2.78's equal limits pin them; one locked at run time without one by the
        position law at gain 1/dt (force range written into the model). ``q`` (n,) positions, ``stopped``
        (n,) velocity motors with target 0, ``kp``, ``linear`` and ``goal`` (the position law's targets)
        as :meth:`apply` has them. Returns ``(target, kp, linear)`` with the law-locked motors' entries
        changed. While the same motors stay locked (and none was put elsewhere), where they stopped
        and what their equalities hold are those of the last call: kept, and only written again.
        ``locking``: some motor is locked (:meth:`_modes`)."""
        lock = self.locked & stopped
        self._locking = locking  # lock is a part of locked
        key, kept = lock.tobytes(), self._lock_kept
        if kept is None or kept[0] != key:  # else lock_q would come out as it is (stopped where it was)
            self._lock_q = lock_q = np.where(lock, np.where(np.isnan(self._lock_q), q, self._lock_q), np.nan)
            on = lock[self._pinned]  # MuJoCo's joint equality with one joint: q - qpos0 = eq_data[0]
            values = (lock_q - views.qpos0[self.qadr])[self._pinned][on]
            law = lock & ~self._pinned
            kept = self._lock_kept = (key, on, slice_or(self._lock_eqs[on]), values, law, law.tobytes())
        _, on, rows, values, law, law_key = kept
        if len(self._lock_eqs):
            views.eq_active[self._lock_rows] = on
            views.eq_data[rows, 0] = values
        limits = law_key + self.max_force.tobytes()
        if limits != self._limits_key:  # written once per change: write_force_limits forgets the key
            force = np.where(law, float(L.MAX_JOINT_FORCE), self.max_force) / np.abs(self.gear)
            views.forcerange[self.act, 0], views.forcerange[self.act, 1] = -force, force
            self._limits_key, self._law_locked = limits, bool(law.any())
        if not self._law_locked:  # every lock an equality's: the laws as apply() has them
            return goal, kp, linear
        return (np.where(law, self._lock_q, goal), np.where(law, 1.0 / dt, kp), linear | law)

    def _inertia(self, views: Views, dt: float, timestep: float) -> np.ndarray:
        """The joints' effective inertia (n,) kg or kg·m² (:func:`mechanisms.effective_inertia`),
        computed once per step of ``dt`` s (model ``timestep`` s): scripts' joint callbacks apply
        the motors at every substep, and the configuration changes little within a step."""
        at, cached = self._inertia_at
        now = float(views.data.time)
        if len(cached) == len(self.act) and 0 <= now - at < dt - 0.5 * timestep:
            return cached
        inertia = mechanisms.effective_inertia(views.model, views.data, self._minv, self._unit, self._diagonal,
                                               self.dadr, self._lock_eqs, views.others, views.eq_active)
        self._inertia_at = (now, inertia)
        return inertia

    def teleported(self, i: int, position: float) -> None:
        """Motor ``i``'s joint was put at ``position`` (rad or m): a lock holds it there from now on,
        as CoppeliaSim's engine locks the joint it re-creates where it was put (PyRep's
        ``set_joint_positions``, ``sim.setConfigurationTree``: RLBench's reset reopens its gripper).

        Args:
            i: the motor's index.
            position: rad or m.
        """
        if not np.isnan(self._lock_q[i]):
            self._lock_q[i] = position
            self._lock_kept = None

    def copy_state(self, src: int, dst: int) -> None:
        """Motor ``dst`` takes the flags, targets and limits of motor ``src`` (model copies).

        Args:
            src: index of a motor.
            dst: index of another motor.
        """
        for name in self._STATE:
            arr = getattr(self, name)
            arr[dst] = arr[src]
        self.refresh_flags()

    def state(self, i: int) -> tuple:
        """Everything a program set on motor ``i`` (kept across scene edits).

        Args:
            i: the motor's index.

        Returns:
            Its values, in ``_STATE``'s order (for :meth:`restore`).
        """
        return tuple(getattr(self, n)[i] for n in self._STATE)

    def restore(self, i: int, state: tuple) -> None:
        """Give motor ``i`` what :meth:`state` returned (after a scene edit).

        Args:
            i: the motor's index in the new model.
            state: what :meth:`state` returned.
        """
        for n, value in zip(self._STATE, state):
            getattr(self, n)[i] = value
        self.refresh_flags()

    _STATE = ("enabled", "loop", "max_velocity", "max_force", "pid_p", "target_position", "target_velocity",
              "joint_mode", "locked", "force_sign", "force_mode", "callback_mode")
