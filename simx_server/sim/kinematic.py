"""Joints in CoppeliaSim 4.1's kinematic modes: ``sim_jointmode_passive`` (0, 4.3+'s
``sim.jointmode_kinematic``) and ``sim_jointmode_ik`` (2), set by ``sim.setJointMode``
(coppeliaSimLib ``simSetJointMode_internal`` -> ``CJoint::setJointMode``).

CoppeliaSim's dynamics engines do not simulate a joint that is not in force/torque mode: its
position is what ``sim.setJointPosition`` (or an IK group) sets, and the bodies it carries move
with it, as a rigid link does. MuJoCo has no such joint, so each kinematic joint is held by a
joint equality of its own, ``simx_kinematic:JOINT`` (one coordinate, no second joint: ``q -
qpos0 = a0``), added inactive to the scene's spec the first time a joint of the scene is made
kinematic (:func:`add_equalities`, one recompile for every joint with a motor). Before each
step :func:`hold` writes the joint's current position into its equality (``eq_data[0]``),
switches it on and zeroes the joint's velocity; after the step :func:`settle` puts the joint
back exactly there (the equality is stiff, but soft as every MuJoCo constraint). A program moves
it with ``sim.setJointPosition`` between steps. The joint's motor gives no force meanwhile
(:mod:`simx_server.sim.motors`), and stopping the simulation gives every joint back its mode
at the start (``CJoint::simulationEnded`` restores ``_initialJointMode``).
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_server.sim.mechanisms import LIMIT_SOLIMP, stiff_solref
from simx_server.sim.motors import JOINTMODE_FORCE

#: Name prefix of the equality that holds a kinematic joint (``simx_kinematic:`` + the joint's name).
PREFIX = "simx_kinematic:"
#: CoppeliaSim 4.1's kinematic joint modes: ``sim_jointmode_passive``, ``sim_jointmode_ik``.
KINEMATIC_MODES = (0, 2)


def equalities(world) -> np.ndarray:
    """The equality of each motor's joint (-1 where the model has none), cached per model.

    Args:
        world: the World.

    Returns:
        (n,) int, by motor number.
    """
    mo = world.motors
    cached = getattr(mo, "_kinematic_eq", None)
    if cached is None:
        m = world.model
        cached = np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY,
                                             PREFIX + (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT,
                                                                         int(m.actuator_trnid[a, 0])) or ""))
                           for a in mo.act], dtype=int)
        mo._kinematic_eq = cached
    return cached


def add_equalities(spec: mujoco.MjSpec, joints: list[str]) -> None:
    """Add the inactive equality of each of ``joints`` that has none (stiff, as V-REP's rigid
    joints: two timesteps, the limits' impedance).

    Args:
        spec: the scene's spec (changed in place).
        joints: joint names.
    """
    taken = {e.name for e in spec.equalities}
    for name in joints:
        if PREFIX + name not in taken:
            spec.add_equality(name=PREFIX + name, type=mujoco.mjtEq.mjEQ_JOINT, name1=name, active=False,
                              data=[0.0] * mujoco.mjNEQDATA, solref=stiff_solref(spec.option.timestep),
                              solimp=list(LIMIT_SOLIMP))


def release(world, motor: int) -> None:
    """Switch off the equality of motor ``motor``'s joint (back to force/torque mode).

    Args:
        world: the World.
        motor: a motor number.
    """
    eq = int(equalities(world)[motor])
    if eq >= 0:
        world.data.eq_active[eq] = 0


def hold(world) -> tuple[np.ndarray, np.ndarray] | None:
    """Before a step: hold every kinematic joint where it is (its equality on at its position,
    its velocity zero).

    Args:
        world: the World.

    Returns:
        ``(motors, positions)`` for :func:`settle`, or None when no joint is kinematic.
    """
    mo = world.motors
    kin = np.flatnonzero(mo.joint_mode != JOINTMODE_FORCE)
    eq = equalities(world)[kin]
    kin, eq = kin[eq >= 0], eq[eq >= 0]
    if not kin.size:
        return None
    m, d = world.model, world.data
    q = d.qpos[mo.qadr[kin]].copy()
    d.qvel[mo.dadr[kin]] = 0.0
    m.eq_data[eq, 0] = q - m.qpos0[mo.qadr[kin]]
    d.eq_active[eq] = 1
    return kin, q


def settle(world, held: tuple[np.ndarray, np.ndarray]) -> None:
    """After a step: the kinematic joints exactly where :func:`hold` found them, at rest.

    Args:
        world: the World.
        held: what :func:`hold` returned.
    """
    kin, q = held
    mo, d = world.motors, world.data
    d.qpos[mo.qadr[kin]] = q
    d.qvel[mo.dadr[kin]] = 0.0
