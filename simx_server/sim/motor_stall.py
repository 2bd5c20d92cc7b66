"""V-REP's velocity motor held back: a constraint that pushes with its whole maximum force when
its target velocity cannot be reached (a gripper closed on a cube grips with its 20 N), where
the servo of :mod:`simx_server.sim.motors` alone gives ``kv * v`` (3 N on the RG2).

A motor in velocity mode with the same target as at the last call (once per step, or per
substep while scripts' joint callbacks run) that covered less than :data:`STALLED` of ``v`` times
the time since, and moves at less than STALLED of ``v`` now, gets ``sign(v) * max_force`` more
(the actuator's force range clips the sum to the maximum); once it moves again, none. While a
motor is held back, the world applies the motors at every substep (:attr:`Stalls.stalled`), so
that one released in the middle of a step stops pushing within a substep. Position control, and
a script's joint callback (its own control law), keep the servo alone.
"""

from __future__ import annotations

import numpy as np

#: A velocity-mode motor is held back (it gets its whole force) when it moved, and moves, at less
#: than this fraction of its target velocity: stopped, not slow.
STALLED = 0.1


class Stalls:
    """The held-back motors of one set of motors.

    Args:
        n: the number of motors.
    """

    def __init__(self, n: int) -> None:
        #: What :meth:`force` returns when no motor is held back (never written).
        self.no_force = np.zeros(n)
        self.reset(n)

    def reset(self, n: int) -> None:
        """Nothing known of the motors' past (a new or reset simulation).

        Args:
            n: the number of motors.
        """
        # positions, velocity targets, the velocity motors among them, time at the last call
        self._last: tuple[np.ndarray, np.ndarray, np.ndarray, float] = (np.zeros(0), np.zeros(0), np.zeros(0, bool),
                                                                        -1.0)
        self._bias = np.zeros(n)
        #: Some motor is held back: the world applies the motors at every substep.
        self.stalled = False

    def force(self, q: np.ndarray, qdot: np.ndarray, v: np.ndarray, velocity_law: np.ndarray, now: float,
              max_force: np.ndarray) -> np.ndarray:
        """The extra force of the motors held back since the last call (module docstring).

        Args:
            q: (n,) the joints' positions now.
            qdot: (n,) their velocities now.
            v: (n,) their target velocities from now on.
            velocity_law: (n,) which motors are in velocity mode from now on.
            now: the simulation time (s).
            max_force: (n,) the motors' maximum forces (N or N·m).

        Returns:
            (n,) the extra force (N or N·m), 0 for the others.
        """
        last_q, last_v, last_law, last_t = self._last
        elapsed = now - last_t
        if len(last_q) == len(q) and elapsed == 0:  # applied again at the same instant
            return self._bias
        self._last = (q.copy(), v.copy(), velocity_law, now)  # velocity_law is never written in place
        if len(last_q) != len(q) or not elapsed > 0:
            self.stalled = False
            self._bias = self.no_force
            return self._bias
        held = velocity_law & (v != 0)  # the motors that could be held back: moving, the same target
        if np.count_nonzero(held):
            held &= last_law & (v == last_v)
        if not np.count_nonzero(held):
            self.stalled = False
            self._bias = self.no_force
            return self._bias
        sign, speed = np.sign(v), np.abs(v)
        blocked = held & ((q - last_q) * sign < STALLED * speed * elapsed) & (qdot * sign < STALLED * speed)
        self.stalled = np.count_nonzero(blocked) > 0
        self._bias = np.where(blocked, sign * max_force, 0.0) if self.stalled else self.no_force
        return self._bias
