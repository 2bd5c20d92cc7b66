"""The MuJoCo arrays :class:`simx_server.sim.motors.Motors` reads and writes at every step, taken
once per ``(model, data)``."""

from __future__ import annotations

import mujoco
import numpy as np


def slice_or(index: np.ndarray) -> slice | np.ndarray:
    """An index array as a slice where its entries are consecutive (basic indexing reads faster
    than fancy indexing).

    Args:
        index: (n,) int indices.

    Returns:
        ``slice(index[0], index[0] + n)`` where the entries are consecutive, else ``index``.
    """
    n = len(index)
    if n and np.array_equal(index, np.arange(index[0], index[0] + n)):
        return slice(int(index[0]), int(index[0]) + n)
    return index


def select(mask: np.ndarray, yes: np.ndarray, no: np.ndarray) -> np.ndarray:
    """``np.where(mask, yes, no)`` for (n,) float arrays, the same values in about a third of its
    time on a few motors: a copy of ``no`` with ``yes`` written where ``mask``.

    Args:
        mask: (n,) bool.
        yes: (n,) or a scalar, taken where ``mask``.
        no: (n,), taken elsewhere (not written).

    Returns:
        A new (n,) array.
    """
    out = no.copy()
    np.copyto(out, yes, where=mask)
    return out


class Views:
    """The arrays :meth:`Motors.apply` reads and writes, taken once per ``(model, data)`` (each
    attribute of MuJoCo's bindings builds a new ndarray), and ``others``: the equalities that are
    not the motors' locks (those a motor's inertia is computed through)."""

    __slots__ = ("biasprm", "ctrl", "dadr", "data", "eq_active", "eq_data", "forcerange", "gainprm", "jnt_limited",
                 "model", "others", "qadr", "qfrc_bias", "qfrc_constraint", "qfrc_passive", "qpos", "qpos0", "qvel")

    def __init__(self, m: mujoco.MjModel, d: mujoco.MjData, locks: np.ndarray, qadr: np.ndarray,
                 dadr: np.ndarray) -> None:
        self.model, self.data = m, d
        self.qadr, self.dadr = slice_or(qadr), slice_or(dadr)  # basic indexing reads faster than fancy
        self.qpos, self.qvel, self.ctrl = d.qpos, d.qvel, d.ctrl
        self.qfrc_bias, self.qfrc_passive, self.qfrc_constraint = d.qfrc_bias, d.qfrc_passive, d.qfrc_constraint
        self.gainprm, self.biasprm = m.actuator_gainprm, m.actuator_biasprm
        self.eq_active, self.eq_data, self.qpos0, self.forcerange = d.eq_active, m.eq_data, m.qpos0, m.actuator_forcerange
        self.jnt_limited = m.jnt_limited
        self.others = np.setdiff1d(np.arange(m.neq), locks)
