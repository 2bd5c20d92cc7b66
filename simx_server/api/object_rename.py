"""Renaming a scene object through the scene editor (``sim.setObjectName``,
``sim.setObjectAlias``, :mod:`simx_server.api.sim.objects`): the object
keeps its handle, its pose, its joint state and its child script across the recompiled model.
"""

from __future__ import annotations

import mujoco

from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import quote
from simx_server.sim.spec_tools import _FRAMES, _KIND, _MJ_OBJ
from simx_server.sim.state import SimulationView
from simx_server.sim import paths
from simx_server.sim.world import JOINT, SHAPE, WORLD, World


def _joint_ids(world: World, obj) -> list[int]:
    """MuJoCo joints whose state replace_model matches by the object's name (itself, or a
    free body's free joint)."""
    m = world.model
    if obj.type == JOINT:
        return [obj.mj_id]
    if obj.type == SHAPE and m.body_jntnum[obj.mj_id] == 1 \
            and m.jnt_type[m.body_jntadr[obj.mj_id]] == mujoco.mjtJoint.mjJNT_FREE:
        return [int(m.body_jntadr[obj.mj_id])]
    return []


def _retarget(spec: mujoco.MjSpec, kind: str, old: str, new: str) -> None:
    """Point the actuators, sensors, constraints and settings that name ``old`` (an element of
    ``kind``) at ``new``: MjSpec refers by name and does not follow a rename."""
    objtype = _MJ_OBJ[kind]
    trn = {"joint": (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT),
           "site": (mujoco.mjtTrn.mjTRN_SITE, mujoco.mjtTrn.mjTRN_SLIDERCRANK),
           "body": (mujoco.mjtTrn.mjTRN_BODY,)}.get(kind, ())
    for a in spec.actuators:
        if a.trntype in trn and a.target == old:
            a.target = new
        if kind == "site":
            a.refsite = new if a.refsite == old else a.refsite
            a.slidersite = new if a.slidersite == old else a.slidersite
    for s in spec.sensors:
        if s.objtype == objtype and s.objname == old:
            s.objname = new
        if s.reftype == objtype and s.refname == old:
            s.refname = new
    for eq in spec.equalities:
        same = (eq.type == mujoco.mjtEq.mjEQ_JOINT) if kind == "joint" else (eq.objtype == objtype)
        if same:
            eq.name1 = new if eq.name1 == old else eq.name1
            eq.name2 = new if eq.name2 == old else eq.name2
    if kind == "body":
        for ex in spec.excludes:
            ex.bodyname1 = new if ex.bodyname1 == old else ex.bodyname1
            ex.bodyname2 = new if ex.bodyname2 == old else ex.bodyname2
        for el in list(spec.cameras) + list(spec.lights):
            if el.targetbody == old:
                el.targetbody = new
    text = spec.text(f"simx:{old}")
    if text is not None:
        text.name = f"simx:{new}"
        # a converted .ttt's own alias (simx_server.sim.paths) follows the new name
        text.data = " ".join(f"alias={paths.alias(new)}" if i.startswith("alias=") else i for i in text.data.split())
    for t in spec.texts:  # and so do the V-REP parents that name it
        if t.name.startswith("simx:") and f"vrep_parent={old}" in t.data.split():
            t.data = " ".join(f"vrep_parent={new}" if i == f"vrep_parent={old}" else i for i in t.data.split())


def rename(sim: SimulationView, handle: int, name: str) -> None:
    """Give object ``handle`` the name ``name`` through the scene editor; it keeps its handle,
    its pose (also one set at run time), its joint state and its child script.

    Raises ArgumentError (the world, a name taken by another object), or the editor's errors
    (UnsupportedError for an object MuJoCo cannot rename, the scene's growth bounds).

    Args:
        sim: the simulation (world and scene editor).
        handle: the object's handle.
        name: the new name (checked by the caller).
    """
    world, editor = sim.world, sim.editor
    if handle == WORLD:
        raise ArgumentError("the world (-1) has no name to change")
    obj = world.get(handle)
    old = obj.name
    if name == old:
        return
    if name in world.by_name:
        raise ArgumentError(f"name {quote(name)} is taken by another object "
                            f"(handle {world.by_name[name].handle})")
    m, d = world.model, world.data
    kind = _KIND.get(obj.type)
    frame = _FRAMES.get(kind)  # the placement in its body, which may have been set at run time
    placed = tuple(getattr(m, f)[obj.mj_id].copy() for f in frame[:2]) if frame else None
    states = [(d.qpos[m.jnt_qposadr[j]:m.jnt_qposadr[j] + _joint_size(m, j)[0]].copy(),
               d.qvel[m.jnt_dofadr[j]:m.jnt_dofadr[j] + _joint_size(m, j)[1]].copy()) for j in _joint_ids(world, obj)]
    mocap = None  # a mocap body's pose lives in MjData, matched by name too
    if obj.type == SHAPE and m.body_mocapid[obj.mj_id] >= 0:
        k = m.body_mocapid[obj.mj_id]
        mocap = (d.mocap_pos[k].copy(), d.mocap_quat[k].copy())
    names = world._handle_of_name  # replace_model keeps a handle for a known name: give it the new one

    def change(spec: mujoco.MjSpec) -> None:
        kind_, el, _ = editor._spec_element(spec, handle)
        el.name = name
        editor._renamed[old] = name  # what commands changed in it at run time follows the name
        _retarget(spec, kind_, old, name)
        names[name] = handle

    try:
        editor._edit(change)
    except BaseException:
        if names.get(name) == handle and name not in world.by_name:
            del names[name]
        raise
    obj = world.get(handle)
    m, d = world.model, world.data
    if placed is not None:
        for f, value in zip(frame[:2], placed):
            getattr(m, f)[obj.mj_id] = value
        if kind == "site":
            m.site_sameframe[obj.mj_id] = 0  # MuJoCo's shortcut for a site at its body's origin
    if mocap is not None and m.body_mocapid[obj.mj_id] >= 0:
        d.mocap_pos[m.body_mocapid[obj.mj_id]], d.mocap_quat[m.body_mocapid[obj.mj_id]] = mocap
    for j, (qpos, qvel) in zip(_joint_ids(world, obj), states):
        d.qpos[m.jnt_qposadr[j]:m.jnt_qposadr[j] + len(qpos)] = qpos
        d.qvel[m.jnt_dofadr[j]:m.jnt_dofadr[j] + len(qvel)] = qvel
    world.changed()


def _joint_size(m: mujoco.MjModel, j: int) -> tuple[int, int]:
    """(nq, nv) of joint ``j``."""
    return {0: (7, 6), 1: (4, 3)}.get(int(m.jnt_type[j]), (1, 1))
