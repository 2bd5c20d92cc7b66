"""``sim.setObjectParent`` on a dynamic shape: grasping and releasing (:mod:`simx_server.sim.grasps`
holds the part; this module adds its weld to the scene's spec the first time, through the scene
editor, and handles ``keepInPlace``).

A dynamic shape is a MuJoCo free body, which MuJoCo keeps among the world's children, so
re-parenting one under another object does not move its body: it is held by a weld switched on
at run time, and the logical tree shows the new parent (``sim.getObjectParent``, poses relative
to it, ``sim.getObjectsInTree``). The first grasp adds a weld for every dynamic shape of the
scene that has none (one recompile: an inactive ``simx_grasp:PART`` weld to the world each,
retargeted at each grasp); later grasps and releases change only the welds' state, not the
model's structure (a model loaded later gets its welds at the first grasp of one of its parts).

CoppeliaSim (``CSceneObject::setParent``) keeps a re-parented object's absolute pose, or with
``keepInPlace`` false its local pose, now relative to the new parent; its dynamics engine
(simExtDynamics' ``CRigidBodyContainerDyn::reportRigidBodyConfigurationsAndVelocities``) moves a
non-static shape hung from a non-joint parent by itself. simx holds it to a new parent that
moves on joints (or is itself held) instead (what pick-and-place programs and PyRep's
``Gripper.grasp`` expect of a re-parented part: that it follows the gripper), and leaves it
free under the world, an object fixed to it, or another dynamic shape (``grasps.holds``). A force sensor always holds its dynamic child, fixed to the world or not:
CoppeliaSim's dynamics plugins join a dynamic shape to its force-sensor parent rigidly
(simMujoco's ``CRigidBodyContainerDyn::_addObjectBranch``: "dyn. shape attached to force
sensor"), and the sensor reads what the weld carries (:mod:`simx_server.sim.force_sensors`).
"""

from __future__ import annotations

import mujoco

from simx_server.sim import grasps
from simx_server.sim.mechanisms import GRASP_SOLIMP, stiff_solref
from simx_server.sim.objects import FORCE_SENSOR, SHAPE, WORLD, SceneObject


def hold(editor, part: SceneObject, parent: SceneObject | None, keep_in_place: bool) -> None:
    """Hang the free body ``part`` from ``parent``: held when ``parent``'s body can move (a
    grasp) or ``parent`` is a force sensor, free under the world (None), another object fixed
    to it or a free dynamic shape (a release; ``grasps.holds``).

    Args:
        editor: the scene's :class:`~simx_server.scene.editor.Editor`.
        part: a shape whose body has a free joint.
        parent: the new parent, any object but ``part`` and its descendants, or None.
        keep_in_place: keep the part's world pose (else its pose relative to its parent is
            kept, now relative to the new parent; its velocity is then zeroed).

    Raises:
        UnsupportedError: the scene cannot be edited to add the part's weld (first grasp).
    """
    world = editor.sim.world
    rel = None if keep_in_place else world.relative_frame(part.handle, part.parent)
    if parent is None or (parent.type != FORCE_SENSOR and not grasps.holds(world, parent)):
        grasps.release(world, part, parent)
        if rel is not None:
            world.set_pose(part.handle, WORLD if parent is None else parent.handle, list(rel[0]), rel[1])
        world.changed()
        return
    if rel is not None:
        world.set_pose(part.handle, parent.handle, list(rel[0]), rel[1])
    if grasps.weld_of(world.model, part.name) < 0:
        name, parent_name = part.name, parent.name
        m = world.model
        free = [o for o in world.objects.values() if o.type == SHAPE and grasps.is_free(m, o.mj_id)
                and grasps.weld_of(m, o.name) < 0]  # every free part at once: one recompile
        editor._edit(lambda spec: [_add_weld(editor, spec, o) for o in free])
        part, parent = world.by_name[name], world.by_name[parent_name]
    grasps.attach(world, part, parent)
    world.changed()


def _add_weld(editor, spec: mujoco.MjSpec, part: SceneObject) -> None:
    """Add the inactive weld that will hold ``part`` (to the world; its other body is set at
    each grasp). Stiff, as V-REP's rigid attachment: two timesteps, MuJoCo's highest impedance
    (:data:`~simx_server.sim.mechanisms.GRASP_SOLIMP`)."""
    _, body, _ = editor._spec_element(spec, part.handle)
    eq = spec.add_equality()
    eq.name = grasps.weld_name(part.name)
    eq.type = mujoco.mjtEq.mjEQ_WELD
    eq.objtype = mujoco.mjtObj.mjOBJ_BODY
    eq.name1, eq.name2 = body.name, "world"
    eq.active = False
    eq.data[10] = 1.0
    eq.solref, eq.solimp = stiff_solref(spec.option.timestep), list(GRASP_SOLIMP)
