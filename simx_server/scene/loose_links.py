"""A joint or force sensor links its parent shape to its child only while it has exactly one
child: CoppeliaSim's dynamics plugins make a joint's (or force sensor's) constraint, and keep
it, only when the object has one child (simExtDynamics 4.1
``CRigidBodyContainerDyn::_addOrUpdateJointConstraint`` and
``_addOrUpdateForceSensorConstraint``: a child count of 1; ``_updateConstraintsFromSceneJoints``
and ``_updateConstraintsFromSceneForceSensors``, at each step, remove one whose joint or sensor
no longer has exactly one child). A dynamic shape
re-parented at run time under a joint or force sensor that already has a child is therefore
linked by nothing: its engine simulates it as a free body.

RLBench's open_wine_bottle does this: once the cap has turned, the task re-parents the cap from
its force sensor to the bottle's joint, whose other child is the shape the joint turns; the
gripper then lifts the cap off. In simx a shape linked through a joint or force sensor is a
MuJoCo body of the chain (:mod:`simx_server.scene.ttt.convert`), so :func:`free` takes its body
out of the chain: a child of the world with a free joint, where it is now, with its velocity
(a recompile, through the scene editor), and force-sensor sites its body carried go to the
bodies of their own V-REP parents. A part held by a weld (:mod:`simx_server.sim.grasps`) under
such a parent is let go instead. The joint's (or sensor's) first child stays on it in MuJoCo's
tree: the joint keeps turning what it turned (in CoppeliaSim that child is free too).
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_server.sim import grasps
from simx_server.sim.objects import FORCE_SENSOR, JOINT, SHAPE, WORLD, SceneObject
from simx_server.sim.spec_tools import (
    _MARK,
    _QUAT,
    _REFERRING_LISTS,
    _clone,
    _compose,
    _inverse,
    free_at_root,
)
from simx_wire.protocol import UnsupportedError


def links_nothing(world, parent: SceneObject | None, child: int) -> bool:
    """Whether ``parent`` would link nothing once ``child`` is one of its children: a joint or
    force sensor with another child already (``CRigidBodyContainerDyn``'s ``childrenCount==1``).

    Args:
        world: the World.
        parent: the new V-REP parent, or None (the world).
        child: the handle of the object to be re-parented.

    Returns:
        True for a joint or force sensor that has a child other than ``child``.
    """
    if parent is None or parent.type not in (JOINT, FORCE_SENSOR):
        return False
    return any(o.parent == parent.handle and o.handle != child for o in world.objects.values())


def free(editor, part: SceneObject, parent: SceneObject, keep_in_place: bool) -> None:
    """Re-parent dynamic shape ``part`` under ``parent`` (a joint or force sensor that links
    nothing, :func:`links_nothing`) as a free body: V-REP's tree shows ``parent``, MuJoCo's body
    is a child of the world with a free joint (see the module).

    Args:
        editor: the scene's :class:`~simx_server.scene.editor.Editor`.
        part: a shape whose body moves (in a chain, or a free body).
        parent: its new V-REP parent.
        keep_in_place: keep the part's world pose (else its pose relative to its old parent,
            now relative to ``parent``, as CoppeliaSim's ``setObjectParent``).

    Raises:
        UnsupportedError: MuJoCo cannot make the edit (references to the part's body lost).
    """
    world = editor.sim.world
    rel = None if keep_in_place else world.relative_frame(part.handle, part.parent)
    m = world.model
    if grasps.is_free(m, part.mj_id):  # a dynamic shape at the world's root: nothing to take out
        grasps.release(world, part, parent)
    else:
        _take_out(editor, part, parent)
        part = world.by_name[part.name]
    if rel is not None:
        world.set_pose(part.handle, parent.handle, list(rel[0]), rel[1])
    world.changed()


def let_go_of_others(world, parent: SceneObject, part: int) -> None:
    """Let go of every part that ``parent`` holds by a weld besides ``part``: with a second child
    the joint or force sensor links none of them (see the module).

    Args:
        world: the World.
        parent: a joint or force sensor.
        part: the handle of the object being re-parented under it.
    """
    for o in list(world.objects.values()):
        g = world.grasps.get(o.name)
        if o.handle != part and o.parent == parent.handle and g is not None and g.held:
            grasps.release(world, o, parent)


def _take_out(editor, part: SceneObject, parent: SceneObject) -> None:
    """Move ``part``'s body (with its subtree) under the world with a free joint, where it is,
    with its velocity; force-sensor sites in it go to their V-REP parents' bodies."""
    world = editor.sim.world
    m, d = world.model, world.data
    b = part.mj_id
    here = (d.xpos[b].copy(), d.xquat[b].copy())
    vel = np.empty(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, b, vel, 0)  # [rot, lin], world axes
    spin, back = np.empty(3), np.empty(4)
    mujoco.mju_negQuat(back, here[1])
    mujoco.mju_rotVecQuat(spin, vel[:3], back)  # a free joint's angular velocity is in body axes
    sites = [o for o in world.objects.values() if o.type == FORCE_SENSOR and o.body == b
             and o.parent != part.handle and o.parent != WORLD]
    site_poses = {o.name: _site_world(world, o) for o in sites}
    name = part.name

    def change(spec: mujoco.MjSpec):
        counts = {n: len(getattr(spec, n)) for n in _REFERRING_LISTS}
        for o in sites:
            host = world.objects[o.parent]
            target = spec.body(host.name) if host.type == SHAPE else editor._carrier(spec, host)
            el = spec.site(o.name)
            moved = _clone("site", el, target, o.name + _MARK)
            spec.delete(el)
            host_body = host.mj_id if host.type == SHAPE else host.body
            moved.pos, moved.quat = _compose(_inverse((d.xpos[host_body], d.xquat[host_body])), site_poses[o.name])
            moved.alt.type = _QUAT
            editor._placed.add(("site", o.name))
        lost = [n for n in _REFERRING_LISTS if len(getattr(spec, n)) < counts[n]]
        if lost:
            raise UnsupportedError(f"freeing {name!r} from {parent.name!r} would lose {', '.join(lost)}")
        free_at_root(spec, name, here, parent.name)
        editor._placed.add(("body", name))
        return lambda: _start(world, name, here, vel[3:], spin)

    editor._edit(change)


def _site_world(world, o: SceneObject) -> tuple[np.ndarray, np.ndarray]:
    d = world.data
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, d.site_xmat[o.mj_id])
    return d.site_xpos[o.mj_id].copy(), q


def _start(world, name: str, here: tuple, linear: np.ndarray, spin: np.ndarray) -> None:
    """After the rebuild: the free body at its pose, moving as it moved."""
    m, d = world.model, world.data
    b = world.by_name[name].mj_id
    j = int(m.body_jntadr[b])
    qa, da = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
    d.qpos[qa:qa + 3], d.qpos[qa + 3:qa + 7] = here
    d.qvel[da:da + 3], d.qvel[da + 3:da + 6] = linear, spin
    mujoco.mj_forward(m, d)
