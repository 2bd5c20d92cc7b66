"""``simIK``'s solving, configuration search, path, joint and object calls: methods of
:class:`simx_server.scripts.sim_ik.SimIK` (defined here to keep each module short; ``self`` is
the SimIK)."""

from __future__ import annotations

import time
from typing import Any

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.scripts.facade_misc import alternate_configs
from simx_server.sim import ik_solver as S
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector
from simx_server.sim import ik as scene_ik
from simx_server.sim.objects import DUMMY, JOINT, WORLD
from simx_server.sim.rotations import euler_from_matrix, matrix_from_euler, matrix_from_quaternion

RESULT_NOT_PERFORMED, RESULT_SUCCESS, RESULT_FAIL = 0, 1, 2
CALC_NOTPERFORMED, CALC_NOTWITHINTOLERANCE = 1, 16
MAX_PATH_POINTS, MAX_SEARCH_SECONDS = 10_000, 10.0


def _precision(self, env, g) -> list[float]:
    """Largest remaining linear (m) and angular (rad) error of the group's enabled elements."""
    d = self._env_data(env)
    lin = ang = 0.0
    for el in g.elements:
        if el.flags & 1 and el.target != -1:
            p, r, _, _ = S.frame(self._world, d, el.tip)
            tp, tr, _, _ = S.frame(self._world, d, el.target)
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


def handleGroup(self, environmentHandle: Any, ikGroupHandle: Any, options: Any = None) -> tuple[int, int, list[float]]:  # noqa: N802, N803
    """Solve a group: ``result, flags, precision`` (``simIK.result_success`` / ``result_fail``,
    ``simIK.calc_*`` bits, the remaining linear (m) and angular (rad) error). ``options``
    ``{syncWorlds = true}`` reads the scene's joints first and writes the result to the scene
    (``allowError = true``: also when it failed). A scene group (``simx:ik:NAME``) is solved as
    ``sim.handleIkGroup``."""
    env = self._env(environmentHandle)
    g = self._group(env, ikGroupHandle)
    opts = _options(options)
    if g.flags == -1:
        return scene_ik.groups(self._world).solve(scene_ik.groups(self._world).group(g.handle)), 0, [0.0, 0.0]
    if not g.flags & 1 or not any(el.flags & 1 and el.target != -1 for el in g.elements):
        return RESULT_NOT_PERFORMED, CALC_NOTPERFORMED, [0.0, 0.0]
    joints = self._joints(env, g)
    if opts.get("syncWorlds"):
        for j in joints:
            env.q[j] = self._world.joint_position(j)
    ok, joints, q = self._solve(env, g)
    env.q.update(zip(joints, (float(v) for v in q)))
    g.failure = "" if ok else "the tip did not reach the target within the elements' precision"
    if opts.get("syncWorlds") and (ok or opts.get("allowError")):
        self._write_scene(joints, q)
    return (RESULT_SUCCESS if ok else RESULT_FAIL), (0 if ok else CALC_NOTWITHINTOLERANCE), _precision(self, env, g)


def handleGroups(self, environmentHandle: Any, ikGroupHandles: Any, options: Any = None) -> tuple[int, int, list[float]]:  # noqa: N802, N803
    """:func:`handleGroup` for each group in turn; the worst result."""
    if not isinstance(ikGroupHandles, (list, tuple)):
        ikGroupHandles = [ikGroupHandles]
    out = (RESULT_NOT_PERFORMED, CALC_NOTPERFORMED, [0.0, 0.0])
    for g in ikGroupHandles:
        r = handleGroup(self, environmentHandle, g, options)
        out = r if r[0] >= out[0] else out
    return out


def applySceneToIkEnvironment(self, environmentHandle: Any, ikGroupHandle: Any = None) -> None:  # noqa: N802, N803
    """CoppeliaSim 4.0-4.2: read the scene's joint positions into the environment."""
    syncFromSim(self, environmentHandle, None if ikGroupHandle is None else [ikGroupHandle])


def applyIkEnvironmentToScene(self, environmentHandle: Any, ikGroupHandle: Any,  # noqa: N802, N803
                              applyOnlyWhenSuccessful: Any = False) -> int:  # noqa: N803
    """CoppeliaSim 4.0-4.2: the scene's joints in, solve, the result out (only on success when
    ``applyOnlyWhenSuccessful``); the result."""
    return handleGroup(self, environmentHandle, ikGroupHandle,
                       {"syncWorlds": True, "allowError": not applyOnlyWhenSuccessful})[0]


def _groups(self, env, groups: Any) -> list:
    if groups is None:
        return list(env.groups.values())
    return [self._group(env, g) for g in (groups if isinstance(groups, (list, tuple)) else [groups])]


def syncFromSim(self, environmentHandle: Any, ikGroups: Any = None) -> None:  # noqa: N802, N803
    """Read the scene's joint positions into the environment (the groups' joints; nil: all)."""
    env = self._env(environmentHandle)
    for g in _groups(self, env, ikGroups):
        for j in self._joints(env, g):
            env.q[j] = self._world.joint_position(j)


def syncToSim(self, environmentHandle: Any, ikGroups: Any = None) -> None:  # noqa: N802, N803
    """Write the environment's joint positions to the scene (motors: as target positions)."""
    env = self._env(environmentHandle)
    for g in _groups(self, env, ikGroups):
        joints = self._joints(env, g)
        self._write_scene(joints, [self._q(env, j) for j in joints])


def _check_joints(self, env, g, jointHandles: Any) -> list[int]:
    group_joints = self._joints(env, g)
    if jointHandles is None:
        return group_joints
    joints = [_int(j, "jointHandles[i]") for j in jointHandles]
    if sorted(joints) != sorted(group_joints):
        raise ArgumentError(f"jointHandles must be the group's joints {group_joints} (in any order)")
    return joints


def findConfigs(self, environmentHandle: Any, ikGroupHandle: Any, jointHandles: Any, params: Any = None,  # noqa: N802, N803
                configs: Any = None) -> list[list[float]]:
    """Configurations of ``jointHandles`` that put the group's tips on their targets: random
    restarts within the joints' ranges (unlimited hinges: ±pi), each solved by damped least
    squares. ``params``: ``maxTime`` (s, default 0.5, at most 10), ``findMultiple`` (default
    false: the first found), ``maxDist`` (keep configs closer than this to the current one,
    ``pMetric`` weighting it). Sorted by distance to the current configuration; empty when none."""
    env = self._env(environmentHandle)
    g = self._group(env, ikGroupHandle)
    joints = _check_joints(self, env, g, jointHandles)
    p = _options(params)
    max_time = min(_num(p.get("maxTime", 0.5), "maxTime"), MAX_SEARCH_SECONDS)
    multiple = bool(p.get("findMultiple", False))
    max_dist = p.get("maxDist")
    metric = np.ones(len(joints)) if p.get("pMetric") is None else np.array(_vector(p["pMetric"], len(joints), "pMetric"))
    order = self._joints(env, g)
    m = self._world.model
    jid = [self._world.get(j).mj_id for j in order]
    low = np.array([m.jnt_range[j][0] if m.jnt_limited[j] else -np.pi for j in jid])
    high = np.array([m.jnt_range[j][1] if m.jnt_limited[j] else np.pi for j in jid])
    current = np.array([self._q(env, j) for j in order])
    rng = np.random.default_rng(int(p.get("seed", 0)) if "seed" in p else None)
    method, damping = g.method, g.damping
    g.method, g.damping = S.METHOD_DLS, max(g.damping, 0.05)
    found: list[np.ndarray] = []
    deadline = time.monotonic() + max_time
    try:
        start = current
        while time.monotonic() < deadline:
            ok, _, q = self._solve(env, g, q0=start.copy(), iterations=max(g.iterations, 100))
            if ok and not any(np.allclose(q, f, atol=1e-3) for f in found):
                d = float(np.sqrt(np.sum((metric * (q - current)) ** 2)))
                if max_dist is None or d <= _num(max_dist, "maxDist"):
                    found.append(q)
                    if not multiple:
                        break
            start = rng.uniform(low, high)
    finally:
        g.method, g.damping = method, damping
    found.sort(key=lambda q: float(np.sqrt(np.sum((metric * (q - current)) ** 2))))
    index = [order.index(j) for j in joints]
    return [[float(q[i]) for i in index] for q in found]


def findConfig(self, environmentHandle: Any, ikGroupHandle: Any, jointHandles: Any, thresholdDist: Any = 0.1,  # noqa: N802, N803
               maxTime: Any = 0.5, metric: Any = None, callback: Any = None, auxData: Any = None) -> list[float] | None:  # noqa: N803
    """CoppeliaSim 4.0-4.2: the first configuration :func:`findConfigs` finds, nil when none
    (``maxTime`` in s; a ``callback`` is refused: simx cannot call back a client)."""
    if callback is not None:
        raise UnsupportedError("simIK.findConfig with a callback: simx cannot call a client's function")
    found = findConfigs(self, environmentHandle, ikGroupHandle, jointHandles, {"maxTime": maxTime, "pMetric": metric})
    return found[0] if found else None


getConfigForTipPose = findConfig


def generatePath(self, environmentHandle: Any, ikGroupHandle: Any, jointHandles: Any, tipHandle: Any,  # noqa: N802, N803
                 pathPointCount: Any, validationCallback: Any = None, auxData: Any = None) -> list[float]:  # noqa: N803
    """A joint path along which the tip moves straight (position linear, rotation along the
    shortest arc) from where it is to its target, ``pathPointCount`` points (2..10,000), as one
    flat list (point after point, ``jointHandles``' order); empty when a point has no solution.
    The environment's joint positions are unchanged afterwards."""
    env = self._env(environmentHandle)
    g = self._group(env, ikGroupHandle)
    joints = _check_joints(self, env, g, jointHandles)
    if validationCallback is not None:
        raise UnsupportedError("simIK.generatePath with a callback: simx cannot call a client's function")
    n = _int(pathPointCount, "pathPointCount")
    if not 2 <= n <= MAX_PATH_POINTS:
        raise ArgumentError(f"pathPointCount must lie in 2..{MAX_PATH_POINTS}")
    tip = _int(tipHandle, "tipHandle")
    el = next((e for e in g.elements if e.tip == tip), None)
    if el is None:
        raise ArgumentError(f"no element of the group has tip {tip}")
    order = self._joints(env, g)
    saved = {j: self._q(env, j) for j in order}
    d = self._env_data(env)
    p0, r0, _, _ = S.frame(self._world, d, el.tip)
    p1, r1, _, _ = S.frame(self._world, d, el.target)
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
            ok, _, q = self._solve(env, g, targets={el.handle: (p0 + t * (p1 - p0), rot.reshape(3, 3))}, q0=q,
                                   iterations=max(g.iterations, 50))
            if not ok:
                return []
            env.q.update(zip(order, (float(v) for v in q)))
            out += [float(q[i]) for i in index]
    finally:
        env.q.update(saved)
    return out


def getAlternateConfigs(self, environmentHandle: Any, jointHandles: Any, lowLimits: Any = None,  # noqa: N802, N803
                        ranges: Any = None) -> list[float]:
    """The environment's configuration and those equal to it up to whole turns of its hinges
    within their ranges (or ``lowLimits``/``ranges``), flat (configuration after configuration),
    at most facade_misc.MAX_ALTERNATE_CONFIGS."""
    env = self._env(environmentHandle)
    joints = [self._world.get(_int(j, "jointHandles[i]"), JOINT) for j in jointHandles]
    config = [self._q(env, obj.handle) for obj in joints]
    return alternate_configs(self._world.model, joints, config, lowLimits, ranges)


def computeGroupJacobian(self, environmentHandle: Any, ikGroupHandle: Any) -> tuple[list[float], list[float]]:  # noqa: N802, N803
    """``jacobian, errorVector`` of the group in the environment's configuration: the weighted,
    constrained rows (world axes for positions, the target's axes for rotations) by the
    group's joints (row after row)."""
    env = self._env(environmentHandle)
    g = self._group(env, ikGroupHandle)
    joints = self._joints(env, g)
    d = self._env_data(env)
    e, rows, _ = S.errors(self._world, d, [el for el in g.elements if el.target != -1], {})
    dadr = np.array([self._world.model.jnt_dofadr[self._world.get(j).mj_id] for j in joints], int)
    return S.jacobian(self._world, d, rows, dadr).reshape(-1).tolist(), e.tolist()


# ----------------------------------------------------------------------- joints
def getJointPosition(self, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """The joint's position in the environment (rad or m)."""
    return self._q(self._env(environmentHandle), self._joint(jointHandle).handle)


def setJointPosition(self, environmentHandle: Any, jointHandle: Any, position: Any) -> None:  # noqa: N802, N803
    self._env(environmentHandle).q[self._joint(jointHandle).handle] = _num(position, "position")


def getJointMode(self, environmentHandle: Any, jointHandle: Any) -> int:  # noqa: N802, N803
    """``simIK.jointmode_ik`` (2: moved by the groups) or ``jointmode_passive`` (0)."""
    return self._env(environmentHandle).mode.get(self._joint(jointHandle).handle, 2)


def setJointMode(self, environmentHandle: Any, jointHandle: Any, jointMode: Any) -> None:  # noqa: N802, N803
    mode = _int(jointMode, "jointMode")
    if mode not in (0, 2):
        raise UnsupportedError("simIK joint modes: jointmode_passive (0) and jointmode_ik (2)")
    self._env(environmentHandle).mode[self._joint(jointHandle).handle] = mode


def getJointType(self, environmentHandle: Any, jointHandle: Any) -> int:  # noqa: N802, N803
    """``simIK.jointtype_revolute`` (10) or ``jointtype_prismatic`` (11)."""
    self._env(environmentHandle)
    kind = int(self._world.model.jnt_type[self._joint(jointHandle).mj_id])
    if kind not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
        raise UnsupportedError("a MuJoCo ball or free joint has no simIK joint type simx handles")
    return 10 if kind == mujoco.mjtJoint.mjJNT_HINGE else 11


def getJointInterval(self, environmentHandle: Any, jointHandle: Any) -> tuple[bool, list[float]]:  # noqa: N802, N803
    """``cyclic, [min, range]`` (the scene joint's, as ``sim.getJointInterval``)."""
    self._env(environmentHandle)
    return self._s.getJointInterval(self._joint(jointHandle).handle)


def setJointInterval(self, environmentHandle: Any, jointHandle: Any, cyclic: Any, interval: Any = None) -> None:  # noqa: N802, N803
    """Sets the scene joint's interval (the environment's joints are the scene's)."""
    self._env(environmentHandle)
    self._s.setJointInterval(self._joint(jointHandle).handle, cyclic, interval)


def getJointMaxStepSize(self, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """Largest step of the joint per solver iteration (default 10° for hinges, 0.1 m for slides)."""
    j = self._joint(jointHandle)
    default = np.radians(10) if int(self._world.model.jnt_type[j.mj_id]) == mujoco.mjtJoint.mjJNT_HINGE else 0.1
    return float(self._env(environmentHandle).max_step.get(j.handle, default))


def setJointMaxStepSize(self, environmentHandle: Any, jointHandle: Any, stepSize: Any) -> None:  # noqa: N802, N803
    v = _num(stepSize, "stepSize")
    if v <= 0:
        raise ArgumentError("stepSize must be positive")
    self._env(environmentHandle).max_step[self._joint(jointHandle).handle] = v


def getJointWeight(self, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """The joint's weight in the solver's weighted least-norm step (default 1)."""
    return float(self._env(environmentHandle).weight.get(self._joint(jointHandle).handle, 1.0))


def setJointWeight(self, environmentHandle: Any, jointHandle: Any, weight: Any) -> None:  # noqa: N802, N803
    """> 0: larger moves the joint more, smaller less (CoppeliaSim's joint weight)."""
    v = _num(weight, "weight")
    if v <= 0:
        raise ArgumentError("weight must be positive (set the joint passive to hold it)")
    self._env(environmentHandle).weight[self._joint(jointHandle).handle] = v


def getJointLimitMargin(self, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """How far inside its range the solver keeps the joint (rad or m, default 0)."""
    return float(self._env(environmentHandle).margin.get(self._joint(jointHandle).handle, 0.0))


def setJointLimitMargin(self, environmentHandle: Any, jointHandle: Any, margin: Any) -> None:  # noqa: N802, N803
    v = _num(margin, "margin")
    if v < 0:
        raise ArgumentError("margin must not be negative")
    self._env(environmentHandle).margin[self._joint(jointHandle).handle] = v


def getJointScrewLead(self, environmentHandle: Any, jointHandle: Any) -> float:  # noqa: N802, N803
    """0: MuJoCo's hinges and slides are not screws."""
    self._env(environmentHandle)
    self._joint(jointHandle)
    return 0.0


def getJointDependency(self, environmentHandle: Any, jointHandle: Any) -> tuple[int, float, float]:  # noqa: N802, N803
    """``masterJoint, offset, multCoeff`` of the scene's joint equality (as ``sim.getJointDependency``)."""
    self._env(environmentHandle)
    return self._s.getJointDependency(self._joint(jointHandle).handle)


def getObjectTransformation(self, environmentHandle: Any, objectHandle: Any,  # noqa: N802, N803
                            relativeToObjectHandle: Any = -1) -> tuple[list[float], list[float], list[float]]:  # noqa: N803
    """CoppeliaSim 4.0-4.2: ``position, quaternion, euler`` (as :func:`getObjectPose`)."""
    p = getObjectPose(self, environmentHandle, objectHandle, relativeToObjectHandle)
    return p[:3], p[3:], list(euler_from_matrix(np.asarray(matrix_from_quaternion(*p[3:]))))


def setObjectTransformation(self, environmentHandle: Any, objectHandle: Any, relativeToObjectHandle: Any,  # noqa: N802, N803
                            position: Any, eulerOrQuaternion: Any) -> None:  # noqa: N803
    """CoppeliaSim 4.0-4.2: place a dummy by position and quaternion (4) or Euler angles (3)."""
    rot = (np.asarray(matrix_from_quaternion(*_vector(eulerOrQuaternion, 4, "quaternion")))
           if isinstance(eulerOrQuaternion, (list, tuple)) and len(eulerOrQuaternion) == 4
           else np.asarray(matrix_from_euler(*_vector(eulerOrQuaternion, 3, "eulerAngles"))))
    self._env(environmentHandle)
    self._s._set_pose(_int(objectHandle, "objectHandle"), _int(relativeToObjectHandle, "relativeToObjectHandle"),
                      position=_vector(position, 3, "position"), rotation=rot)


# ---------------------------------------------------------------------- objects
def getObjectHandle(self, environmentHandle: Any, objectName: Any) -> int:  # noqa: N802, N803
    """The scene object of that name or path (the environment's objects are the scene's)."""
    self._env(environmentHandle)
    return self._s.getObject(_text(objectName, "objectName"))


def doesObjectExist(self, environmentHandle: Any, objectName: Any) -> bool:  # noqa: N802, N803
    self._env(environmentHandle)
    return self._s.getObject(_text(objectName, "objectName"), {"noError": True}) != -1


def getObjects(self, environmentHandle: Any, index: Any) -> tuple[int, str, bool, int]:  # noqa: N802, N803
    """``objectHandle, objectName, isJoint, jointType`` of the ``index``-th dummy or joint; -1 past the last."""
    self._env(environmentHandle)
    objs = [o for o in self._world.objects.values() if o.type in (DUMMY, JOINT)]
    i = _int(index, "index")
    if not 0 <= i < len(objs):
        return -1, "", False, -1
    o = objs[i]
    kind = int(self._world.model.jnt_type[o.mj_id]) if o.type == JOINT else -1
    return o.handle, o.name, o.type == JOINT, {3: 10, 2: 11}.get(kind, -1) if o.type == JOINT else -1


def getObjectType(self, environmentHandle: Any, objectHandle: Any) -> int:  # noqa: N802, N803
    """``simIK.objecttype_joint`` (1) or ``objecttype_dummy`` (4)."""
    self._env(environmentHandle)
    o = self._world.get(_int(objectHandle, "objectHandle"))
    if o.type not in (DUMMY, JOINT):
        raise UnsupportedError(f"{o.name!r} is neither a dummy nor a joint: not an IK object")
    return o.type


def getObjectParent(self, environmentHandle: Any, objectHandle: Any) -> int:  # noqa: N802, N803
    self._env(environmentHandle)
    return self._world.get(_int(objectHandle, "objectHandle")).parent


def getObjectPose(self, environmentHandle: Any, objectHandle: Any, relativeToObjectHandle: Any = -1) -> list[float]:  # noqa: N802, N803
    """``[x y z qx qy qz qw]`` in the environment's configuration (relative to another object, -1 world)."""
    env = self._env(environmentHandle)
    d = self._env_data(env)
    p, r, _, _ = S.frame(self._world, d, _int(objectHandle, "objectHandle"))
    rel = _int(relativeToObjectHandle, "relativeToObjectHandle")
    if rel != WORLD:
        pr, rr, _, _ = S.frame(self._world, d, rel)
        p, r = rr.T @ (p - pr), rr.T @ r
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, r.reshape(9).copy())
    return [*p.tolist(), float(q[1]), float(q[2]), float(q[3]), float(q[0])]


def setObjectPose(self, environmentHandle: Any, objectHandle: Any, pose: Any, relativeToObjectHandle: Any = -1) -> None:  # noqa: N802, N803
    """Place a dummy (a target): the scene's, which the environment shares."""
    self._env(environmentHandle)
    v = _vector(pose, 7, "pose")
    self._s._set_pose(_int(objectHandle, "objectHandle"), _int(relativeToObjectHandle, "relativeToObjectHandle"),
                      position=v[:3], rotation=np.asarray(matrix_from_quaternion(*v[3:])))


def getObjectMatrix(self, environmentHandle: Any, objectHandle: Any, relativeToObjectHandle: Any = -1) -> list[float]:  # noqa: N802, N803
    """12 numbers (3x4, row by row), as :func:`getObjectPose`."""
    p = getObjectPose(self, environmentHandle, objectHandle, relativeToObjectHandle)
    r = np.asarray(matrix_from_quaternion(*p[3:]))
    return np.hstack([r, np.array(p[:3]).reshape(3, 1)]).reshape(12).tolist()


def setObjectMatrix(self, environmentHandle: Any, objectHandle: Any, matrix: Any, relativeToObjectHandle: Any = -1) -> None:  # noqa: N802, N803
    self._env(environmentHandle)
    m = np.array(_vector(matrix, 12, "matrix")).reshape(3, 4)
    self._s._set_pose(_int(objectHandle, "objectHandle"), _int(relativeToObjectHandle, "relativeToObjectHandle"),
                      position=m[:, 3].tolist(), rotation=m[:, :3])


def createDebugOverlay(self, environmentHandle: Any, tipHandle: Any, baseHandle: Any = -1) -> int:  # noqa: N802, N803
    """Headless: nothing is drawn; an overlay handle (0)."""
    self._env(environmentHandle)
    return 0


def eraseDebugOverlay(self, debugObject: Any) -> None:  # noqa: N802, N803
    """Headless: nothing to erase."""
