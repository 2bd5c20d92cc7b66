"""Grasping: a dynamic shape (a MuJoCo free body) hung from another object by
``sim.setObjectParent(part, gripperAttachPoint, true)``, as pick-and-place programs and PyRep's
``Gripper.grasp`` hold what they pick, and given back to the world by
``sim.setObjectParent(part, -1, true)``, or to an object that does not move (PyRep's
``Gripper.release`` gives the part back to its old parent, often a task's static dummy).

Which parents hold (:func:`holds`): an object carried by a body that moves on joints or as a
mocap body, or by a free body that is itself held, and a force sensor wherever it is
(CoppeliaSim joins a dynamic shape to its force-sensor parent). Under the world, another object
fixed to it, or another dynamic shape the part stays free, only its logical parent changes, as
CoppeliaSim's engines simulate a dynamic shape under a static or a dynamic one by itself.

MuJoCo allows free joints only in children of the world, so the part's body stays where it is
and a weld equality named ``simx_grasp:PART`` (added to the model once per part, inactive, by
:mod:`simx_server.scene.grasping`) holds it to the body that carries the new parent: at grasp
time the weld's other body (``eq_obj2id``) and its relative pose (``eq_data``) are written from
the current poses and the weld is switched on (``eq_active``); no recompile. After any command
that moves the parent (a joint set, a pose set), the part is put back exactly at its pose
relative to that body (:func:`follow`): it moves with the parent as a CoppeliaSim child does.
A physics step leaves it where the engine put it: the weld holds it, its weight loads the
gripper, and what it meets stops it (and the gripper through it). CoppeliaSim's dynamics plugins
hold a dynamic shape to its force-sensor parent by a constraint the engine solves with the
contacts (Bullet 2.78's ``CConstraintDyn::init`` for a force sensor: a locked
``btGeneric6DofConstraint``) and report the shape's pose from the engine after each step, the
link's deviation kept as the sensor's intrinsic error (``CRigidBodyDyn_base::
reportConfigurationToShape``), never the pose its parent would give it. Release switches the
weld off: the part falls from its current pose with its current velocity (the gripper's).

The logical tree (``sim.getObjectParent``, poses relative to the parent, ``getObjectsInTree``)
shows the new parent. Stopping the simulation (``World.reset``) lets every part go and gives it
back its parent at the start, as CoppeliaSim's ``CSceneObject::simulationEnded_restoreHierarchy``
restores the hierarchy; an edit (``World.replace_model``) keeps the grasps whose part, parent and
weld are still there.

The record of the grasps is ``World.grasps``: part name -> :class:`Grasp`.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from simx_server.sim.objects import SHAPE, WORLD, SceneObject

#: Name prefix of the weld equality that holds a grasped part (``simx_grasp:`` + the part's name).
PREFIX = "simx_grasp:"
_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


@dataclass
class Grasp:
    """One grasped part: what holds it (names, so that it survives an edit's new model)."""

    parent: str  #: the V-REP parent object's name
    body: str  #: the MuJoCo body that carries the parent ("world": body 0)
    relpose: np.ndarray  #: (7,) that body's pose in the part's frame (MuJoCo's weld ``relpose``)
    home: int  #: the part's parent handle before its first grasp (given back on reset)
    held: bool = True  #: False: a parent that does not move (the part is free, only its parent changed)


def weld_name(part: str) -> str:
    """The name of the weld equality that holds a part.

    Args:
        part: the part's name.

    Returns:
        ``simx_grasp:`` + ``part``.
    """
    return PREFIX + part


def is_free(m: mujoco.MjModel, body: int) -> bool:
    """Whether a MuJoCo body moves freely (one free joint: a dynamic shape).

    Args:
        m: the model.
        body: a body id.

    Returns:
        True for a body other than the world whose only joint is a free joint.
    """
    return body > 0 and int(m.body_jntnum[body]) == 1 and int(m.jnt_type[m.body_jntadr[body]]) == _FREE


def weld_of(m: mujoco.MjModel, part: str) -> int:
    """The weld equality made for a part.

    Args:
        m: the model.
        part: the part's name.

    Returns:
        Its equality id, or -1 when the model has none.
    """
    return int(mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, weld_name(part)))


def moves(m: mujoco.MjModel, body: int) -> bool:
    """Whether a MuJoCo body can move (a joint above it, or a mocap body): what holds a part.

    Args:
        m: the model.
        body: a body id (0: the world).

    Returns:
        False for the world and the bodies welded to it (``body_weldid`` 0).
    """
    return int(m.body_weldid[body]) != 0


def holds(world, parent: SceneObject) -> bool:
    """Whether re-parenting a dynamic shape under ``parent`` holds it there: ``parent``'s body
    moves on joints or as a mocap body, or it is a free body held itself (a grasped part, a part
    under a force sensor). A free body that is not held (another dynamic shape) does not hold:
    CoppeliaSim's engines simulate a dynamic shape under a dynamic shape by itself
    (simExtDynamics ``CRigidBodyContainerDyn::reportRigidBodyConfigurationsAndVelocities``), as
    a dynamic shape under a static object.

    Args:
        world: the World.
        parent: the new parent.

    Returns:
        True when the part is to be held.
    """
    m = world.model
    body = carrier(parent)
    if not moves(m, body):
        return False
    root = int(m.body_weldid[body])  # the body that moves, with those welded to it
    if not is_free(m, root):
        return True
    names = [o.name for o in world.objects.values() if o.type == SHAPE and o.mj_id == root]
    return any(n in world.grasps and world.grasps[n].held for n in names)


def carrier(obj: SceneObject) -> int:
    """The MuJoCo body that carries an object (a shape is its body).

    Args:
        obj: the object.

    Returns:
        The body id (0: the world).
    """
    return obj.mj_id if obj.type == SHAPE else obj.body


def _pose(d: mujoco.MjData, body: int) -> tuple[np.ndarray, np.ndarray]:
    return d.xpos[body].copy(), d.xquat[body].copy()


def _relative(a: tuple, b: tuple) -> np.ndarray:
    """Pose ``b`` seen from pose ``a``, as (7,) position + quaternion."""
    qinv, q, p = np.empty(4), np.empty(4), np.empty(3)
    mujoco.mju_negQuat(qinv, a[1])
    mujoco.mju_mulQuat(q, qinv, b[1])
    mujoco.mju_rotVecQuat(p, b[0] - a[0], qinv)
    return np.concatenate([p, q])


def _weld_data(m: mujoco.MjModel, e: int, relpose: np.ndarray) -> None:
    """Hold the part of weld ``e`` at ``relpose`` (the holder's pose in the part's frame, (7,)),
    the weld's point at the part's origin. MuJoCo's body weld joins the point ``eq_data[3:6]`` of
    its first body (the part) to the point ``eq_data[0:3]`` of its second (the holder) and turns
    the first by ``eq_data[6:10]`` relative to the second: with the point at the holder's origin,
    an error of the part's orientation moved the part by that angle times its distance from the
    holder's origin (a part 1.35 m from the world's origin, held by a sensor fixed to the world,
    swung 2 cm)."""
    rel = np.asarray(relpose, float)
    qinv, origin = np.empty(4), np.empty(3)
    mujoco.mju_negQuat(qinv, rel[3:])
    mujoco.mju_rotVecQuat(origin, -rel[:3], qinv)  # the part's origin in the holder's frame
    m.eq_data[e][:3] = origin
    m.eq_data[e][3:6] = 0.0
    m.eq_data[e][6:10] = rel[3:]


def attach(world, part: SceneObject, parent: SceneObject, relpose: np.ndarray | None = None) -> None:
    """Hold free body ``part`` to the body carrying ``parent`` by its weld, at their current
    relative pose (or ``relpose``); ``part``'s V-REP parent becomes ``parent``. The model must
    have the part's weld (:func:`weld_of`).

    Args:
        world: the World.
        part: a shape whose body is free (:func:`is_free`).
        parent: the object that holds it.
        relpose: (7,) the carrier's pose in the part's frame (m, quaternion w x y z), or None
            for the current one.

    Raises:
        KeyError: the model has no weld for ``part``.
    """
    m, d = world.model, world.data
    e = weld_of(m, part.name)
    if e < 0:
        raise KeyError(weld_name(part.name))
    body = carrier(parent)
    mujoco.mj_kinematics(m, d)
    if relpose is None:
        relpose = _relative(_pose(d, part.mj_id), _pose(d, body))
    m.eq_obj1id[e], m.eq_obj2id[e] = part.mj_id, body
    _weld_data(m, e, relpose)
    m.eq_data[e][10] = 1.0  # torquescale: orientation held as firmly as position
    d.eq_active[e] = 1
    old = world.grasps.get(part.name)
    home = old.home if old is not None else part.parent
    world.grasps[part.name] = Grasp(parent.name, mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, body) or "world",
                                    np.asarray(relpose, float).copy(), home)
    part.parent = parent.handle


def release(world, part: SceneObject, parent: SceneObject | None = None) -> None:
    """Let ``part`` go: its weld off, its V-REP parent ``parent`` (the world, or an object that
    does not move: the part stays free, as a dynamic shape under a static object in
    CoppeliaSim); it keeps its pose and velocity.

    Args:
        world: the World.
        part: a free part, grasped or not.
        parent: its new V-REP parent; None: the world.
    """
    e = weld_of(world.model, part.name)
    if e >= 0:
        world.data.eq_active[e] = 0
    old = world.grasps.pop(part.name, None)
    home = old.home if old is not None else part.parent
    handle = WORLD if parent is None else parent.handle
    if handle != home:  # remembered, so that an edit's new registry keeps it (until a stop)
        world.grasps[part.name] = Grasp("" if parent is None else parent.name, "", np.zeros(7), home, held=False)
    part.parent = handle


def placed(world, part: SceneObject) -> None:
    """``part`` was placed by a command while grasped: it keeps its new pose relative to the
    body that holds it (as a child placed in its parent's frame).

    Args:
        world: the World.
        part: the part placed (not grasped: nothing happens).
    """
    g = world.grasps.get(part.name)
    e = weld_of(world.model, part.name)
    if g is None or not g.held or e < 0:
        return
    m, d = world.model, world.data
    mujoco.mj_kinematics(m, d)
    g.relpose = _relative(_pose(d, part.mj_id), _pose(d, int(m.eq_obj2id[e])))
    _weld_data(m, e, g.relpose)


def held_parts(world) -> list[tuple[int, int, np.ndarray]]:
    """The grasped parts that follow their holder now, as :func:`place_held` takes them.

    Args:
        world: the World.

    Returns:
        ``(part body, holder body, relpose (7,))`` of each held part, in grasp order.
    """
    m = world.model
    out = []
    for name, g in world.grasps.items():
        if not g.held:
            continue
        obj = world.by_name.get(name)
        body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, g.body) if g.body != "world" else 0
        if obj is None or body < 0 or not is_free(m, obj.mj_id):
            continue
        out.append((int(obj.mj_id), int(body), np.array(g.relpose, float)))
    return out


def place_held(m: mujoco.MjModel, d: mujoco.MjData, held: list[tuple[int, int, np.ndarray]]) -> None:
    """Put each held part exactly at its pose relative to its holder's body in ``d`` (its free
    joint's position; velocity kept), from the holders' poses by ``mj_kinematics``; the caller
    computes ``d``'s poses again afterwards (``mj_kinematics`` or ``mj_forward``).

    Args:
        m: the model.
        d: its data (the world's, or a scratch copy).
        held: ``(part body, holder body, relpose (7,))`` (:func:`held_parts`).
    """
    if not held:
        return
    mujoco.mj_kinematics(m, d)
    qinv, q, p = np.empty(4), np.empty(4), np.empty(3)
    for part, body, relpose in held:
        # the part's pose: the holder's pose composed with the inverse of relpose
        mujoco.mju_negQuat(qinv, relpose[3:])
        mujoco.mju_mulQuat(q, d.xquat[body], qinv)
        mujoco.mju_rotVecQuat(p, relpose[:3], q)
        a = int(m.jnt_qposadr[m.body_jntadr[part]])
        d.qpos[a:a + 3] = d.xpos[body] - p
        d.qpos[a + 3:a + 7] = q
        if len(held) > 1:  # a part held by another grasped part follows it
            mujoco.mj_kinematics(m, d)


def follow(world) -> None:
    """Put every grasped part exactly at its pose relative to the body that holds it (its
    free joint's position; velocity kept). Runs before ``mj_forward`` in ``World.changed`` after
    a command, not after a physics step (the module's docstring).

    Args:
        world: the World.
    """
    place_held(world.model, world.data, held_parts(world))


def let_all_go(world) -> None:
    """``World.reset``: every grasp ends, each part back under its parent at the start (the
    welds' state comes back with the model's initial fields and ``mj_resetData``).

    Args:
        world: the World.
    """
    for name, g in world.grasps.items():
        obj = world.by_name.get(name)
        if obj is not None:
            obj.parent = g.home
    world.grasps.clear()


def reapply(world, grasps: dict[str, Grasp]) -> None:
    """After ``World.replace_model``: hold again each part of ``grasps`` whose part, parent and
    weld are in the new model (the others are let go).

    Args:
        world: the World, its new model installed.
        grasps: the grasps before the edit.
    """
    for name, g in grasps.items():
        part, parent = world.by_name.get(name), world.by_name.get(g.parent)
        if part is None or not is_free(world.model, part.mj_id) or (parent is None and g.parent):
            continue
        if g.held and weld_of(world.model, name) >= 0:
            attach(world, part, parent, g.relpose)
        elif not g.held:
            release(world, part, parent)
        else:
            continue
        world.grasps[name].home = g.home
