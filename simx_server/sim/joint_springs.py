"""CoppeliaSim's spring-damper joint mode as the velocity motor it is.

A joint in force/torque mode with its motor and control loop on and "spring-damper" chosen (the
``.ttt``'s control mode 12, or ``Va9`` bit 7 before 4.4) is not a free spring in CoppeliaSim:
``CJoint::handleDynJointControl`` (coppeliaSimLib 4.1) computes the control value
``ctrl = K e + C de/dt`` (``e`` the target position minus the position, N or N·m) and hands the
engine a *velocity* motor of target velocity ``sign(ctrl) * |target velocity|`` whose force is at
most ``min(|ctrl|, maximum force)``. Where the joint's target velocity is far above the speeds it
reaches, that is a spring-damper (the converter then gives the MuJoCo joint its own stiffness and
damping, which MuJoCo integrates at every substep). Where it is not, the target velocity binds:
with a target velocity of 0 (RLBench's door handles) the motor is a brake that holds the joint
against up to ``|K e|`` and never pushes it back, so a handle that gravity pulls down sinks until
``K e`` holds it and stays there; a free spring would swing about that point without end.

The converter marks such joints ``mode=spring`` with ``spring_k`` and ``spring_c`` (their ``simx:``
settings); :class:`~simx_server.sim.motors.Motors` drives them with its velocity law at the
velocity and force limit :meth:`Springs.law` gives, recomputed at every substep (as CoppeliaSim's
control runs at every dynamics pass: the spring's force follows its joint). A program puts a joint
in the mode at run time with ``sim.jointintparam_dynctrlmode`` (:mod:`simx_server.sim.dyn_ctrl`) and
sets K and C with ``sim.jointfloatparam_kc_k`` / ``_kc_c`` (CoppeliaSim's defaults: 0.1 and 0,
``CJoint::_commonInit``); a stop gives every joint the mode, K and C it started with.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

#: CoppeliaSim's spring constant K and damping C of a new joint (``CJoint::_commonInit``: ``_dynCtrl_kc``).
DEFAULT_K, DEFAULT_C = 0.1, 0.0


class Springs:
    """The spring-damper settings of a model's motors (per motor, indexed as the motors).

    Args:
        mask: (n,) which motors are in spring-damper mode.
        k: (n,) the spring constants K (N/m or N·m/rad; 0 where not in the mode).
        c: (n,) the damping coefficients C (N·s/m or N·m·s/rad).
    """

    def __init__(self, mask: np.ndarray, k: np.ndarray, c: np.ndarray) -> None:
        self.initial = (np.array(mask, bool), np.array(k, float), np.array(c, float))
        self.reset()

    @classmethod
    def read(cls, settings: list[tuple[dict[str, str], str]], number: Callable[..., float]
             ) -> tuple[Springs | None, tuple[np.ndarray, np.ndarray]]:
        """The spring-damper motors among a model's motors, from their ``simx:`` settings
        (``mode=spring``, ``spring_k``, ``spring_c``), None where none is in that mode; and every
        motor's K and C (:meth:`parameters`).

        Args:
            settings: per motor, its joint's settings and the joint's name.
            number: reads a setting as a non-negative number, ``number(settings, key, default,
                joint)`` (:func:`simx_server.sim.motor_spec.joint_setting`: raises ValueError naming the
                joint and the setting for a bad value).

        Returns:
            ``(springs or None, (k, c))``.
        """
        mask = np.array([s.get("mode") == "spring" for s, _ in settings], dtype=bool)
        k, c = cls.parameters(settings, number)
        return (cls(mask, k, c) if mask.any() else None), (k, c)

    @staticmethod
    def parameters(settings: list[tuple[dict[str, str], str]], number: Callable[..., float]
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Every motor's K and C from its ``simx:`` settings (``spring_k``, ``spring_c``),
        CoppeliaSim's defaults (DEFAULT_K, DEFAULT_C) where absent.

        Args:
            settings: as :meth:`read` takes them.
            number: as :meth:`read` takes it.

        Returns:
            ``(k, c)``, each (n,).
        """
        k, c = (np.array([number(s, key, default, name) for s, name in settings], dtype=float)
                for key, default in (("spring_k", DEFAULT_K), ("spring_c", DEFAULT_C)))
        return k, c

    def reset(self) -> None:
        """The mode, K and C every motor started with, and no last error (``simxStopSimulation``):
        the next law has no damping term, as CoppeliaSim's first control pass after a start
        (``init``) has none."""
        self.mask, self.k, self.c = (a.copy() for a in self.initial)
        self._last_error = np.full(len(self.mask), np.nan)
        self._last_time = np.nan
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        self._active = np.zeros(len(self.mask), bool)

    def law(self, error: np.ndarray, now: float, loop: np.ndarray, target_velocity: np.ndarray,
            max_force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The velocity motor of the spring-damper motors for the next step
        (``CJoint::handleDynJointControl``, spring branch).

        Args:
            error: (n,) target position minus position (rad or m).
            now: the simulation time (s); the damping term uses the error's change since the
                last call at an earlier time.
            loop: (n,) the motors' control loop flags: the mode acts only where it is on
                (CoppeliaSim's spring-damper is a kind of position control).
            target_velocity: (n,) the joints' target velocities (rad/s or m/s): only their
                magnitude counts.
            max_force: (n,) the joints' maximum forces (N or N·m).

        Returns:
            ``(active, velocity)``: (n,) the motors the mode drives now and their target
            velocities; their force limits (the spring-damper's force, at most the maximum
            force) go into the model at :meth:`write_limits`.
        """
        self._active = self.mask & loop
        elapsed = now - self._last_time
        if elapsed == 0 and self._last is not None:  # applied again at the same instant
            return self._active, self._last[0]
        ctrl = self.k * error
        if elapsed > 0:
            ctrl = ctrl + np.where(np.isnan(self._last_error), 0.0, self.c * (error - self._last_error) / elapsed)
        self._last_error, self._last_time = np.where(self.mask, error, np.nan), now
        velocity = np.where(ctrl < 0, -np.abs(target_velocity), np.abs(target_velocity))
        self._last = (velocity, np.minimum(np.abs(ctrl), max_force))
        return self._active, velocity

    def write_limits(self, m: mujoco.MjModel, act: np.ndarray, gear: np.ndarray, max_force: np.ndarray) -> None:
        """Write the spring-damper motors' force ranges into ``m`` (actuator units): the force of
        the last :meth:`law` where the mode is active, else the maximum force.

        Args:
            m: the model.
            act: (n,) the motors' actuator ids.
            gear: (n,) their gears.
            max_force: (n,) the maximum forces (N or N·m).
        """
        if self._last is None:
            return
        mask = self.mask
        force = np.where(self._active, self._last[1], max_force)[mask] / np.abs(gear[mask])
        m.actuator_forcerange[act[mask], 0] = -force
        m.actuator_forcerange[act[mask], 1] = force
