"""``simIK``'s solving, path, joint and object calls, over the environments of
:mod:`simx_server.api.simik.environments` (apart from them to keep each module short; the
configuration search is :mod:`simx_server.api.simik.search`)."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import simik_function
from simx_server.api.simik import chains as _chains, dummies as _dummies, environments as _environments
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.api.sim.misc import alternate_configs
from simx_server.sim import ik_solver as S
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector
from simx_server.sim import ik as scene_ik
from simx_server.sim.ik_chain import coupling_matrix
from simx_server.sim.objects import DUMMY, JOINT, WORLD
from simx_server.sim.rotations import euler_from_matrix, matrix_from_euler, matrix_from_quaternion

RESULT_NOT_PERFORMED, RESULT_SUCCESS, RESULT_FAIL = 0, 1, 2
CALC_NOTPERFORMED, CALC_NOTWITHINTOLERANCE = 1, 16
MAX_PATH_POINTS = 10_000


def _precision(ctx: CallContext, env, g) -> list[float]:
    """Largest remaining linear (m) and angular (rad) error of the group's enabled elements."""
    d = _environments.env_data(ctx, env)
    lin = ang = 0.0
    for el in g.elements:
        if el.flags & 1 and el.target != -1:
            p, r, _, _ = _environments.frame(ctx, env, d, el.tip)
            tp, tr, _, _ = _environments.frame(ctx, env, d, el.target)
            lin = max(lin, float(np.linalg.norm((tp - p)[[i for i, b in enumerate((1, 2, 4)) if el.constraints & b]])))
            if el.constraints & 24:
                ang = max(ang, float(np.linalg.norm(S._rotvec(tr, r))))
    return [lin, ang]


def _options(options: Any) -> dict:
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ArgumentError("options must be a table ({syncWorlds = true, allowError = false})")
    return options


@simik_function("handleGroup")
def handleGroup(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, options: Any = None) -> tuple[int, int, list[float]]:  # noqa: N802, N803
    """Solve a group: ``result, flags, precision`` (``simIK.result_success`` / ``result_fail``,
    ``simIK.calc_*`` bits, the remaining linear (m) and angular (rad) error). ``options``
    ``{syncWorlds = true}`` reads the scene's joints first and writes the result to the scene
    (``allowError = true``: also when it failed). A scene group (``simx:ik:NAME``) is solved as
    ``sim.handleIkGroup``."""
    env = _environments.env_of(ctx, environmentHandle)
    g = _environments.group_of(ctx, env, ikGroupHandle)
    opts = _options(options)
    if g.flags == -1:
        return scene_ik.groups(ctx.world).solve(scene_ik.groups(ctx.world).group(g.handle)), 0, [0.0, 0.0]
    if not g.flags & 1 or not any(el.flags & 1 and el.target != -1 for el in g.elements):
        return RESULT_NOT_PERFORMED, CALC_NOTPERFORMED, [0.0, 0.0]
    joints = _environments.joints_of(ctx, env, g)
    if opts.get("syncWorlds"):
        for j in joints:
            env.q[j] = ctx.world.joint_position(j)
    ok, joints, q = _environments.solve(ctx, env, g)
    env.q.update(zip(joints, (float(v) for v in q)))
    g.failure = "" if ok else "the tip did not reach the target within the elements' precision"
    if opts.get("syncWorlds") and (ok or opts.get("allowError")):
        _environments.write_scene(ctx, *_environments.with_slaves(ctx, env, joints, q))
    return (RESULT_SUCCESS if ok else RESULT_FAIL), (0 if ok else CALC_NOTWITHINTOLERANCE), _precision(ctx, env, g)


@simik_function("handleGroups")
def handleGroups(ctx: CallContext, environmentHandle: Any, ikGroupHandles: Any, options: Any = None) -> tuple[int, int, list[float]]:  # noqa: N802, N803
    """:func:`handleGroup` for each group in turn; the worst result."""
    if not isinstance(ikGroupHandles, (list, tuple)):
        ikGroupHandles = [ikGroupHandles]
    out = (RESULT_NOT_PERFORMED, CALC_NOTPERFORMED, [0.0, 0.0])
    for g in ikGroupHandles:
        r = handleGroup(ctx, environmentHandle, g, options)
        out = r if r[0] >= out[0] else out
    return out


@simik_function("applySceneToIkEnvironment")
def applySceneToIkEnvironment(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any = None) -> None:  # noqa: N802, N803
    """CoppeliaSim 4.0-4.2: read the scene's joint positions into the environment."""
    syncFromSim(ctx, environmentHandle, None if ikGroupHandle is None else [ikGroupHandle])


@simik_function("applyIkEnvironmentToScene")
def applyIkEnvironmentToScene(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any,  # noqa: N802, N803
                              applyOnlyWhenSuccessful: Any = False) -> int:  # noqa: N803
    """CoppeliaSim 4.0-4.2: the scene's joints in, solve, the result out (only on success when
    ``applyOnlyWhenSuccessful``); the result."""
    return handleGroup(ctx, environmentHandle, ikGroupHandle,
                       {"syncWorlds": True, "allowError": not applyOnlyWhenSuccessful})[0]


def _groups(ctx: CallContext, env, groups: Any) -> list:
    if groups is None:
        return list(env.groups.values())
    return [_environments.group_of(ctx, env, g) for g in (groups if isinstance(groups, (list, tuple)) else [groups])]


@simik_function("syncFromSim")
def syncFromSim(ctx: CallContext, environmentHandle: Any, ikGroups: Any = None) -> None:  # noqa: N802, N803
    """Read the scene's joint positions into the environment (the groups' joints; nil: all)."""
    env = _environments.env_of(ctx, environmentHandle)
    for g in _groups(ctx, env, ikGroups):
        for j in _environments.joints_of(ctx, env, g):
            env.q[j] = ctx.world.joint_position(j)


@simik_function("syncToSim")
def syncToSim(ctx: CallContext, environmentHandle: Any, ikGroups: Any = None) -> None:  # noqa: N802, N803
    """Write the environment's joint positions to the scene (motors: as target positions)."""
    env = _environments.env_of(ctx, environmentHandle)
    for g in _groups(ctx, env, ikGroups):
        joints = _environments.joints_of(ctx, env, g)
        _environments.write_scene(ctx, *_environments.with_slaves(ctx, env, joints,
                                                                  [_environments.q_of(ctx, env, j) for j in joints]))


@simik_function("generatePath")
def generatePath(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, jointHandles: Any, tipHandle: Any,  # noqa: N802, N803
                 pathPointCount: Any, validationCallback: Any = None, auxData: Any = None) -> list[float]:  # noqa: N803
    """A joint path along which the tip moves straight (position linear, rotation along the
    shortest arc) from where it is to its target, ``pathPointCount`` points (2..10,000), as one
    flat list (point after point, ``jointHandles``' order); empty when a point has no solution.
    The environment's joint positions are unchanged afterwards."""
    env = _environments.env_of(ctx, environmentHandle)
    g = _environments.group_of(ctx, env, ikGroupHandle)
    with _chains.only_joints(ctx, env, g, jointHandles) as joints:
        if validationCallback is not None:
            raise UnsupportedError("simIK.generatePath with a callback: simx cannot call a client's function")
        n = _int(pathPointCount, "pathPointCount")
        if not 2 <= n <= MAX_PATH_POINTS:
            raise ArgumentError(f"pathPointCount must lie in 2..{MAX_PATH_POINTS}")
        tip = _environments.object_of(ctx, env, tipHandle, "tipHandle")
        el = next((e for e in g.elements if e.tip == tip), None)
        if el is None:
            raise ArgumentError(f"no element of the group has tip {tip}")
        order = _environments.joints_of(ctx, env, g)
        saved = {j: _environments.q_of(ctx, env, j) for j in order}
        d = _environments.env_data(ctx, env)
        p0, r0, _, _ = _environments.frame(ctx, env, d, el.tip)
        p1, r1, _, _ = _environments.frame(ctx, env, d, el.target)
        q0, q1, qt = np.empty(4), np.empty(4), np.empty(4)
        mujoco.mju_mat2Quat(q0, r0.reshape(9).copy())
        mujoco.mju_mat2Quat(q1, r1.reshape(9).copy())
        index = [order.index(j) for j in joints]
        q = np.array([saved[j] for j in order])
        out: list[float] = []
        try:
            for k in range(n):
                t = k / (n - 1)
                dq = np.empty(3)
                mujoco.mju_subQuat(dq, q1, q0)
                qt[:] = q0
                mujoco.mju_quatIntegrate(qt, dq, t)
                rot = np.empty(9)
                mujoco.mju_quat2Mat(rot, qt)
                ok, _, q = _environments.solve(ctx, env, g, targets={el.handle: (p0 + t * (p1 - p0), rot.reshape(3, 3))}, q0=q,
                                       iterations=max(g.iterations, 50))
                if not ok:
                    return []
                env.q.update(zip(order, (float(v) for v in q)))
                out += [float(q[i]) for i in index]
        finally:
            env.q.update(saved)
        return out


@simik_function("getAlternateConfigs")
def getAlternateConfigs(ctx: CallContext, environmentHandle: Any, jointHandles: Any, lowLimits: Any = None,  # noqa: N802, N803
                        ranges: Any = None) -> list[float]:
    """The environment's configuration and those equal to it up to whole turns of its hinges
    within their ranges (or ``lowLimits``/``ranges``), flat (configuration after configuration),
    at most :data:`simx_server.api.sim.misc.MAX_ALTERNATE_CONFIGS`."""
    env = _environments.env_of(ctx, environmentHandle)
    joints = [ctx.world.get(ctx.h(j, "jointHandles[i]"), JOINT) for j in jointHandles]
    config = [_environments.q_of(ctx, env, obj.handle) for obj in joints]
    return alternate_configs(ctx.world.model, joints, config, lowLimits, ranges)


@simik_function("computeGroupJacobian")
def computeGroupJacobian(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any) -> tuple[list[float], list[float]]:  # noqa: N802, N803
    """``jacobian, errorVector`` of the group in the environment's configuration: the constrained
    rows (world axes for positions, the target's axes for rotations) by the group's joints (row
    after row), unweighted (``CikGroup::computeGroupIk`` returns them before ``computeDq`` weights)."""
    env = _environments.env_of(ctx, environmentHandle)
    g = _environments.group_of(ctx, env, ikGroupHandle)
    joints = _environments.joints_of(ctx, env, g)
    d = _environments.env_data(ctx, env)
    e, rows, _ = S.errors(ctx.world, d, [el for el in g.elements if el.target != -1], {},
                          lambda data, h: _environments.frame(ctx, env, data, h), weighted=False)
    dadr = np.array([ctx.world.model.jnt_dofadr[ctx.world.get(j).mj_id] for j in joints], int)
    slaves = _environments.slaves_of(ctx, env, joints)
    columns = coupling_matrix(ctx.world.model.nv, dadr, [(dof, col, k) for _, dof, col, _, k in slaves]) if slaves else None
    return S.jacobian(ctx.world, d, rows, dadr, columns).reshape(-1).tolist(), e.tolist()


# ----------------------------------------------------------------------- joints
@simik_function("getJointPosition")
def getJointPosition(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """The joint's position in the environment (rad or m)."""
    return _environments.q_of(ctx, _environments.env_of(ctx, environmentHandle), _environments.joint_of(ctx, jointHandle).handle)


@simik_function("setJointPosition")
def setJointPosition(ctx: CallContext, environmentHandle: Any, jointHandle: Any, position: Any) -> None:  # noqa: N802, N803
    _environments.env_of(ctx, environmentHandle).q[_environments.joint_of(ctx, jointHandle).handle] = _num(position, "position")


@simik_function("getJointMode")
def getJointMode(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> int:  # noqa: N802, N803
    """``simIK.jointmode_ik`` (2: moved by the groups) or ``jointmode_passive`` (0)."""
    return _environments.env_of(ctx, environmentHandle).mode.get(_environments.joint_of(ctx, jointHandle).handle, 2)


@simik_function("setJointMode")
def setJointMode(ctx: CallContext, environmentHandle: Any, jointHandle: Any, jointMode: Any) -> None:  # noqa: N802, N803
    mode = _int(jointMode, "jointMode")
    if mode not in (0, 2):
        raise UnsupportedError("simIK joint modes: jointmode_passive (0) and jointmode_ik (2)")
    _environments.env_of(ctx, environmentHandle).mode[_environments.joint_of(ctx, jointHandle).handle] = mode


@simik_function("getJointType")
def getJointType(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> int:  # noqa: N802, N803
    """``simIK.jointtype_revolute`` (10), ``jointtype_prismatic`` (11) or ``jointtype_spherical``
    (12: a MuJoCo ball joint)."""
    _environments.env_of(ctx, environmentHandle)
    kind = int(ctx.world.model.jnt_type[_environments.joint_of(ctx, jointHandle).mj_id])
    if kind == mujoco.mjtJoint.mjJNT_BALL:
        return 12
    if kind not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
        raise UnsupportedError("a MuJoCo free joint has no simIK joint type")
    return 10 if kind == mujoco.mjtJoint.mjJNT_HINGE else 11


@simik_function("getJointInterval")
def getJointInterval(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> tuple[bool, list[float]]:  # noqa: N802, N803
    """``cyclic, [min, range]`` (the scene joint's, as ``sim.getJointInterval``)."""
    _environments.env_of(ctx, environmentHandle)
    return ctx.sim.getJointInterval(_environments.joint_of(ctx, jointHandle).handle)


@simik_function("setJointInterval")
def setJointInterval(ctx: CallContext, environmentHandle: Any, jointHandle: Any, cyclic: Any, interval: Any = None) -> None:  # noqa: N802, N803
    """Sets the scene joint's interval (the environment's joints are the scene's)."""
    _environments.env_of(ctx, environmentHandle)
    ctx.sim.setJointInterval(_environments.joint_of(ctx, jointHandle).handle, cyclic, interval)


@simik_function("getJointMaxStepSize")
def getJointMaxStepSize(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """Largest step of the joint per solver iteration (default 10° for hinges, 0.1 m for slides)."""
    j = _environments.joint_of(ctx, jointHandle)
    default = np.radians(10) if int(ctx.world.model.jnt_type[j.mj_id]) == mujoco.mjtJoint.mjJNT_HINGE else 0.1
    return float(_environments.env_of(ctx, environmentHandle).max_step.get(j.handle, default))


@simik_function("setJointMaxStepSize")
def setJointMaxStepSize(ctx: CallContext, environmentHandle: Any, jointHandle: Any, stepSize: Any) -> None:  # noqa: N802, N803
    v = _num(stepSize, "stepSize")
    if v <= 0:
        raise ArgumentError("stepSize must be positive")
    _environments.env_of(ctx, environmentHandle).max_step[_environments.joint_of(ctx, jointHandle).handle] = v


@simik_function("getJointWeight")
def getJointWeight(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """The joint's weight in the solver's weighted least-norm step (default 1)."""
    return float(_environments.env_of(ctx, environmentHandle).weight.get(_environments.joint_of(ctx, jointHandle).handle, 1.0))


@simik_function("setJointWeight")
def setJointWeight(ctx: CallContext, environmentHandle: Any, jointHandle: Any, weight: Any) -> None:  # noqa: N802, N803
    """> 0: larger moves the joint more, smaller less (CoppeliaSim's joint weight)."""
    v = _num(weight, "weight")
    if v <= 0:
        raise ArgumentError("weight must be positive (set the joint passive to hold it)")
    _environments.env_of(ctx, environmentHandle).weight[_environments.joint_of(ctx, jointHandle).handle] = v


@simik_function("getJointLimitMargin")
def getJointLimitMargin(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """How far inside its range the solver keeps the joint (rad or m, default 0)."""
    return float(_environments.env_of(ctx, environmentHandle).margin.get(_environments.joint_of(ctx, jointHandle).handle, 0.0))


@simik_function("setJointLimitMargin")
def setJointLimitMargin(ctx: CallContext, environmentHandle: Any, jointHandle: Any, margin: Any) -> None:  # noqa: N802, N803
    v = _num(margin, "margin")
    if v < 0:
        raise ArgumentError("margin must not be negative")
    _environments.env_of(ctx, environmentHandle).margin[_environments.joint_of(ctx, jointHandle).handle] = v


@simik_function("getJointScrewLead")
def getJointScrewLead(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """0: MuJoCo's hinges and slides are not screws."""
    _environments.env_of(ctx, environmentHandle)
    _environments.joint_of(ctx, jointHandle)
    return 0.0


@simik_function("getJointDependency")
def getJointDependency(ctx: CallContext, environmentHandle: Any, jointHandle: Any) -> tuple[int, float, float]:  # noqa: N802, N803
    """``masterJoint, offset, multCoeff``: the environment's (``simIK.setJointDependency``), else
    the scene's joint equality (as ``sim.getJointDependency``)."""
    env = _environments.env_of(ctx, environmentHandle)
    j = _environments.joint_of(ctx, jointHandle).handle
    if j in env.dependency:
        return env.dependency[j]
    return ctx.sim.getJointDependency(j)


@simik_function("getObjectTransformation")
def getObjectTransformation(ctx: CallContext, environmentHandle: Any, objectHandle: Any,  # noqa: N802, N803
                            relativeToObjectHandle: Any = -1) -> tuple[list[float], list[float], list[float]]:  # noqa: N803
    """CoppeliaSim 4.0-4.2: ``position, quaternion, euler`` (as :func:`getObjectPose`)."""
    p = getObjectPose(ctx, environmentHandle, objectHandle, relativeToObjectHandle)
    return p[:3], p[3:], list(euler_from_matrix(np.asarray(matrix_from_quaternion(*p[3:]))))


@simik_function("setObjectTransformation")
def setObjectTransformation(ctx: CallContext, environmentHandle: Any, objectHandle: Any, relativeToObjectHandle: Any,  # noqa: N802, N803
                            position: Any, eulerOrQuaternion: Any) -> None:  # noqa: N803
    """CoppeliaSim 4.0-4.2: place a dummy by position and quaternion (4) or Euler angles (3)."""
    rot = (np.asarray(matrix_from_quaternion(*_vector(eulerOrQuaternion, 4, "quaternion")))
           if isinstance(eulerOrQuaternion, (list, tuple)) and len(eulerOrQuaternion) == 4
           else np.asarray(matrix_from_euler(*_vector(eulerOrQuaternion, 3, "eulerAngles"))))
    _dummies.place(ctx, environmentHandle, objectHandle, relativeToObjectHandle, _vector(position, 3, "position"), rot)


# ---------------------------------------------------------------------- objects
@simik_function("getObjectHandle")
def getObjectHandle(ctx: CallContext, environmentHandle: Any, objectName: Any) -> int:  # noqa: N802, N803
    """The environment's dummy of that name, else the scene object of that name or path (the
    environment's other objects are the scene's)."""
    env = _environments.env_of(ctx, environmentHandle)
    name = _text(objectName, "objectName")
    own = next((d.handle for d in env.dummies.values() if d.name == name), None)
    return int(own) if own is not None else ctx.sim.getObject(name)


@simik_function("doesObjectExist")
def doesObjectExist(ctx: CallContext, environmentHandle: Any, objectName: Any) -> bool:  # noqa: N802, N803
    env = _environments.env_of(ctx, environmentHandle)
    name = _text(objectName, "objectName")
    return any(d.name == name for d in env.dummies.values()) or ctx.sim.getObject(name, {"noError": True}) != -1


@simik_function("getObjects")
def getObjects(ctx: CallContext, environmentHandle: Any, index: Any) -> tuple[int, str, bool, int]:  # noqa: N802, N803
    """``objectHandle, objectName, isJoint, jointType`` of the ``index``-th dummy or joint (the
    scene's, then the environment's own dummies); -1 past the last."""
    env = _environments.env_of(ctx, environmentHandle)
    objs = [o for o in ctx.world.objects.values() if o.type in (DUMMY, JOINT)]
    i = _int(index, "index")
    if len(objs) <= i < len(objs) + len(env.dummies):
        dummy = list(env.dummies.values())[i - len(objs)]
        return dummy.handle, dummy.name, False, -1
    if not 0 <= i < len(objs):
        return -1, "", False, -1
    o = objs[i]
    kind = int(ctx.world.model.jnt_type[o.mj_id]) if o.type == JOINT else -1
    return o.handle, o.name, o.type == JOINT, {3: 10, 2: 11}.get(kind, -1) if o.type == JOINT else -1


@simik_function("getObjectType")
def getObjectType(ctx: CallContext, environmentHandle: Any, objectHandle: Any) -> int:  # noqa: N802, N803
    """``simIK.objecttype_joint`` (1) or ``objecttype_dummy`` (4)."""
    env = _environments.env_of(ctx, environmentHandle)
    h = _environments.object_of(ctx, env, objectHandle)
    if h in env.dummies:
        return DUMMY
    o = ctx.world.get(h)
    if o.type not in (DUMMY, JOINT):
        raise UnsupportedError(f"{o.name!r} is neither a dummy nor a joint: not an IK object")
    return o.type


@simik_function("getObjectParent")
def getObjectParent(ctx: CallContext, environmentHandle: Any, objectHandle: Any) -> int:  # noqa: N802, N803
    """The object's parent (-1: none): an environment's dummy's own (``simIK.setObjectParent``), a
    scene object's in the scene."""
    env = _environments.env_of(ctx, environmentHandle)
    h = _environments.object_of(ctx, env, objectHandle)
    return int(env.dummies[h].parent) if h in env.dummies else ctx.world.get(h).parent


@simik_function("getObjectPose")
def getObjectPose(ctx: CallContext, environmentHandle: Any, objectHandle: Any, relativeToObjectHandle: Any = -1) -> list[float]:  # noqa: N802, N803
    """``[x y z qx qy qz qw]`` in the environment's configuration (relative to another object, -1 world)."""
    env = _environments.env_of(ctx, environmentHandle)
    d = _environments.env_data(ctx, env)
    h = _environments.object_of(ctx, env, objectHandle)
    p, r, _, _ = _environments.frame(ctx, env, d, h)
    rel = getObjectParent(ctx, environmentHandle, h) if relativeToObjectHandle == _environments.HANDLE_PARENT \
        else _environments.object_of(ctx, env, relativeToObjectHandle, "relativeToObjectHandle")
    if rel != WORLD:
        pr, rr, _, _ = _environments.frame(ctx, env, d, rel)
        p, r = rr.T @ (p - pr), rr.T @ r
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, r.reshape(9).copy())
    return [*p.tolist(), float(q[1]), float(q[2]), float(q[3]), float(q[0])]


@simik_function("setObjectPose")
def setObjectPose(ctx: CallContext, environmentHandle: Any, objectHandle: Any, pose: Any, relativeToObjectHandle: Any = -1) -> None:  # noqa: N802, N803
    """Place a dummy (a target): one of the environment's own in the environment, a scene object
    in the scene (which the environment shares)."""
    v = _vector(pose, 7, "pose")
    _dummies.place(ctx, environmentHandle, objectHandle, relativeToObjectHandle, v[:3], np.asarray(matrix_from_quaternion(*v[3:])))


@simik_function("getObjectMatrix")
def getObjectMatrix(ctx: CallContext, environmentHandle: Any, objectHandle: Any, relativeToObjectHandle: Any = -1) -> list[float]:  # noqa: N802, N803
    """12 numbers (3x4, row by row), as :func:`getObjectPose`."""
    p = getObjectPose(ctx, environmentHandle, objectHandle, relativeToObjectHandle)
    r = np.asarray(matrix_from_quaternion(*p[3:]))
    return np.hstack([r, np.array(p[:3]).reshape(3, 1)]).reshape(12).tolist()


@simik_function("setObjectMatrix")
def setObjectMatrix(ctx: CallContext, environmentHandle: Any, objectHandle: Any, matrix: Any, relativeToObjectHandle: Any = -1) -> None:  # noqa: N802, N803
    m = np.array(_vector(matrix, 12, "matrix")).reshape(3, 4)
    _dummies.place(ctx, environmentHandle, objectHandle, relativeToObjectHandle, m[:, 3].tolist(), m[:, :3])


@simik_function("createDebugOverlay")
def createDebugOverlay(ctx: CallContext, environmentHandle: Any, tipHandle: Any, baseHandle: Any = -1) -> int:  # noqa: N802, N803
    """Headless: nothing is drawn; an overlay handle (0)."""
    _environments.env_of(ctx, environmentHandle)
    return 0


@simik_function("eraseDebugOverlay")
def eraseDebugOverlay(ctx: CallContext, debugObject: Any) -> None:  # noqa: N802, N803
    """Headless: nothing to erase."""
