"""Force sensors as CoppeliaSim reads them: the force and torque that the sensor's child side
exerts on its parent side, in the sensor's frame, the torque about the sensor's origin.

In CoppeliaSim a force sensor is a rigid link between its parent (object 1) and what hangs below
it in the object tree (object 2 and everything carried by it). Its dynamics plugins report the
link's reaction on the parent: CoppeliaSim's MuJoCo plugin (simMujoco,
``CRigidBodyContainerDyn::_addObjectBranch`` puts a site at the sensor in the child shape's body,
``handleDynamics`` reports ``-sensordata`` of MuJoCo's force and torque sensors on it: MuJoCo's
read what the parent does to the child), its ODE plugin (``CConstraintDyn`` reports
``-f2``, the force on the child body, moved to the sensor's origin) and
``CForceSensor::addCumulativeForcesAndTorques`` stores them. A mass ``m`` hanging below the
sensor reads ``m·g`` along gravity, in the sensor's frame: ``+m·g`` on z for a sensor whose z
points down (an arm's flange with the gripper pointing down).

The child side in simx's MuJoCo model (:func:`child_bodies`): the bodies of the shapes and
joints below the sensor in V-REP's tree (``SceneObject.parent``), with every MuJoCo body below
them; for a sensor of an MJCF scene (a site with no ``vrep_parent=`` setting: docs/SCENES.md)
also the body of its site, MuJoCo's own convention (the site in the child body). What links the
two sides (:func:`child_wrench`): each child-side body whose MuJoCo parent is on the parent side
transmits ``cfrc_int`` (the interaction force MuJoCo's ``mj_rnePostConstraint`` computes, with
the contacts and applied forces on the bodies below it), and each grasped part
(:mod:`simx_server.sim.grasps`: a dynamic shape held by a weld after ``sim.setObjectParent``)
held on or by the child side transmits what holds it rigidly to its holder. So a cube grasped
under PyRep's gripper weighs on the arm's wrist sensor and on the gripper's attach point, and
the gripper's own mass not on the latter. A shape linked to a dummy that hangs from the sensor
(a loop closure, V-REP's suction pads: ``force sensor --> dummy -- dummy <-- part``) is held
through the sensor too, as CoppeliaSim's engines make that link the sensor's constraint.
"""

from __future__ import annotations

import operator
from typing import NamedTuple

import mujoco
import numpy as np

from simx_server.sim import grasps
from simx_server.sim.kept import PerObject, entry
from simx_server.sim.objects import DUMMY, JOINT, SHAPE, SceneObject, subtree

_FREE = int(mujoco.mjtJoint.mjJNT_FREE)
_PARENT = operator.attrgetter("parent")
_EQUALITY = int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)
_WELD, _SITE = int(mujoco.mjtEq.mjEQ_WELD), int(mujoco.mjtObj.mjOBJ_SITE)


def in_mjcf_convention(sensor: SceneObject) -> bool:
    """Whether ``sensor`` follows MJCF's convention (its site's body is its child side): a
    site in a body other than the world, with no ``vrep_parent=`` setting. A converted ``.ttt``
    file, ``sim.createForceSensor`` and ``sim.setObjectParent`` give their sensors that setting:
    their child side is what hangs below them in V-REP's tree.

    Args:
        sensor: a force sensor.

    Returns:
        True for a sensor of an MJCF scene that sits in a body.
    """
    return "vrep_parent" not in sensor.settings and sensor.body != 0


_NO_ROTATION = np.eye(3).reshape(9)  # mju_transformSpatial's rotation: none
_NO_ROWS = np.zeros(0, dtype=np.int64)


def child_bodies(world, sensor: SceneObject) -> np.ndarray:
    """The MuJoCo bodies on ``sensor``'s child side (see the module's docstring).

    Args:
        world: the :class:`~simx_server.sim.world.World`.
        sensor: a force sensor.

    Returns:
        (nbody,) bool: True for a body on the child side (read-only: kept per model).
    """
    return _child_side(world, sensor).mask


class _Side(NamedTuple):
    """A force sensor's two sides, as V-REP's tree and MuJoCo's model place them."""

    mask: np.ndarray  # (nbody,) bool: :func:`child_bodies`
    roots: np.ndarray  # the child side's bodies joined to the parent side in MuJoCo's tree
    root_trees: np.ndarray  # their trees' roots (``body_rootid``): where ``cfrc_int`` is taken
    dummies: frozenset[int]  # the sites of the dummies hanging from the sensor (:func:`_linked_parts`)


def _child_side(world, sensor: SceneObject) -> _Side:
    """The sensor's :class:`_Side`, kept per model while V-REP's tree is the same (a grasp
    re-parents)."""
    parents = tuple(map(_PARENT, world.objects.values()))
    return entry(_sides(world.model), (sensor.handle, in_mjcf_convention(sensor), parents),  # type: ignore[no-any-return]
                 lambda: _side_now(world, sensor), _KEPT_SIDES)


def _side_now(world, sensor: SceneObject) -> _Side:
    m = world.model
    seeds = [sensor.body] if in_mjcf_convention(sensor) else []
    for o in subtree(world, sensor.handle)[1:]:
        if o.type == SHAPE:
            seeds.append(o.mj_id)
        elif o.type == JOINT:
            seeds.append(o.body)  # the body it moves
    mask = np.zeros(m.nbody, bool)
    mask[seeds] = True
    mask[0] = False
    parent = m.body_parentid
    for b in range(1, m.nbody):  # MuJoCo orders bodies parents first
        if mask[parent[b]]:
            mask[b] = True
    free = (m.body_jntnum == 1) & (m.jnt_type[np.maximum(m.body_jntadr, 0)] == _FREE)
    roots = np.flatnonzero(mask & ~mask[m.body_parentid] & ~free)
    trees = m.body_rootid[roots]
    mask.flags.writeable = roots.flags.writeable = trees.flags.writeable = False  # kept and shared
    dummies = frozenset(o.mj_id for o in world.objects.values() if o.parent == sensor.handle and o.type == DUMMY)
    return _Side(mask, roots, trees, dummies)


#: The child sides kept per model ({(sensor, its convention, V-REP's parents): _side_now's}),
#: at most _KEPT_SIDES.
_sides = PerObject(lambda m: {})
_KEPT_SIDES = 64


def _transmitted(site: np.ndarray, subtree_com: np.ndarray, cfrc_int: np.ndarray, side: _Side) -> np.ndarray:
    """The spatial force (6,) torque:force, the torque about ``site`` (3,), that the parent side
    exerts on the roots of ``side`` (``cfrc_int``, each at its tree's reference point
    ``subtree_com``): ``sum(cfrc[:3] + (com - site) x cfrc[3:]), sum(cfrc[3:])``. One root (a
    finger's pad, a gripper on its flange) in plain floats, the same operations in the same order
    as numpy's (its sum of one row adds it to 0.0), at a tenth of their cost."""
    if side.roots.size != 1:
        com = subtree_com[side.root_trees]
        cfrc = cfrc_int[side.roots]
        return np.concatenate([(cfrc[:, :3] + _cross_rows(com - site, cfrc[:, 3:])).sum(axis=0),
                               cfrc[:, 3:].sum(axis=0)])
    t0, t1, t2, f0, f1, f2 = cfrc_int[side.roots[0]].tolist()
    c0, c1, c2 = subtree_com[side.root_trees[0]].tolist()
    s0, s1, s2 = site.tolist()
    a0, a1, a2 = c0 - s0, c1 - s1, c2 - s2
    return np.array([0.0 + (t0 + (a1 * f2 - a2 * f1)), 0.0 + (t1 + (a2 * f0 - a0 * f2)),
                     0.0 + (t2 + (a0 * f1 - a1 * f0)), 0.0 + f0, 0.0 + f1, 0.0 + f2])


def _cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b row by row for (k, 3) arrays, as ``np.cross`` computes it (ten times faster on a few rows)."""
    out = np.empty_like(a)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def _cross(a, b) -> np.ndarray:
    """a x b for two 3-vectors (``np.cross`` costs 30 times more on one pair)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _at(vec: np.ndarray, old: np.ndarray, new: np.ndarray, force: bool = True) -> np.ndarray:
    """A spatial vector (6,) moved from point ``old`` to point ``new`` (m) without rotation,
    MuJoCo's ``mju_transformSpatial``: a force (torque:force) gains the force's moment, a motion
    (angular:linear) the angular part's."""
    out = np.empty(6)
    mujoco.mju_transformSpatial(out, vec, int(force), new, old, _NO_ROTATION)
    return out


def _rigid_hold(m: mujoco.MjModel, d: mujoco.MjData, part: int, holder: int) -> np.ndarray:
    """The spatial force (6,) torque:force at the part's reference point (``subtree_com`` of its
    own tree) that holds free body ``part`` rigidly to body ``holder`` (one in MuJoCo's tree):
    its inertial force moving as the holder's frame moves (MuJoCo's ``cinert * cacc + cvel x* cinert * cvel``, gravity in
    ``cacc``), less the other forces on it (``cfrc_ext``, computed without the grasp welds).
    V-REP's link is rigid; the weld is soft (MuJoCo's constraints are), and reading its force
    would miss the part's sag at each step (1 % at MuJoCo's 0.99 impedance)."""
    ref, href = d.subtree_com[m.body_rootid[part]], d.subtree_com[m.body_rootid[holder]]
    acc, vel = _at(d.cacc[holder], href, ref, force=False), _at(d.cvel[holder], href, ref, force=False)
    momentum = _inert_times(d.cinert[part], vel)
    spin = np.concatenate([_cross(vel[:3], momentum[:3]) + _cross(vel[3:], momentum[3:]),
                           _cross(vel[:3], momentum[3:])])  # mju_crossForce
    return _inert_times(d.cinert[part], acc) + spin - d.cfrc_ext[part]


def _inert_times(i: np.ndarray, v: np.ndarray) -> np.ndarray:
    """MuJoCo's ``mju_mulInertVec``: a com-based inertia (10,) (the 3x3 inertia about the
    reference point, mass x the centre of mass's offset, mass) times a motion (6,)."""
    inertia = np.array([[i[0], i[3], i[4]], [i[3], i[1], i[5]], [i[4], i[5], i[2]]])
    mc = i[6:9]
    return np.concatenate([inertia @ v[:3] + _cross(mc, v[3:]), i[9] * v[3:] + _cross(v[:3], mc)])


def _linked_parts(world, dummies: frozenset[int]) -> list[tuple[int, int, int]]:
    """The shapes a force sensor holds through a dummy link: ``(equality, part body, holder
    body)`` for each active site weld (a loop closure of the scene or one made at run time,
    :mod:`simx_server.sim.dummy_links`) from a dummy hanging from ``sensor`` to a dummy on a free
    body, as CoppeliaSim links ``shape --> force sensor --> dummy -- dummy <-- shape`` through
    the sensor (simDyn ``CRigidBodyContainerDyn_base::_addConstraintFromJointOrForceSensor``, its
    second case: the force sensor's constraint joins its parent shape to the linked dummy's
    shape, and the sensor measures it): a suction pad's link sensor and the part it holds.
    ``dummies``: the sites of the dummies hanging from the sensor."""
    m, d = world.model, world.data
    if not dummies:
        return []
    out = []
    for e in np.flatnonzero((m.eq_type == _WELD) & (m.eq_objtype == _SITE) & (d.eq_active != 0)):
        a, b = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
        for mine, other in ((a, b), (b, a)):
            part = int(m.site_bodyid[other])
            if mine in dummies and other not in dummies and _is_free(m, part):
                out.append((int(e), part, int(m.site_bodyid[mine])))
    return out


def _is_free(m: mujoco.MjModel, body: int) -> bool:
    return body > 0 and int(m.body_jntnum[body]) == 1 and int(m.jnt_type[m.body_jntadr[body]]) == _FREE


def child_wrench(world, sensor: SceneObject) -> tuple[np.ndarray, np.ndarray] | None:
    """The force (3,) N and torque (3,) N·m that ``sensor``'s child side exerts on its parent
    side, in the sensor's frame, the torque about the sensor's origin: what CoppeliaSim's
    ``sim.readForceSensor`` reads (see the module's docstring). Includes the child side's inertial
    forces (the accelerations of the world's last ``mj_forward``).

    The bodies of the child side joined to the parent side in MuJoCo's tree transmit their
    ``cfrc_int``; a grasped part (a weld of :mod:`simx_server.sim.grasps`) held on or by the
    child side transmits what holds it rigidly (:func:`_rigid_hold`), as V-REP's link holds it.
    Both are computed by ``mj_rnePostConstraint`` with the grasp welds' forces left out (and put
    back after), so that each load counts once, through its rigid hold.

    Args:
        world: the :class:`~simx_server.sim.world.World`, after ``mj_forward``.
        sensor: a force sensor.

    The answer is kept while the state is the same (the world's ``version``, which every
    ``World.changed`` moves on, and the writes that change the reading without it: a weld switched,
    gravity, forces applied for the next step): a second read of one state computes nothing.

    Returns:
        ``(force, torque)`` (read-only arrays), or None when nothing hangs below the sensor (no
        body on its child side).
    """
    side = _child_side(world, sensor)
    # The state: its version (every World.changed), and what writes change without a new one
    # (sim.setLinkDummy's switch of a weld, gravity, sim.addForce's applied forces).
    d = world.data
    key = (world.version, id(side), d.eq_active.tobytes(), world.model.opt.gravity.tobytes(),
           d.xfrc_applied.tobytes())
    table = _wrenches(d)
    kept = table.get(sensor.handle)
    if kept is None or kept[0] != key:  # the side kept alive with the answer: its id stays its own
        kept = table[sensor.handle] = (key, _wrench_now(world, sensor, side), side)
    return kept[1]  # type: ignore[no-any-return]


#: ``child_wrench``'s last answer per MuJoCo data and sensor: {handle: (key, answer, side)}.
_wrenches = PerObject(lambda d: {})


def _wrench_now(world, sensor: SceneObject, side: _Side) -> tuple[np.ndarray, np.ndarray] | None:
    """:func:`child_wrench` computed now (its arrays read-only: kept and shared)."""
    m, d = world.model, world.data
    mask, roots = side.mask, side.roots  # roots: joined to the parent side
    linked = _linked_parts(world, side.dummies)
    if not roots.size and not mask.any() and not linked:
        return None
    welds = [e for e in (grasps.weld_of(m, name) for name, g in world.grasps.items() if g.held)
             if e >= 0 and d.eq_active[e]] + [e for e, _, _ in linked] if world.grasps or linked else []
    rows = np.flatnonzero((d.efc_type[:d.ne] == _EQUALITY) & np.isin(d.efc_id[:d.ne], welds)) if welds else _NO_ROWS
    kept = d.efc_force[rows].copy() if rows.size else None
    if rows.size:
        d.efc_force[rows] = 0.0
    try:
        mujoco.mj_rnePostConstraint(m, d)  # cacc, cfrc_int, cfrc_ext without the grasp welds
        site = d.site_xpos[sensor.mj_id]
        total = _transmitted(site, d.subtree_com, d.cfrc_int, side)
        holders = {int(m.eq_obj1id[e]): int(m.eq_obj2id[e]) for e in welds}
        for part, holder in holders.items():  # parts held on the child side or by it
            if mask[part] or mask[holder]:
                moving = holder
                for _ in range(len(holders)):  # a part held by a held part moves with the first holder
                    moving = holders.get(moving, moving)
                total += _at(_rigid_hold(m, d, part, moving), d.subtree_com[m.body_rootid[part]], site)
        for _, part, holder in linked:  # shapes linked to a dummy below the sensor
            total += _at(_rigid_hold(m, d, part, holder), d.subtree_com[m.body_rootid[part]], site)
    finally:
        if kept is not None:
            d.efc_force[rows] = kept
            mujoco.mj_rnePostConstraint(m, d)
    rot = d.site_xmat[sensor.mj_id].reshape(3, 3)
    force, torque = -(rot.T @ total[3:]), -(rot.T @ total[:3])  # the parent side's force on the child, reversed
    force.flags.writeable = torque.flags.writeable = False
    return force, torque
