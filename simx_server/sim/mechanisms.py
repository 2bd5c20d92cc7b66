"""Linked mechanisms: V-REP's dependent joints and loop closures as MuJoCo equalities that hold,
and the inertia a motor moves when its joint is part of such a mechanism (CoppeliaSim's
``CJoint::setDependencyParams``, its MuJoCo plugin's ``CRigidBodyContainerDyn`` in ``simDyn``).

Stiffness. MuJoCo's constraints are soft: a constraint's reference acceleration is scaled by the
inverse inertia MuJoCo estimated for it at ``qpos0`` (``efc_diagApprox``), and a light body that
closes a loop (V-REP's RG2 drives its fingers through a 1 g helper) gets a constraint, or a joint
limit, too soft to hold a 20 N motor (with MuJoCo's defaults, ``solref`` 0.02 s and ``solimp``
0.95, the RG2's open/close joint ran 9.5 mm past its limit). V-REP's engines (Bullet, ODE) treat
joint limits and loop closures as hard constraints. :func:`stiff_solref` (a time constant of two
timesteps, the shortest MuJoCo takes without its own safety clamp) and LIMIT_SOLIMP (99 %
impedance) hold that limit to under 1 mm; loop closures and dependencies take the same time
constant with MuJoCo's default impedance (LOOP_SOLIMP).

Inertia. V-REP's grippers (the RG2, most parallel grippers) close their kinematic loops with
dummy-to-dummy links and dependent joints, MuJoCo equalities here
(:mod:`simx_server.scene.ttt.mechanisms`). A motor on such a joint, often on a 1 g helper body,
moves the whole linkage through the constraints: the open chain's inertia ``1 / (M^-1)_ii``
(a few grams) understates what it drives by orders of magnitude, and a servo gain taken from it
(:mod:`simx_server.sim.motors`) cannot move the fingers against their own weight.

With ``J`` the equality rows of the constraint Jacobian (``efc_J``, as MuJoCo computed it at the
last ``mj_forward``) and ``R`` their regularisation (``efc_R``: MuJoCo's soft constraints), the
inverse inertia of dof ``i`` seen through the constraints is

    ``w_i = (M^-1)_ii - (M^-1 J^T (J M^-1 J^T + R)^-1 J M^-1)_ii``

(the Schur complement of the constrained system: the acceleration a unit force on dof ``i``
gives once the constraints push back). Without equalities it is ``(M^-1)_ii``.
"""

from __future__ import annotations

import mujoco
import numpy as np

_EQUALITY = int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)
#: Impedance of joint limits (dmin, dmax, width m, midpoint, power): 99 % from the first
#: millimetre (MuJoCo's default 0.9-0.95 lets a light body's limit give way under its motor).
LIMIT_SOLIMP = (0.99, 0.99, 0.001, 0.5, 2.0)
#: Impedance of the weld that holds a grasped part (:mod:`simx_server.sim.grasps`): MuJoCo's
#: highest (``mjMAXIMP``). MuJoCo's constraint softness is the impedance's ``(1 - d) / d`` times
#: the inverse inertia of the bodies it joins, so a light part's weld gives way, in rotation most:
#: a 1 kg bar 40 cm long, held at its middle, turned 62 degrees under 10 N m at 99 %, 1 degree at
#: 99.99 %; CoppeliaSim's link (Bullet's locked ``btGeneric6DofConstraint``) is rigid.
GRASP_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)
#: Impedance of loop closures and dependencies: MuJoCo's default. A loop closure often
#: over-constrains its mechanism (a parallel gripper's welds fix the finger's orientation twice);
#: at 99 % such redundant rows leave the solver too little regularisation, and the RG2 chatters.
LOOP_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)
#: The smallest fraction of the open chain's inverse inertia kept (a joint that the constraints
#: lock entirely would otherwise get an infinite inertia, and an infinite servo gain).
MIN_FRACTION = 1e-6


def equality_jacobian(m: mujoco.MjModel, d: mujoco.MjData,
                      ignore: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The active equality constraints' Jacobian rows and regularisation.

    Args:
        m: the model.
        d: its data after ``mj_forward`` (its ``efc_*`` arrays are read).
        ignore: equality ids left out (None: none).

    Returns:
        ``(J, R)``: J (k, nv) dense, R (k,) MuJoCo's ``efc_R`` of those rows; k = 0 when the
        model has no active equality.
    """
    if m.neq == 0 or d.nefc == 0:
        return _no_rows(m.nv)
    held = d.eq_active.astype(bool)
    if ignore is not None and len(ignore):
        held[ignore] = False
    if not held.any():  # every active equality is ignored (a gripper's own locks): no rows to read
        return _no_rows(m.nv)
    rows = np.flatnonzero(d.efc_type[:d.nefc] == _EQUALITY)
    rows = rows[held[d.efc_id[rows]]]
    if not rows.size:
        return _no_rows(m.nv)
    if mujoco.mj_isSparse(m):  # only the kept rows, from MuJoCo's compressed rows
        dense = np.zeros((rows.size, m.nv))
        nnz, adr, col = d.efc_J_rownnz[rows], d.efc_J_rowadr[rows], d.efc_J_colind
        for k in range(rows.size):
            a, n = int(adr[k]), int(nnz[k])
            dense[k, col[a:a + n]] = d.efc_J[a:a + n]
        return dense, d.efc_R[rows].copy()
    return d.efc_J[:d.nefc * m.nv].reshape(d.nefc, m.nv)[rows].copy(), d.efc_R[rows].copy()


def _no_rows(nv: int) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((0, nv)), np.zeros(0)


def inverse_inertia(m: mujoco.MjModel, d: mujoco.MjData, minv_rows: np.ndarray, dofs: np.ndarray,
                    ignore: np.ndarray | None = None) -> np.ndarray:
    """The inverse inertia of each of ``dofs`` with the equality constraints held.

    Args:
        m: the model.
        d: its data after ``mj_forward``.
        minv_rows: (n, nv) rows ``dofs`` of ``M^-1`` (``mj_solveM`` of unit rows).
        dofs: (n,) dof indices.
        ignore: equality ids not held (None: all are).

    Returns:
        (n,) inverse inertias (1/kg or 1/(kg m^2)), each at most the open chain's
        ``(M^-1)_ii`` and at least MIN_FRACTION of it.
    """
    n = len(dofs)
    open_chain = minv_rows[np.arange(n), dofs]
    J, R = equality_jacobian(m, d, ignore)
    if not J.shape[0] or not n:
        return open_chain
    minv_jt = np.zeros_like(J)
    mujoco.mj_solveM(m, d, minv_jt, J)  # rows: M^-1 J^T, transposed (M is symmetric)
    a = J @ minv_jt.T + np.diag(R)
    x = minv_rows @ J.T  # (n, k): e_i^T M^-1 J^T
    try:
        y = np.linalg.solve(a, x.T)
    except np.linalg.LinAlgError:  # R > 0 keeps it regular; a degenerate one is left as it was
        return open_chain
    w = open_chain - np.einsum("ik,ki->i", x, y)
    return np.clip(w, MIN_FRACTION * open_chain, open_chain)


def effective_inertia(m: mujoco.MjModel, d: mujoco.MjData, minv_rows: np.ndarray, unit_rows: np.ndarray,
                      diagonal: np.ndarray, dofs: np.ndarray, locks: np.ndarray, others: np.ndarray,
                      eq_active: np.ndarray) -> np.ndarray:
    """The effective inertia of each of ``dofs`` that a joint motor drives: through the scene's
    equalities when one is active (a motor closing a loop drives the whole linkage,
    :func:`inverse_inertia`; a motor's own lock is not a part of the mechanism it drives), else
    the open chain's ``1 / (M^-1)_ii`` (:func:`inverse_inertia`'s first step).

    Args:
        m: the model.
        d: its data after ``mj_forward``.
        minv_rows: (n, nv), written: rows ``dofs`` of ``M^-1``.
        unit_rows: (n, nv) the unit rows of ``dofs``.
        diagonal: (n,) the places of ``(M^-1)_ii`` in ``minv_rows``, flat.
        dofs: (n,) dof indices.
        locks: the motors' lock equalities (ignored).
        others: the other equalities.
        eq_active: the data's ``eq_active``.

    Returns:
        (n,) kg or kg·m² (at most 1e12).
    """
    mujoco.mj_solveM(m, d, minv_rows, unit_rows)
    if others.size and np.count_nonzero(eq_active[others]):
        inverse = inverse_inertia(m, d, minv_rows, dofs, locks)
    else:
        inverse = minv_rows.take(diagonal)
    return np.reciprocal(np.maximum(inverse, 1e-12))  # 1 / x


def stiff_solref(timestep: float) -> list[float]:
    """The stiffest ``solref`` (time constant s, damping ratio) MuJoCo takes at ``timestep`` s
    without clamping it: two timesteps, critically damped. A larger timestep later (a changed
    ``opt.timestep``) is clamped by MuJoCo itself (its ``refsafe``), never unstable.

    Args:
        timestep: the model's timestep (s), > 0.

    Returns:
        ``[time constant, 1.0]``.
    """
    return [2.0 * float(timestep), 1.0]


#: ``solmix`` of the geoms of static shapes fixed to the world (the ground, tables, walls): their
#: ``solref`` decides their contacts with geoms that have another (MuJoCo averages two geoms'
#: ``solref`` weighted by it).
GROUND_SOLMIX = 1000.0
#: The damping ratio of V-REP's rigid contact. MuJoCo's spring is 1 / (dmax * time constant *
#: ratio)^2 and its damping 2 / (dmax * time constant): at 2 the spring at V-REP's 5 ms substep is
#: MuJoCo's default one (a resting body sinks as much), stiffer at shorter steps (six times at
#: 2 ms), and the damping is the stiffest one's. Critically damped (1), bodies that overlap at
#: load were pushed apart at depth / (2 * time constant): a wall overlapping another by 6 mm left
#: at 8 m/s and through the floor.
RIGID_DAMPING_RATIO = 2.0
#: MuJoCo's default ``solref`` and ``solmix`` of a geom.
DEFAULT_SOLREF, DEFAULT_SOLMIX = (0.02, 1.0), 1.0


def rigid_contact(geom, timestep: float, static: bool = True) -> None:
    """Give a geom of a V-REP shape V-REP's rigid contact: the stiffest time constant MuJoCo
    takes (two timesteps, :func:`stiff_solref`), damped twice critically
    (:data:`RIGID_DAMPING_RATIO`); a static shape's (fixed to the world) also rules the contacts
    of geoms that have another (:data:`GROUND_SOLMIX`).

    Bullet's contacts are rigid, between two dynamic bodies as against a static one: it corrects
    an overlap within a few steps whatever the bodies' masses. MuJoCo's default contact (a 20 ms
    time constant) is a soft spring: what fell or was pressed on V-REP's 4 cm floor box sank by
    its speed x 20 ms, passed the box's middle and fell for ever; a Panda finger pressed on a
    fridge's door (a dynamic shape on its hinge) sank 7 mm into it, and the friction of that
    overlap held the closing finger before it reached the handle (RLBench's fridge tasks). The
    ``.ttt`` converter gives it to every shape of a file, ``sim.createPureShape`` /
    ``sim.createPrimitiveShape`` / ``sim.createMeshShape`` to those made at run time, and
    ``sim_shapeintparam_static`` switches between the static and the dynamic form. At a timestep
    over 5 ms (an MJCF scene's own) two timesteps damped twice critically would be softer than
    MuJoCo's default contact, which the geom then keeps.

    Args:
        geom: an ``MjsGeom`` of the spec.
        timestep: the model's timestep (s).
        static: a static shape fixed to the world (True) or a dynamic one (False).
    """
    stiff = stiff_solref(timestep)[0]
    if stiff * RIGID_DAMPING_RATIO <= DEFAULT_SOLREF[0] * DEFAULT_SOLREF[1]:  # MuJoCo's spring: 1 / (tc r)^2
        geom.solref = [stiff, RIGID_DAMPING_RATIO]
    else:
        geom.solref = list(DEFAULT_SOLREF)
    geom.solmix = GROUND_SOLMIX if static else DEFAULT_SOLMIX


def dependency_polycoef(qpos0_joint: float, qpos0_master: float, offset: float, mult: float) -> list[float]:
    """MuJoCo's joint-equality coefficients for V-REP's dependency ``q = offset + mult * q_master``.

    MuJoCo's ``<equality><joint polycoef>`` relates the joints' displacements from ``qpos0``
    (their ``ref``): ``q1 - q1_0 = a0 + a1 (q2 - q2_0)``; V-REP's relation is on the positions
    themselves (CoppeliaSim's ``CJoint::setDependencyParams``; its MuJoCo plugin writes
    ``polycoef = offset mult`` for joints whose ``ref`` is their position at the start).

    Args:
        qpos0_joint: the dependent joint's ``qpos0`` (rad or m).
        qpos0_master: the master's ``qpos0``.
        offset: V-REP's offset (rad or m).
        mult: V-REP's multiplier.

    Returns:
        The 5 polycoef values ``[a0, a1, 0, 0, 0]``.
    """
    return [offset + mult * qpos0_master - qpos0_joint, mult, 0.0, 0.0, 0.0]


def dependency_of_polycoef(qpos0_joint: float, qpos0_master: float, a0: float, a1: float) -> tuple[float, float]:
    """V-REP's ``(offset, mult)`` of a joint equality's ``a0, a1`` (the inverse of
    :func:`dependency_polycoef`; the polynomial's higher terms, which V-REP has not, are not
    read).

    Args:
        qpos0_joint: the dependent joint's ``qpos0``.
        qpos0_master: the master's ``qpos0``.
        a0: MuJoCo's constant term.
        a1: MuJoCo's linear term.

    Returns:
        ``(offset, mult)``.
    """
    return a0 + qpos0_joint - a1 * qpos0_master, a1


#: V-REP's bound on a dependency's offset and multiplier (CJoint::setDependencyParams).
MAX_DEPENDENCY_PARAM = 10_000.0


def set_dependency(spec: mujoco.MjSpec, joint: str, master: str | None, offset: float, mult: float,
                   qpos0: tuple[float, float] = (0.0, 0.0)) -> None:
    """``sim.setJointDependency`` on a spec: ``joint`` follows ``master`` (``q = offset + mult *
    q_master``), or nothing (``master`` None), as CoppeliaSim's ``simSetJointDependency_internal``
    and ``CJoint::setDependencyMasterJointHandle`` do it: the joint's former dependency goes; a
    joint of the master's chain that depended on ``joint`` loses its dependency (V-REP breaks the
    loop there); offset and multiplier are bounded to +-10000. The equality is stiff (see the
    module).

    Args:
        spec: the scene's spec (changed in place).
        joint: the dependent joint's name.
        master: the master joint's name, or None.
        offset: rad or m.
        mult: the multiplier.
        qpos0: the compiled model's ``qpos0`` of ``joint`` and ``master`` (rad or m; the spec's
            ``ref`` may be in degrees).

    Raises:
        ValueError: ``master`` is ``joint`` (V-REP refuses it too).
    """
    if master == joint:
        raise ValueError(f"joint {joint!r} cannot depend on itself")
    joint_eqs = [e for e in spec.equalities if e.type == mujoco.mjtEq.mjEQ_JOINT and e.name2]
    for eq in joint_eqs:
        if eq.name1 == joint:
            spec.delete(eq)
    if master is None:
        return
    masters = {e.name1: e for e in joint_eqs if e.name1 != joint}
    current, seen = master, set()
    while current in masters and current not in seen:
        seen.add(current)
        eq = masters[current]
        if eq.name2 == joint:  # the master's chain leads back here: V-REP cuts it at that link
            spec.delete(eq)
            break
        current = eq.name2
    offset = min(max(float(offset), -MAX_DEPENDENCY_PARAM), MAX_DEPENDENCY_PARAM)
    mult = min(max(float(mult), -MAX_DEPENDENCY_PARAM), MAX_DEPENDENCY_PARAM)
    data = dependency_polycoef(qpos0[0], qpos0[1], offset, mult)
    spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=joint, name2=master,
                      data=data + [0.0] * (mujoco.mjNEQDATA - len(data)),
                      solref=stiff_solref(spec.option.timestep), solimp=list(LOOP_SOLIMP))


def dependency(m: mujoco.MjModel, joint_id: int) -> tuple[int, float, float] | None:
    """The dependency of joint ``joint_id`` in V-REP's terms (positions,
    :func:`dependency_of_polycoef`): the first joint equality whose first joint it is.

    Args:
        m: the model.
        joint_id: a joint's id.

    Returns:
        ``(master joint id, offset, mult)``, or None without a dependency.
    """
    for e in range(m.neq):
        if m.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and m.eq_obj1id[e] == joint_id and m.eq_obj2id[e] >= 0:
            master = int(m.eq_obj2id[e])
            off, mult = dependency_of_polycoef(float(m.qpos0[m.jnt_qposadr[joint_id]]),
                                               float(m.qpos0[m.jnt_qposadr[master]]),
                                               float(m.eq_data[e][0]), float(m.eq_data[e][1]))
            return master, off, mult
    return None
