"""CoppeliaSim 4.x's ``simIK`` on MuJoCo, for ZMQ clients (``client.require('simIK')``) and scripts.

An **environment** (``simIK.createEnvironment``) holds IK groups and its own positions of the
scene's joints; its objects are the scene's, with the scene's handles (``addElementFromScene``'s
``simToIkMap`` / ``ikToSimMap`` map each handle to itself). A **group** has elements (tip,
target, base, constraints, weights, precision, flags), a calculation method (damped least
squares, pseudo-inverse, Jacobian transpose), damping and iterations; its joints are those
between each element's base and tip that are in ``simIK.jointmode_ik``. The solver is
:mod:`simx_server.sim.ik_solver` (MuJoCo's Jacobians, as the scene's own IK groups).

``handleGroup(env, group, {syncWorlds = true})`` reads the scene's joint positions into the
environment, solves, and writes the result back: while the physics runs, a joint with a motor
gets it as its target position (physics follows at the next step, as V-REP's IK in a dynamic
scene), one without as its position; while the simulation is stopped every joint gets it as its
position (:func:`write_scene`). A new group ignores the joints' max step sizes, as CoppeliaSim's
(``CikGroup``: ``group_enabled | group_ignoremaxsteps``, 3 iterations). Without ``syncWorlds`` the result stays in the environment (``getJointPosition``,
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

from simx_server.api.context import CallContext
from simx_server.api.registry import simik_function
from simx_server.api.sim.engine import dynamics_running
from simx_wire.protocol import ArgumentError, ObjectTypeError, UnknownObjectError
from simx_server.base.arguments import quote
from simx_server.sim import ik_solver as S
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector
from simx_server.sim import ik as scene_ik, ik_chain
from simx_server.sim.objects import DUMMY, JOINT, WORLD

#: ``simIK.NAME`` constants (CoppeliaSim 4.x's: ``simIK.constraint_pose``, ``method_damped_least_squares``...).
CONSTANTS: dict[str, int] = json.loads((Path(__file__).resolve().parents[2] / "zmq" / "coppeliasim_api.json")
                                       .read_text(encoding="utf-8"))["constants"]["simIK"]
RESULT_NOT_PERFORMED, RESULT_SUCCESS, RESULT_FAIL = 0, 1, 2
HANDLE_PARENT = CONSTANTS["handle_parent"]
JOINTMODE_PASSIVE, JOINTMODE_IK = 0, 2
GROUP_ENABLED, GROUP_IGNOREMAXSTEPS = 1, 2  # simIK.group_* bits
PRECISION = (0.0005, np.radians(0.1))  # a new element's linear (m) and angular (rad), CikElement's
_FIRST_GROUP = 1000  # created groups' handles (the scene's groups keep theirs, from 1)
MAX_ENVIRONMENTS, MAX_GROUPS, MAX_ITERATIONS = 64, 256, 1000


@dataclasses.dataclass
class Group:
    handle: int
    name: str
    elements: list = dataclasses.field(default_factory=list)
    method: int = S.METHOD_PSEUDO_INVERSE
    damping: float = 0.1
    iterations: int = 3
    flags: int = 3  # simIK.group_enabled | group_ignoremaxsteps (CikGroup's defaults)
    failure: str = ""


#: Handles of an environment's own dummies (``simIK.createDummy``): above the scene's, below
#: ``simIK.handleflag_tipdummy``; at most MAX_DUMMIES per environment.
FIRST_DUMMY, MAX_DUMMIES = 2_000_000, 1024


LocalDummy = ik_chain.LocalDummy


@dataclasses.dataclass
class Environment:
    groups: dict = dataclasses.field(default_factory=dict)
    q: dict = dataclasses.field(default_factory=dict)  # joint handle -> position in the environment
    mode: dict = dataclasses.field(default_factory=dict)  # joint handle -> simIK.jointmode_*
    weight: dict = dataclasses.field(default_factory=dict)  # joint handle -> weight in the step
    margin: dict = dataclasses.field(default_factory=dict)  # joint handle -> limit margin (rad or m)
    max_step: dict = dataclasses.field(default_factory=dict)
    #: joint handle -> (master, offset, mult): simIK.setJointDependency (master -1: none)
    dependency: dict = dataclasses.field(default_factory=dict)
    #: ball joint handle -> its rotation (w, x, y, z) in the environment (simIK.setSphericalJoint*)
    ball: dict = dataclasses.field(default_factory=dict)
    #: handle -> LocalDummy: the environment's own dummies
    dummies: dict = dataclasses.field(default_factory=dict)
    next_dummy: int = FIRST_DUMMY
    next_group: int = _FIRST_GROUP
    next_element: int = 1


# ``simIK.*`` over one caller's context (its world, its simulation); the environments live in
# its :class:`~simx_server.api.context.CallerState`, so that they last between a client's calls.

def _envs(ctx: CallContext) -> dict[int, Environment]:
    envs = ctx.state.ik_environments
    if envs is None:
        envs = ctx.state.ik_environments = {}
    return envs


def env_of(ctx: CallContext, handle: Any) -> Environment:
    env = _envs(ctx).get(_int(handle, "environmentHandle"))
    if env is None:
        raise UnknownObjectError(f"no IK environment {quote(handle)} (simIK.createEnvironment makes one)")
    return env


def group_of(ctx: CallContext, env: Environment, handle: Any) -> Group:
    h = _int(handle, "ikGroupHandle")
    g = env.groups.get(h)
    if g is None:
        for sg in scene_ik.groups(ctx.world).groups.values():
            if sg.handle == h:
                return Group(h, sg.name, flags=-1)  # a scene group: solved by simx_server.sim.ik
        raise UnknownObjectError(f"no IK group {h} in this environment")
    return g


def _element(ctx: CallContext, g: Group, handle: Any) -> S.Element:
    h = _int(handle, "elementHandle")
    if h == -4194304 or h == 4194304:  # simIK.handleflag_tipdummy alone: the first element
        h = g.elements[0].handle if g.elements else -1
    for el in g.elements:
        if el.handle == h or el.tip == (h & ~4194304):
            return el
    raise UnknownObjectError(f"IK group {g.name!r} has no element {h}")


def joint_of(ctx: CallContext, handle: Any) -> Any:
    return ctx.world.get(ctx.h(handle, "jointHandle"), JOINT)


def q_of(ctx: CallContext, env: Environment, joint: int) -> float:
    """The joint's position in the environment (a dependent joint's: from its master's)."""
    if env.dependency.get(joint, (-1,))[0] != -1:
        root, offset, mult = ik_chain.root_of(env.dependency, joint)
        return offset + mult * q_of(ctx, env, root)
    if joint not in env.q:
        env.q[joint] = ctx.world.joint_position(joint)
    return env.q[joint]


def frame(ctx: CallContext, env: Environment, data: mujoco.MjData, handle: int) -> tuple[np.ndarray, np.ndarray, str, int]:
    """``position, rotation, kind, id`` of an object in ``data`` (:func:`simx_server.sim.ik_solver.frame`;
    the environment's own dummies: :func:`simx_server.sim.ik_chain.dummy_frame`)."""
    if handle not in env.dummies:
        return S.frame(ctx.world, data, handle)
    return ik_chain.dummy_frame(ctx.world, env.dummies, data, handle, lambda h: S.frame(ctx.world, data, h))


def object_of(ctx: CallContext, env: Environment, handle: Any, what: str = "objectHandle") -> int:
    """An object argument: one of the environment's dummies (by handle or name), else the
    scene's (every form ``sim.getObject`` takes). UnknownObjectError when neither."""
    if isinstance(handle, str):
        for d in env.dummies.values():
            if d.name == handle:
                return int(d.handle)
    h = ctx.h(handle, what)
    if h not in env.dummies and h != WORLD:
        ctx.world.get(h)
    return h


def joints_of(ctx: CallContext, env: Environment, g: Group) -> list[int]:
    """The joints the group moves, base first: the chains' joints in IK mode, a dependent joint
    replaced by its master (when every joint from it to its master is in IK mode), once each
    (CoppeliaSim's ``CikElement::_getNakedJacobian``)."""
    out: list[int] = []
    for el in g.elements:
        if el.flags & 1:
            tip_body = ik_chain.carrier(ctx.world, env.dummies, el.tip) if el.tip in env.dummies else None
            for j in S.chain(ctx.world, el.tip, el.base, tip_body):
                if env.mode.get(j, JOINTMODE_IK) != JOINTMODE_IK:
                    continue
                while j is not None and env.dependency.get(j, (-1,))[0] != -1:
                    j = env.dependency[j][0]
                    j = j if env.mode.get(j, JOINTMODE_IK) == JOINTMODE_IK else None
                if j is not None and j not in out:
                    out.append(j)
    return out


def slaves_of(ctx: CallContext, env: Environment, joints: list[int]) -> list[tuple[int, int, int, float, float]]:
    """The dependent joints that follow one of ``joints``, for :func:`simx_server.sim.ik_solver.solve`."""
    m = ctx.world.model
    out = []
    for slave, col, offset, mult in ik_chain.couplings(env.dependency, joints):
        jid = ctx.world.get(slave).mj_id
        out.append((int(m.jnt_qposadr[jid]), int(m.jnt_dofadr[jid]), col, offset, mult))
    return out


def _scratch(ctx: CallContext) -> mujoco.MjData:
    w = ctx.world
    data = ctx.state.ik_scratch
    if data is None or ctx.state.ik_scratch_model is not w.model:
        data = mujoco.MjData(w.model)
        ctx.state.ik_scratch, ctx.state.ik_scratch_model = data, w.model
    data.qpos[:] = w.data.qpos
    data.mocap_pos[:], data.mocap_quat[:] = w.data.mocap_pos, w.data.mocap_quat
    return data


def env_data(ctx: CallContext, env: Environment) -> mujoco.MjData:
    """A scratch MjData with the scene's state and the environment's joint positions."""
    w, d = ctx.world, _scratch(ctx)
    for j, q in env.q.items():
        if j in w.objects:
            d.qpos[w.model.jnt_qposadr[w.objects[j].mj_id]] = q
    for j, (master, _, _) in env.dependency.items():
        if master != -1 and j in w.objects:
            d.qpos[w.model.jnt_qposadr[w.objects[j].mj_id]] = q_of(ctx, env, j)
    for j, quat in env.ball.items():
        if j in w.objects:
            adr = w.model.jnt_qposadr[w.objects[j].mj_id]
            d.qpos[adr:adr + 4] = quat
    mujoco.mj_kinematics(w.model, d)
    mujoco.mj_comPos(w.model, d)
    return d


def solve(ctx: CallContext, env: Environment, g: Group, targets: dict | None = None, q0: np.ndarray | None = None,
           iterations: int | None = None) -> tuple[bool, list[int], np.ndarray]:
    joints = joints_of(ctx, env, g)
    env_data(ctx, env)
    d = ctx.state.ik_scratch
    q = np.array([q_of(ctx, env, j) for j in joints]) if q0 is None else q0
    steps = np.array([env.max_step.get(j, np.radians(10) if int(ctx.world.model.jnt_type[
        ctx.world.get(j).mj_id]) == mujoco.mjtJoint.mjJNT_HINGE else 0.1) for j in joints])
    weights = np.array([env.weight.get(j, 1.0) for j in joints])
    margins = np.array([env.margin.get(j, 0.0) for j in joints])
    ok, q, _ = S.solve(ctx.world, d, joints, q, g.elements, g.method, g.damping,
                       g.iterations if iterations is None else iterations, steps, targets, weights, margins,
                       slaves_of(ctx, env, joints), lambda data, h: frame(ctx, env, data, h),
                       bound_steps=not g.flags & GROUP_IGNOREMAXSTEPS, numeric=True)
    return ok, joints, q


def with_slaves(ctx: CallContext, env: Environment, joints: list[int], q: Any) -> tuple[list[int], list[float]]:
    """``joints`` and ``q``, then the dependent joints that follow them at their positions."""
    slaves = ik_chain.couplings(env.dependency, joints)
    return ([*joints, *(s for s, _, _, _ in slaves)],
            [*(float(v) for v in q), *(offset + mult * float(q[col]) for _, col, offset, mult in slaves)])


def write_scene(ctx: CallContext, joints: list[int], q: Any) -> None:
    """``simIK.syncToSim``: a joint in dynamic mode (with a motor) gets ``q`` as its target
    position while the physics engine simulates it, any other joint (and every joint while the
    simulation is stopped, or in its first pass) as its position (simIK.lua's ``syncToSim``:
    ``sim.isDynamicallyEnabled``)."""
    w = ctx.world
    dynamic = dynamics_running(ctx)
    for j, v in zip(joints, q):
        if dynamic and j in w.motor_index:
            try:
                w.set_joint_target_position(j, float(v))
                continue
            except ObjectTypeError:  # velocity mode: the motor keeps its own target
                pass
        w.set_joint_position(j, float(v))


@simik_function("createEnvironment")
def createEnvironment(ctx: CallContext, flags: Any = 0) -> int:  # noqa: N802 (CoppeliaSim's names)
    """A new, empty IK environment (the scene's IK groups are in it too); its handle."""
    envs = _envs(ctx)
    if len(envs) >= MAX_ENVIRONMENTS:
        raise ArgumentError(f"at most {MAX_ENVIRONMENTS} IK environments: erase one first")
    h = max(envs, default=-1) + 1
    envs[h] = Environment()
    return h


@simik_function("eraseEnvironment")
def eraseEnvironment(ctx: CallContext, environmentHandle: Any) -> None:  # noqa: N802, N803
    env_of(ctx, environmentHandle)
    del _envs(ctx)[_int(environmentHandle, "environmentHandle")]


@simik_function("duplicateEnvironment")
def duplicateEnvironment(ctx: CallContext, environmentHandle: Any) -> int:  # noqa: N802, N803
    """A copy of an environment (groups, elements, joint positions and modes)."""
    import copy
    src = env_of(ctx, environmentHandle)
    h = createEnvironment(ctx)
    _envs(ctx)[h] = copy.deepcopy(src)
    return h


@simik_function("createGroup")
def createGroup(ctx: CallContext, environmentHandle: Any, ikGroupName: Any = "") -> int:  # noqa: N802, N803
    """A new group (pseudo-inverse, 3 iterations, ``group_enabled | group_ignoremaxsteps``, as
    CoppeliaSim's ``CikGroup``); its handle."""
    env = env_of(ctx, environmentHandle)
    if len(env.groups) >= MAX_GROUPS:
        raise ArgumentError(f"at most {MAX_GROUPS} IK groups per environment")
    h, env.next_group = env.next_group, env.next_group + 1
    env.groups[h] = Group(h, _text(ikGroupName or f"group{h}", "ikGroupName"))
    return h


@simik_function("getGroupHandle")
def getGroupHandle(ctx: CallContext, environmentHandle: Any, ikGroupName: Any) -> int:  # noqa: N802, N803
    """The handle of the group named so (the environment's, else the scene's ``simx:ik:NAME``)."""
    env, name = env_of(ctx, environmentHandle), _text(ikGroupName, "ikGroupName")
    for g in env.groups.values():
        if g.name == name:
            return g.handle
    return scene_ik.groups(ctx.world).group(name).handle


@simik_function("doesGroupExist")
def doesGroupExist(ctx: CallContext, environmentHandle: Any, ikGroupName: Any) -> bool:  # noqa: N802, N803
    try:
        getGroupHandle(ctx, environmentHandle, ikGroupName)
    except UnknownObjectError:
        return False
    return True


@simik_function("setGroupCalculation")
def setGroupCalculation(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, method: Any, damping: Any,  # noqa: N802, N803
                        maxIterations: Any) -> None:  # noqa: N803
    """``simIK.method_*`` (0 pseudo-inverse, 1 damped least squares, 2 Jacobian transpose,
    3 undamped), damping λ, iterations (1..1000)."""
    g = group_of(ctx, env_of(ctx, environmentHandle), ikGroupHandle)
    m, lam, n = _int(method, "method"), _num(damping, "damping"), _int(maxIterations, "maxIterations")
    if m not in (0, 1, 2, 3) or lam < 0 or not 1 <= n <= MAX_ITERATIONS:
        raise ArgumentError(f"method 0-3, damping >= 0, maxIterations 1..{MAX_ITERATIONS}")
    g.method, g.damping, g.iterations = m, lam, n


@simik_function("getGroupCalculation")
def getGroupCalculation(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any) -> tuple[int, float, int]:  # noqa: N802, N803
    g = group_of(ctx, env_of(ctx, environmentHandle), ikGroupHandle)
    return g.method, g.damping, g.iterations


@simik_function("setGroupFlags")
def setGroupFlags(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, flags: Any) -> None:  # noqa: N802, N803
    """``simIK.group_enabled`` (bit 0) and ``group_ignoremaxsteps`` (bit 1, set: each iteration's
    step is not scaled down to the joints' max step sizes); the other bits are kept, unused."""
    group_of(ctx, env_of(ctx, environmentHandle), ikGroupHandle).flags = _int(flags, "flags")


@simik_function("getGroupFlags")
def getGroupFlags(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any) -> int:  # noqa: N802, N803
    return group_of(ctx, env_of(ctx, environmentHandle), ikGroupHandle).flags


@simik_function("getGroupJoints")
def getGroupJoints(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any) -> list[int]:  # noqa: N802, N803
    """The joints the group moves, base first."""
    env = env_of(ctx, environmentHandle)
    return joints_of(ctx, env, group_of(ctx, env, ikGroupHandle))


@simik_function("getFailureDescription")
def getFailureDescription(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any) -> str:  # noqa: N802, N803
    return group_of(ctx, env_of(ctx, environmentHandle), ikGroupHandle).failure


@simik_function("getGroupJointLimitHits")
def getGroupJointLimitHits(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any) -> tuple[list[int], list[float]]:  # noqa: N802, N803
    """Joints at a limit in the environment and by how much (0 at the limit)."""
    env = env_of(ctx, environmentHandle)
    m, hits, over = ctx.world.model, [], []
    for j in joints_of(ctx, env, group_of(ctx, env, ikGroupHandle)):
        jid = ctx.world.get(j).mj_id
        lo, hi = m.jnt_range[jid]
        q = q_of(ctx, env, j)
        if m.jnt_limited[jid] and (q <= lo + 1e-9 or q >= hi - 1e-9):
            hits.append(j)
            over.append(0.0)
    return hits, over


@simik_function("addElementFromScene")
def addElementFromScene(ctx: CallContext, environmentHandle: Any, ikGroup: Any, baseHandle: Any, tipHandle: Any,  # noqa: N802, N803
                        targetHandle: Any, constraints: Any) -> tuple[int, dict, dict]:  # noqa: N803
    """An element pulling the scene's ``tipHandle`` onto ``targetHandle`` (both dummies or
    shapes), its chain from ``baseHandle`` (-1: the world); returns ``elementHandle,
    simToIkMap, ikToSimMap`` (the environment's objects are the scene's: identity maps)."""
    env = env_of(ctx, environmentHandle)
    g = group_of(ctx, env, ikGroup)
    if g.flags == -1:
        raise ArgumentError("the scene's IK groups are declared in the MJCF (simx:ik:NAME); create a group")
    w = ctx.world
    base, tip, target = (_int(v, n) for v, n in ((baseHandle, "baseHandle"), (tipHandle, "tipHandle"),
                                                  (targetHandle, "targetHandle")))
    for h in (tip, target) + ((base,) if base != WORLD else ()):
        w.get(h)
    el = S.Element(env.next_element, tip, target, base, _int(constraints, "constraints"), precision=PRECISION)
    env.next_element += 1
    g.elements.append(el)
    objects = [h for h in (base, tip, target) if h != WORLD] + S.chain(w, tip, base)
    for j in S.chain(w, tip, base):
        q_of(ctx, env, j)
    ident = {h: h for h in objects}
    return el.handle, ident, dict(ident)


@simik_function("addElement")
def addElement(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, tipDummyHandle: Any) -> int:  # noqa: N802, N803
    """An element for a tip already known (a scene dummy or one of the environment's); target and
    base set later."""
    env = env_of(ctx, environmentHandle)
    tip = object_of(ctx, env, tipDummyHandle, "tipDummyHandle")
    if tip not in env.dummies:
        tip = ctx.world.get(tip, DUMMY).handle
    el = S.Element(env.next_element, tip, -1, precision=PRECISION)
    env.next_element += 1
    group_of(ctx, env, ikGroupHandle).elements.append(el)
    return el.handle


def _el(ctx: CallContext, env: Any, group: Any, element: Any) -> S.Element:
    return _element(ctx, group_of(ctx, env_of(ctx, env), group), element)


@simik_function("setElementBase")
def setElementBase(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any, baseHandle: Any,  # noqa: N802, N803
                   constraintsBaseHandle: Any = -1) -> None:  # noqa: N803
    el = _el(ctx, environmentHandle, ikGroupHandle, elementHandle)
    b = ctx.h(baseHandle, "baseHandle")
    if b != WORLD:
        ctx.world.get(b)
    el.base = b


@simik_function("getElementBase")
def getElementBase(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> tuple[int, int]:  # noqa: N802, N803
    return _el(ctx, environmentHandle, ikGroupHandle, elementHandle).base, -1


@simik_function("setElementConstraints")
def setElementConstraints(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any,  # noqa: N802, N803
                          constraints: Any) -> None:
    """``simIK.constraint_x`` (1) ... ``constraint_gamma`` (16) bits."""
    c = _int(constraints, "constraints")
    if not 0 <= c <= 31:
        raise ArgumentError("constraints are bits 1-16 (simIK.constraint_*)")
    _el(ctx, environmentHandle, ikGroupHandle, elementHandle).constraints = c


@simik_function("getElementConstraints")
def getElementConstraints(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> int:  # noqa: N802, N803
    return _el(ctx, environmentHandle, ikGroupHandle, elementHandle).constraints


@simik_function("setElementFlags")
def setElementFlags(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any, flags: Any) -> None:  # noqa: N802, N803
    """Bit 0: the element is enabled."""
    _el(ctx, environmentHandle, ikGroupHandle, elementHandle).flags = _int(flags, "flags")


@simik_function("getElementFlags")
def getElementFlags(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> int:  # noqa: N802, N803
    return _el(ctx, environmentHandle, ikGroupHandle, elementHandle).flags


@simik_function("setElementPrecision")
def setElementPrecision(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any,  # noqa: N802, N803
                        precision: Any) -> None:
    """``{linear (m), angular (rad)}`` within which the element counts as reached."""
    lin, ang = _vector(precision, 2, "precision")
    if lin <= 0 or ang <= 0:
        raise ArgumentError("precision must be positive")
    _el(ctx, environmentHandle, ikGroupHandle, elementHandle).precision = (lin, ang)


@simik_function("getElementPrecision")
def getElementPrecision(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> list[float]:  # noqa: N802, N803
    return list(_el(ctx, environmentHandle, ikGroupHandle, elementHandle).precision)


@simik_function("setElementWeights")
def setElementWeights(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any,  # noqa: N802, N803
                      weights: Any) -> None:
    """``{linear, angular}`` weights of the element's error rows (>= 0; a third is ignored)."""
    w = weights[:2] if isinstance(weights, (list, tuple)) and len(weights) == 3 else weights
    lin, ang = _vector(w, 2, "weights")
    if lin < 0 or ang < 0:
        raise ArgumentError("weights must not be negative")
    _el(ctx, environmentHandle, ikGroupHandle, elementHandle).weights = (lin, ang)


@simik_function("getElementWeights")
def getElementWeights(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, elementHandle: Any) -> list[float]:  # noqa: N802, N803
    return list(_el(ctx, environmentHandle, ikGroupHandle, elementHandle).weights)


@simik_function("setTargetDummy")
def setTargetDummy(ctx: CallContext, environmentHandle: Any, tipDummyHandle: Any, targetDummyHandle: Any) -> None:  # noqa: N802, N803
    """Link a tip to a target: every element of the environment with that tip."""
    env = env_of(ctx, environmentHandle)
    tip = object_of(ctx, env, tipDummyHandle, "tipDummyHandle")
    target = object_of(ctx, env, targetDummyHandle, "targetDummyHandle")
    for g in env.groups.values():
        for el in g.elements:
            if el.tip == tip:
                el.target = target


@simik_function("getTargetDummy")
def getTargetDummy(ctx: CallContext, environmentHandle: Any, tipDummyHandle: Any) -> int:  # noqa: N802, N803
    env = env_of(ctx, environmentHandle)
    tip = object_of(ctx, env, tipDummyHandle, "tipDummyHandle")
    return next((el.target for g in env.groups.values() for el in g.elements if el.tip == tip), -1)
