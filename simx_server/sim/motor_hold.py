"""A velocity motor told to stop, as V-REP's: a velocity constraint bounded by the maximum force.

V-REP's velocity motor (Bullet 2.78's joint motor, ``CJoint::handleDynJoint`` with the control
loop off) is a constraint on the joint's velocity whose impulse per step is bounded by the
maximum force: at target velocity 0 it holds the joint still against any load below that force,
brakes a moving joint with at most that force, and never drives it the other way. A servo whose
force is clipped to the maximum cannot do this in MuJoCo: a clamped actuator force is explicit
(``mjd_actuator_vel`` skips an actuator at its force range), so a light joint braked with the
whole force passes its rest within a substep and chatters from one side to the other (a 0.05 kg
gripper finger with a 50 N motor, stopped at 0.5 m/s, ran backwards at 0.5 m/s for ever).

MuJoCo's constraint of that kind is a joint's dry friction (``dof_frictionloss``): a
velocity-level row of the constraint solver, solved with the contacts, its force bounded by the
friction loss. :class:`Holds` gives the joint of each held motor its maximum force as friction
loss, made stiff (``dof_solref``, ``dof_solimp``, which MuJoCo uses for that friction only), on
top of the joint's own; the motor's actuator then gives no force (:meth:`Motors.apply
<simx_server.sim.motors.Motors.apply>`). The model's arrays are written only when the held
motors or their forces change.
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_server.sim.mechanisms import stiff_solref

#: ``solimp`` of a held joint's friction row: impedance 0.9999 (MuJoCo's largest), so that the
#: row's softness lets a 1 kg joint under 8 N move under a micrometre per 50 ms step.
HOLD_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
_FRICTION_DOF = int(mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF)  # an int: numpy compares an enum as an object


class Holds:
    """The held motors of one model: friction loss, ``solref`` and ``solimp`` of their dofs.

    Args:
        m: the compiled model; its joints' own values are kept and restored.
        dofs: (n,) each motor's dof address.
    """

    def __init__(self, m: mujoco.MjModel, dofs: np.ndarray) -> None:
        self.dofs = dofs
        self.usable = not m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS
        self._friction = m.dof_frictionloss[dofs].copy()
        self._solref = m.dof_solref[dofs].copy()
        self._solimp = m.dof_solimp[dofs].copy()
        self._stiff = np.array(stiff_solref(m.opt.timestep))
        #: (n,) which motors are held now (their joint's friction row is the motor).
        self.held = np.zeros(len(dofs), dtype=bool)
        self._key: bytes | None = None

    def forget(self) -> None:
        """The model's arrays are unknown (a reset or a new data): written again at the next call."""
        self._key = None

    def write(self, m: mujoco.MjModel, hold: np.ndarray, max_force: np.ndarray) -> None:
        """Hold the motors ``hold`` (n,) with their ``max_force`` (n,) N or N·m, the others not.

        Args:
            m: the model written (``dof_frictionloss``, ``dof_solref``, ``dof_solimp``).
            hold: which motors to hold.
            max_force: each motor's maximum force, joint units.
        """
        key = hold.tobytes() + max_force.tobytes()
        if key == self._key:
            return
        self._key = key
        self.held = hold.copy()
        dofs, on = self.dofs, hold[:, None]
        m.dof_frictionloss[dofs] = self._friction + np.where(hold, max_force, 0.0)
        m.dof_solref[dofs] = np.where(on, self._stiff, self._solref)
        m.dof_solimp[dofs] = np.where(on, HOLD_SOLIMP, self._solimp)

    def force(self, d: mujoco.MjData, i: int) -> float:
        """The force (N or N·m) held motor ``i``'s friction row applies now (0 if it has none).

        Args:
            d: the data of the model written.
            i: a motor number.

        Returns:
            The row's force on the joint.
        """
        n = d.nefc
        rows = (d.efc_type[:n] == _FRICTION_DOF) & (d.efc_id[:n] == self.dofs[i])
        return float(d.efc_force[:n][rows].sum())
