"""Joints, dummies, sensors, lights and IK groups of a converted scene
(:mod:`simx_server.scene.ttt.convert`), with their ``simx:`` settings (docs/PORTING.md); loop
closures and dependent joints are in :mod:`simx_server.scene.ttt.mechanisms`."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_server.scene.ttt import kinds, looks, mechanisms
from simx_server.scene.ttt.filters import vision_settings
from simx_server.scene.ttt.geometry import camera_quat, quat_to_mat
from simx_server.base.limits import MAX_IK_ITERATIONS
from simx_server.sim.ik import MAX_ELEMENTS as MAX_IK_ELEMENTS
from simx_server.sim.motors import DEFAULT_PID_P
from simx_server.sim.proximity_volume import CYLINDER_FACES
from simx_server.scene.ttt.model import Pose, TttObject

REVOLUTE, PRISMATIC, SPHERICAL = 10, 11, 12
PASSIVE, MOTION_OLD, IK_OLD, IK_DEPENDENT_OLD, DEPENDENT, FORCE = 0, 1, 2, 3, 4, 5
_PROXIMITY_CONE = 33


#: The contact margin of a motored wheel's round shape (m): :func:`wheel_contacts`.
WHEEL_MARGIN = 5e-4
#: How much higher than its model's lowest respondable point a wheel's lowest point may lie (m).
WHEEL_SUPPORT = 1e-3


def wheel_contacts(conv, wheels: list[tuple[TttObject, TttObject, np.ndarray, np.ndarray]]) -> None:
    """Let motored wheels carry their robot as Bullet's rigid contacts do. Bullet (V-REP's and
    CoppeliaSim 4.1's default engine) rests a wheeled robot on its wheels where its casters or
    skids stand even a fraction of a millimetre higher; MuJoCo's soft contacts share the weight
    among all supports (a TurtleBot's two casters, 0.036 mm higher than its wheels' line, took
    half of it, and their sideways drag stopped it turning: 0.0003 rad/s where Bullet's statics
    give 0.61). A wheel here is a round shape (a cylinder about the joint's axis, or a sphere)
    centred on the axis of a joint in velocity mode, the axis horizontal (within 10 degrees, as
    the file places it), whose lowest point is among its model's lowest (within
    :data:`WHEEL_SUPPORT` of every respondable shape's): its geoms touch from
    :data:`WHEEL_MARGIN` away (MuJoCo's ``margin``), so the robot rides that much higher on its
    wheels and its casters take what its pitch puts there (the TurtleBot's back caster 1.3% of
    its weight; Bullet's statics 1.5%). A handle or a knob on a motored hinge is not a wheel.

    Args:
        conv: the converter, after every object is emitted (its joint settings, world poses,
            bodies and models are read).
        wheels: ``(joint, shape, axis, pos)`` of each joint with one child shape: the shape, the
            axis and the joint's position in the shape's body frame.
    """
    level = math.sin(math.radians(10))
    wheels = [w for w in wheels if "mode=velocity" in conv.settings.get(w[0].name, ())
              and abs((quat_to_mat(conv.world_pose[w[1].handle].quat) @ w[2])[2]) <= level]
    models = {conv.model_of.get(shape.handle, -1) for _, shape, _, _ in wheels}
    low = {o.handle: _lowest(conv, o) for o in conv.scene.objects.values()  # only the models with wheels
           if o.kind == "shape" and o.data.respondable and conv.model_of.get(o.handle, -1) in models}
    lowest: dict[int, float] = {}  # model base -> lowest respondable point (m, world z)
    for handle, z in low.items():
        model = conv.model_of.get(handle, -1)
        lowest[model] = min(lowest.get(model, math.inf), z)
    for _, child, axis, pos in wheels:
        if not (child.handle in low and low[child.handle] <= lowest[conv.model_of.get(child.handle, -1)] + WHEEL_SUPPORT):
            continue
        axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
        for g in conv.bodies[child.handle].geoms:
            along = quat_to_mat(np.asarray(g.quat, float)) @ np.array([0.0, 0, 1])
            off = np.asarray(g.pos, float) - pos
            centred = float(np.linalg.norm(off - (off @ axis) * axis)) < 1e-3
            round_ = g.type == mujoco.mjtGeom.mjGEOM_SPHERE or (
                g.type == mujoco.mjtGeom.mjGEOM_CYLINDER and abs(float(along @ axis)) > 0.999)
            if round_ and centred and (g.contype or g.conaffinity):
                g.margin = WHEEL_MARGIN


def _lowest(conv, obj: TttObject) -> float:
    """The lowest point (world z, m) of shape ``obj``'s meshes as the file places it."""
    pose = conv.world_pose[obj.handle]
    r = quat_to_mat(pose.quat)
    return min((float(np.min((np.asarray(mesh.vertices) @ (r @ quat_to_mat(mesh.frame.quat)).T)[:, 2]))
                + float((r @ mesh.frame.pos + pose.pos)[2]) for mesh in obj.data.meshes if len(mesh.vertices)),
               default=math.inf)


def settings_text(items: dict[str, str]) -> str:
    return " ".join(f"{k}={v}" for k, v in items.items())


def add_joint(conv, obj: TttObject, body, pos: np.ndarray, axis: np.ndarray) -> None:
    """The joint ``obj`` in ``body`` at ``pos`` along ``axis`` (body frame), its motor as simx
    models it: an actuator with V-REP's maximum force, ``mode`` and ``max_velocity`` in its
    ``simx:`` setting; a dependent joint an MJCF joint equality; a limit that holds
    (:mod:`simx_server.scene.ttt.mechanisms`). A driven joint (a motor, its own spring) gets
    ``mechanisms.DRIVEN_ARMATURE``, as do the joints of a closed mechanism
    (:func:`simx_server.scene.ttt.mechanisms.add_loop_closures`); any other (no motor, a
    spherical joint) none, as in V-REP, where a free joint moves its child with the child's
    inertia alone: a caster, a rope's link or a screw turned by a screwdriver carries no
    flywheel."""
    j = obj.data
    jt = body.add_joint()
    jt.name = obj.name
    jt.pos = pos
    jt.axis = axis / max(np.linalg.norm(axis), 1e-12)
    jt.armature = 0.0
    if j.type == SPHERICAL:
        jt.type = mujoco.mjtJoint.mjJNT_BALL
        conv.report.add("spherical joint positions (start at the file's pose, zero there)", approximated=True)
        return
    jt.type = mujoco.mjtJoint.mjJNT_HINGE if j.type == REVOLUTE else mujoco.mjtJoint.mjJNT_SLIDE
    jt.ref = j.position
    if not (j.type == REVOLUTE and j.cyclic) and math.isfinite(j.range) and j.range > 0:
        jt.range = [j.minimum, j.minimum + j.range]
        jt.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        mechanisms.stiff_limit(conv, jt)  # V-REP's limits are hard: they hold under the motors
    else:
        jt.limited = mujoco.mjtLimited.mjLIMITED_FALSE
    mode = None
    if j.mode == DEPENDENT or (j.dependency is not None and j.mode in (DEPENDENT, IK_DEPENDENT_OLD)):
        mechanisms.dependent(conv, obj)  # its equality (scene/ttt/mechanisms.py), or free
        conv.setting(obj.name, "mode=passive")
        return
    if j.mode == FORCE:
        spring = j.spring is not None and j.control_mode == 12
        slow = spring and _slow_spring(j)
        if spring and not slow and _spring(jt, j):
            jt.armature = mechanisms.DRIVEN_ARMATURE
            conv.setting(obj.name, "mode=passive")  # the joint's own spring-damper instead of a motor
            return
        if slow:
            mode = "spring"  # a velocity motor at the target velocity (sim/joint_springs.py)
        elif not j.motor:
            mode = "passive"
        elif j.control_mode in (1, 16):  # 4.4+'s force and callback modes (sim/dyn_ctrl.py)
            mode = "force" if j.control_mode == 1 else "callback"
        else:
            mode = "position" if j.control_loop else "velocity"
    elif j.mode in (IK_OLD, MOTION_OLD):
        mode = "position"
        if j.mode == MOTION_OLD:
            conv.report.add("motion-mode joints (position control instead)", approximated=True)
    else:  # passive: moved only by what pushes it (no motor)
        conv.setting(obj.name, "mode=passive")
        return
    if mode != "passive":
        jt.armature = mechanisms.DRIVEN_ARMATURE
    act = conv.spec.add_actuator()
    act.name = f"{obj.name}_motor"
    act.target = obj.name
    act.trntype = mujoco.mjtTrn.mjTRN_JOINT
    act.set_to_motor()
    force = max(abs(j.max_force) if math.isfinite(j.max_force) else 0.0, 1e-9)  # MuJoCo: a range lo < hi
    act.forcerange = [-force, force]
    act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    items = [f"mode={mode}"]
    if mode == "spring" and j.spring is not None:
        items.append(f"spring_k={j.spring[0]:.9g} spring_c={j.spring[1]:.9g}")
    if j.max_velocity is not None and math.isfinite(j.max_velocity) and j.max_velocity > 0:
        items.append(f"max_velocity={j.max_velocity:.9g}")
    if j.pid is not None and math.isfinite(j.pid[0]) and j.pid[0] > 0 and abs(j.pid[0] - DEFAULT_PID_P) > 1e-9:
        items.append(f"pid_p={j.pid[0]:.9g}")
    if j.pid is not None and mode == "position" and any(v != 0 for v in j.pid[1:]):
        conv.report.add("position loops' I and D terms (simx's position law is V-REP's P loop)", approximated=True)
    target = j.target_position
    if mode in ("position", "spring") and target is not None and math.isfinite(target) \
            and abs(target - j.position) > 1e-9:
        items.append(f"target_position={target:.9g}")
    if math.isfinite(j.target_velocity) and j.target_velocity != 0:
        items.append(f"target_velocity={j.target_velocity:.9g}")
    if j.velocity_lock:  # "lock motor when target velocity is zero" (sim_jointintparam_velocity_lock)
        items.append("velocity_lock=1")
    conv.setting(obj.name, *items)


def _slow_spring(j) -> bool:
    """Whether the spring-damper joint ``j``'s target velocity binds: below its upper velocity
    limit (a button's spring at 100 m/s never reaches it, a door handle's at 0 is a brake).
    CoppeliaSim drives the mode as a velocity motor at that speed (``CJoint::
    handleDynJointControl``); where it binds, so does simx (:mod:`simx_server.sim.joint_springs`),
    and where it does not, the joint's own MuJoCo spring-damper (:func:`_spring`) is the same force,
    integrated at every substep. Its K and C must be usable (finite, not negative)."""
    k, c = j.spring
    fast = j.max_velocity if j.max_velocity is not None and math.isfinite(j.max_velocity) else math.inf
    usable = math.isfinite(k) and math.isfinite(c) and k >= 0 and c >= 0
    return usable and math.isfinite(j.target_velocity) and abs(j.target_velocity) < fast


def _spring(jt, j) -> bool:
    """V-REP's spring mode (4.4's control mode 12; ``Va9`` bit 7 before) as the MuJoCo joint's
    own spring and damper: stiffness K and damping C from the file (``CJoint::handleDynJointControl``:
    force K e + C de/dt; its cap at the motor's maximum force is not kept), at rest at the target
    position (the joint's position where the file gives none). False (and nothing set) where the
    file's values are not usable."""
    values = _spring_values(j)
    if values is None:
        return False
    k, c, rest = values
    jt.stiffness, jt.damping, jt.springref = [k, 0.0, 0.0], [c, 0.0, 0.0], rest
    return True


def _spring_values(j) -> tuple[float, float, float] | None:
    """The spring-damper joint ``j``'s K, C and rest position, None where not usable."""
    k, c = j.spring
    rest = j.position if j.target_position is None else j.target_position
    if not (math.isfinite(k) and math.isfinite(c) and k >= 0 and c >= 0 and math.isfinite(rest)):
        return None
    return k, c, rest


def motorised(j) -> bool:
    """Whether :func:`joint` gives the joint data ``j`` a motor (an actuator): the old IK and
    motion modes, and a force/torque-mode joint with its motor on or a spring of binding target
    velocity, but for a spring that is the joint's own MuJoCo spring-damper."""
    if j.type == SPHERICAL or j.mode == DEPENDENT or (j.dependency is not None and j.mode == IK_DEPENDENT_OLD):
        return False
    if j.mode in (IK_OLD, MOTION_OLD):
        return True
    if j.mode != FORCE:
        return False
    spring = j.spring is not None and j.control_mode == 12
    if spring and _slow_spring(j):
        return True
    return j.motor and not (spring and _spring_values(j) is not None)


#: The least rangefinder cutoff a proximity sensor gets (m): MuJoCo's cutoff 0 means none.
_MIN_CUTOFF = 1e-3
#: V-REP's proximity volume types (``Snt``) that simx casts as sets of rays (sim/proximity.py).
_VOLUMES = {30: "pyramid", 31: "cylinder", 32: "disc"}


def _volume_settings(p, start: float) -> list[str] | None:
    """The ``simx:`` settings of a pyramid, cylinder or disc volume starting at ``start`` m
    (:func:`_near_part`), None where the file's sizes are not usable (not finite, negative)."""
    kind = _VOLUMES[p.type]
    items = [f"volume={kind}", f"offset={start:.6g}"]
    if start + p.range < _MIN_CUTOFF and kind != "disc":  # ends at or behind the origin: past what a cutoff holds
        items.append(f"far={start + p.range:.6g}")
    sizes = p.sizes
    if kind == "pyramid" and len(sizes) >= 4:
        values = sizes[:4]
        items += [f"size={values[0]:.6g},{values[1]:.6g}", f"size_far={values[2]:.6g},{values[3]:.6g}"]
    elif kind == "cylinder" and len(sizes) >= 6:
        values = sizes[4:6]
        items += [f"radius={values[0]:.6g}", f"radius_far={values[1]:.6g}"]
        if CYLINDER_FACES[0] <= p.faces <= CYLINDER_FACES[1]:
            items.append(f"faces={p.faces}")
    elif kind == "disc" and 1e-3 < p.angle < math.pi:
        values = ()
        items.append(f"angle={math.degrees(p.angle):.6g}")
    else:
        return None
    if not all(math.isfinite(v) and 0 <= v < 1e3 for v in values):
        return None
    return items


def _near_part(p, cone: bool) -> tuple[float, float]:
    """A ray or cone sensor's offset along +z and, for a cone, its radius (m, within 1000):
    CoppeliaSim casts a ray from ``(0, 0, offset)`` (``CProxSensorRoutine::_detectShape``) and
    sees in a cone between ``radius`` and ``radius + range`` from an apex at that offset
    (``CConvexVolume``'s cone volume); nothing nearer is seen."""
    start = min(max(p.offset, -1000.0), 1000.0) if math.isfinite(p.offset) else 0.0
    near = p.sizes[4] if cone and len(p.sizes) >= 5 and math.isfinite(p.sizes[4]) else 0.0
    return start, min(max(near, 0.0), 1000.0)


def _start_settings(start: float, near: float) -> list[str]:
    """The ``simx:`` settings ``offset=`` and ``radius=`` of :func:`_near_part`, where not 0."""
    return ([f"offset={start:.6g}"] if start != 0 else []) + ([f"radius={near:.6g}"] if near > 0 else [])


def add_sensor(conv, obj: TttObject, body, local: Pose) -> None:
    """Dummies, proximity and vision sensors, lights, and the objects kept only as sites."""
    kind = obj.kind
    if kind == "vision_sensor":
        v = obj.data
        cam = body.add_camera()
        cam.name = obj.name
        cam.pos, cam.quat = local.pos, camera_quat(local.quat)
        w, h = (max(1, min(int(n), 4096)) for n in v.resolution)
        cam.resolution = [w, h]
        if (w, h) == (1, 1):  # MuJoCo's default: simx cannot tell it from an unset one (256x256)
            conv.report.add("1x1 vision sensors (256x256 in simx)", approximated=True)
        if v.perspective:
            angle = min(max(v.view_angle, 1e-3), math.pi - 1e-3)
            fovy = angle if h >= w else 2 * math.atan(math.tan(angle / 2) * h / w)
            cam.fovy = math.degrees(fovy)
        else:
            cam.proj = mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC
            cam.fovy = max(v.ortho_size, 1e-4) * (h / w if w > h else 1.0)
        conv.setting(obj.name, "image=rgb", f"near={max(v.near, 1e-4):.6g}", f"far={max(v.far, v.near + 1e-3):.6g}",
                     *vision_settings(conv, v, obj.name))
        return
    if kind == "light":
        light = body.add_light()
        light.name = obj.name
        light.pos = local.pos
        light.dir = quat_to_mat(local.quat) @ np.array([0.0, 0, 1])
        looks.add_light(conv, obj.data if isinstance(obj.data, looks.LightData) else looks.LightData(), light)
        return
    site = body.add_site()
    site.name = obj.name
    site.pos, site.quat = local.pos, local.quat
    if kind == "dummy":
        site.size = [max(obj.data.size / 2, 1e-3), 0, 0]
        site.group = 4
        return
    if kind == "proximity_sensor":
        p = obj.data
        site.size = [0.005, 0, 0]
        site.group = 4
        sensor = conv.spec.add_sensor()
        sensor.type = mujoco.mjtSensor.mjSENS_RANGEFINDER
        sensor.objtype = mujoco.mjtObj.mjOBJ_SITE
        sensor.objname = obj.name
        cone = p.type == _PROXIMITY_CONE and p.angle > 1e-3
        start, near = _near_part(p, cone)
        sensor.cutoff = max(start + near + p.range, _MIN_CUTOFF)
        sensor.intprm[0] = 1  # the distance (what MJCF's parser sets by default)
        if cone:
            conv.setting(obj.name, f"angle={math.degrees(p.angle):.6g}", *_start_settings(start, near))
        elif p.type in _VOLUMES and (volume := _volume_settings(p, start)) is not None:
            conv.setting(obj.name, *volume)
        elif p.type == 34:
            if start != 0:
                conv.setting(obj.name, *_start_settings(start, 0.0))
        else:
            conv.report.add("proximity sensor volumes without usable sizes (a ray along +z)", approximated=True)
        return
    site.size = [1e-3, 0, 0]
    site.group = 5
    if kinds.add_kept_object(conv, obj):  # a camera or old path keeps its type (scene.ttt.kinds)
        return
    if kind != "script":  # a 4.6+ script object: a site its script runs on (scripts.write_scripts)
        conv.report.add(f"{kind.replace('_', ' ')} objects (kept as dummies)")


#: ``sim_ik_*_method`` of an old group's ``Cmt`` by the words of ``simx:ik:NAME method=``.
_IK_METHODS = {0: "pseudo_inverse", 1: "damped_least_squares", 2: "jacobian_transpose", 3: "undamped"}


def _ik_element(conv, element, n: str) -> list[str] | None:
    """The settings of one element (``n``: "" for the first, "2"... for the others), or None."""
    tip = conv.scene.objects.get(element.tip)
    target = conv.scene.objects.get(tip.data.linked) if tip is not None and tip.kind == "dummy" else None
    if target is None or not 1 <= element.constraints <= 31:
        return None
    words = {31: "pose", 7: "position"}
    items = [f"tip{n}={tip.name}", f"target{n}={target.name}",
             f"constraints{n}={words.get(element.constraints, element.constraints)}"]
    base = conv.scene.objects.get(element.base)
    if base is not None and base.handle in conv.bodies:
        items.append(f"base{n}={base.name}")
    items.append(f"precision{n}={element.precision[0]:.9g},{element.precision[1]:.9g}")
    if tuple(element.weights) != (1.0, 1.0):
        items.append(f"weights{n}={element.weights[0]:.9g},{element.weights[1]:.9g}")
    return items


def add_ik_groups(conv) -> None:
    """Old IK groups (``IKO``) as ``simx:ik:NAME`` settings (:mod:`simx_server.sim.ik`): each
    element's tip dummy, its linked target, its base, constraint bits, precision and weights
    (the first as ``tip= target= ...``, the others ``tipN= targetN= ...``), and the group's
    method, damping, iterations and max-step flag as the file has them (``CIkGroup_old``)."""
    taken = set()
    for group in conv.scene.ik_groups:
        elements = [e for e in group.elements if e.enabled]
        if not elements:
            continue
        first = _ik_element(conv, elements[0], "")
        if first is None:
            conv.report.add("IK groups without a linked tip dummy")
            continue
        name = group.name
        while name in taken:
            name += "_"
        taken.add(name)
        items = first
        for n, element in enumerate(elements[1:MAX_IK_ELEMENTS], start=2):
            more = _ik_element(conv, element, str(n))
            if more is None:
                conv.report.add("IK group elements without a linked tip dummy")
                continue
            items += more
        if len(elements) > MAX_IK_ELEMENTS:
            conv.report.add(f"IK group elements beyond the {MAX_IK_ELEMENTS}th")
        items += [f"method={_IK_METHODS.get(group.method, 'pseudo_inverse')}", f"damping={group.damping:.9g}",
                  f"iterations={max(1, min(group.iterations, MAX_IK_ITERATIONS))}",
                  f"max_steps={'true' if group.max_steps else 'false'}"]
        if group.explicit:
            items.append("explicit=true")
        if not group.enabled:
            items.append("enabled=false")
        conv.setting(f"ik:{name}", *items)


#: V-REP's collection element types (``Gty``) by simx's names (simx_server.sim.scene_collections).
_ELEMENTS = {0: "single", 1: "tree", 2: "tree_without_base", 3: "chain", 4: "chain_without_tip", 5: "all"}


def add_collections(conv) -> None:
    """Collections (``GRP``) as ``simx:collection:NAME items=...`` settings, their elements in
    order (additive ``+``, subtractive ``-``)."""
    for group in conv.scene.collections:
        items = []
        for handle, kind, additive in group.elements:
            element = _ELEMENTS.get(kind)
            obj = conv.scene.objects.get(handle)
            if element is None or (element != "all" and obj is None):
                conv.report.add("collection elements of unknown types or objects")
                continue
            items.append(("+" if additive else "-") + (element if element == "all" else f"{element}:{obj.name}"))
        if group.name and items:
            conv.setting(f"collection:{group.name}", "items=" + ",".join(items))
