"""CoppeliaSim 4.x's ``simIK`` on MuJoCo, for ZMQ clients (``client.require('simIK')``) and scripts.

An **environment** (``simIK.createEnvironment``) holds IK groups and its own positions of the
scene's joints; its objects are the scene's, with the scene's handles (``addElementFromScene``'s
``simToIkMap`` / ``ikToSimMap`` map each handle to itself). A **group** has elements (tip,
target, base, constraints, weights, precision, flags), a calculation method (damped least
squares, pseudo-inverse, Jacobian transpose), damping and iterations; its joints are those
between each element's base and tip that are in ``simIK.jointmode_ik``. The solver is
:mod:`simx_server.sim.ik_solver` (MuJoCo's Jacobians, as the scene's own IK groups).

``handleGroup(env, group, {syncWorlds = true})`` reads the scene's joint positions into the
environment, solves, and writes the result back: a joint with a motor gets it as its target
position (physics follows at the next step, as V-REP's IK in a dynamic scene), one without as
its position. Without ``syncWorlds`` the result stays in the environment (``getJointPosition``,
``syncToSim``). The scene's own IK groups (``simx:ik:NAME``) are groups of every environment
too, under their names and handles: ``handleGroup`` on one solves it as ``sim.handleIkGroup``.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, ObjectTypeError, UnknownObjectError
from simx_server.base.arguments import quote
from simx_server.sim import ik_solver as S
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector
from simx_server.sim import ik as scene_ik
from simx_server.sim.objects import DUMMY, JOINT, WORLD

#: ``simIK.NAME`` constants (CoppeliaSim 4.x's: ``simIK.constraint_pose``, ``method_damped_least_squares``...).
CONSTANTS: dict[str, int] = json.loads((Path(__file__).resolve().parents[1] / "zmq" / "coppeliasim_api.json")
                                       .read_text(encoding="utf-8"))["constants"]["simIK"]
RESULT_NOT_PERFORMED, RESULT_SUCCESS, RESULT_FAIL = 0, 1, 2
JOINTMODE_PASSIVE, JOINTMODE_IK = 0, 2
_FIRST_GROUP = 1000  # created groups' handles (the scene's groups keep theirs, from 1)
MAX_ENVIRONMENTS, MAX_GROUPS, MAX_ITERATIONS = 64, 256, 1000


@dataclasses.dataclass
class Group:
    handle: int
    name: str
    elements: list = dataclasses.field(default_factory=list)
    method: int = S.METHOD_PSEUDO_INVERSE
    damping: float = 0.1
    iterations: int = 6
    flags: int = 1  # simIK.group_enabled
    failure: str = ""


@dataclasses.dataclass
class Environment:
    groups: dict = dataclasses.field(default_factory=dict)
    q: dict = dataclasses.field(default_factory=dict)  # joint handle -> position in the environment
    mode: dict = dataclasses.field(default_factory=dict)  # joint handle -> simIK.jointmode_*
    weight: dict = dataclasses.field(default_factory=dict)  # joint handle -> weight in the step
    margin: dict = dataclasses.field(default_factory=dict)  # joint handle -> limit margin (rad or m)
    max_step: dict = dataclasses.field(default_factory=dict)
    next_group: int = _FIRST_GROUP
    next_element: int = 1


class SimIK:
    """``simIK.*`` over one ``sim`` facade (its world, its simulation); the environments live on
    the facade, so that they last between a client's calls."""

    def __init__(self, sim: Any):
        self._s = sim

    def __getattr__(self, name: str) -> Any:
        if name in CONSTANTS:
            return CONSTANTS[name]
        raise AttributeError(f"simIK.{name} is not available in simx (docs/COVERAGE.md lists what is)")

    # ------------------------------------------------------------------ helpers
    @property
    def _world(self):
        return self._s._world

    def _envs(self) -> dict[int, Environment]:
        envs = getattr(self._s, "_ik_environments", None)
        if envs is None:
            envs = self._s._ik_environments = {}
        return envs

    def _env(self, handle: Any) -> Environment:
        env = self._envs().get(_int(handle, "environmentHandle"))
        if env is None:
            raise UnknownObjectError(f"no IK environment {quote(handle)} (simIK.createEnvironment makes one)")
        return env

    def _group(self, env: Environment, handle: Any) -> Group:
        h = _int(handle, "ikGroupHandle")
        g = env.groups.get(h)
        if g is None:
            for sg in scene_ik.groups(self._world).groups.values():
                if sg.handle == h:
                    return Group(h, sg.name, flags=-1)  # a scene group: solved by simx_server.sim.ik
            raise UnknownObjectError(f"no IK group {h} in this environment")
        return g

    def _element(self, g: Group, handle: Any) -> S.Element:
        h = _int(handle, "elementHandle")
        if h == -4194304 or h == 4194304:  # simIK.handleflag_tipdummy alone: the first element
            h = g.elements[0].handle if g.elements else -1
        for el in g.elements:
            if el.handle == h or el.tip == (h & ~4194304):
                return el
        raise UnknownObjectError(f"IK group {g.name!r} has no element {h}")

    def _joint(self, handle: Any) -> Any:
        return self._world.get(_int(handle, "jointHandle"), JOINT)

    def _q(self, env: Environment, joint: int) -> float:
        if joint not in env.q:
            env.q[joint] = self._world.joint_position(joint)
        return env.q[joint]

    def _joints(self, env: Environment, g: Group) -> list[int]:
        out: list[int] = []
        for el in g.elements:
            if el.flags & 1:
                out += [j for j in S.chain(self._world, el.tip, el.base) if j not in out]
        return [j for j in out if env.mode.get(j, JOINTMODE_IK) == JOINTMODE_IK]

    def _scratch(self) -> mujoco.MjData:
        w = self._world
        data = getattr(self._s, "_ik_scratch", None)
        if data is None or getattr(self._s, "_ik_scratch_model", None) is not w.model:
            data = mujoco.MjData(w.model)
            self._s._ik_scratch, self._s._ik_scratch_model = data, w.model
        data.qpos[:] = w.data.qpos
        data.mocap_pos[:], data.mocap_quat[:] = w.data.mocap_pos, w.data.mocap_quat
        return data

    def _env_data(self, env: Environment) -> mujoco.MjData:
        """A scratch MjData with the scene's state and the environment's joint positions."""
        w, d = self._world, self._scratch()
        for j, q in env.q.items():
            if j in w.objects:
                d.qpos[w.model.jnt_qposadr[w.objects[j].mj_id]] = q
        mujoco.mj_kinematics(w.model, d)
        mujoco.mj_comPos(w.model, d)
        return d

    def _solve(self, env: Environment, g: Group, targets: dict | None = None, q0: np.ndarray | None = None,
               iterations: int | None = None) -> tuple[bool, list[int], np.ndarray]:
        joints = self._joints(env, g)
        self._env_data(env)
        d = self._s._ik_scratch
        q = np.array([self._q(env, j) for j in joints]) if q0 is None else q0
        steps = np.array([env.max_step.get(j, np.radians(10) if int(self._world.model.jnt_type[
            self._world.get(j).mj_id]) == mujoco.mjtJoint.mjJNT_HINGE else 0.1) for j in joints])
        weights = np.array([env.weight.get(j, 1.0) for j in joints])
        margins = np.array([env.margin.get(j, 0.0) for j in joints])
        ok, q, _ = S.solve(self._world, d, joints, q, g.elements, g.method, g.damping,
                           g.iterations if iterations is None else iterations, steps, targets, weights, margins)
        return ok, joints, q

    def _write_scene(self, joints: list[int], q: np.ndarray) -> None:
        w = self._world
        for j, v in zip(joints, q):
            if j in w.motor_index:
                try:
                    w.set_joint_target_position(j, float(v))
                    continue
                except ObjectTypeError:  # velocity mode: the motor keeps its own target
                    pass
            w.set_joint_position(j, float(v))

    # ------------------------------------------------------------ environments
    def createEnvironment(self, flags: Any = 0) -> int:  # noqa: N802 (CoppeliaSim's names)
        """A new, empty IK environment (the scene's IK groups are in it too); its handle."""
        envs = self._envs()
        if len(envs) >= MAX_ENVIRONMENTS:
            raise ArgumentError(f"at most {MAX_ENVIRONMENTS} IK environments: erase one first")
        h = max(envs, default=-1) + 1
        envs[h] = Environment()
        return h

    def eraseEnvironment(self, environmentHandle: Any) -> None:  # noqa: N802, N803
        self._env(environmentHandle)
        del self._envs()[_int(environmentHandle, "environmentHandle")]

    def duplicateEnvironment(self, environmentHandle: Any) -> int:  # noqa: N802, N803
        """A copy of an environment (groups, elements, joint positions and modes)."""
        import copy
        src = self._env(environmentHandle)
        h = self.createEnvironment()
        self._envs()[h] = copy.deepcopy(src)
        return h

    # ------------------------------------------------------------------ groups
    def createGroup(self, environmentHandle: Any, ikGroupName: Any = "") -> int:  # noqa: N802, N803
        """A new group (pseudo-inverse, 6 iterations, enabled); its handle."""
        env = self._env(environmentHandle)
        if len(env.groups) >= MAX_GROUPS:
            raise ArgumentError(f"at most {MAX_GROUPS} IK groups per environment")
        h, env.next_group = env.next_group, env.next_group + 1
        env.groups[h] = Group(h, _text(ikGroupName or f"group{h}", "ikGroupName"))
        return h

    def getGroupHandle(self, environmentHandle: Any, ikGroupName: Any) -> int:  # noqa: N802, N803
        """The handle of the group named so (the environment's, else the scene's ``simx:ik:NAME``)."""
        env, name = self._env(environmentHandle), _text(ikGroupName, "ikGroupName")
        for g in env.groups.values():
            if g.name == name:
                return g.handle
        return scene_ik.groups(self._world).group(name).handle

    def doesGroupExist(self, environmentHandle: Any, ikGroupName: Any) -> bool:  # noqa: N802, N803
        try:
            self.getGroupHandle(environmentHandle, ikGroupName)
        except UnknownObjectError:
            return False
        return True

    def setGroupCalculation(self, environmentHandle: Any, ikGroupHandle: Any, method: Any, damping: Any,  # noqa: N802, N803
                            maxIterations: Any) -> None:  # noqa: N803
        """``simIK.method_*`` (0 pseudo-inverse, 1 damped least squares, 2 Jacobian transpose,
        3 undamped), damping λ, iterations (1..1000)."""
        g = self._group(self._env(environmentHandle), ikGroupHandle)
        m, lam, n = _int(method, "method"), _num(damping, "damping"), _int(maxIterations, "maxIterations")
        if m not in (0, 1, 2, 3) or lam < 0 or not 1 <= n <= MAX_ITERATIONS:
            raise ArgumentError(f"method 0-3, damping >= 0, maxIterations 1..{MAX_ITERATIONS}")
        g.method, g.damping, g.iterations = m, lam, n

    def getGroupCalculation(self, environmentHandle: Any, ikGroupHandle: Any) -> tuple[int, float, int]:  # noqa: N802, N803
        g = self._group(self._env(environmentHandle), ikGroupHandle)
        return g.method, g.damping, g.iterations

    def setGroupFlags(self, environmentHandle: Any, ikGroupHandle: Any, flags: Any) -> None:  # noqa: N802, N803
        """``simIK.group_enabled`` (bit 0); the other bits are kept (simx's solver always bounds steps)."""
        self._group(self._env(environmentHandle), ikGroupHandle).flags = _int(flags, "flags")

    def getGroupFlags(self, environmentHandle: Any, ikGroupHandle: Any) -> int:  # noqa: N802, N803
        return self._group(self._env(environmentHandle), ikGroupHandle).flags

    def getGroupJoints(self, environmentHandle: Any, ikGroupHandle: Any) -> list[int]:  # noqa: N802, N803
        """The joints the group moves, base first."""
        env = self._env(environmentHandle)
        return self._joints(env, self._group(env, ikGroupHandle))

    def getFailureDescription(self, environmentHandle: Any, ikGroupHandle: Any) -> str:  # noqa: N802, N803
        return self._group(self._env(environmentHandle), ikGroupHandle).failure

    def getGroupJointLimitHits(self, environmentHandle: Any, ikGroupHandle: Any) -> tuple[list[int], list[float]]:  # noqa: N802, N803
        """Joints at a limit in the environment and by how much (0 at the limit)."""
        env = self._env(environmentHandle)
        m, hits, over = self._world.model, [], []
        for j in self._joints(env, self._group(env, ikGroupHandle)):
            jid = self._world.get(j).mj_id
            lo, hi = m.jnt_range[jid]
            q = self._q(env, j)
            if m.jnt_limited[jid] and (q <= lo + 1e-9 or q >= hi - 1e-9):
                hits.append(j)
                over.append(0.0)
        return hits, over

    # ---------------------------------------------------------------- elements
    def addElementFromScene(self, environmentHandle: Any, ikGroup: Any, baseHandle: Any, tipHandle: Any,  # noqa: N802, N803
                            targetHandle: Any, constraints: Any) -> tuple[int, dict, dict]:  # noqa: N803
        """An element pulling the scene's ``tipHandle`` onto ``targetHandle`` (both dummies or
        shapes), its chain from ``baseHandle`` (-1: the world); returns ``elementHandle,
        simToIkMap, ikToSimMap`` (the environment's objects are the scene's: identity maps)."""
        env = self._env(environmentHandle)
        g = self._group(env, ikGroup)
        if g.flags == -1:
            raise ArgumentError("the scene's IK groups are declared in the MJCF (simx:ik:NAME); create a group")
        w = self._world
        base, tip, target = (_int(v, n) for v, n in ((baseHandle, "baseHandle"), (tipHandle, "tipHandle"),
                                                      (targetHandle, "targetHandle")))
        for h in (tip, target) + ((base,) if base != WORLD else ()):
            w.get(h)
        el = S.Element(env.next_element, tip, target, base, _int(constraints, "constraints"))
        env.next_element += 1
        g.elements.append(el)
        objects = [h for h in (base, tip, target) if h != WORLD] + S.chain(w, tip, base)
        for j in S.chain(w, tip, base):
            self._q(env, j)
        ident = {h: h for h in objects}
        return el.handle, ident, dict(ident)

    def addElement(self, environmentHandle: Any, ikGroupHandle: Any, tipDummyHandle: Any) -> int:  # noqa: N802, N803
        """An element for a tip already known (a scene dummy); target and base set later."""
        env = self._env(environmentHandle)
        tip = self._world.get(_int(tipDummyHandle, "tipDummyHandle"), DUMMY).handle
        el = S.Element(env.next_element, tip, -1)
        env.next_element += 1
        self._group(env, ikGroupHandle).elements.append(el)
        return el.handle

    def _el(self, env: Any, group: Any, element: Any) -> S.Element:
        return self._element(self._group(self._env(env), group), element)

    def setElementBase(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any, baseHandle: Any,  # noqa: N802, N803
                       constraintsBaseHandle: Any = -1) -> None:  # noqa: N803
        el = self._el(environmentHandle, ikGroupHandle, elementHandle)
        b = _int(baseHandle, "baseHandle")
        if b != WORLD:
            self._world.get(b)
        el.base = b

    def getElementBase(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> tuple[int, int]:  # noqa: N802, N803
        return self._el(environmentHandle, ikGroupHandle, elementHandle).base, -1

    def setElementConstraints(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any,  # noqa: N802, N803
                              constraints: Any) -> None:
        """``simIK.constraint_x`` (1) ... ``constraint_gamma`` (16) bits."""
        c = _int(constraints, "constraints")
        if not 0 <= c <= 31:
            raise ArgumentError("constraints are bits 1-16 (simIK.constraint_*)")
        self._el(environmentHandle, ikGroupHandle, elementHandle).constraints = c

    def getElementConstraints(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> int:  # noqa: N802, N803
        return self._el(environmentHandle, ikGroupHandle, elementHandle).constraints

    def setElementFlags(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any, flags: Any) -> None:  # noqa: N802, N803
        """Bit 0: the element is enabled."""
        self._el(environmentHandle, ikGroupHandle, elementHandle).flags = _int(flags, "flags")

    def getElementFlags(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> int:  # noqa: N802, N803
        return self._el(environmentHandle, ikGroupHandle, elementHandle).flags

    def setElementPrecision(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any,  # noqa: N802, N803
                            precision: Any) -> None:
        """``{linear (m), angular (rad)}`` within which the element counts as reached."""
        lin, ang = _vector(precision, 2, "precision")
        if lin <= 0 or ang <= 0:
            raise ArgumentError("precision must be positive")
        self._el(environmentHandle, ikGroupHandle, elementHandle).precision = (lin, ang)

    def getElementPrecision(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> list[float]:  # noqa: N802, N803
        return list(self._el(environmentHandle, ikGroupHandle, elementHandle).precision)

    def setElementWeights(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any,  # noqa: N802, N803
                          weights: Any) -> None:
        """``{linear, angular}`` weights of the element's error rows (>= 0; a third is ignored)."""
        w = weights[:2] if isinstance(weights, (list, tuple)) and len(weights) == 3 else weights
        lin, ang = _vector(w, 2, "weights")
        if lin < 0 or ang < 0:
            raise ArgumentError("weights must not be negative")
        self._el(environmentHandle, ikGroupHandle, elementHandle).weights = (lin, ang)

    def getElementWeights(self, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> list[float]:  # noqa: N802, N803
        return list(self._el(environmentHandle, ikGroupHandle, elementHandle).weights)

    def setTargetDummy(self, environmentHandle: Any, tipDummyHandle: Any, targetDummyHandle: Any) -> None:  # noqa: N802, N803
        """Link a tip to a target: every element of the environment with that tip."""
        env = self._env(environmentHandle)
        tip, target = _int(tipDummyHandle, "tipDummyHandle"), _int(targetDummyHandle, "targetDummyHandle")
        self._world.get(target)
        for g in env.groups.values():
            for el in g.elements:
                if el.tip == tip:
                    el.target = target

    def getTargetDummy(self, environmentHandle: Any, tipDummyHandle: Any) -> int:  # noqa: N802, N803
        env, tip = self._env(environmentHandle), _int(tipDummyHandle, "tipDummyHandle")
        return next((el.target for g in env.groups.values() for el in g.elements if el.tip == tip), -1)

    from simx_server.scripts.sim_ik_calls import (  # noqa: E402 (the rest of the namespace)
        applyIkEnvironmentToScene, applySceneToIkEnvironment, computeGroupJacobian, createDebugOverlay,
        doesObjectExist, eraseDebugOverlay, findConfig, findConfigs, generatePath, getAlternateConfigs,
        getConfigForTipPose, getJointInterval, getJointMaxStepSize, getJointMode, getJointPosition, getJointType,
        getJointDependency, getJointLimitMargin, getJointScrewLead, getJointWeight, getObjectTransformation,
        setJointLimitMargin, setJointWeight, setObjectTransformation,
        getObjectHandle, getObjectMatrix, getObjectParent, getObjectPose, getObjects, getObjectType, handleGroup,
        handleGroups, setJointInterval, setJointMaxStepSize, setJointMode, setJointPosition, setObjectMatrix,
        setObjectPose, syncFromSim, syncToSim)


def functions() -> dict[str, Any]:
    """``name -> function`` of every ``simIK.NAME`` (for the ZMQ service and Lua)."""
    return {n: v for n, v in vars(SimIK).items() if not n.startswith("_") and callable(v)}

