"""Scripts' callbacks at the dynamics step: ``sysCall_jointCallback`` (a script's own
controller for its joint) and ``sysCall_dynCallback``, run at every MuJoCo substep as V-REP ran
them at every step of its physics engine.

* ``sysCall_jointCallback(inData)`` of a script attached to a joint with a motor is called before
  each substep with the joint's state: ``handle``, ``revolute``, ``cyclic``, ``lowLimit``,
  ``highLimit``, ``passCnt`` (1-based substep of this simulation step), ``totalPasses``,
  ``currentPos``, ``currentVel``, ``targetPos``, ``targetVel``, ``errorValue`` (target minus
  current position), ``effort`` (the force the motor applied last), ``dynStepSize`` (s),
  ``maxVel``, ``maxForce``, ``velUpperLimit``, ``first`` / ``last`` (first / last substep). It
  returns ``{force=f, velocity=v}`` (the motor drives the joint toward velocity ``v`` with at most
  ``|f|``, as CoppeliaSim applies it), or nil to leave the motor as it is. The values it sets
  stay the motor's (a client reads them back) until something sets others. A cyclic joint's
  ``currentPos`` is in [-pi, pi] and its ``errorValue`` the shortest way to the target
  (``CJoint::handleDynJoint``, simDyn's ``getAngleMinusAlpha``).
* A joint in CoppeliaSim 4.x's callback mode (``sim.jointdynctrl_callback``,
  :mod:`simx_server.sim.dyn_ctrl`) is driven at each substep by the first answer of: its own
  script's ``sysCall_jointCallback``, then ``sysCall_joint(inData)`` of the scripts of the joint
  and of its ancestors, nearest first (``CJoint::handleDynJoint``, ``CSceneObjectContainer::
  _callScripts`` with the joint as branch). ``inData`` has 4.x's keys too (``mode``, ``joint``,
  ``pos``, ``vel``, ``accel``, ``targetPos``, ``error``, ``dt``, ``force``: the signed target
  force). An answer ``{force=f}`` applies ``f``; ``{vel=v}`` (or ``velocity``) drives toward ``v``
  with at most 10000 N or N·m; both, toward ``v`` with at most ``|f|`` (``ctrl`` is a name of
  ``force``). No answer: no force. The motor's targets are left as they are.
* ``sysCall_dynCallback(inData)`` of any script is called before and after each substep with
  ``passCnt``, ``totalPasses``, ``dynStepSize`` and ``afterStep`` (false, then true).
* ``sysCall_contactCallback(inData)`` of any script decides, before each substep, how each pair
  of shapes that may touch is handled, as V-REP asked it in its physics engine's broad phase:
  ``inData`` is ``{handle1, handle2, engine}`` (the shapes' handles, -1 for the scene's static
  geometry; ``engine`` is ``sim.physics_mujoco``). The script returns nil or
  ``{ignoreContact=true}`` to leave the pair to the engine, or ``{ignoreContact=false,
  collisionResponse=b}``: the pair collides (``b`` true) or passes through (false) during that
  substep. The first script that does not ignore the pair decides. The pairs are MuJoCo's: geoms
  whose bounding boxes overlap and whose ``contype`` / ``conaffinity`` let them collide
  (:mod:`simx_server.sim.contact_filter`). Engine-specific tables (``bullet``, ``ode``,
  ``vortex``, ``newton``: friction, restitution...) have no MuJoCo counterpart: one log line per
  script, and MuJoCo's contact parameters stay.

An error in a callback is logged once (then at debug level) and the simulation goes on. Every
callback runs in the step's pass and counts toward the scene's scripts' time
(:mod:`simx_server.scripts.budget`): a script that passes the pass's end or the scripts' share is
named and its callbacks are skipped until the next start.
"""

from __future__ import annotations

import logging
import math
from contextlib import AbstractContextManager
from typing import Any, Callable

import mujoco
import numpy as np

from simx_server.sim import dyn_ctrl
from simx_server.sim.contact_filter import ContactFilter
from simx_server.sim.objects import JOINT, SHAPE, WORLD

log = logging.getLogger("simx.scripts")

JOINT_CALLBACK, DYN_CALLBACK = "sysCall_jointCallback", "sysCall_dynCallback"
#: CoppeliaSim 4.x's joint callback (joints in callback mode).
JOINT_4X = "sysCall_joint"
#: The force of a callback's velocity with no force, and the velocity of a force alone
#: (``CJoint::handleDynJoint``: "unlimited" force, a velocity the force never reaches).
CALLBACK_FORCE = 10000.0
#: CoppeliaSim's ``sim.jointmode_dynamic``: the ``mode`` a joint callback is told.
JOINTMODE_DYNAMIC = 5
CONTACT_CALLBACK = "sysCall_contactCallback"
#: CoppeliaSim's ``sim.physics_mujoco``: the engine a contact callback is told about.
PHYSICS_MUJOCO = 4
_ENGINE_TABLES = ("bullet", "ode", "vortex", "newton", "mujoco")


class DynamicsCallbacks:
    """The scene's scripts that have dynamics-step callbacks; installs the world's substep hook
    while any such script runs (:meth:`install` at start, :meth:`remove` at stop)."""

    def __init__(self, world: Any, step_pass: Callable[[], AbstractContextManager[Any]] | None = None):
        self.world = world
        self._step_pass = step_pass  # the scripts' pass of the current step (budget.ScriptBudget.pass_of)
        self.joints: list[tuple[Any, int]] = []  # (script, joint handle)
        self.joint_4x: dict[int, Any] = {}  # owner handle -> its script with sysCall_joint
        self.dyn: list[Any] = []
        self.contact: list[Any] = []
        self._filter: ContactFilter | None = None
        self._shape_of: tuple[Any, np.ndarray] | None = None  # (model, geom -> shape handle)
        self._told: set[str] = set()  # scripts told that engine tables are not applied
        self._pass = 0

    def install(self, scripts: list) -> None:
        self.remove()
        w = self.world
        for script in scripts:
            if not script.running or script.load_error:
                continue
            if script._defines(JOINT_CALLBACK):
                obj = w.get(script.owner)
                if obj.type == JOINT and script.owner in w.motor_index:
                    self.joints.append((script, script.owner))
                else:
                    log.error("%s: %s runs only in a script attached to a joint with a motor; %r is not",
                              script.label, JOINT_CALLBACK, obj.name)
            if script._defines(JOINT_4X):
                self.joint_4x[script.owner] = script
            if script._defines(DYN_CALLBACK):
                self.dyn.append(script)
            if script._defines(CONTACT_CALLBACK):
                self.contact.append(script)
        w.substep_hook = self._substep if (self.joints or self.joint_4x or self.dyn or self.contact) else None

    def remove(self) -> None:
        self.world.substep_hook = None
        self.joints, self.dyn, self.contact, self.joint_4x = [], [], [], {}
        if self._filter is not None:
            self._filter.close()
            self._filter = None
        self._shape_of = None

    def _substep(self, m: mujoco.MjModel, d: mujoco.MjData) -> None:
        """Before one MuJoCo substep (the world's hook), in the step's pass of the scripts."""
        if self._step_pass is None:
            self._callbacks(m, d)
            return
        with self._step_pass():
            self._callbacks(m, d)

    def _callbacks(self, m: mujoco.MjModel, d: mujoco.MjData) -> None:
        """The callbacks of one substep; the dyn callbacks' after-step call for the previous
        substep comes first."""
        w = self.world
        total = w.substeps
        self._pass = self._pass % total + 1
        step = float(m.opt.timestep)
        if self._pass > 1:
            self._dyn(self._pass - 1, total, step, True)
        self._dyn(self._pass, total, step, False)
        changed = False
        motors = w.motors
        answered: set[int] = set()  # callback-mode motors whose own jointCallback answered
        for script, handle in self.joints:
            i = w.motor_index[handle]
            if motors.force_mode[i]:  # CoppeliaSim's force mode calls no joint callback
                continue
            out = call_back(script, JOINT_CALLBACK, self._joint_data(m, d, handle, self._pass, total, step), True)
            if motors.callback_mode[i]:
                if isinstance(out, dict) and _callback_answer(motors, i, out):
                    answered.add(i)
                continue
            if isinstance(out, dict) and ("force" in out or "velocity" in out):
                if "velocity" in out:
                    motors.target_velocity[i] = float(out["velocity"])
                if "force" in out:
                    motors.max_force[i] = abs(float(out["force"]))
                motors.enabled[i], motors.loop[i] = True, False
                motors.scripted[i] = True  # the script's own law: no stall force (sim/motors.py)
                changed = True
        if motors.forcing and np.count_nonzero(motors.callback_mode):
            self._callback_mode(m, d, answered, total, step)
            changed = True
        if changed:
            w.motors.write_force_limits(m)
            w.motors.apply(m, d, w.dt)
        if self.contact:
            self._contacts(m, d)
        if self._pass == total:
            self._dyn(total, total, step, True)

    def _callback_mode(self, m: mujoco.MjModel, d: mujoco.MjData, answered: set[int], total: int,
                       step: float) -> None:
        """The motors in callback mode that their own ``sysCall_jointCallback`` did not drive: the
        first ``sysCall_joint`` answer of the scripts of the joint and its ancestors, nearest
        first; none: no force (``CJoint::handleDynJoint``'s defaults, 0 and 0)."""
        w, motors = self.world, self.world.motors
        handle_of = {i: h for h, i in motors.index.items()}
        for i in np.flatnonzero(motors.callback_mode):
            i = int(i)
            if i in answered:
                continue
            motors.callback_velocity[i] = motors.callback_force[i] = 0.0
            motors.callback_pure[i] = False
            if not self.joint_4x:
                continue
            handle = handle_of[i]
            data = None
            owner = handle
            while owner >= 0:
                script = self.joint_4x.get(owner)
                if script is not None:
                    data = data or self._joint_data(m, d, handle, self._pass, total, step)
                    out = call_back(script, JOINT_4X, data, True)
                    if isinstance(out, dict) and _callback_answer(motors, i, out):
                        break
                owner = w.get(owner).parent

    def _contacts(self, m: mujoco.MjModel, d: mujoco.MjData) -> None:
        """Ask the contact callbacks about each pair MuJoCo's broad phase lets through now, and
        drop the pairs they refuse in the coming substep (and the ``mj_forward`` after it)."""
        if self._filter is None or self._filter.data is not d:  # first substep, or new MjData
            if self._filter is not None:
                self._filter.close()
            self._filter = ContactFilter(d)
        if self._shape_of is None or self._shape_of[0] is not m:
            handles = np.full(m.nbody, WORLD, dtype=np.int64)
            for obj in self.world.objects.values():
                if obj.type == SHAPE:
                    handles[obj.mj_id] = obj.handle
            self._shape_of = (m, handles[m.geom_bodyid])
        shape_of = self._shape_of[1]
        discarded = set()
        for g1, g2 in sorted(self._filter.candidates(m)):
            data = {"handle1": int(shape_of[g1]), "handle2": int(shape_of[g2]), "engine": PHYSICS_MUJOCO}
            for script in self.contact:
                out = call_back(script, CONTACT_CALLBACK, data, True)
                if not isinstance(out, dict) or out.get("ignoreContact", False):
                    continue
                if script.label not in self._told and any(k in out for k in _ENGINE_TABLES):
                    self._told.add(script.label)
                    log.warning("%s: %s returned engine parameters (%s): MuJoCo's contact parameters stay",
                                script.label, CONTACT_CALLBACK, ", ".join(k for k in _ENGINE_TABLES if k in out))
                if not out.get("collisionResponse", True):
                    discarded.add((g1, g2))
                break
        self._filter.set_discarded(discarded)

    def _dyn(self, n: int, total: int, step: float, after: bool) -> None:
        for script in self.dyn:
            call_back(script, DYN_CALLBACK, {"passCnt": n, "totalPasses": total, "dynStepSize": step,
                                               "afterStep": after}, True)

    def _joint_data(self, m: mujoco.MjModel, d: mujoco.MjData, handle: int, n: int, total: int,
                    step: float) -> dict:
        w = self.world
        obj = w.get(handle)
        j = obj.mj_id
        i = w.motor_index[handle]
        motors = w.motors
        q, v = float(d.qpos[m.jnt_qposadr[j]]), float(d.qvel[m.jnt_dofadr[j]])
        revolute = int(m.jnt_type[j]) == mujoco.mjtJoint.mjJNT_HINGE
        limited = bool(m.jnt_limited[j])
        lo, hi = (float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1])) if limited else (-np.inf, np.inf)
        target = float(motors.target_position[i])
        error = target - q
        if revolute and not limited:  # a cyclic joint: in [-pi, pi], the shortest way round
            q, error = math.remainder(q, math.tau), math.remainder(error, math.tau)
        effort = float(d.actuator_force[motors.act[i]] * motors.gear[i])
        return {"handle": handle, "joint": handle, "mode": JOINTMODE_DYNAMIC, "revolute": revolute,
                "cyclic": revolute and not limited,
                "lowLimit": lo if limited else -1e30, "highLimit": hi if limited else 1e30,
                "passCnt": n, "totalPasses": total, "currentPos": q, "pos": q, "currentVel": v, "vel": v,
                "accel": float(d.qacc[m.jnt_dofadr[j]]), "targetPos": target,
                "targetVel": float(motors.target_velocity[i]), "errorValue": error, "error": error,
                "effort": effort, "dynStepSize": step, "dt": step,
                "maxVel": float(motors.max_velocity[i]), "velUpperLimit": float(motors.max_velocity[i]),
                "maxForce": float(motors.max_force[i]), "force": dyn_ctrl.target_force(motors, i),
                "first": n == 1, "last": n == total}


def _callback_answer(motors: Any, i: int, out: dict) -> bool:
    """Take a callback-mode joint callback's answer for motor ``i`` (``CJoint::handleDynJoint``):
    ``force`` (or ``ctrl``) alone, a force applied; ``vel`` (or ``velocity``) alone, that velocity
    with at most CALLBACK_FORCE; both, the velocity with at most ``|force|``.

    Args:
        motors: the world's Motors.
        i: a motor number.
        out: the callback's table.

    Returns:
        Whether it answered (a force or a velocity).
    """
    def number(*keys: str) -> float | None:
        value = next((out[k] for k in keys if isinstance(out.get(k), (int, float))), None)
        return float(value) if value is not None and math.isfinite(value) else None

    force, velocity = number("force", "ctrl"), number("vel", "velocity")
    if force is None and velocity is None:
        return False
    motors.callback_pure[i] = velocity is None
    motors.callback_force[i] = force if force is not None else CALLBACK_FORCE
    motors.callback_velocity[i] = velocity if velocity is not None else 0.0
    return True


def call_back(script: Any, function: str, data: dict, flat: bool = False) -> Any:
    """A system callback ``function(data)`` of ``script`` in the current pass, charged and bounded
    as every callback (:mod:`simx_server.scripts.budget`): its first result; None when it is
    skipped (the script cut, the pass's time spent) or fails (logged).

    Args:
        script: a :class:`~simx_server.scripts.child.ChildScript`.
        function: the callback's name.
        data: its ``inData``.
        flat: ``data`` is simx's own flat table (str keys, numbers and booleans): converted
            without the bound on a client's arguments (a joint callback's, at every substep).

    Returns:
        Its first result (Lua tables as lists or dicts, strings as bytes), or None.
    """
    if not script._may_run(function) or script._pass_spent(function):
        return None
    result: list = []
    script._guarded(function, lambda: result.extend(script._run_values(function, (data,), flat=flat)))
    return result[0] if result else None
