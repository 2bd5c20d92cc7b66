"""A shape's static and respondable flags switched at run time: ``sim_shapeintparam_static``
(3003) and ``sim_shapeintparam_respondable`` (3004) of ``sim.setObjectInt32Param`` /
``simxSetObjectIntParameter``, as CoppeliaSim's ``CShape::setStatic`` and
``CShape::setRespondable`` (coppeliaSimLib ``simSetObjectInt32Param_internal``). Like
CoppeliaSim's, the flags keep their value when the simulation stops.

* respondable: whether the shape's geoms take part in MuJoCo's contacts (``contype`` /
  ``conaffinity`` not both 0), which MuJoCo reads at every step: switching it off zeroes them
  and keeps their values (:attr:`World.respondable_bits`), switching it on gives them back
  (1/1, MuJoCo's default, for geoms that never had any). No recompile, except for a mesh compiled
  without its convex hull (:func:`set_respondable`); scene edits keep the values
  (``scene/kept_state.py``).
* static: a static shape is a body welded to the world (``body_weldid`` 0), a dynamic one a
  free body. MuJoCo fixes a body's joints when it compiles, so the switch rebuilds the scene
  through its spec, as the scene editor does for every edit (the state of everything else
  kept, ``Editor._edit``): a dynamic shape made static loses its free joint and stays where it
  is now (its compiled pose stays the one at the start, so stopping the simulation puts it
  back); a static shape made dynamic gets a free joint, at rest where it is: at the world's
  root, or, hanging from a static shape (a spawner's copy hung under it), taken out of that
  body to the root with V-REP's parent kept in its ``vrep_parent=`` setting, since V-REP
  simulates a dynamic shape that no joint or force sensor links to its parent as a free body
  (simDyn ``CRigidBodyContainerDyn_base::_getShapesToConsiderAsRigidBodies``: every non-static
  shape is a rigid body of its own; ``_updateRigidBodiesFromShapes``: one whose static flag
  changed is made again at the next step; constraints come only from joints, force sensors and
  dummy links, ``_updateConstraintsFromJointsAndForceSensors``). A ``.ttt``'s such shapes load
  the same way (:mod:`simx_server.scene.ttt.convert`). The geoms' contact follows (:func:`simx_server.sim.mechanisms.rigid_contact`): V-REP's
  rigid contact in its static or dynamic form. A shape carried by joints, or one grasped (held by a weld, :mod:`simx_server.sim.grasps`),
  cannot be switched: UnsupportedError.
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_wire.protocol import UnsupportedError
from simx_server.sim import grasps
from simx_server.sim.collisions import collidable
from simx_server.sim.mechanisms import rigid_contact
from simx_server.sim.objects import SceneObject
from simx_server.sim.spec_tools import free_at_root

#: ``sim_shapeintparam_static``, ``sim_shapeintparam_respondable``.
STATIC, RESPONDABLE = 3003, 3004


def is_static(world, obj: SceneObject) -> bool:
    """Whether a shape is static (its body welded to the world).

    Args:
        world: the World.
        obj: a shape.

    Returns:
        True when ``body_weldid`` is 0.
    """
    return int(world.model.body_weldid[obj.mj_id]) == 0


def is_respondable(world, obj: SceneObject) -> bool:
    """Whether a shape is respondable (some geom of it has contact bits).

    Args:
        world: the World.
        obj: a shape.

    Returns:
        True when a geom of its body has ``contype`` or ``conaffinity``.
    """
    m = world.model
    return bool(np.any(collidable(m)[m.geom_bodyid == obj.mj_id]))


def set_respondable(world, obj: SceneObject, value: bool, editor=None) -> None:
    """Switch a shape's geoms in or out of MuJoCo's contacts (see the module). A mesh compiled
    while the shape was not respondable has no convex hull, and MuJoCo's convex collider then
    finds one contact point per touching geom, from the vertices alone: an object resting on
    a table rocks from one support point to the next and creeps. Switched on, such a shape's
    scene is compiled again through ``editor`` (which writes the new contact bits into the
    spec), so that its meshes get their hulls and face contacts (RLBench's procedural objects:
    ``Shape.import_mesh``, made respondable after).

    Args:
        world: the World.
        obj: a shape.
        value: respondable or not.
        editor: the scene editor (``Simulation.editor``), or None (no recompile).
    """
    if is_respondable(world, obj) == value:
        return
    m = world.model
    geoms = np.flatnonzero(m.geom_bodyid == obj.mj_id)
    if not value:
        world.respondable_bits[obj.name] = (m.geom_contype[geoms].copy(), m.geom_conaffinity[geoms].copy())
        m.geom_contype[geoms] = m.geom_conaffinity[geoms] = 0
    else:
        kept = world.respondable_bits.pop(obj.name, None)
        if kept is not None and len(kept[0]) == len(geoms):
            m.geom_contype[geoms], m.geom_conaffinity[geoms] = kept
        else:
            m.geom_contype[geoms] = m.geom_conaffinity[geoms] = 1
    body_contact_bits(m)  # MuJoCo's broad phase tests the body's bits first
    world.changed()
    if value and editor is not None and _hull_missing(m, geoms):
        editor._edit(lambda spec: None)


def _hull_missing(m: mujoco.MjModel, geoms: np.ndarray) -> bool:
    """Whether a mesh geom among ``geoms`` has a mesh compiled without its convex hull."""
    meshes = m.geom_dataid[geoms[m.geom_type[geoms] == mujoco.mjtGeom.mjGEOM_MESH]]
    return bool(meshes.size and np.any(m.mesh_graphadr[meshes] < 0))


def body_contact_bits(model: mujoco.MjModel) -> None:
    """Recompute each body's ``body_contype`` / ``body_conaffinity`` (the OR of its geoms', which
    MuJoCo's broad phase tests before any geom: a body compiled with none never collides) after
    geoms' contact bits were written at run time.

    Args:
        model: the model (its body fields are written).
    """
    model.body_contype[:] = 0
    model.body_conaffinity[:] = 0
    np.bitwise_or.at(model.body_contype, model.geom_bodyid, model.geom_contype)
    np.bitwise_or.at(model.body_conaffinity, model.geom_bodyid, model.geom_conaffinity)


def set_static(sim, obj: SceneObject, static: bool) -> None:
    """Make a dynamic shape static or a static one dynamic (see the module); the scene is
    rebuilt through the scene editor (``sim.editor``).

    Args:
        sim: the simulation (its world and editor).
        obj: a shape.
        static: the new flag.

    Raises:
        UnsupportedError: a shape carried by joints or grasped, a mocap body, or a scene that
            cannot be edited.
    """
    world = sim.world
    if is_static(world, obj) == static:
        return
    m, d, b = world.model, world.data, obj.mj_id
    name = obj.name
    pos, quat = d.xpos[b].copy(), d.xquat[b].copy()
    if static and not grasps.is_free(m, b):
        raise UnsupportedError(f"shape {name!r} moves on joints of the scene: simx makes a shape static by "
                               "taking its free joint away, and it has none")
    held = world.grasps.get(name)
    if held is not None and held.held:
        raise UnsupportedError(f"shape {name!r} is held by {held.parent!r} (a grasp): release it first")
    if not static and (int(m.body_jntnum[b]) or m.body_mocapid[b] >= 0):
        raise UnsupportedError(f"shape {name!r} is a mocap body or moves on joints of the scene")
    hanging = not static and int(m.body_parentid[b]) != 0  # under a static shape: freed to the root
    vrep_parent = world.objects[obj.parent].name if obj.parent in world.objects else "-1"

    def change(spec: mujoco.MjSpec):
        _, body, _ = sim.editor._spec_element(spec, obj.handle)
        if static:
            for joint in list(body.joints):
                spec.delete(joint)
        elif hanging:
            body = free_at_root(spec, name, (pos, quat), vrep_parent)
            sim.editor._placed.add(("body", name))
        else:
            body.add_freejoint()
        for geom in body.geoms:  # a static shape's contact rules its pairs, a dynamic one's does not
            rigid_contact(geom, spec.option.timestep, static)
        return lambda: _place(world, name, pos, quat, static)

    sim.editor._edit(change)


def _place(world, name: str, pos: np.ndarray, quat: np.ndarray, static: bool) -> None:
    """After the rebuild: the shape where it was (a static body: its model pose; a free body:
    its joint's position), at rest."""
    m, d = world.model, world.data
    b = world.by_name[name].mj_id
    if static:
        m.body_pos[b], m.body_quat[b] = pos, quat  # a run-time placement: reset() restores the start
    else:
        j = int(m.body_jntadr[b])
        qa, da = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        d.qpos[qa:qa + 3], d.qpos[qa + 3:qa + 7] = pos, quat
        d.qvel[da:da + 6] = 0.0
    world.changed()
