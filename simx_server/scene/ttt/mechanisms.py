"""V-REP's linked mechanisms in a converted scene (:mod:`simx_server.scene.ttt.convert`):
dependent joints, dynamics loop closures and joint limits, as MuJoCo constraints that hold
under the motors' forces (:mod:`simx_server.sim.mechanisms` says why they are stiffened).

* A **dependent joint** (V-REP's joint mode 4, or an old IK-dependent joint with a master):
  ``q = offset + mult * q_master`` as MuJoCo's joint equality, the relation on positions
  (CoppeliaSim's ``CJoint::setDependencyParams``; its MuJoCo plugin's ``<equality><joint
  polycoef>``, ``simDyn``'s ``CRigidBodyContainerDyn``).
* A **dynamics loop closure** (two dummies linked with ``sim_dummy_linktype_dynamics_loop_closure``,
  V-REP's "dynamic, overlap constraint"): the two dummies' frames overlap, position and
  orientation, as CoppeliaSim's MuJoCo plugin writes it (a ``<weld>`` between the dummies'
  parents with the dummies' relative pose; here a weld of the two sites). A connect (position
  only) leaves a parallel gripper's fingers free to turn: V-REP's RG2 then swings both fingers
  one way instead of mirroring them.
* **Joint limits** are hard in V-REP's engines: every limited joint gets the stiff limit.
* **Armature**: V-REP's engines give no joint a rotor inertia. MuJoCo needs one where a motor or a
  spring acts on a light link, and in a closed mechanism, whose light links the stiff loop and
  joint equalities couple to the motor that drives them (without it a gripper's linkage of a
  few grams stops short of its stroke or keeps oscillating): those joints get
  :data:`DRIVEN_ARMATURE`, every other joint none.
"""

from __future__ import annotations

import mujoco

from simx_server.scene.ttt.model import TttObject
from simx_server.sim.mechanisms import LIMIT_SOLIMP, LOOP_SOLIMP, dependency_polycoef, stiff_solref

LOOP_CLOSURE = 0  # sim_dummy_linktype_dynamics_loop_closure
#: The rotor inertia (kg m^2, or kg for a prismatic joint) simx gives a driven joint and the
#: joints of a closed mechanism (see the module).
DRIVEN_ARMATURE = 0.01


def stiff_limit(conv, jt) -> None:
    """Give the MjSpec joint ``jt`` a limit that holds under its motor (see the module)."""
    jt.solref_limit = stiff_solref(conv.spec.option.timestep)
    jt.solimp_limit = list(LIMIT_SOLIMP)


def dependent(conv, obj: TttObject) -> bool:
    """Record the dependent joint ``obj`` (its equality is added by :func:`add_loop_closures`,
    once every joint exists). False (and a report line) when its master is missing or is not a
    joint: V-REP then moves it as a free joint."""
    j = obj.data
    master = conv.scene.objects.get(j.dependency[0]) if j.dependency else None
    if master is None or master.kind != "joint" or master.handle == obj.handle:
        conv.report.add("dependent joints without their master (left free)")
        return False
    if master.data.type not in (10, 11):
        conv.report.add("dependent joints on spherical masters (left free)")
        return False
    mult, off = j.dependency[1], j.dependency[2]
    conv.deferred_equalities.append((obj.name, master.name, off, mult, j.position, master.data.position))
    return True


def add_loop_closures(conv) -> None:
    """Dummy pairs linked as dynamics loop closures as site welds, and the dependent joints'
    equalities (:func:`dependent`), all stiff (see the module)."""
    solref = stiff_solref(conv.spec.option.timestep)
    done = set()
    for obj in conv.scene.objects.values():
        if obj.kind != "dummy" or obj.data.linked < 0 or obj.data.link_type != LOOP_CLOSURE:
            continue
        other = conv.scene.objects.get(obj.data.linked)
        pair = frozenset((obj.handle, obj.data.linked))
        if pair in done:
            continue
        done.add(pair)
        if other is None or other.kind != "dummy" or other.handle == obj.handle:
            conv.report.add("loop closures to a missing dummy (left open)")
            continue
        eq = conv.spec.add_equality()
        eq.name = f"loop:{obj.name}:{other.name}"
        eq.type = mujoco.mjtEq.mjEQ_WELD
        eq.objtype = mujoco.mjtObj.mjOBJ_SITE
        eq.name1, eq.name2 = obj.name, other.name
        eq.data[10] = 1.0  # torquescale: CoppeliaSim's default (mujoco.overlapConstrTorquescale)
        eq.solref, eq.solimp = solref, list(LOOP_SOLIMP)
        _driven(_loop_joints(conv.spec, obj.name, other.name))
    for dep, master, off, mult, q0, q0_master in conv.deferred_equalities:
        eq = conv.spec.add_equality()
        eq.type = mujoco.mjtEq.mjEQ_JOINT
        eq.name1, eq.name2 = dep, master
        eq.data[:5] = dependency_polycoef(q0, q0_master, off, mult)
        eq.solref, eq.solimp = solref, list(LOOP_SOLIMP)
        _driven([conv.spec.joint(dep), conv.spec.joint(master)])


def bodies_up(body) -> list:
    """The MjSpec body ``body`` and its ancestors below the world, nearest first (none for the
    world or None)."""
    out = []
    while body is not None and body.name != "world":
        out.append(body)
        body = body.parent
    return out


def _loop_joints(spec: mujoco.MjSpec, site1: str, site2: str) -> list:
    """The joints on the tree path between the bodies that carry two sites (a closed loop's
    joints: from each body up to, not including, their deepest common ancestor)."""
    one, two = ([] if s is None else bodies_up(s.parent) for s in (spec.site(site1), spec.site(site2)))
    shared = {b.name for b in one} & {b.name for b in two}
    return [j for b in one + two if b.name not in shared for j in b.joints]


def _driven(joints: list) -> None:
    """Give joints that have none :data:`DRIVEN_ARMATURE` (a joint MjSpec could not find is None)."""
    for j in joints:
        if j is not None and j.armature == 0:
            j.armature = DRIVEN_ARMATURE
