"""The simulated world: a MuJoCo model and data seen as V-REP scene objects.

No transport in here; every method runs on the simulation thread and is testable alone.

Mapping (see docs/SCENES.md and docs/ARCHITECTURE.md): named bodies are shapes, joints are joints,
sites are dummies, cameras are vision sensors, lights are lights, -1 is the world. Objects get
handles in tree order, starting at 1, stable while the scene is loaded. A name that elements of
several kinds share is given out by :mod:`simx_server.sim.naming` (``head``, ``head#0``, ...).

Per-object settings that MJCF has no attribute for come from ``<custom><text name="simx:NAME"
data="key=value ..."/></custom>``: a joint's ``mode`` (``position``/``velocity``/``passive``: the
initial state of its motor, see :mod:`simx_server.sim.motors`) and ``max_velocity`` (rad/s or m/s),
a vision sensor's ``image`` (``rgb``/``depth``), ``near`` and ``far`` (m), an object's
``child_script`` (a file next to the scene).
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import ContextManager

import mujoco
import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, ObjectTypeError, UnknownObjectError
from simx_server.base import limits as L
from simx_server.sim import (change_batch, dummy_links, friction, grasps, integrator, kinematic, motor_spec, motors,
                             naming, physics, properties, scene_settings, surfaces, urdf)
from simx_server.sim.objects import (  # noqa: F401 (importers of the world use them)
    _TYPE_NAMES, CAMERA, DUMMY, FORCE_SENSOR, JOINT, KEPT_TYPES, LIGHT, PATH, PROXIMITY_SENSOR, SHAPE, VISION_SENSOR,
    WORLD, SceneObject, apply_vrep_parents, parse_settings, text_at)
from simx_server.sim.joints import Joints
from simx_server.sim.poses import Poses
from simx_server.sim.rotations import (  # noqa: F401
    _frame_with_z,
    euler_from_matrix,
    matrix_from_euler,
    matrix_from_quaternion,
    quaternion_from_matrix,
)

log = logging.getLogger("simx.world")

#: Model fields that clients may change while the simulation runs (poses, masses, view
#: angles); reset() restores them, as V-REP restores a scene on stop.
_RESTORED_FIELDS = ("body_pos", "body_quat", "site_pos", "site_quat", "cam_pos", "cam_quat", "light_pos",
                    "light_dir", "body_mass", "body_inertia", "cam_fovy", "jnt_pos", "jnt_axis",
                    "eq_obj1id", "eq_obj2id", "eq_data")  # eq_*: grasps (simx_server.sim.grasps)
#: (nq, nv) of each mjtJoint: free, ball, slide, hinge.
_JOINT_SIZES = {0: (7, 6), 1: (4, 3), 2: (1, 1), 3: (1, 1)}

DEFAULT_MAX_VELOCITY = math.pi  # rad/s, used where a joint declares none
POSITION_MODE, VELOCITY_MODE = 0, 1  # World.mode: a motor's control loop on / off


class World(Poses, Joints):
    """A loaded scene: model, data, object registry and joint motors.

    Args:
        scene: path of an MJCF file, or of a URDF file (:mod:`simx_server.sim.urdf`).
        dt: simulation step in s, made of MuJoCo substeps of the model's own timestep; None: the
            step the scene declares (:mod:`simx_server.sim.scene_settings`), else V-REP's 0.05.
        name: the file the user gave, when ``scene`` is its conversion (a .ttt's MJCF): what
            messages name (default: ``scene``'s file name).
        bounded: a client's scene: the compiled model's data arena, step work and contacts as
            loaded must stay within MAX_ARENA_BYTES, MAX_STEP_WORK and MAX_SCENE_CONTACTS
            (:func:`physics.check_cost`), checked before its MjData is made, and each step
            within MAX_STEP_SECONDS (:func:`physics.timed_step`). Its edits, and a
            client's edits of any scene (:meth:`replace_model`), are checked too.

    Raises:
        ValueError: the scene cannot be loaded (MuJoCo's message, with the file name), or
            ``dt`` or the scene exceeds a bound of :mod:`simx_server.base.limits` (MAX_DT,
            MAX_SUBSTEPS, MAX_RESOLUTION).
    """

    def __init__(self, scene: str | Path, dt: float | None = 0.05, bounded: bool = False, name: str | None = None):
        self.scene_path = Path(scene).resolve()
        #: The file the user gave (a .ttt for its converted MJCF): what messages about the scene name.
        self.scene_name = name or self.scene_path.name
        #: A client's scene: its compiled model's arena and step work are bounded (check_cost).
        self.bounded = bounded
        #: ``hook(model, data)`` run before each MuJoCo substep (scripts' sysCall_jointCallback
        #: and sysCall_dynCallback, set by simx_server.scripts.dynamics), or None.
        self.substep_hook = None
        physics.install_warning_handler()  # MuJoCo's warnings go to the log, not to stdout
        try:
            if dt is not None:
                self.requested_dt = physics.check_dt(dt)  # s; the actual dt is a whole number of timesteps
        except ArgumentError as exc:
            raise ValueError(str(exc)) from None
        try:  # through MjSpec: joints without an actuator get a (disabled) motor
            model = motor_spec.compile_spec(urdf.load_spec(self.scene_path))  # MJCF, or URDF (simx_server.sim.urdf)
        except Exception as exc:
            raise ValueError(f"cannot load scene {name or self.scene_path}: {exc}") from exc
        #: The step and real-time mode the scene declares (a .ttt's saved ones), used where the
        #: server's options say nothing (``dt`` None here, no ``--speed``).
        self.scene_settings = scene_settings.read(model, self.scene_name)
        if dt is None:
            try:
                self.requested_dt = physics.check_dt(self.scene_settings.dt or scene_settings.DEFAULT_DT)
            except ArgumentError as exc:
                raise ValueError(f"scene {self.scene_name}: saved time step: {exc}") from None
        self.version = 0  # bumped whenever the state changes (cache key for renders)
        self._batch = change_batch.ChangeBatch()  # one_change's block
        self._product: bool | None = None  # step()'s friction.applies, for the changed() that ends it
        self.time = 0.0  # s, simulation time as of the last changed()
        self._handle_of_name: dict[str, int] = {}  # names present now -> their handles
        self._next_handle = 1  # handles are never given twice
        self.properties = properties.ObjectProperties()  # special and model properties set at run time
        #: Grasped parts (dynamic shapes hung from another object): name -> grasps.Grasp.
        self.grasps: dict[str, grasps.Grasp] = {}
        #: Contact bits of shapes made not respondable (sim/shape_dynamics.py): name -> (contype, conaffinity).
        self.respondable_bits: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        #: Joints' frames in their bodies (3, 3) changed at run time, by name (:mod:`simx_server.sim.poses`).
        self.joint_frames: dict[str, np.ndarray] = {}
        #: Shapes' initial velocities set at run time, (6,) linear and angular, world axes, by name
        #: (:mod:`simx_server.sim.surfaces`: a static shape's moves its contacts' surface).
        self.init_velocities: dict[str, np.ndarray] = {}
        #: Dummy links made at run time: pool weld name -> the two sites (:mod:`simx_server.sim.dummy_links`).
        self.dummy_links: dict[str, tuple[str, str]] = {}
        try:
            self._install(model)
        except ArgumentError as exc:
            raise ValueError(f"scene {self.scene_name}: {exc}") from None
        self.reset()

    def _install(self, model: mujoco.MjModel, bounded: bool = False) -> None:
        """Adopt ``model``: fresh data, registry (keeping known names' handles), motors.

        Raises ArgumentError (before changing anything) when the model's per-step work exceeds
        a bound: substeps of the current dt, camera resolutions; for a client's scene or edit
        (``bounded``), its cost (:func:`physics.check_cost`).
        """
        substeps = physics.check_scene(model, self.requested_dt)
        previous = getattr(self, "model", None)  # an edit: bounded, unless no worse than before
        if self.bounded or bounded:
            physics.check_cost(model, substeps, previous, getattr(self, "substeps", 1))
        self.model = model
        self.data = mujoco.MjData(model)
        # A view kept for the hottest read (each ``data.qpos`` builds a new ndarray): MjData's
        # buffers live as long as the MjData, and every new MjData comes through here.
        self._qpos = self.data.qpos
        self._bad_state = physics.bad_state_view(self.data)  # nonzero after a blow-up
        self.substeps = substeps
        self.dt = self.substeps * model.opt.timestep
        self.settings = self._read_settings()
        self.objects: dict[int, SceneObject] = {}
        self.by_name: dict[str, SceneObject] = {}
        self._register_objects()
        properties.apply_rendering(self)  # non-renderable shapes out of the vision sensors' groups
        scalar = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        self._scalar_joints = {o.handle: (int(model.jnt_qposadr[o.mj_id]), int(model.jnt_dofadr[o.mj_id]))
                               for o in self.objects.values()
                               if o.type == JOINT and int(model.jnt_type[o.mj_id]) in scalar}
        self.refresh_cyclic()
        for gone in [n for n in self._handle_of_name if n not in self.by_name]:
            del self._handle_of_name[gone]  # its handle is never given again
        self._init_motors()
        self._initial_fields = {f: getattr(model, f).copy() for f in _RESTORED_FIELDS}

    def replace_model(self, model: mujoco.MjModel, bounded: bool = True) -> None:
        """Swap in an edited model (scene editing) while the simulation goes on.

        Objects keep their handles (matched by name); joints keep their positions and
        velocities, motors their mode, targets and maximum force; the simulation time goes on.
        Objects that disappeared lose their handle for good; new ones get new handles.
        Raises ArgumentError, changing nothing, when the model exceeds a bound (see _install).

        Args:
            model: the edited scene, compiled.
            bounded: a client's edit: its data arena, step work and contacts as loaded are
                checked (:func:`physics.check_cost`, no worse than the model it replaces);
                the operator's own edits of its own scene are not (docs/SECURITY.md). A
                client's scene is always checked.

        Raises:
            ArgumentError: a bound; or MuJoCo cannot compute the edited scene's state (its data
                arena overflows: two robots loaded at one place, thousands of contacts). The
                world is then as it was.
        """
        saved = {k: dict(v) if isinstance(v, dict) else v for k, v in vars(self).items()}
        try:
            self._replace(model, bounded)
        except mujoco.FatalError as exc:  # raised by mj_forward: nothing of the new model is kept
            vars(self).clear()
            vars(self).update(saved)
            text = "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())
            raise ArgumentError(f"MuJoCo cannot compute the edited scene's state: {text}") from None

    def _replace(self, model: mujoco.MjModel, bounded: bool) -> None:
        old_model, old_data = self.model, self.data
        held = dict(self.grasps)
        velocities, links = dict(self.init_velocities), dict(self.dummy_links)
        joints = {o.name: o.mj_id for o in self.objects.values() if o.type in (JOINT,)}
        kept = {h: self.motors.state(i) for h, i in self.motor_index.items()}
        free = {o.name: int(old_model.body_jntadr[o.mj_id]) for o in self.objects.values()
                if o.type == SHAPE and old_model.body_jntnum[o.mj_id] == 1
                and old_model.jnt_type[old_model.body_jntadr[o.mj_id]] == mujoco.mjtJoint.mjJNT_FREE}
        self._install(model, bounded)
        self.reset()
        self.init_velocities.update(velocities)
        m, d = self.model, self.data
        copies = [(old_model.jnt_qposadr[j], old_model.jnt_dofadr[j], self.by_name[n].mj_id)
                  for n, j in joints.items() if n in self.by_name and self.by_name[n].type == JOINT]
        copies += [(old_model.jnt_qposadr[j], old_model.jnt_dofadr[j], int(m.body_jntadr[self.by_name[n].mj_id]))
                   for n, j in free.items() if n in self.by_name and m.body_jntnum[self.by_name[n].mj_id] == 1]
        for qadr, dadr, j in copies:
            nq, nv = _JOINT_SIZES[int(m.jnt_type[j])]
            d.qpos[m.jnt_qposadr[j]:m.jnt_qposadr[j] + nq] = old_data.qpos[qadr:qadr + nq]
            d.qvel[m.jnt_dofadr[j]:m.jnt_dofadr[j] + nv] = old_data.qvel[dadr:dadr + nv]
        for h, state in kept.items():
            i = self.motor_index.get(h)
            if i is not None:
                self.motors.restore(i, state)
        self.motors.write_force_limits(m)
        d.time = old_data.time
        grasps.reapply(self, held)
        dummy_links.reapply(self, links)
        self.changed()

    # ----------------------------------------------------------------- registry
    def _read_settings(self) -> dict[str, dict[str, str]]:
        m = self.model
        out = {}
        for i in range(m.ntext):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXT, i) or ""
            if name.startswith("simx:"):
                raw = text_at(m, i)
                try:
                    out[name[5:]] = parse_settings(raw)
                except ValueError as exc:
                    raise ValueError(f"{self.scene_path}: custom text {name!r}: {exc}") from exc
        return out

    def _add(self, name: str | None, otype: int, mj_id: int, body: int, parent: int) -> int:
        if not name:
            return parent
        if name in self.by_name:
            log.warning("scene %s: name %r used twice; the %s keeps it", self.scene_name,
                        name, _TYPE_NAMES[self.by_name[name].type])
            return parent
        handle = self._handle_of_name.get(name)
        if handle is None:
            handle = self._handle_of_name[name] = self._next_handle
            self._next_handle += 1
        obj = SceneObject(handle, name, otype, mj_id, body, parent, self.settings.get(name, {}))
        self.objects[handle] = obj
        self.by_name[name] = obj
        return obj.handle

    def _register_objects(self) -> None:
        m = self.model
        body_handle = {0: WORLD}
        # global names (see simx_server.sim.naming); elements still there keep theirs across edits
        vrep_names, renamed, self._identities = naming.vrep_names(m, getattr(self, "_identities", None))
        names = lambda t, i: vrep_names.get((int(t), int(i)))  # noqa: E731
        if renamed and set(renamed) != getattr(self, "_renamed", None):  # once, not at every edit
            log.warning("%s", naming.describe(self.scene_name, renamed, L.MAX_RENAMES_LOGGED))
            for line in naming.details(self.scene_name, renamed) if log.isEnabledFor(logging.DEBUG) else ():
                log.debug("%s", line)
        self._renamed = set(renamed)
        site_type = {}  # sites carrying a rangefinder or a force sensor are sensors
        for k in range(m.nsensor):
            if m.sensor_objtype[k] == mujoco.mjtObj.mjOBJ_SITE:
                kind = {mujoco.mjtSensor.mjSENS_RANGEFINDER: PROXIMITY_SENSOR,
                        mujoco.mjtSensor.mjSENS_FORCE: FORCE_SENSOR}.get(int(m.sensor_type[k]))
                if kind is not None:
                    site_type[int(m.sensor_objid[k])] = kind
        for b in range(1, m.nbody):
            parent = body_handle[int(m.body_parentid[b])]
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
                parent = self._add(names(mujoco.mjtObj.mjOBJ_JOINT, j), JOINT, j, b, parent)
            body_handle[b] = self._add(names(mujoco.mjtObj.mjOBJ_BODY, b), SHAPE, b, b, parent)
            me = body_handle[b]
            for s in np.flatnonzero(m.site_bodyid == b):
                self._add(names(mujoco.mjtObj.mjOBJ_SITE, s), self._site_type(site_type, names, int(s)), int(s), b, me)
            for c in np.flatnonzero(m.cam_bodyid == b):
                self._add(names(mujoco.mjtObj.mjOBJ_CAMERA, c), VISION_SENSOR, int(c), b, me)
            for li in np.flatnonzero(m.light_bodyid == b):
                self._add(names(mujoco.mjtObj.mjOBJ_LIGHT, li), LIGHT, int(li), b, me)
        for otype, table, count in (
            (DUMMY, mujoco.mjtObj.mjOBJ_SITE, m.nsite),
            (VISION_SENSOR, mujoco.mjtObj.mjOBJ_CAMERA, m.ncam),
            (LIGHT, mujoco.mjtObj.mjOBJ_LIGHT, m.nlight),
        ):
            bodies = {DUMMY: m.site_bodyid, VISION_SENSOR: m.cam_bodyid, LIGHT: m.light_bodyid}[otype]
            for i in np.flatnonzero(bodies[:count] == 0):
                t = self._site_type(site_type, names, int(i)) if otype == DUMMY else otype
                self._add(names(table, int(i)), t, int(i), 0, WORLD)
        apply_vrep_parents(self.objects, self.by_name)  # V-REP's tree where MuJoCo's differs

    def _site_type(self, sensors: dict[int, int], names, site: int) -> int:
        """A site's object type: a sensor's (rangefinder, force), else the ``object_type=N`` its
        settings keep (a .ttt's camera 3 or old path 8), else a dummy."""
        if site in sensors:
            return sensors[site]
        return KEPT_TYPES.get(self.settings.get(names(mujoco.mjtObj.mjOBJ_SITE, site) or "", {}).get("object_type", ""), DUMMY)

    def resolve(self, name: str) -> SceneObject:
        """The object named ``name`` (``simxGetObjectHandle`` rules).

        Exact names; a trailing ``#`` is ignored (``"UR5#"`` is ``"UR5"``); CoppeliaSim 4.2
        paths (``"/UR5/UR5_joint1"``) and 4.3+ alias paths (``"/Franka/link2_resp/joint"``,
        ``"/Cuboid[1]"``: :mod:`simx_server.sim.paths`) resolve through the object tree.

        Raises:
            UnknownObjectError: no such object.

        Args:
            name: a V-REP name, or a CoppeliaSim path.

        Returns:
            The object.
        """
        if not isinstance(name, str):
            raise ArgumentError(f"object name must be a string, got {type(name).__name__}")
        key = name[:-1] if name.endswith("#") else name
        obj = self.by_name.get(key)
        if obj is None and key.startswith("/"):
            from simx_server.sim import paths  # paths reads this module's World: imported when first needed
            try:
                found = paths.find(self, key)
            except ArgumentError:
                found = []
            obj = self.objects[found[0]] if found else None
        if obj is None:
            raise UnknownObjectError(f"object {name!r} does not exist in scene {self.scene_name}")
        return obj

    def get(self, handle: int, otype: int | None = None) -> SceneObject:
        """The object with ``handle``, optionally checked to be of type ``otype``.

        Raises:
            UnknownObjectError: no object has that handle.
            ObjectTypeError: the object is not of type ``otype``.

        Args:
            handle: an object's handle.
            otype: an object type (``sim_object_*_type``), or None for any.

        Returns:
            The object.
        """
        if not isinstance(handle, int) or isinstance(handle, bool):
            raise ArgumentError(f"handle must be an int, got {type(handle).__name__}")
        obj = self.objects.get(handle)
        if obj is None:
            raise UnknownObjectError(f"no object with handle {handle}")
        if otype is not None and obj.type != otype:
            raise ObjectTypeError(
                f"object {obj.name!r} (handle {handle}) is a {_TYPE_NAMES[obj.type]}, "
                f"not a {_TYPE_NAMES[otype]}"
            )
        return obj

    def objects_of_type(self, otype: int) -> list[int]:
        """Handles of every object of ``otype`` (``sim_handle_all`` = -2: every object).

        Args:
            otype: a ``sim_object_*_type`` value, or -2.

        Returns:
            Handles, in tree order.
        """
        return [o.handle for o in self.objects.values() if otype == C.sim_handle_all or o.type == otype]

    # ------------------------------------------------------------------ motors
    def _init_motors(self) -> None:
        joints = [(o.handle, o.mj_id, o.settings) for o in self.objects.values() if o.type == JOINT]
        self.motors = motors.Motors(self.model, joints)

    # The motor state, by motor number (see simx_server.sim.motors).
    motor_index = property(lambda self: self.motors.index, doc="joint handle -> motor number")
    target_position = property(lambda self: self.motors.target_position, doc="rad or m, per motor")
    target_velocity = property(lambda self: self.motors.target_velocity, doc="rad/s or m/s, per motor")
    max_velocity = property(lambda self: self.motors.max_velocity, doc="upper velocity, per motor")
    mode = property(lambda self: np.where(self.motors.loop, POSITION_MODE, VELOCITY_MODE),
                    doc="control loop per motor, read-only: POSITION_MODE (loop on) or VELOCITY_MODE (off)")

    def motor(self, handle: int) -> int:
        """Index of the motor of joint ``handle``.

        Raises ObjectTypeError for a ball/free joint, and for a joint moved through a tendon
        (it has no motor of its own: the error names the tendon).

        Args:
            handle: a joint's handle.

        Returns:
            The motor's index in :attr:`motors`.

        Raises:
            UnknownObjectError: no such object.
            ObjectTypeError: not a joint, or one without a motor of its own.
        """
        i = self.motors.index.get(handle)
        if i is not None:
            return i
        obj = self.get(handle, JOINT)
        self._scalar_joint(handle)  # spherical joints: V-REP's error
        tendon = self.motors.tendon_of_joint.get(obj.mj_id)
        if tendon is not None:
            raise ObjectTypeError(f"joint {obj.name!r} has no motor of its own: an actuator drives it through "
                                  f"tendon {tendon!r}, which simx does not control")
        raise ObjectTypeError(f"joint {obj.name!r} has no motor")

    def reset(self) -> None:
        """Back to the initial state (``simxStopSimulation``): qpos0, targets at rest."""
        for field, initial in self._initial_fields.items():
            getattr(self.model, field)[:] = initial
        mujoco.mj_setConst(self.model, self.data)  # masses may have changed back
        mujoco.mj_resetData(self.model, self.data)
        self.motors.reset(self.model, self.data.qpos)
        self.data.ctrl[:] = 0.0
        grasps.let_all_go(self)
        self.joint_frames.clear()
        self.init_velocities.clear()
        self.dummy_links.clear()
        self.changed()

    # -------------------------------------------------------------------- time
    def set_dt(self, dt: float) -> None:
        """New simulation step (s), rounded to a whole number of model timesteps.

        Raises ArgumentError unless 0 < dt <= limits.MAX_DT and dt makes at most
        limits.MAX_SUBSTEPS substeps; nothing changes then.

        Implements ``simxSetFloatingParameter(sim_floatparam_simulation_time_step)`` and ``--dt``.

        Args:
            dt: the step asked for, s.
        """
        dt = physics.check_dt(dt)
        self.substeps = physics.substeps(dt, float(self.model.opt.timestep))
        self.requested_dt = dt
        self.dt = self.substeps * self.model.opt.timestep

    def step(self) -> None:
        """Advance one simulation step of ``dt`` s (its substeps in MuJoCo; Bullet's friction
        between them, :func:`friction.steps`). Before the substeps, each joint motor's actuator
        gets the gain and bias of V-REP's law for its mode (free joint, position control toward
        the target no faster than the upper velocity, or velocity control; force limited), see
        :mod:`simx_server.sim.motors`. Joints in a kinematic mode are held where the step finds
        them and put back there after it (:mod:`simx_server.sim.kinematic`).

        Raises:
            physics.PhysicsError: MuJoCo found a NaN, infinite or huge position, velocity or
                acceleration and reset the state (its warnings go to physics.SINK, not stdout);
                or, a client's scene (``bounded``), the step took more than
                limits.MAX_STEP_SECONDS (physics.StepTimeError, the rest of its substeps not run).
        """
        m, d = self.model, self.data
        integrator.choose(m, d)  # implicit while a body spins, else implicitfast (sim/integrator.py)
        held = kinematic.hold(self) if self.motors.kinematic else None  # joints in a kinematic mode
        self.motors.apply(m, d, self.dt)
        belts = surfaces.moving(self) if self.init_velocities else None  # static shapes' moving surfaces
        product = friction.applies(m)  # Bullet's combined friction (sim/friction.py)
        one = mujoco.mj_step if belts is None and not product else lambda m_, d_: surfaces.substep(m_, d_, belts, product)
        many = friction.steps if product and belts is None else None  # Bullet's rule, all substeps at once
        if self.substep_hook is not None:  # scripts' joint and dynamics callbacks: at each substep
            for _ in range(self.substeps):
                self.substep_hook(m, d)
                one(m, d)
        elif self.motors.stalled and not self.bounded:  # a motor held back: judged at every substep
            for _ in range(self.substeps):
                one(m, d)
                self.motors.apply(m, d, self.dt)
        elif self.bounded:  # a client's scene: at most MAX_STEP_SECONDS of the simulation thread
            physics.timed_step(m, d, self.substeps, L.MAX_STEP_SECONDS, one, many)
        elif belts is not None:
            for _ in range(self.substeps):
                one(m, d)
        else:  # Bullet's friction (sim/friction.py), or all in MuJoCo
            (many or mujoco.mj_step)(m, d, self.substeps)
        if np.count_nonzero(self._bad_state):  # MuJoCo reset the state (and would warn at every step)
            raise physics.blow_up(m, d, self.time)
        if held is not None:
            kinematic.settle(self, held)
        if physics.SINK.count:
            physics.SINK.report()  # other warnings (contact buffer full...): once per kind
        self._product = product  # nothing changes the rule between: changed() need not ask again
        self.changed(stepped=True)  # mj_step leaves positions and sensors one substep behind the state

    def changed(self, stepped: bool = False) -> None:
        """After any change of state: recompute derived quantities, invalidate cached renders,
        and note the simulation time (``time``, s: every reply reads it, and a plain attribute costs
        no call into MuJoCo's bindings). Grasped parts are put back on what holds them first
        (:func:`simx_server.sim.grasps.follow`), except after a physics step, which leaves them
        where the engine put them; once at the end of a :meth:`one_change`.

        Args:
            stepped: the change is a physics step's (:meth:`step`).
        """
        product, self._product = self._product, None  # step()'s answer (once), else asked now
        if self._batch.holds():
            return
        if self.grasps and not stepped:
            grasps.follow(self)
        if product is None:
            product = friction.applies(self.model)
        (friction.forward if product else mujoco.mj_forward)(self.model, self.data)
        self.version += 1
        self.time = self.data.time

    def one_change(self) -> ContextManager[None]:
        """A block of writes reading nothing derived between them (PyRep's ``set_joint_positions``)
        with one :meth:`changed` at its end (:mod:`simx_server.sim.change_batch`): the same state.

        Returns:
            The context manager."""
        return self._batch.block(self.changed)
