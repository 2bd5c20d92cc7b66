"""Inverse kinematics groups: V-REP's IK through target dummies, on MuJoCo's Jacobians.

A scene declares an IK group with a custom text (one per group)::

    <text name="simx:ik:UR5" data="tip=UR5_tip target=UR5_target base=UR5
                                   constraints=pose damping=0.05 iterations=10"/>

* ``tip``, ``target``: dummies (sites). The group moves the chain so that the tip reaches the
  target (V-REP's tip-target pair of an IK element).
* ``base``: the body where the chain starts (optional: default the world). The chain is every
  hinge or slide joint with a motor between ``base`` and the tip's body.
* ``constraints``: ``position`` (x, y, z), ``pose`` (position and orientation; default),
  ``orientation``, or V-REP's constraint bits (x 1, y 2, z 4, alpha-beta 8, gamma 16: ``16`` is
  the rotation about the target's z alone).
* ``tip2``, ``target2``, ``base2``, ``constraints2`` ... up to MAX_ELEMENTS: V-REP's further
  elements of the same group, solved together with the first (one damped least squares over
  every element's constrained rows, :mod:`simx_server.sim.ik_solver`); the chain is every
  element's joints.
* ``damping``: λ of the damped least squares (m or rad; default 0.05).
* ``iterations``: most solver iterations per resolution (default 10, at most
  :data:`simx_server.base.limits.MAX_IK_ITERATIONS`).
* ``method``: ``damped_least_squares`` (default), ``pseudo_inverse`` (λ 1e-6, as
  coppeliaKinematicsRoutines ``CikGroup::computeDq``), ``jacobian_transpose`` or ``undamped``
  (V-REP's ``sim_ik_*_method`` of the group).
* ``precision``, ``precision2`` ...: ``linear,angular`` (m, rad) within which an element counts as
  reached (V-REP's element precision; default 1e-5,1e-4); ``weights``, ``weights2`` ...:
  ``position,orientation`` weights of the element's error rows (default 1,1; the error only, not
  the Jacobian, as V-REP's ``CIkElement::prepareIkEquations``).
* ``max_steps``: ``false`` lets one iteration's step be as large as the solver computes it (V-REP's
  "ignore max step sizes", a group's default); ``true`` (default) scales it down to 0.2 rad /
  0.05 m. A group with any of ``method``, ``precision``, ``weights``, ``max_steps`` is solved by
  :func:`simx_server.sim.ik_solver.solve` (as one of several elements), from the file's
  settings: a ``.ttt``'s old IK groups carry all of them (:mod:`simx_server.scene.ttt.parts`).
* ``explicit``: ``true`` leaves the group to scripts (``sim.handleIkGroup``), as V-REP's
  "explicit handling" flag; otherwise it is solved every simulation step.
* ``enabled``: ``false`` for a group V-REP's dialog left inactive: never solved, neither every
  step nor when a script asks (coppeliaSimLib ``CIkGroup_old::computeGroupIk``).

Every simulation step, after the child scripts' actuation and before physics (where V-REP's
main script called ``sim.handleIkGroup(sim.handle_all_except_explicit)``), each group is solved
by damped least squares: ``e`` = target pose - tip pose (position, and for ``pose`` the
rotation vector), ``J`` = ``mj_jacSite`` of the tip restricted to the chain's dofs,
``dq = Jᵀ (J Jᵀ + λ² I)⁻¹ e``, iterated on a scratch ``MjData`` (``mj_kinematics`` +
``mj_comPos`` only) from the chain's current target positions. The result becomes the
chain's joints' target positions, clamped to their ranges: the joints' own position control
then moves them, so limits, maximum velocities and forces still hold (V-REP's IK in a dynamic
scene set its joints' target positions the same way).
"""

from __future__ import annotations

import dataclasses
import logging
import weakref
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, ObjectTypeError, UnknownObjectError
from simx_server.base import limits as L
from simx_server.base.arguments import quote
from simx_server.sim import ik_solver
from simx_server.sim.world import DUMMY, JOINT, SHAPE, World

log = logging.getLogger("simx.ik")

PREFIX = "ik:"  # simx:ik:NAME
#: Errors below which an iteration stops early (m, rad).
_POSITION_TOLERANCE = 1e-5
_ORIENTATION_TOLERANCE = 1e-4
_HINGE = int(mujoco.mjtJoint.mjJNT_HINGE)  # an int: numpy compares an enum as an object
#: Largest joint step of one iteration of the general solver (rad, m), as CoppeliaSim's IK
#: bounds its joints' steps: near a singular pose (an arm stretched out) damped least squares
#: otherwise jumps to a far solution, turns away from the current pose.
MAX_STEP_RAD, MAX_STEP_M = 0.2, 0.05
#: V-REP's return of sim.handleIkGroup: sim_ikresult_not_performed / success / fail.
IK_NOT_PERFORMED, IK_SUCCESS, IK_FAIL = 0, 1, 2


@dataclasses.dataclass
class IkGroup:
    """One IK group, bound to the current model (ids change when the scene is edited)."""

    name: str
    handle: int  # V-REP handle of the group (its own number space, from 1)
    tip: int  # site ids
    target: int
    pose: bool  # constraints=pose (else position only)
    damping: float
    iterations: int
    explicit: bool
    joints: list[int]  # world handles of the chain's joints (base to tip)
    qadr: np.ndarray  # their qpos addresses
    dadr: np.ndarray  # their dof addresses
    low: np.ndarray  # their ranges (-inf/+inf where unlimited)
    high: np.ndarray
    #: all the elements, for a group with several or with partial constraints (solved by
    #: :func:`simx_server.sim.ik_solver.solve`); empty for one tip with pose or position
    elements: list = dataclasses.field(default_factory=list)
    #: False: never solved (V-REP's inactive group)
    enabled: bool = True
    #: the general solver's method (ik_solver.METHOD_*)
    method: int = ik_solver.METHOD_DLS
    #: scale each step down to the joints' largest steps (False: V-REP's "ignore max step sizes")
    bound_steps: bool = True
    #: every element as :class:`simx_server.sim.ik_solver.Element` (also for the plain groups)
    parts: list = dataclasses.field(default_factory=list)


def _setting(settings: dict[str, str], key: str, default: str) -> str:
    return settings.get(key, default)


#: ``constraints=`` words and V-REP's constraint bits (x 1, y 2, z 4, alpha-beta 8, gamma 16).
_CONSTRAINTS = {"pose": 31, "position": 7, "orientation": 24}
_ELEMENT_KEYS = ("tip", "target", "base", "constraints", "precision", "weights")
#: ``method=`` words (``sim_ik_*_method``; :data:`simx_server.sim.ik_solver.METHOD_DLS` ...).
METHODS = {"pseudo_inverse": ik_solver.METHOD_PSEUDO_INVERSE, "damped_least_squares": ik_solver.METHOD_DLS,
           "jacobian_transpose": ik_solver.METHOD_TRANSPOSE, "undamped": ik_solver.METHOD_UNDAMPED}
MAX_ELEMENTS = 8


def _bits(text: str) -> int:
    if text in _CONSTRAINTS:
        return _CONSTRAINTS[text]
    try:
        bits = int(text)
    except ValueError:
        bits = 0
    if not 1 <= bits <= 31:
        raise ValueError(f"constraints must be pose, position, orientation or V-REP's bits (1-31), got {text!r}")
    return bits


def _pair(settings: dict[str, str], key: str, default: tuple[float, float]) -> tuple[float, float]:
    """``key=a,b``: two positive numbers (a weight may be 0)."""
    if key not in settings:
        return default
    try:
        a, b = (float(v) for v in settings[key].split(","))
    except ValueError:
        raise ValueError(f"{key} must be two numbers a,b, got {settings[key]!r}") from None
    if not (a >= 0 and b >= 0 and np.isfinite(a + b)) or (key.startswith("precision") and not (a > 0 and b > 0)):
        raise ValueError(f"{key} must be two positive numbers, got {settings[key]!r}")
    return a, b


def _element(world: World, settings: dict[str, str], n: str) -> tuple[Any, Any, int, str | None, int]:
    """Element ``n`` ("" for the first, "2", "3"... for the others): tip and target dummies, the
    base body (0: the world) and its name, the constraint bits."""
    sites = {}
    for key in ("tip", "target"):
        if key + n not in settings:
            raise ValueError(f"{key}{n}= is missing")
        obj = world.by_name.get(settings[key + n])
        if obj is None or obj.type != DUMMY:
            raise ValueError(f"{key}{n}={settings[key + n]!r} is not a dummy (site) of the scene")
        sites[key] = obj
    base_name = settings.get("base" + n)
    base_body = 0
    if base_name is not None:
        obj = world.by_name.get(base_name)
        if obj is None or obj.type != SHAPE:
            raise ValueError(f"base{n}={base_name!r} is not a body of the scene")
        base_body = obj.mj_id
    return sites["tip"], sites["target"], base_body, base_name, _bits(_setting(settings, "constraints" + n, "pose"))


def _chain(world: World, tip: Any, base_body: int, base_name: str | None) -> list[tuple[int, int]]:
    """(handle, joint id) of the joints with a motor from the base down to the tip's body."""
    m = world.model
    chain = []
    b = tip.body
    while b not in (0, base_body):
        for j in range(m.body_jntadr[b] + m.body_jntnum[b] - 1, m.body_jntadr[b] - 1, -1):
            jname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            obj = world.by_name.get(jname or "")
            if obj is not None and obj.type == JOINT and obj.handle in world.motor_index \
                    and int(m.jnt_type[j]) in (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)):
                chain.append((obj.handle, j))
        b = int(m.body_parentid[b])
    if b != base_body:
        raise ValueError(f"the tip {tip.name!r} is not below the base {base_name!r}")
    return chain[::-1]


def _parse(world: World, name: str, settings: dict[str, str], handle: int) -> IkGroup:
    """Build a group from its ``simx:ik:NAME`` settings; raises ValueError naming the problem."""
    m = world.model
    numbered = [str(k) for k in range(2, MAX_ELEMENTS + 1)]
    allowed = {"damping", "iterations", "explicit", "enabled", "method", "max_steps"} | \
        {key + n for key in _ELEMENT_KEYS for n in ["", *numbered]}
    unknown = set(settings) - allowed
    if unknown:
        raise ValueError(f"unknown key(s) {sorted(unknown)}")
    names = ["", *(n for n in numbered if "tip" + n in settings or "target" + n in settings)]
    elements = [_element(world, settings, n) for n in names]
    tolerances = [_pair(settings, "precision" + n, (_POSITION_TOLERANCE, _ORIENTATION_TOLERANCE)) for n in names]
    weights = [_pair(settings, "weights" + n, (1.0, 1.0)) for n in names]
    method = settings.get("method", "damped_least_squares")
    if method not in METHODS:
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}")
    try:
        damping = float(_setting(settings, "damping", "0.05"))
        iterations = int(_setting(settings, "iterations", "10"))
    except ValueError as exc:
        raise ValueError(f"bad number: {exc}") from None
    if not 0 <= damping <= 10:
        raise ValueError(f"damping must be in [0, 10], got {damping}")
    if not 1 <= iterations <= L.MAX_IK_ITERATIONS:
        raise ValueError(f"iterations must be in [1, {L.MAX_IK_ITERATIONS}] "
                         f"(simx_server.base.limits.MAX_IK_ITERATIONS), got {iterations}")
    chain: list[tuple[int, int]] = []
    for tip, _, base_body, base_name, _ in elements:  # every element's joints, base first, once each
        chain += [link for link in _chain(world, tip, base_body, base_name) if link not in chain]
    if not chain:
        raise ValueError("no motorised hinge or slide joint between the base and the tip")
    ids = np.array([j for _, j in chain])
    limited = m.jnt_limited[ids].astype(bool)
    tip, target, _, _, bits = elements[0]
    parts = [ik_solver.Element(i, t.handle, g.handle, constraints=c, precision=tolerances[i], weights=weights[i])
             for i, (t, g, _, _, c) in enumerate(elements)]
    # the general solver (ik_solver): several elements, partial constraints, or the settings of a
    # V-REP group (method, precision, weights, max steps) beyond the plain pose / position group
    several = len(elements) > 1 or bits not in (7, 31) or \
        any(k.startswith(("precision", "weights")) or k in ("method", "max_steps") for k in settings)
    return IkGroup(
        name=name, handle=handle, tip=tip.mj_id, target=target.mj_id,
        pose=bits == 31, damping=damping, iterations=iterations,
        explicit=_setting(settings, "explicit", "false").lower() in ("true", "1", "yes"),
        enabled=_setting(settings, "enabled", "true").lower() in ("true", "1", "yes"),
        joints=[h for h, _ in chain], qadr=m.jnt_qposadr[ids].copy(), dadr=m.jnt_dofadr[ids].copy(),
        low=np.where(limited, m.jnt_range[ids, 0], -np.inf), high=np.where(limited, m.jnt_range[ids, 1], np.inf),
        method=METHODS[method],
        bound_steps=_setting(settings, "max_steps", "true").lower() in ("true", "1", "yes"),
        elements=parts if several else [], parts=parts)


class IkGroups:
    """The IK groups of one world's current model (rebuilt by :func:`groups` when it changes)."""

    def __init__(self, world: World):
        self.world = world
        self.model = world.model
        self.groups: dict[str, IkGroup] = {}
        handle = 0
        for key, settings in sorted(world.settings.items()):
            if not key.startswith(PREFIX):
                continue
            handle += 1
            name = key[len(PREFIX):]
            try:
                self.groups[name] = _parse(world, name, settings, handle)
            except ValueError as exc:
                log.error("IK group %r (custom text simx:%s) ignored: %s", name, key, exc)
        self._scratch = mujoco.MjData(self.model) if self.groups else None
        self._by_handle = {g.handle: g for g in self.groups.values()}
        nv = self.model.nv
        self._jacp, self._jacr = np.zeros((3, nv)), np.zeros((3, nv))

    def group(self, which: Any) -> IkGroup:
        """The group named ``which`` (str) or of handle ``which`` (int).

        Args:
            which: a group's name or handle.

        Returns:
            The group.

        Raises:
            UnknownObjectError: no such group.
        """
        if isinstance(which, str):
            g = self.groups.get(which)
        else:
            g = self._by_handle.get(which)
        if g is None:
            raise UnknownObjectError(f"no IK group {quote(which)} in the scene "
                                     "(declare one with a simx:ik:NAME custom text)")
        return g

    def solve_automatic(self) -> None:
        """Solve every enabled group that is not explicit (once per simulation step: V-REP's
        main script's ``sim.handleIkGroup(sim.handle_all_except_explicit)``)."""
        for g in self.groups.values():
            if g.enabled and not g.explicit:
                self.solve(g)

    def tip_error(self, g: IkGroup, data: mujoco.MjData) -> np.ndarray:
        """Target pose minus tip pose in ``data``: (3,) m, then for ``pose`` (3,) rad (world frame).

        Args:
            g: the group.
            data: MuJoCo data whose kinematics are up to date.

        Returns:
            Array (3,) or, for a pose group, (6,).
        """
        e = data.site_xpos[g.target] - data.site_xpos[g.tip]
        if not g.pose:
            return e
        rt = data.site_xmat[g.target].reshape(3, 3)
        rc = data.site_xmat[g.tip].reshape(3, 3)
        # rotation vector of rt rc^T (exact for any angle below pi)
        qt, qc, dq = np.empty(4), np.empty(4), np.empty(3)
        mujoco.mju_mat2Quat(qt, rt.reshape(9).copy())
        mujoco.mju_mat2Quat(qc, rc.reshape(9).copy())
        mujoco.mju_subQuat(dq, qt, qc)  # in the tip's frame
        return np.concatenate([e, rc @ dq])

    def solve(self, g: IkGroup) -> int:
        """Solve ``g`` from the chain's current target positions; set the new targets.

        Returns IK_SUCCESS when the tip reaches the target within 0.01 mm / 0.1 mrad on the
        kinematic model, IK_FAIL otherwise (the targets still move as far as the iterations got,
        as V-REP's damped resolution did). A chain joint a client put in velocity mode keeps
        its own target velocity (its target position is not set).

        Implements V-REP's ``simHandleIkGroup`` on one group (damped least squares on
        ``mj_jacSite``, or :func:`simx_server.sim.ik_solver.solve` for several elements).

        Args:
            g: the group.

        Returns:
            IK_SUCCESS (1) or IK_FAIL (2).
        """
        w, m, d, s = self.world, self.model, self.world.data, self._scratch
        s.qpos[:] = d.qpos
        s.mocap_pos[:], s.mocap_quat[:] = d.mocap_pos, d.mocap_quat
        motors = [w.motor_index[h] for h in g.joints]
        q = w.target_position[motors].astype(float)
        q = np.clip(q, g.low, g.high)
        if g.elements:  # several elements, or constraints other than pose and position
            hinge = m.jnt_type[[w.get(h).mj_id for h in g.joints]] == _HINGE
            ok, q, _ = ik_solver.solve(w, s, g.joints, q, g.elements, g.method, g.damping, g.iterations,
                                       np.where(hinge, MAX_STEP_RAD, MAX_STEP_M), bound_steps=g.bound_steps)
            self._set_targets(g, q)
            return IK_SUCCESS if ok else IK_FAIL
        lam2 = g.damping * g.damping
        jacp, jacr = self._jacp, self._jacr
        ok = False
        for _ in range(g.iterations + 1):
            s.qpos[g.qadr] = q
            mujoco.mj_kinematics(m, s)
            mujoco.mj_comPos(m, s)
            e = self.tip_error(g, s)
            if np.linalg.norm(e[:3]) < _POSITION_TOLERANCE and (not g.pose or np.linalg.norm(e[3:]) < _ORIENTATION_TOLERANCE):
                ok = True
                break
            if _ == g.iterations:
                break
            mujoco.mj_jacSite(m, s, jacp, jacr, g.tip)
            jac = np.vstack([jacp[:, g.dadr], jacr[:, g.dadr]]) if g.pose else jacp[:, g.dadr]
            dq = jac.T @ np.linalg.solve(jac @ jac.T + lam2 * np.eye(len(e)), e)
            q = np.clip(q + dq, g.low, g.high)
        self._set_targets(g, q)
        return IK_SUCCESS if ok else IK_FAIL

    def check(self, g: IkGroup, joints: list[int]) -> tuple[int, list[float]]:
        """Solve ``g`` from the joints' current positions moving only ``joints`` (the chain's
        others stay where they are), and leave the scene as it was: coppeliaSimLib
        ``CIkGroup_old::checkIkGroup`` (``sim.checkIkGroup``), with the group's own method,
        damping, iterations, precision and weights.

        Args:
            g: the group.
            joints: handles of the joints the solver may move (any of the chain's).

        Returns:
            ``(result, values)``: IK_SUCCESS (1), IK_FAIL (2) or IK_NOT_PERFORMED (0, a group
            saved inactive), and the joints' positions reached (rad or m), in ``joints``' order.

        Raises:
            ArgumentError: a joint that is not in the group's chain.
        """
        q0, steps = self._start(g, joints)
        if not g.enabled or not joints:
            return IK_NOT_PERFORMED, q0.tolist()
        ok, q, _ = ik_solver.solve(self.world, self._scratch, joints, q0, g.parts, g.method, g.damping,
                                   g.iterations, steps, bound_steps=g.bound_steps)
        return (IK_SUCCESS if ok else IK_FAIL), [float(v) for v in q]

    def path(self, g: IkGroup, joints: list[int], count: int,
             collides: Callable[[np.ndarray], bool] | None = None) -> np.ndarray | None:
        """``count`` configurations of ``joints`` that carry each tip of ``g`` from where it is
        to its target in equal steps (positions on the line, orientations by spherical
        interpolation), each solved from the one before with the group's own settings; None
        when a step fails its precision or ``collides``. The scene is left as it was.
        coppeliaSimLib ``simGenerateIkPath_internal`` (``sim.generateIkPath``): an inactive
        group is solved too, the chain's joints not in ``joints`` are held.

        Args:
            g: the group.
            joints: handles of the joints the solver may move (any of the chain's).
            count: the number of configurations (>= 2).
            collides: ``collides(q)``: whether a configuration collides (None: not checked).

        Returns:
            Array (count, len(joints)) of joint positions (rad or m), or None.

        Raises:
            ArgumentError: a joint that is not in the group's chain.
        """
        q, steps = self._start(g, joints)
        return ik_solver.path(self.world, self._scratch, joints, q, g.parts, g.method, g.damping, g.iterations,
                              steps, count, collides, bound_steps=g.bound_steps)

    def _start(self, g: IkGroup, joints: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """The joints' positions now and their largest steps; the scratch data set to the scene's state."""
        w, s = self.world, self._scratch
        for h in joints:
            if h not in g.joints:
                raise ArgumentError(f"joint {quote(h)} is not in the chain of IK group {g.name!r}")
        s.qpos[:] = w.data.qpos
        s.mocap_pos[:], s.mocap_quat[:] = w.data.mocap_pos, w.data.mocap_quat
        hinge = self.model.jnt_type[[w.get(h).mj_id for h in joints]] == _HINGE
        return np.array([w.joint_position(h) for h in joints], float), np.where(hinge, MAX_STEP_RAD, MAX_STEP_M)

    def _set_targets(self, g: IkGroup, q: np.ndarray) -> None:
        for h, value in zip(g.joints, q):
            try:
                self.world.set_joint_target_position(h, float(value))
            except ObjectTypeError:  # a client put the joint in velocity mode: it is not driven
                pass


_GROUPS: "weakref.WeakKeyDictionary[World, IkGroups]" = weakref.WeakKeyDictionary()


def groups(world: World) -> IkGroups:
    """The IK groups of ``world``'s current model (parsed once per model: an edit re-parses).

    Args:
        world: the world.

    Returns:
        Its :class:`IkGroups` (a declaration that cannot be used is logged and left out).
    """
    g = _GROUPS.get(world)
    if g is None or g.model is not world.model:
        g = _GROUPS[world] = IkGroups(world)
    return g


def step(world: World) -> None:
    """Solve the world's automatic IK groups (the simulation step's hook); cheap without any.

    Args:
        world: the world about to step.
    """
    g = _GROUPS.get(world)
    if g is None or g.model is not world.model:
        g = groups(world)
    if g.groups:
        try:
            g.solve_automatic()
        except Exception:  # never a step fault: the arm keeps its last targets
            log.exception("IK groups of %s not solved this step", world.scene_name)


def set_properties(world: World, g: IkGroup, **changes: str) -> None:
    """Change a group's ``simx:ik:NAME`` settings (``method``, ``iterations``, ``damping``,
    ``constraintsN``...) and re-read the groups: ``sim.setIkGroupProperties`` /
    ``sim.setIkElementProperties``. The settings are checked as the scene's are.

    Args:
        world: the world.
        g: the group.
        changes: setting -> value (text).

    Raises:
        ArgumentError: a value the group cannot take (the group is left as it was).
    """
    key = PREFIX + g.name
    settings = world.settings[key]
    updated = {**settings, **changes}
    try:
        _parse(world, g.name, updated, g.handle)
    except ValueError as exc:
        raise ArgumentError(f"IK group {g.name!r}: {exc}") from None
    settings.update(changes)
    _GROUPS.pop(world, None)


# ------------------------------------------------------------ for sim.handleIkGroup & co.
def group_arg(value: Any) -> Any:
    """An IK group argument as the ``sim`` calls take it (:mod:`simx_server.api.sim.ik_groups`).

    Args:
        value: a handle (int, or an integral float from Lua) or a name (str or bytes).

    Returns:
        The handle (int) or the name (str).

    Raises:
        ArgumentError: anything else.
    """
    if isinstance(value, (bytes, bytearray)):
        value = bytes(value).decode("utf-8", "replace")
    if isinstance(value, str):
        return value
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, int) or isinstance(value, bool):
        raise ArgumentError(f"IK group must be a handle or a name, got {quote(value)}")
    return value

