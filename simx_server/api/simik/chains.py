"""``simIK``'s joints and chains beyond positions: a joint's intrinsic transform
(``getJointMatrix``, ``getJointTransformation``), a spherical joint's rotation
(``setSphericalJointMatrix``, ``setSphericalJointRotation``), linear joint dependencies
(``setJointDependency``) and the Jacobian of a chain (``computeJacobian``).

All of them act on the environment (:mod:`simx_server.api.simik.environments`), never on the
scene: a spherical joint's rotation and a dependency set here hold in the environment only, as
in CoppeliaSim, where an IK environment is a world of its own. The mathematics is in
:mod:`simx_server.sim.ik_chain`; CoppeliaSim's ``simIK`` plugin (``sourceCode/simIK.cpp``) and
its kinematics routines (``ik.cpp``: ``ikComputeJacobian``, ``ikGetJointTransformation``,
``ikSetSphericalJointQuaternion``, ``ikSetJointDependency``) are the reference for the argument
forms and the behaviour.

simx's solver moves hinge and slide joints (MuJoCo's revolute and prismatic joints); a
spherical (ball) joint holds the rotation the environment gives it (the scene's until
``setSphericalJoint*`` sets one), and ``computeJacobian`` has its three columns (rotations about
the joint's own x, y, z, as CoppeliaSim's).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import simik_function
from simx_server.api.simik import environments as _environments
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_vector as _vector
from simx_server.sim import ik_chain, ik_solver
from simx_server.sim.objects import JOINT, WORLD
from simx_server.sim.rotations import euler_from_matrix, matrix_from_euler, matrix_from_quaternion, quaternion_from_matrix
from simx_wire.protocol import ArgumentError, UnsupportedError

_HINGE, _SLIDE, _BALL = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE),
                         int(mujoco.mjtJoint.mjJNT_BALL))


def _kind(ctx: CallContext, joint: Any) -> int:
    return int(ctx.world.model.jnt_type[joint.mj_id])


def _ball(ctx: CallContext, env: _environments.Environment, joint: Any) -> np.ndarray:
    """A ball joint's rotation (w, x, y, z) in the environment (the scene's until one is set)."""
    if joint.handle in env.ball:
        return np.asarray(env.ball[joint.handle], float)
    adr = int(ctx.world.model.jnt_qposadr[joint.mj_id])
    return np.array(ctx.world.data.qpos[adr:adr + 4], float)


def _spherical(ctx: CallContext, jointHandle: Any) -> Any:  # noqa: N803
    joint = _environments.joint_of(ctx, jointHandle)
    if _kind(ctx, joint) != _BALL:
        raise ArgumentError(f"joint {joint.name!r} is not spherical (a MuJoCo ball joint)")
    return joint


def _intrinsic(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> tuple[np.ndarray, np.ndarray]:  # noqa: N803
    env = _environments.env_of(ctx, environmentHandle)
    joint = _environments.joint_of(ctx, jointHandle)
    kind = _kind(ctx, joint)
    if kind == _BALL:
        return ik_chain.intrinsic(kind, quat_wxyz=_ball(ctx, env, joint))
    if kind not in (_HINGE, _SLIDE):
        raise ArgumentError(f"joint {joint.name!r} is a free joint: it has no intrinsic transformation in simIK")
    ref = float(ctx.world.model.qpos0[ctx.world.model.jnt_qposadr[joint.mj_id]])
    return ik_chain.intrinsic(kind, _environments.q_of(ctx, env, joint.handle), ref)


@simik_function("getJointMatrix")
def getJointMatrix(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> list[float]:  # noqa: N802, N803
    """The joint's intrinsic transformation at its position in the environment: 12 numbers, the
    3x4 matrix row by row (a revolute joint's rotation about z, a prismatic joint's
    translation along z, a spherical joint's rotation; ``ikGetJointMatrix``).

    Raises:
        UnknownObjectError: no such environment or joint.
        ArgumentError: a free joint.
    """
    t, r = _intrinsic(ctx, environmentHandle, jointHandle)
    return np.hstack([r, t.reshape(3, 1)]).reshape(12).tolist()


@simik_function("getJointTransformation")
def getJointTransformation(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> tuple[list[float], list[float], list[float]]:  # noqa: N802, N803
    """``position, quaternion, euler`` of the joint's intrinsic transformation (as
    :func:`getJointMatrix`; quaternion x, y, z, w; Euler angles alpha, beta, gamma), CoppeliaSim
    4.0-4.4's ``simIK.getJointTransformation``."""
    t, r = _intrinsic(ctx, environmentHandle, jointHandle)
    return t.tolist(), quaternion_from_matrix(r), list(euler_from_matrix(r))


@simik_function("setSphericalJointMatrix")
def setSphericalJointMatrix(ctx: CallContext, environmentHandle: Any, jointHandle: Any, matrix: Any) -> None:  # noqa: N802, N803
    """Set a spherical joint's rotation in the environment from a 3x4 matrix (12 numbers, row by
    row; the translation is ignored, the rotation normalised: ``ikSetSphericalJointMatrix``).

    Raises:
        ArgumentError: not a spherical joint, not 12 numbers, or a singular rotation part.
    """
    env = _environments.env_of(ctx, environmentHandle)
    joint = _spherical(ctx, jointHandle)
    m = np.array(_vector(matrix, 12, "matrix")).reshape(3, 4)
    env.ball[joint.handle] = ik_chain.unit_quaternion(m[:, :3])


@simik_function("setSphericalJointRotation")
def setSphericalJointRotation(ctx: CallContext, environmentHandle: Any, jointHandle: Any, eulerOrQuaternion: Any) -> None:  # noqa: N802, N803
    """Set a spherical joint's rotation in the environment: 3 numbers are Euler angles (alpha,
    beta, gamma), 4 a quaternion (x, y, z, w; normalised, as ``ikSetSphericalJointQuaternion``).

    Raises:
        ArgumentError: not a spherical joint, neither 3 nor 4 numbers, or a zero quaternion.
    """
    env = _environments.env_of(ctx, environmentHandle)
    joint = _spherical(ctx, jointHandle)
    n = len(eulerOrQuaternion) if isinstance(eulerOrQuaternion, (list, tuple)) else 0
    if n == 4:
        r = matrix_from_quaternion(*_vector(eulerOrQuaternion, 4, "eulerOrQuaternion"))
    elif n == 3:
        r = matrix_from_euler(*_vector(eulerOrQuaternion, 3, "eulerOrQuaternion"))
    else:
        raise ArgumentError("eulerOrQuaternion must hold 3 Euler angles or 4 quaternion numbers (x, y, z, w)")
    env.ball[joint.handle] = ik_chain.unit_quaternion(r)


@simik_function("setJointDependency")
def setJointDependency(ctx: CallContext, environmentHandle: Any, jointHandle: Any, depJointHandle: Any,  # noqa: N802, N803
                       offset: Any = 0.0, mult: Any = 1.0, callback: Any = None) -> None:
    """Make a joint follow another in the environment: ``position = offset + mult *
    depJointPosition`` (``depJointHandle`` -1: follow none). The solver then moves the master
    only and the dependent joint with it (its motion is part of the master's Jacobian column);
    setting a dependency that would close a loop frees the joint of the master's chain that
    followed this one, as CoppeliaSim's ``CJoint::setDependencyJointHandle``. ``offset`` and
    ``mult`` are kept only with a master (``ikSetJointDependency``).

    Raises:
        UnknownObjectError: no such environment or joint.
        ArgumentError: a spherical or free joint (it has no scalar position to follow with).
        UnsupportedError: a ``callback`` (simx's solver cannot call a script's function).
    """
    env = _environments.env_of(ctx, environmentHandle)
    if callback is not None:
        raise UnsupportedError("simIK.setJointDependency with a callback: simx applies linear dependencies only "
                               "(offset + mult * master)")
    joint = _environments.joint_of(ctx, jointHandle)
    dep = ctx.h(depJointHandle, "depJointHandle")
    master = None if dep == -1 else ctx.world.get(dep, JOINT)
    for j in (joint, master):
        if j is not None and _kind(ctx, j) not in (_HINGE, _SLIDE):
            raise ArgumentError(f"joint {j.name!r} is not revolute or prismatic: it has no position to depend on")
    off, k = _num(offset, "offset"), _num(mult, "mult")
    ik_chain.link_dependency(env.dependency, joint.handle, -1 if master is None else master.handle)
    if master is not None and env.dependency[joint.handle][0] != -1:
        env.dependency[joint.handle] = (master.handle, off, k)


def _pose(value: Any, what: str) -> tuple[np.ndarray, np.ndarray]:
    """A pose (7 numbers: x y z qx qy qz qw) or a matrix (12: 3x4 row by row), as simIK.cpp's
    ``computeJacobian`` reads its pose arguments (fewer than 12 numbers: a pose)."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) < 7:
        raise ArgumentError(f"{what} must be a pose (7 numbers) or a matrix (12 numbers)")
    if len(value) < 12:
        v = _vector(list(value[:7]), 7, what)
        return np.array(v[:3]), matrix_from_quaternion(*v[3:])
    m = np.array(_vector(list(value[:12]), 12, what)).reshape(3, 4)
    return m[:, 3].copy(), _rotation(m[:, :3])


def _rotation(m: np.ndarray) -> np.ndarray:
    quat, rot = ik_chain.unit_quaternion(m), np.empty(9)
    mujoco.mju_quat2Mat(rot, quat)
    return rot.reshape(3, 3)


def _chain(ctx: CallContext, env: _environments.Environment, base: int, last: Any) -> list[Any]:
    """The joints from ``base`` (-1: the world) to ``last``, base first (CoppeliaSim walks from
    the tip's parent, the last joint, up to the base).

    Raises:
        ArgumentError: ``last`` is not below ``base``.
    """
    w = ctx.world
    m = w.model
    stop = -1 if base == WORLD else w.get(base).body
    by_id = {o.mj_id: o for o in w.objects.values() if o.type == JOINT}
    out, b = [], last.body
    while b > 0 and b != stop:
        for j in range(m.body_jntadr[b] + m.body_jntnum[b] - 1, m.body_jntadr[b] - 1, -1):
            if j in by_id and (b != last.body or j <= last.mj_id):
                out.append(by_id[j])
        b = int(m.body_parentid[b])
    if stop != -1 and b != stop:
        raise ArgumentError(f"joint {last.name!r} is not below the base object {base}")
    return out[::-1]


@simik_function("computeJacobian")
def computeJacobian(ctx: CallContext, environmentHandle: Any, baseObject: Any, lastJoint: Any, constraints: Any,  # noqa: N802, N803
                    tipMatrix: Any, targetMatrix: Any = None, constrBaseMatrix: Any = None) -> tuple[list[float], list[float]]:  # noqa: N803
    """``jacobian, errorVector`` of a tip carried by the chain from ``baseObject`` (-1: the world)
    to ``lastJoint``, in the environment's configuration (``ikComputeJacobian``).

    The tip is at ``tipMatrix`` (world; a pose of 7 numbers or a matrix of 12), rigidly attached
    to ``lastJoint``'s moving side; the target at ``targetMatrix`` (default: the tip, a zero
    error). Rows, in CoppeliaSim's order, those of ``constraints`` (``simIK.constraint_x`` ...
    ``constraint_gamma``): x, y, z in the frame of ``constrBaseMatrix`` (default the base
    object's, the world's for -1), alpha, beta, gamma about the tip's own axes (alpha-beta alone
    or gamma alone reorient the target first, as CoppeliaSim). Columns: the chain's joints in
    IK mode from base to tip (a dependent joint's motion is in its master's column, a spherical
    joint has three). The jacobian comes row by row (rows x columns numbers).

    Raises:
        UnknownObjectError: no such environment or object.
        ArgumentError: constraints outside 1..31, a malformed pose, or ``lastJoint`` not below
            ``baseObject``.
    """
    env = _environments.env_of(ctx, environmentHandle)
    w = ctx.world
    base = ctx.h(baseObject, "baseObject")
    if base != WORLD:
        w.get(base)
    last = _environments.joint_of(ctx, lastJoint)
    bits = _int(constraints, "constraints")
    if not 1 <= bits <= 31:
        raise ArgumentError("constraints must combine simIK.constraint_x ... constraint_gamma (1..31)")
    tip = _pose(tipMatrix, "tipMatrix")
    target = tip if targetMatrix is None else _pose(targetMatrix, "targetMatrix")
    d = _environments.env_data(ctx, env)
    if constrBaseMatrix is not None:
        cb = _pose(constrBaseMatrix, "constrBaseMatrix")[1]
    elif base != WORLD:
        cb = _frame_rotation(ctx, d, base)
    else:
        cb = np.eye(3)
    columns: list[Any] = []
    for j in _chain(ctx, env, base, last):
        if env.mode.get(j.handle, _environments.JOINTMODE_IK) != _environments.JOINTMODE_IK:
            continue
        h: int | None = j.handle
        while h is not None and env.dependency.get(h, (-1,))[0] != -1:
            h = env.dependency[h][0]
            h = h if env.mode.get(h, _environments.JOINTMODE_IK) == _environments.JOINTMODE_IK else None
        if h is not None and all(c.handle != h for c in columns):
            columns.append(w.get(h))
    m = w.model
    dofs = [[int(m.jnt_dofadr[c.mj_id]) + k for k in range(3 if _kind(ctx, c) == _BALL else 1)] for c in columns]
    scalar = [c.handle for c in columns if _kind(ctx, c) != _BALL]
    first = np.cumsum([0] + [len(x) for x in dofs])[:-1]
    col_of = {c.handle: int(first[i]) for i, c in enumerate(columns)}
    slaves = [(int(m.jnt_dofadr[w.get(s).mj_id]), col_of[scalar[i]], k)
              for s, i, _, k in ik_chain.couplings(env.dependency, scalar)]
    mat = ik_chain.coupling_matrix(m.nv, np.array([a for x in dofs for a in x], int), slaves)
    jac, err = ik_chain.point_jacobian(m, d, last.body, bits, tip, target, cb, mat)
    return jac.reshape(-1).tolist(), err.tolist()


def _frame_rotation(ctx: CallContext, data: mujoco.MjData, handle: int) -> np.ndarray:
    return ik_solver.frame(ctx.world, data, handle)[1]


@contextlib.contextmanager
def only_joints(ctx: CallContext, env, g, jointHandles: Any) -> Iterator[list[int]]:  # noqa: N803
    """The joints a search may move: ``jointHandles`` (any subset of the group's joints, in any
    order; None: all), the group's other joints held where they are while it runs, as
    CoppeliaSim 4.1's ``simGetConfigForTipPose`` / ``simGenerateIkPath`` set the group's joints
    passive, then the given ones to IK mode (a Baxter arm's group also holds its torso's joints).

    Args:
        ctx: the call's context.
        env: the IK environment.
        g: its group.
        jointHandles: joint handles, or None.

    Yields:
        The joints' handles, in ``jointHandles``' order (None: the group's, base first).

    Raises:
        ArgumentError: a handle twice, none, or one that is not the group's.
    """
    group_joints = _environments.joints_of(ctx, env, g)
    if jointHandles is None:
        yield group_joints
        return
    joints = [_int(j, "jointHandles[i]") for j in jointHandles]
    if not joints or len(set(joints)) != len(joints) or not set(joints) <= set(group_joints):
        raise ArgumentError(f"jointHandles must be joints of the group {group_joints}, each once")
    held = {j: env.mode.get(j) for j in group_joints if j not in joints}
    env.mode.update(dict.fromkeys(held, _environments.JOINTMODE_PASSIVE))
    try:
        yield joints
    finally:
        for j, mode in held.items():
            if mode is None:
                env.mode.pop(j, None)
            else:
                env.mode[j] = mode
