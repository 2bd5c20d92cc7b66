"""The motors simx gives a scene's joints when it compiles: each named hinge or slide joint
without an actuator (and not driven through a tendon) gets one of its own, ``simx_motor:<joint>``
(:data:`ADDED_PREFIX`), disabled until a program enables it (:mod:`simx_server.sim.motors`)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_server.base import limits as L
from simx_server.sim.mechanisms import LIMIT_SOLIMP, stiff_solref

#: Prefix of the actuators simx adds to joints that have none (their motor starts disabled).
ADDED_PREFIX = "simx_motor:"
#: Prefix of the joint equalities that lock a stopped velocity motor (:func:`add_locks`).
LOCK_PREFIX = "simx_lock:"

JOINT_TRNS = (int(mujoco.mjtTrn.mjTRN_JOINT), int(mujoco.mjtTrn.mjTRN_JOINTINPARENT))
TENDON_TRN = int(mujoco.mjtTrn.mjTRN_TENDON)
SCALAR = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def tendon_driven(m: mujoco.MjModel) -> dict[int, str]:
    """The joints moved only through a tendon an actuator drives.

    Args:
        m: the model.

    Returns:
        Joint id -> the name of a tendon that an actuator drives and that wraps the joint.
    """
    out = {}
    for a in range(m.nu):
        if m.actuator_trntype[a] == TENDON_TRN:
            t = int(m.actuator_trnid[a, 0])
            for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]):
                if m.wrap_type[w] == mujoco.mjtWrap.mjWRAP_JOINT:
                    out.setdefault(int(m.wrap_objid[w]), mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TENDON, t) or f"#{t}")
    return out


def compile_spec(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """Compile ``spec`` after giving each named hinge/slide joint without an actuator (and not
    driven through a tendon) a motor of its own, ``simx_motor:<joint>`` (added to ``spec``), and
    each joint whose ``simx:`` settings say ``velocity_lock=1`` its lock (:func:`add_locks`).

    Raises ValueError: MuJoCo cannot compile the spec.

    Args:
        spec: the scene's spec (actuators are added to it).

    Returns:
        The compiled model.
    """
    add_locks(spec)
    model = _compile_predicted(spec)
    if model is not None:
        return model
    model = spec.compile()
    missing = _missing(model, model.nu)
    if not missing:
        return model
    taken = {a.name for a in spec.actuators}
    for name in missing:
        if ADDED_PREFIX + name not in taken:
            _add_motor(spec, name)
    return spec.compile()


def lock_name(joint: str) -> str:
    """The name of the joint equality that locks a joint.

    Args:
        joint: the joint's name.

    Returns:
        :data:`LOCK_PREFIX` + ``joint``.
    """
    return LOCK_PREFIX + joint


def add_locks(spec: mujoco.MjSpec) -> None:
    """Give each hinge/slide joint whose ``simx:`` text says ``velocity_lock=1`` ("lock motor when
    target velocity is zero", what a ``.ttt`` saved) an inactive joint equality ``simx_lock:<joint>``
    that :class:`~simx_server.sim.motors.Motors` switches on, pinned where the motor stopped, while
    its target velocity is 0: a rigid hold with no force bound, as CoppeliaSim's Bullet 2.78 plugin
    sets the hinge's or slider's two limits to where it stopped
    (``CConstraintDyn_bullet278::_handleRevoluteMotor_controllerDisabled``). Stiff as a limit: two
    timesteps, 99 % impedance. Joints that have one keep it.

    Args:
        spec: the scene's spec (equalities are added to it).
    """
    settings = {t.name[len("simx:"):]: t.data for t in spec.texts if t.name.startswith("simx:")}
    locked = [name for name, data in settings.items() if "velocity_lock=1" in data.split()]
    if not locked:
        return
    taken = {e.name for e in spec.equalities}
    joints = {j.name for j in spec.joints if int(j.type) in SCALAR}
    for name in locked:
        if name in joints and lock_name(name) not in taken:
            eq = spec.add_equality()
            eq.name = lock_name(name)
            eq.type = mujoco.mjtEq.mjEQ_JOINT
            eq.objtype = mujoco.mjtObj.mjOBJ_JOINT
            eq.name1 = name
            eq.active = False
            eq.data[:5] = 0.0
            eq.solref, eq.solimp = stiff_solref(spec.option.timestep), list(LIMIT_SOLIMP)


def _add_motor(spec: mujoco.MjSpec, joint: str) -> mujoco.MjsActuator:
    return spec.add_actuator(name=ADDED_PREFIX + joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                             gear=[1, 0, 0, 0, 0, 0], ctrllimited=0, forcelimited=0)


def _missing(model: mujoco.MjModel, nu: int) -> list[str]:
    """Names of the named hinge/slide joints that none of the model's first ``nu`` actuators
    drives, directly or through a tendon, in joint order."""
    driven = {int(model.actuator_trnid[a, 0]) for a in range(nu) if model.actuator_trntype[a] in JOINT_TRNS}
    tendons = tendon_driven(model)
    return [name for j in range(model.njnt)
            if int(model.jnt_type[j]) in SCALAR and j not in driven and j not in tendons
            and (name := mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j))]


def _compile_predicted(spec: mujoco.MjSpec) -> mujoco.MjModel | None:
    """:func:`compile_spec`'s model in one compile, its motors read from the spec beforehand
    (a scene that needs motors was compiled twice: the UR5 scene's compile is 20 ms, nearly all
    of it generating its textures). None, with ``spec`` as it was, where the spec has tendons,
    needs no motor, or the compiled model shows another set or order of joints without an
    actuator than the spec read: :func:`compile_spec` then compiles, adds, compiles again."""
    if len(spec.tendons):
        return None
    driven = {a.target for a in spec.actuators if int(a.trntype) in JOINT_TRNS}
    taken = {a.name for a in spec.actuators}
    names = [j.name for j in spec.joints if int(j.type) in SCALAR and j.name and j.name not in driven]
    if not names or any(ADDED_PREFIX + n in taken for n in names):
        return None
    added = [_add_motor(spec, n) for n in names]
    try:
        model = spec.compile()
    except Exception:  # the compile without the motors says what is wrong
        model = None
    # the joints none of the scene's own actuators drives, in joint order: what the spec said
    if model is not None and _missing(model, model.nu - len(added)) == names:
        return model
    for actuator in added:
        spec.delete(actuator)
    return None


def max_force(m: mujoco.MjModel, a: int, j: int) -> float:
    """Maximum force/torque on joint ``j`` (N or N·m) from actuator ``a``'s or the joint's limits
    (:mod:`simx_server.sim.motors`).

    Args:
        m: the model.
        a: the actuator's id.
        j: the joint's id.

    Returns:
        The force (limits.MAX_JOINT_FORCE where nothing limits it).
    """
    g = abs(float(m.actuator_gear[a, 0])) or 1.0
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or ""
    if not name.startswith(ADDED_PREFIX):
        if m.actuator_forcelimited[a]:
            return float(np.max(np.abs(m.actuator_forcerange[a]))) * g
        force_control = (m.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
                         and m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE)
        if force_control and m.actuator_ctrllimited[a]:
            return float(np.max(np.abs(m.actuator_ctrlrange[a]))) * abs(float(m.actuator_gainprm[a, 0])) * g
    if m.jnt_actfrclimited[j]:
        return float(np.max(np.abs(m.jnt_actfrcrange[j])))
    return float(L.MAX_JOINT_FORCE)


def own_kv(m: mujoco.MjModel, a: int) -> float:
    """The ``kv`` of a ``<velocity>`` actuator (joint units), or 0 for any other type.

    Args:
        m: the model.
        a: the actuator's id.

    Returns:
        kv (N·s/m or N·m·s/rad), or 0.
    """
    gain, bias = m.actuator_gainprm[a], m.actuator_biasprm[a]
    if (m.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED and m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE
            and bias[0] == 0 and bias[1] == 0 and gain[0] > 0 and bias[2] == -gain[0]
            and m.actuator_dyntype[a] == mujoco.mjtDyn.mjDYN_NONE):
        return float(gain[0]) * float(m.actuator_gear[a, 0]) ** 2
    return 0.0


def joint_setting(settings: dict, key: str, default: float, joint: str, signed: bool = False) -> float:
    """A joint's number setting (``simx:`` ``key=``), ``default`` when absent.

    Args:
        settings: the joint's ``simx:`` settings.
        key: the setting's name.
        default: its value when absent.
        joint: the joint's name, for the error.
        signed: negative values are allowed.

    Returns:
        The value.

    Raises:
        ValueError: naming the joint and the setting, for a value that is not a finite number (or
            is negative where ``signed`` is false).
    """
    raw = settings.get(key)
    if raw is None:
        return default
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or (value < 0 and not signed):
        raise ValueError(f"joint {joint!r}: {key}={raw!r} in its simx: settings is not a "
                         f"{'finite' if signed else 'non-negative'} number")
    return value
