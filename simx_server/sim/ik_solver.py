"""The solver of ``simIK`` groups (:mod:`simx_server.api.simik.environments`), and of the scene's IK
groups with several elements or partial constraints (:mod:`simx_server.sim.ik`), on MuJoCo's
Jacobians.

An IK environment keeps its own joint positions; a group's elements each pull a tip (a dummy or a
shape) onto a target (a dummy, or an explicit pose) under constraints (CoppeliaSim's
``simIK.constraint_x`` ... ``constraint_gamma`` bits). :func:`solve` iterates on a scratch
``MjData`` (``mj_kinematics`` + ``mj_comPos``, as :mod:`simx_server.sim.ik` does for the scene's
groups): the stacked error of the elements' constrained rows, each scaled by its element's
weight, the Jacobian of the group's joints (``mj_jacSite`` / ``mj_jacBody``), and a step by the group's method (damped least
squares ``Jᵀ(JJᵀ + λ²I)⁻¹e``, pseudo-inverse, Jacobian transpose), each joint's step bounded
by its maximum step size (unless the group ignores them, as ``simIK``'s do by default) and its
position clamped to its range, as coppeliaKinematicsRoutines' ``CIkGroupContainer::computeIk``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import mujoco
import numpy as np

from simx_server.sim import old_paths
from simx_server.sim.ik_chain import coupling_matrix
from simx_server.sim.objects import JOINT, SITES

_SITES = SITES  # objects that are MuJoCo sites

METHOD_PSEUDO_INVERSE, METHOD_DLS, METHOD_TRANSPOSE, METHOD_UNDAMPED = 0, 1, 2, 3
CONSTRAINT_POSITION, CONSTRAINT_ALPHA_BETA, CONSTRAINT_GAMMA = 7, 8, 16
#: CoppeliaSim's joint displacement for its numeric Jacobian (rad or m; ``CikElement``).
FD_STEP = 0.01


@dataclasses.dataclass
class Element:
    """One tip-target pair of a group (handles are the scene's)."""

    handle: int
    tip: int
    target: int  # -1: none (an explicit target pose is then given to solve)
    base: int = -1
    constraints: int = 31  # simIK.constraint_pose
    weights: tuple[float, float] = (1.0, 1.0)  # linear, angular
    precision: tuple[float, float] = (0.001, 0.5 * np.pi / 180)  # m, rad
    flags: int = 1  # bit 0: enabled


def frame(world, data: mujoco.MjData, handle: int) -> tuple[np.ndarray, np.ndarray, str, int]:
    """``position, rotation, kind, id`` of a dummy (a site) or another object (its body's frame)
    in ``data``.

    Args:
        world: the world.
        data: MuJoCo data whose kinematics are up to date.
        handle: an object's handle.

    Returns:
        ``(position (3,) m, rotation (3, 3), "site" or "body", MuJoCo id)``.

    Raises:
        UnknownObjectError: no such object.
    """
    obj = world.get(handle)
    if obj.type in _SITES:
        return data.site_xpos[obj.mj_id].copy(), data.site_xmat[obj.mj_id].reshape(3, 3).copy(), "site", obj.mj_id
    return data.xpos[obj.body].copy(), data.xmat[obj.body].reshape(3, 3).copy(), "body", obj.body


def _rotvec(r_target: np.ndarray, r_tip: np.ndarray) -> np.ndarray:
    """Rotation vector (world axes, rad) turning ``r_tip`` onto ``r_target``."""
    qt, qc, dq = np.empty(4), np.empty(4), np.empty(3)
    mujoco.mju_mat2Quat(qt, r_target.reshape(9).copy())
    mujoco.mju_mat2Quat(qc, r_tip.reshape(9).copy())
    mujoco.mju_subQuat(dq, qt, qc)  # in the tip's frame
    return r_tip @ dq


def chain(world, tip: int, base: int, tip_body: int | None = None) -> list[int]:
    """Handles of the hinge and slide joints between ``base`` (-1: the world) and ``tip``, base first.

    Args:
        world: the world.
        tip: handle of the chain's tip.
        base: handle of its base, or -1.
        tip_body: the body that carries the tip, when it is no scene object (a dummy of a
            ``simIK`` environment): ``tip`` is then not looked up.

    Returns:
        Joint handles, base first.

    Raises:
        UnknownObjectError: ``tip`` or ``base`` is no object.
    """
    m = world.model
    stop = -1 if base == -1 else world.get(base).body
    joint_of = {o.mj_id: o.handle for o in world.objects.values() if o.type == JOINT}
    out, b = [], world.get(tip).body if tip_body is None else tip_body
    while b > 0 and b != stop:
        for j in range(m.body_jntadr[b] + m.body_jntnum[b] - 1, m.body_jntadr[b] - 1, -1):
            if int(m.jnt_type[j]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE) and j in joint_of:
                out.append(joint_of[j])
        b = int(m.body_parentid[b])
    return out[::-1]


def errors(world, data, elements: list[Element], targets: dict[int, tuple],
           frame_of: Callable[[mujoco.MjData, int], tuple] | None = None,
           weighted: bool = True) -> tuple[np.ndarray, list, bool]:
    """Stacked weighted error, the rows' (element, kind, rows) and whether each element is within
    its precision.

    Args:
        world: the world.
        data: MuJoCo data whose kinematics are up to date.
        elements: the IK elements (disabled ones, ``flags`` bit 0 clear, are skipped).
        targets: element handle -> ``(position (3,), rotation (3, 3))`` instead of its target
            object's frame.
        frame_of: ``frame_of(data, handle)`` as :func:`frame` (default), for objects that are no
            scene objects (a ``simIK`` environment's own dummies: kind ``"point"``, the id the
            body that carries them).
        weighted: scale each element's rows by its linear / angular weight (as
            ``CikGroup::computeDq`` does to the error vector only; False: the plain error, as
            ``simIK.computeGroupJacobian`` answers it).

    Returns:
        ``(error, rows, ok)``: the weighted error (m and rad, flat), what each block of rows is
        (for :func:`jacobian`), and whether every element is within its precision.
    """
    parts, rows, ok = [], [], True
    fr = frame_of or (lambda d, h: frame(world, d, h))
    for el in elements:
        if not el.flags & 1:
            continue
        p, r, kind, mid = fr(data, el.tip)
        tp, tr = targets[el.handle] if el.handle in targets else fr(data, el.target)[:2]
        lin = tp - p
        ang = _rotvec(tr, r)
        pick_lin = [i for i, bit in enumerate((1, 2, 4)) if el.constraints & bit]
        ang_local = tr.T @ ang  # in the target's frame: alpha-beta = x, y; gamma = z
        pick_ang = ([0, 1] if el.constraints & CONSTRAINT_ALPHA_BETA else []) + \
                   ([2] if el.constraints & CONSTRAINT_GAMMA else [])
        if np.linalg.norm(lin[pick_lin]) > el.precision[0] or np.linalg.norm(ang_local[pick_ang]) > el.precision[1]:
            ok = False
        wl, wa = el.weights if weighted else (1.0, 1.0)
        parts.append(wl * lin[pick_lin])
        parts.append(wa * ang_local[pick_ang])
        rows.append((el, kind, mid, pick_lin, pick_ang, tr, p))
    return (np.concatenate(parts) if parts else np.zeros(0)), rows, ok


def jacobian(world, data, rows: list, dadr: np.ndarray, columns: np.ndarray | None = None) -> np.ndarray:
    """The Jacobian of the rows :func:`errors` chose, over the chain's joints. The elements'
    weights scale only the error, not these rows: coppeliaKinematicsRoutines ``CikGroup::computeDq``
    multiplies the error vector's rows by them and leaves the Jacobian as ``CikElement`` built it,
    as V-REP 4.1's ``CIkElement::prepareIkEquations`` did (a smaller weight is a shorter step
    towards that part of the target, not a lesser row of the least squares).

    Args:
        world: the world.
        data: MuJoCo data whose kinematics (and ``mj_comPos``) are up to date.
        rows: the rows of :func:`errors`.
        dadr: the chain joints' dof addresses.
        columns: (nv, len(dadr)) map from the chain's joint velocities to dof velocities, when
            dependent joints follow them (:func:`simx_server.sim.ik_chain.coupling_matrix`);
            None: each column is its joint's dof alone.

    Returns:
        Array (len(error), len(dadr)).
    """
    m = world.model
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    blocks = []
    for el, kind, mid, pick_lin, pick_ang, tr, p in rows:
        if kind == "point":  # a point carried by body ``mid`` (0: the world, fixed)
            mujoco.mj_jac(m, data, jacp, jacr, p, mid)
        else:
            (mujoco.mj_jacSite if kind == "site" else mujoco.mj_jacBody)(m, data, jacp, jacr, mid)
        lin, ang = jacp[pick_lin], (tr.T @ jacr)[pick_ang]
        if columns is None:
            lin, ang = lin[:, dadr], ang[:, dadr]
        else:
            lin, ang = lin @ columns, ang @ columns
        blocks.append(lin)
        blocks.append(ang)
    return np.vstack(blocks) if blocks else np.zeros((0, len(dadr)))


def bounds(model: mujoco.MjModel, jids: list[int], margins: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where :func:`solve` clamps each joint: its range, each limited joint ``margins`` inside it
    (at most to its middle), an unlimited joint's bounds infinite.

    Args:
        model: the MuJoCo model.
        jids: MuJoCo joint ids.
        margins: (len(jids),) rad or m, or None.

    Returns:
        ``(low, high, top)``, (len(jids),) each: the bounds, and the ranges' upper ends before
        the margins (where ``simIK``'s numeric Jacobian is clamped).
    """
    limited = np.array([bool(model.jnt_limited[j]) for j in jids])
    low = np.where(limited, [model.jnt_range[j][0] for j in jids], -np.inf)
    high = np.where(limited, [model.jnt_range[j][1] for j in jids], np.inf)
    top = high.copy()
    if margins is not None:  # an unlimited joint's bounds stay infinite (their middle is NaN)
        mid = np.where(limited, (np.where(limited, low, 0) + np.where(limited, high, 0)) / 2, 0.0)
        low = np.where(limited, np.minimum(low + margins, mid), low)
        high = np.where(limited, np.maximum(high - margins, mid), high)
    return low, high, top


def solve(world, scratch: mujoco.MjData, joints: list[int], q: np.ndarray, elements: list[Element],
          method: int, damping: float, iterations: int, max_step: np.ndarray,
          targets: dict[int, tuple] | None = None, weights: np.ndarray | None = None,
          margins: np.ndarray | None = None,
          slaves: list[tuple[int, int, int, float, float]] | None = None,
          frame_of: Callable[[mujoco.MjData, int], tuple] | None = None,
          bound_steps: bool = True, numeric: bool = False) -> tuple[bool, np.ndarray, np.ndarray]:
    """Iterate from ``q`` (the joints' positions); ``(within precision, q, final error)``.
    ``scratch`` must hold the scene's other positions already. ``weights`` (per joint, > 0)
    make a joint move more (a larger weight) or less in the weighted least-norm step
    ``W Jᵀ (J W Jᵀ + λ²I)⁻¹ e``; ``margins`` keep each joint that far inside its range.
    ``slaves`` are dependent joints ``(qpos address, dof address, column, offset, mult)``:
    each is put at ``offset + mult * q[column]`` at every iteration, and its motion is part of
    its column of the Jacobian (CoppeliaSim's linear joint dependencies). A hinge's step is
    wrapped into (-pi, pi] (``CikGroup::computeDq``); with ``bound_steps`` a step larger than a
    joint's ``max_step`` is scaled down whole, as ``CIkGroupContainer::computeIk`` interpolates
    the target unless the group has ``simIK.group_ignoremaxsteps``. Each step is clamped into
    the joints' ranges (``CikGroup::applyDq`` through ``CJoint::setPosition``), so a joint at a
    limit whose step points outwards stays there and the step the others were given assumes it
    moved: the group can stop short of a target its other joints alone would get closer to.

    With ``numeric`` (``simIK``, CoppeliaSim 4.2+), a limited joint within ``FD_STEP`` of its
    upper limit also moves the tip less in the Jacobian, not at all at the limit: coppelia-
    KinematicsRoutines differentiates by moving each joint ``FD_STEP`` *up* through the clamping
    ``CJoint::setPosition`` (``CikElement::_getNakedJacobian``), so such a joint stays at its
    upper limit, while one at its lower limit keeps its whole column, and a target that pushes
    it outwards stalls the chain (a fixed point short of the target). CoppeliaSim 4.10's own
    files show it: a scene saved with ``simIK`` running while stopped sits at that stall (a
    replica of ``CikElement::getJacobian`` and ``CIkGroupContainer::computeIk`` moves its
    joints < 5e-6 rad from there; without the column they would move 0.27 rad). V-REP 4.1's old IK groups
    (``sim.handleIkGroup``, ``sim.checkIkGroup``) differentiate analytically
    (coppeliaSimLib 4.1 ``CIkRoutine::getJacobian``): no column depends on the limits.

    Args:
        world: the world.
        scratch: MuJoCo data to iterate in.
        joints: the chain's joint handles.
        q: their start positions (rad or m).
        elements: the IK elements.
        method: METHOD_PSEUDO_INVERSE, METHOD_DLS, METHOD_TRANSPOSE or METHOD_UNDAMPED.
        damping: λ of the damped least squares.
        iterations: the most steps.
        max_step: per joint, the largest change of one step (rad or m).
        targets: see :func:`errors`.
        weights: see above.
        margins: see above (rad or m).
        slaves: see above.
        frame_of: see :func:`errors`.
        bound_steps: scale steps down to ``max_step`` (False: the group ignores max step sizes,
            CoppeliaSim's default for ``simIK.createGroup``).
        numeric: the Jacobian is ``simIK``'s numeric one, clamped at the upper limits (see above).

    Returns:
        ``(ok, q, error)``: whether every element is within precision, the positions reached
        (len(joints),) and the last weighted error.
    """
    m = world.model
    qadr = np.array([world.model.jnt_qposadr[world.get(h).mj_id] for h in joints], int)
    dadr = np.array([world.model.jnt_dofadr[world.get(h).mj_id] for h in joints], int)
    jid = [world.get(h).mj_id for h in joints]
    hinge = np.array([int(m.jnt_type[j]) == mujoco.mjtJoint.mjJNT_HINGE for j in jid], bool)
    low, high, top = bounds(m, jid, margins)
    w = np.ones(len(joints)) if weights is None else np.asarray(weights, float)
    targets = targets or {}
    q = np.clip(np.asarray(q, float), low, high)
    slaves = slaves or []
    columns = None
    if slaves:
        columns = coupling_matrix(m.nv, dadr, [(dof, col, mult) for _, dof, col, _, mult in slaves])
    e = np.zeros(0)
    for it in range(iterations + 1):
        scratch.qpos[qadr] = q
        for sq, _, col, offset, mult in slaves:
            scratch.qpos[sq] = offset + mult * q[col]
        mujoco.mj_kinematics(m, scratch)
        mujoco.mj_comPos(m, scratch)
        e, rows, ok = errors(world, scratch, elements, targets, frame_of)
        if ok or it == iterations or not len(joints):
            return ok, q, e
        jac = jacobian(world, scratch, rows, dadr, columns)
        if numeric:
            jac = jac * np.clip((top - q) / FD_STEP, 0.0, 1.0)
        if method == METHOD_TRANSPOSE:
            dq = w * (jac.T @ e)
        else:
            lam2 = damping * damping if method == METHOD_DLS else 1e-10
            dq = w * (jac.T @ np.linalg.solve((jac * w) @ jac.T + lam2 * np.eye(len(e)), e))
        scale = np.max(np.abs(dq) / max_step) if bound_steps and len(dq) else 0.0
        if scale > 1:
            dq = dq / scale
        dq = np.where(hinge, np.arctan2(np.sin(dq), np.cos(dq)), dq)
        q = np.clip(q + dq, low, high)
    return False, q, e


def path(world, scratch: mujoco.MjData, joints: list[int], q: np.ndarray, elements: list[Element], method: int,
         damping: float, iterations: int, max_step: np.ndarray, count: int,
         collides: Callable[[np.ndarray], bool] | None = None, bound_steps: bool = True) -> np.ndarray | None:
    """``count`` configurations that carry each element's tip from where it is in ``scratch`` to
    its target in equal steps (positions on the line, orientations by ``C4Vector``'s spherical
    interpolation), each solved by :func:`solve` from the one before; None when one is not
    within precision or ``collides`` (coppeliaSimLib ``simGenerateIkPath_internal``).

    Args:
        world, scratch, joints, q, elements, method, damping, iterations, max_step, bound_steps:
            as :func:`solve` (``scratch`` holds the scene's state).
        count: the number of configurations (>= 2).
        collides: ``collides(q)``: whether a configuration collides (None: not checked).

    Returns:
        Array (count, len(joints)) of joint positions (rad or m), or None.
    """
    mujoco.mj_kinematics(world.model, scratch)
    ends = {}
    for el in elements:
        (p0, r0), (p1, r1) = frame(world, scratch, el.tip)[:2], frame(world, scratch, el.target)[:2]
        ends[el.handle] = (p0, old_paths.matrix_to_quat(r0), p1, old_paths.matrix_to_quat(r1))
    out = np.empty((count, len(joints)))
    for i in range(count):
        t = i / (count - 1)
        targets = {h: (p0 + t * (p1 - p0), _matrix(old_paths.slerp(a, b, t))) for h, (p0, a, p1, b) in ends.items()}
        ok, q, _ = solve(world, scratch, joints, q, elements, method, damping, iterations, max_step,
                         targets=targets, bound_steps=bound_steps)
        if not ok or (collides is not None and collides(q)):
            return None
        out[i] = q
    return out


def _matrix(quat: np.ndarray) -> np.ndarray:
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, quat)
    return out.reshape(3, 3)
