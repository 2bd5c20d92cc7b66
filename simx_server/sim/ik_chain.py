"""Kinematic chains of ``simIK`` environments: joints' intrinsic transforms, linear joint
dependencies, and the Jacobian of a point carried by a chain (``simIK.computeJacobian``).

CoppeliaSim's kinematics routines (CoppeliaRobotics' ``coppeliaKinematicsRoutines``) are the
reference:

* a joint's *intrinsic* transform (``ikGetJointTransformation``, ``CSceneObject::
  getLocalTransformation``) is its motion about its own z axis: a revolute joint turns by its
  position, a prismatic one translates along z, a spherical one turns by its rotation. On
  MuJoCo the position is measured from the joint's reference (``qpos0``), as
  :func:`simx_server.sim.kinematics.joint_matrix` does for ``sim.getJointMatrix``.
* a dependent joint (``ikSetJointDependency``, ``CJoint::setPosition``) follows its master:
  ``position = offset + mult * masterPosition``; the solver never moves it on its own, and its
  master's Jacobian column carries its motion too (``CikElement::_getNakedJacobian``: "dependent
  joints are invisible", the column of the master is the derivative with the slaves moving).
* ``ikComputeJacobian`` attaches a temporary tip to the chain's last joint at the given world
  pose and differentiates it: rows x, y, z in the constraint base's frame, then alpha, beta,
  gamma (the tip's rotation in its own frame); the error vector is the target's offset from the
  tip in those same rows. CoppeliaSim takes finite differences with a step of 0.01; simx gives
  their limit, MuJoCo's analytic Jacobian of the point (``mj_jac``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError

_HINGE, _SLIDE, _BALL = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE),
                         int(mujoco.mjtJoint.mjJNT_BALL))
CONSTRAINT_X, CONSTRAINT_Y, CONSTRAINT_Z, CONSTRAINT_ALPHA_BETA, CONSTRAINT_GAMMA = 1, 2, 4, 8, 16
#: How many dependencies a chain of slaves may have (a loop is broken before this).
MAX_DEPENDENCY_DEPTH = 64


# ---------------------------------------------------------------------- intrinsic
def intrinsic(kind: int, q: float = 0.0, ref: float = 0.0, quat_wxyz: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A joint's intrinsic transform: ``(translation (3,) m, rotation (3, 3))`` in its own frame.

    Args:
        kind: MuJoCo joint type (hinge, slide or ball).
        q: a hinge's or slide's position (rad or m).
        ref: its reference position (``qpos0``): the motion is ``q - ref``.
        quat_wxyz: a ball joint's rotation (w, x, y, z).

    Returns:
        Translation and rotation matrix.

    Raises:
        ArgumentError: a free joint (its motion is its body's pose).
    """
    t, r = np.zeros(3), np.eye(3)
    if kind == _HINGE:
        c, s = math.cos(q - ref), math.sin(q - ref)
        r[:2, :2] = [[c, -s], [s, c]]
    elif kind == _SLIDE:
        t[2] = q - ref
    elif kind == _BALL:
        quat = np.asarray(quat_wxyz, float)
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, quat / np.linalg.norm(quat))
        r = rot.reshape(3, 3)
    else:
        raise ArgumentError("a free joint has no intrinsic transformation in simIK (its motion is its body's pose)")
    return t, r


def unit_quaternion(rotation: np.ndarray) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of the nearest rotation to a 3x3 matrix (CoppeliaSim
    normalises the matrix first, ``ikSetSphericalJointMatrix``).

    Args:
        rotation: a 3x3 matrix (9 numbers), a rotation up to scale and noise.

    Returns:
        Array (4,): w, x, y, z, unit length.

    Raises:
        ArgumentError: a singular matrix (no rotation is near it).
    """
    m = np.asarray(rotation, float).reshape(3, 3)
    u, s, vt = np.linalg.svd(m)
    if not np.all(np.isfinite(s)) or s.min() < 1e-9:
        raise ArgumentError("the matrix's 3x3 part must be a rotation (it is singular)")
    r = u @ vt
    if np.linalg.det(r) < 0:
        raise ArgumentError("the matrix's 3x3 part must be a rotation (it is a reflection)")
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, r.reshape(9).copy())
    return quat / np.linalg.norm(quat)


def rotation_matrix(quat_wxyz: np.ndarray) -> np.ndarray:
    """The rotation matrix of a unit quaternion.

    Args:
        quat_wxyz: w, x, y, z.

    Returns:
        Array (3, 3).
    """
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, np.asarray(quat_wxyz, float))
    return rot.reshape(3, 3)


# ------------------------------------------------------------------ environments' own dummies
@dataclasses.dataclass
class LocalDummy:
    """A dummy of a ``simIK`` environment only (``simIK.createDummy``): its pose relative to its
    parent (-1 the world, a scene object, or another of the environment's dummies)."""

    handle: int
    name: str
    parent: int = -1
    position: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(3))


def dummy_frame(world, dummies: dict[int, LocalDummy], data: mujoco.MjData, handle: int,
                scene_frame: Callable[[int], tuple]) -> tuple[np.ndarray, np.ndarray, str, int]:
    """``position, rotation, "point", body`` of an environment's dummy in ``data``: its dummy
    ancestors' poses composed on its first scene ancestor's frame (``scene_frame(handle)``; the
    world for -1), carried by that ancestor's body (0: the world). A loop of parents cannot
    happen (``simIK.setObjectParent`` refuses one).

    Args:
        world: the world.
        dummies: the environment's dummies by handle.
        data: MuJoCo data whose kinematics are up to date.
        handle: one of ``dummies``.
        scene_frame: a scene object's ``(position, rotation, ...)`` in ``data``.

    Returns:
        ``(position (3,) m, rotation (3, 3), "point", MuJoCo body id)``.
    """
    line = []
    while handle in dummies:
        line.append(dummies[handle])
        handle = line[-1].parent
    p, r = (np.zeros(3), np.eye(3)) if handle == -1 else scene_frame(handle)[:2]
    for dummy in reversed(line):
        p, r = p + r @ dummy.position, r @ dummy.rotation
    return p, r, "point", 0 if handle == -1 else int(world.get(handle).body)


def carrier(world, dummies: dict[int, LocalDummy], handle: int) -> int:
    """The MuJoCo body that carries one of an environment's dummies.

    Args:
        world: the world.
        dummies: the environment's dummies by handle.
        handle: one of them (or a scene object: its own body).

    Returns:
        The body id of its first scene ancestor (0: the world).
    """
    while handle in dummies:
        handle = dummies[handle].parent
    return 0 if handle == -1 else int(world.get(handle).body)


# ------------------------------------------------------------------- dependencies
def link_dependency(dependency: dict[int, tuple[int, float, float]], slave: int, master: int) -> None:
    """Record that ``slave`` follows ``master`` (-1: none), breaking a loop as CoppeliaSim does
    (``CJoint::setDependencyJointHandle``: the joint of the master's chain that followed
    ``slave`` follows nothing any more). Offset and factor are kept (set them after).

    Args:
        dependency: slave handle -> ``(master, offset, mult)`` (master -1: none).
        slave: the joint that follows.
        master: the joint it follows, or -1.
    """
    _, offset, mult = dependency.get(slave, (-1, 0.0, 1.0))
    dependency[slave] = (master, offset, mult)
    if master == -1:
        return
    j = master
    for _ in range(MAX_DEPENDENCY_DEPTH):
        nxt = dependency.get(j, (-1, 0.0, 1.0))[0]
        if nxt == -1:
            return
        if nxt == slave:
            _, o, k = dependency[j]
            dependency[j] = (-1, o, k)
            return
        j = nxt


def root_of(dependency: dict[int, tuple[int, float, float]], joint: int) -> tuple[int, float, float]:
    """Where a joint's position comes from, following slaves of slaves.

    Args:
        dependency: slave handle -> ``(master, offset, mult)`` (master -1: none).
        joint: a joint's handle.

    Returns:
        ``(root master, offset, mult)`` with ``position(joint) = offset + mult *
        position(root)``; ``(joint, 0, 1)`` for a joint that follows nothing.

    Raises:
        ArgumentError: a line of dependencies longer than MAX_DEPENDENCY_DEPTH.
    """
    offset, mult = 0.0, 1.0
    for _ in range(MAX_DEPENDENCY_DEPTH):
        master, o, k = dependency.get(joint, (-1, 0.0, 1.0))
        if master == -1:
            return joint, offset, mult
        offset, mult = offset + mult * o, mult * k
        joint = master
    raise ArgumentError(f"joint dependencies deeper than {MAX_DEPENDENCY_DEPTH} joints")


def couplings(dependency: dict[int, tuple[int, float, float]], columns: list[int]) -> list[tuple[int, int, float, float]]:
    """The slaves that follow one of the solver's joints.

    Args:
        dependency: slave handle -> ``(master, offset, mult)`` (master -1: none).
        columns: the solver's joint handles.

    Returns:
        ``(slave, column index, offset, mult)`` each, offset and factor from its root master.
    """
    index = {j: i for i, j in enumerate(columns)}
    out = []
    for slave, (master, _, _) in dependency.items():
        if master == -1:
            continue
        root, offset, mult = root_of(dependency, slave)
        if root in index:
            out.append((slave, index[root], offset, mult))
    return out


def coupling_matrix(nv: int, dadr: np.ndarray, slaves: list[tuple[int, int, float]]) -> np.ndarray:
    """``M`` (nv, columns) such that ``J_full @ M`` is the Jacobian over the solver's joints
    with their slaves moving along: ``M[dadr[i], i] = 1``, ``M[slave dof, i] += mult``.

    Args:
        nv: the model's dof count.
        dadr: the columns' dof addresses.
        slaves: ``(slave dof address, column index, mult)``.

    Returns:
        Array (nv, len(dadr)).
    """
    m = np.zeros((nv, len(dadr)))
    m[np.asarray(dadr, int), np.arange(len(dadr))] = 1.0
    for dof, col, mult in slaves:
        m[dof, col] += mult
    return m


# ----------------------------------------------------------------------- Jacobian
def rotation_vector(r: np.ndarray) -> np.ndarray:
    """Axis times angle of a rotation (the limit of CoppeliaSim's Euler angles of a small
    interpolated step, divided by the step).

    Args:
        r: rotation matrix (3, 3).

    Returns:
        Array (3,), rad.
    """
    quat, v = np.empty(4), np.empty(3)
    mujoco.mju_mat2Quat(quat, np.asarray(r, float).reshape(9).copy())
    mujoco.mju_quat2Vel(v, quat, 1.0)
    return v


def _partial_target(constraints: int, r_tip: np.ndarray, r_target: np.ndarray) -> np.ndarray:
    """The target's rotation as ``CikElement::getJacobian`` reorients it for partial orientation
    constraints: alpha-beta alone turns it about its z to resemble the tip's x; gamma alone
    turns it by the least rotation that brings its z onto the tip's."""
    orient = constraints & (CONSTRAINT_ALPHA_BETA | CONSTRAINT_GAMMA)
    if orient == CONSTRAINT_ALPHA_BETA:
        x = r_target.T @ r_tip[:, 0]
        angle = math.atan2(x[1], x[0])
        c, s = math.cos(angle), math.sin(angle)
        return r_target @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    if orient == CONSTRAINT_GAMMA:
        zt, zc = r_target[:, 2], r_tip[:, 2]
        axis = np.cross(zt, zc)
        s, c = float(np.linalg.norm(axis)), float(np.dot(zt, zc))
        if s < 1e-12:
            return r_target
        quat, rot = np.empty(4), np.empty(9)
        mujoco.mju_axisAngle2Quat(quat, axis / s, math.atan2(s, c))
        mujoco.mju_quat2Mat(rot, quat)
        return rot.reshape(3, 3) @ r_target
    return r_target


def rows_of(constraints: int) -> tuple[list[int], list[int]]:
    """The rows of constraint bits, in CoppeliaSim's order.

    Args:
        constraints: ``simIK.constraint_*`` bits.

    Returns:
        ``(position rows (0 x, 1 y, 2 z), rotation rows (0 alpha, 1 beta, 2 gamma))``.
    """
    lin = [i for i, bit in enumerate((CONSTRAINT_X, CONSTRAINT_Y, CONSTRAINT_Z)) if constraints & bit]
    ang = ([0, 1] if constraints & CONSTRAINT_ALPHA_BETA else []) + ([2] if constraints & CONSTRAINT_GAMMA else [])
    return lin, ang


def point_jacobian(model: mujoco.MjModel, data: mujoco.MjData, body: int, constraints: int,
                   tip: tuple[np.ndarray, np.ndarray], target: tuple[np.ndarray, np.ndarray],
                   constraint_base: np.ndarray, columns: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian and error vector of a tip frame carried by ``body`` (``ikComputeJacobian``).

    Args:
        model: the model.
        data: data whose kinematics and ``mj_comPos`` are up to date.
        body: the body that carries the tip (the chain's last joint's).
        constraints: ``simIK.constraint_*`` bits.
        tip: the tip's world ``(position (3,), rotation (3, 3))``.
        target: the target's, likewise.
        constraint_base: rotation (3, 3) of the frame the position rows are expressed in.
        columns: (nv, n) map from the chain's joint velocities to dof velocities
            (:func:`coupling_matrix`).

    Returns:
        ``(jacobian (rows, n), error (rows,))``: position rows in the constraint base's axes,
        rotation rows in the tip's; the error is the target's offset from the tip in the same
        rows.
    """
    p, r = tip
    tp, tr = target
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, jacr, np.asarray(p, float), body)
    lin, ang = rows_of(constraints)
    jac = np.vstack([(constraint_base.T @ jacp)[lin], (r.T @ jacr)[ang]]) @ columns
    tr = _partial_target(constraints, r, tr)
    err = np.concatenate([(constraint_base.T @ (tp - p))[lin], rotation_vector(r.T @ tr)[ang]])
    return jac, err
