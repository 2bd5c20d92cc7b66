"""A read ``.ttt``/``.ttm`` (:class:`TttScene`) as an MJCF scene simx loads, built with
``mujoco.MjSpec`` in the shape of simx's own scenes (``scenes/ur5_rg2_kinect.xml``).

Object by object (docs/PORTING.md, "Bring your .ttt"): a shape is a named body (static: welded
to its parent; dynamic under a joint: that joint's body; dynamic elsewhere: a free body at the
top level, as V-REP simulates it), a joint a named ``<joint>`` (children posed relative to its
displaced frame, ``ref`` = its position in the file), a dummy a site, a proximity sensor a site
with a ``<rangefinder>``, a force sensor a site with ``<force>``/``<torque>``, a vision sensor a
``<camera>``, a light a ``<light>``; V-REP's view cameras and old paths become sites that keep
their types (:mod:`.kinds`), graphs and others sites so that their names still resolve. V-REP semantics MJCF has no attribute for go into
``<custom><text name="simx:NAME" .../>`` settings.
"""

from __future__ import annotations

import base64
import json
import math
import re
from collections import Counter
from pathlib import Path

import mujoco
import numpy as np

from simx_server.scene.ttt import geoms as G
from simx_server.scene.ttt import inertia, looks, measurements, settings
from simx_server.scene.ttt.geometry import compose, inverse, joint_displacement, quat_to_mat
from simx_server.scene.ttt.model import Pose, TttObject, TttScene
from simx_server.sim.properties import SHAPE_DEFAULT
from simx_server.scene.ttt.mechanisms import add_loop_closures, bodies_up
from simx_server.scene.ttt.parts import add_collections, add_ik_groups, add_joint, add_sensor, wheel_contacts

_MAX_EXCLUDES = 20_000
#: The dry friction of a passive joint whose contacts with its static parent are left out, as a
#: fraction of the friction of its weight on that parent (``_parent_friction``): RLBench's 0.34 kg
#: drawer gets 8 mN, which holds it against its axis 0.02 degrees off level (1 mN) and gives
#: way to any hand.
PARENT_FRICTION = 0.01
ENGINES = ("Bullet", "ODE", "Vortex", "Newton", "MuJoCo")


#: MuJoCo's ``impratio`` of a converted scene (and PyRep's empty one, ``pyrep/assets/empty.xml``).
STATIC_FRICTION_IMPRATIO = 10.0
IMPLICITFAST_BELOW = 0.01  #: a converted scene's ``implicitfast_below``, rad per timestep (sim/integrator.py)


class Report:
    """What did not carry over as V-REP had it, by kind: ``counts`` ``{kind: count}`` of every
    kind; the kinds in ``approximated`` were carried over in the closest form MuJoCo has (the
    kind's text says which), the others were left out. :meth:`lines` one line per kind left out,
    :meth:`approximations` one per kind approximated; ``taken``: the file's simulation settings
    that were applied (:mod:`.settings`), ``repaired``: what was changed so that MuJoCo accepts it
    (:mod:`.inertia`), ``physics``: MuJoCo's timestep and why (:mod:`.settings`), one line each."""

    def __init__(self):
        self.counts: Counter[str] = Counter()
        self.approximated: set[str] = set()
        self.taken: list[str] = []  # the file's settings that were applied, one line each
        self.repaired: list[str] = []  # what was changed so that MuJoCo accepts it, one line each
        self.physics: list[str] = []  # MuJoCo's timestep and why (settings.needs_fallback), one line

    def add(self, kind: str, n: int = 1, approximated: bool = False) -> None:
        """Count ``n`` items of ``kind``; ``approximated``: carried over in a close form, not left out."""
        self.counts[kind] += n
        if approximated:
            self.approximated.add(kind)

    def lines(self) -> list[str]:
        """``"N x kind"`` for each kind not carried over."""
        return [f"{n} x {kind}" for kind, n in sorted(self.counts.items()) if kind not in self.approximated]

    def approximations(self) -> list[str]:
        """``"N x kind"`` for each kind carried over approximately."""
        return [f"{n} x {kind}" for kind, n in sorted(self.counts.items()) if kind in self.approximated]


class Converter:
    """Builds the MjSpec of one scene. ``out``: the folder that receives meshes and scripts."""

    def __init__(self, scene: TttScene, out: Path | None, timestep_cap: float | None = None):
        self.scene, self.out = scene, out
        self.timestep_cap = timestep_cap  # s: the largest MuJoCo timestep (settings.apply), None: the engine's step
        self.report = Report()
        self.spec = mujoco.MjSpec()
        self.spec.modelname = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(scene.file).stem) or "scene"
        self.spec.compiler.degree = False
        self.spec.compiler.autolimits = True
        self.spec.compiler.fusestatic = False
        self.spec.compiler.balanceinertia = True  # V-REP accepts moments that break A + B >= C
        if out is not None:
            self.spec.compiler.meshdir = str(out / "meshes")  # written relative (convert)
            self.spec.compiler.texturedir = str(out / "textures")
        self.geoms = G.GeomMaker(self.spec, out, self.report, scene.textures)
        self.settings: dict[str, list[str]] = {}  # simx:NAME -> key=value items
        self.wheels: list[tuple[TttObject, TttObject, np.ndarray, np.ndarray]] = []  # joints with one shape: wheel_contacts
        self.names: dict[int, str] = {}           # handle -> element name
        self.bodies: dict[int, object] = {}       # shape handle -> mjsBody
        self.model_of: dict[int, int] = {}        # shape handle -> its model base's handle (-1 none)
        self.world_pose: dict[int, Pose] = {}     # handle -> world pose in the file
        self.moved: set[int] = set()              # dynamic shapes hung from the world (free)
        #: dependent joints: (joint, master, offset, multiplier, their positions in the file)
        self.deferred_equalities: list[tuple[str, str, float, float, float, float]] = []
        self.repaired_inertias: list[str] = []    # shapes whose moments broke A + B >= C

    # ---------------------------------------------------------------- entry
    def build(self) -> mujoco.MjSpec:
        s = self.scene
        settings.apply(self, self.timestep_cap)  # time step, gravity, real-time mode (simx:scene:simulation)
        # implicit, a spinning body's spin kept; implicitfast while none spins (text below, sim/integrator.py)
        self.spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICIT
        self.spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        # Bullet's, ODE's and Vortex's friction is static: a held or resting load does not move.
        # MuJoCo's is a soft constraint that creeps at a speed proportional to the load over
        # impratio; 10 makes it ten times stiffer than the normal (MuJoCo's advice for grasping)
        self.spec.option.impratio = STATIC_FRICTION_IMPRATIO
        looks.headlight(self.spec, s.ambient)  # V-REP's ambient light, no camera headlight
        if s.background is not None:  # V-REP's background gradient as a sky box
            sky = self.spec.add_texture()
            sky.name = "ttt_background"
            sky.type = mujoco.mjtTexture.mjTEXTURE_SKYBOX
            sky.builtin = mujoco.mjtBuiltin.mjBUILTIN_GRADIENT
            sky.rgb1, sky.rgb2 = s.background
            sky.width = sky.height = 256
        for obj in s.objects.values():
            self.names[obj.handle] = obj.name
        for root in s.roots:
            self._world_poses(root, Pose())
        for root in s.roots:
            self._emit(root, self.spec.worldbody, Pose(), -1)
        self._aliases()
        wheel_contacts(self, self.wheels)
        looks.count_lights(self)
        self._special_properties()
        add_loop_closures(self)
        add_ik_groups(self)
        self._excludes()
        self._static_parent_excludes()
        for kind, n in s.skipped.items():
            self.report.add(kind, n)
        add_collections(self)
        measurements.add(self)  # COL/DST: named collision and distance objects
        inertia.report(self)  # shapes whose inertias MuJoCo would refuse, repaired
        if s.engine != 0:
            engine = ENGINES[s.engine] if 0 <= s.engine < len(ENGINES) else str(s.engine)
            self.report.add(f"{engine} engine settings (MuJoCo's used; friction taken from Bullet's)", approximated=True)
        # fixed statistic so that the clipping planes are the vision sensors' (MuJoCo's
        # znear/zfar are fractions of the extent), as in simx's own scenes
        sensors = [o.data for o in s.objects.values() if o.kind == "vision_sensor"]
        self.spec.stat.extent = 2.0
        near = min([v.near for v in sensors if v.near > 0] + [0.01])
        far = max([v.far for v in sensors] + [50.0])
        self.spec.visual.map.znear = max(near, 1e-4) / 2.0
        self.spec.visual.map.zfar = far / 2.0
        if not s.is_model:  # sensors render with V-REP's lighting (sim/vision_look.py), contacts have
            # Bullet's friction (sim/friction.py); a model loaded into a scene takes the scene's
            self.setting("scene:vision", "look=vrep")
            self.setting("scene:friction", "combine=product")
            self.setting("scene:integrator", f"implicitfast_below={IMPLICITFAST_BELOW}")
        for name, value in self.geoms.texture_maps.items():  # texture parameters at run time
            self.setting(name, f"texture_map={value}")
        for name, items in self.settings.items():
            t = self.spec.add_text()
            t.name = f"simx:{name}"
            t.data = " ".join(items)
        return self.spec

    def setting(self, name: str, *items: str) -> None:
        self.settings.setdefault(name, []).extend(items)

    def vrep_parent(self, obj: TttObject) -> None:
        """Record ``obj``'s parent in V-REP's tree (``vrep_parent=NAME``, ``-1`` the world),
        for an object the MJCF hangs elsewhere: paths (``sim.getObject``) walk V-REP's tree."""
        parent = self.scene.objects.get(obj.parent)
        name = parent.name if parent is not None else "-1"
        if _setting_safe(name):
            self.setting(obj.name, f"vrep_parent={name}")

    def _aliases(self) -> None:
        """CoppeliaSim 4.3+ aliases that are not the name less its ``#N`` (``alias=A``), model
        bases (``model_base=1``), referenced handles (``refs.TAG=NAME,NAME``; ``refs=`` the
        untagged ones) and extension strings (``extension=BASE64``)."""
        for obj in self.scene.objects.values():
            alias = re.sub(r"[^A-Za-z0-9_]", "_", obj.alias)
            if alias and alias != re.sub(r"#\d+$", "", obj.name):
                self.setting(obj.name, f"alias={alias}")
            if obj.model_base:  # paths' ':' and '::' (simx_server.sim.paths)
                self.setting(obj.name, "model_base=1")
            for tag, handles in obj.references.items():  # sim.getReferencedHandles
                names = [self.names[h] for h in handles if h in self.names]
                if re.fullmatch(r"[A-Za-z0-9_.]*", tag) and names and all(
                        _setting_safe(n) and "," not in n for n in names):
                    self.setting(obj.name, f"refs{'.' + tag if tag else ''}={','.join(names)}")
                else:
                    self.report.add("referenced handles of tags or names simx cannot store")
            if obj.extension.strip():  # sim.getExtensionString: the text as unpadded URL-safe base64
                text = base64.urlsafe_b64encode(obj.extension.encode()).decode().rstrip("=")
                self.setting(obj.name, f"extension={text}")

    def _special_properties(self) -> None:
        """Each object's special properties (collidable, measurable, detectable, renderable:
        the file's ``Omp``, coppeliaSimLib ``CSceneObject::serialize``) as ``special=N`` where
        they differ from simx's default for the type, and a model base's override bits (``Mpo``:
        ``sim.modelproperty_not_*``) as ``model_property=N`` (:mod:`simx_server.sim.properties`
        combines them as ``CSceneObject::getCumulativeObjectSpecialProperty``). A proximity
        sensor's detection type (``Sst``) becomes ``sensable=N`` where it is not ultrasonic (16,
        V-REP's default)."""
        for obj in self.scene.objects.values():
            if obj.kind == "proximity_sensor" and obj.data.sensable != 16:
                self.setting(obj.name, f"sensable={obj.data.sensable}")
            if obj.special is not None and obj.special != (SHAPE_DEFAULT if obj.kind == "shape" else 0):
                self.setting(obj.name, f"special={obj.special}")
            if obj.model_base and obj.model_property & 0xF000 != 0xF000 and obj.model_property != 0:
                self.setting(obj.name, f"model_property={obj.model_property}")
            if obj.object_property & 256:  # sim.objectproperty_dontshowasinsidemodel (model boxes)
                self.setting(obj.name, f"object_property={obj.object_property}")
            if obj.kind == "joint" and obj.data.size is not None:  # its bounding box (sim.bounding_boxes)
                length, diameter = obj.data.size
                if 0 <= length < 1e3 and 0 <= diameter < 1e3:
                    self.setting(obj.name, f"length={length:.6g}", f"diameter={diameter:.6g}")
            if obj.kind == "shape" and any(m.primitive in (G.PLANE, G.DISC) for m in obj.data.meshes):
                self.setting(obj.name, "flat=1")  # a plane's bounding box has no height

    # ---------------------------------------------------------------- tree
    def _world_poses(self, obj: TttObject, parent: Pose) -> None:
        """World poses as V-REP computes them (children of joints from the displaced frame)."""
        pose = compose(parent, obj.pose)
        self.world_pose[obj.handle] = pose
        frame = pose
        if obj.kind == "joint":
            frame = compose(pose, joint_displacement(obj.data.type, obj.data.position))
        for child in obj.children:
            self._world_poses(child, frame)

    def _emit(self, obj: TttObject, body, t: Pose, model: int) -> None:
        """Add ``obj`` (and its subtree) to ``body``; ``t`` is the frame of obj's V-REP parent
        (displaced, for a joint's child) in ``body``'s frame; ``model`` its model base."""
        local = compose(t, obj.pose)
        if obj.model_base:
            model = obj.handle
        if obj.kind == "shape":
            self._shape(obj, body, local, model)
        elif obj.kind == "joint":
            self._joint(obj, body, local, model)
        elif obj.kind == "force_sensor":
            self._force_sensor(obj, body, local, model)
        else:
            add_sensor(self, obj, body, local)
            for child in obj.children:  # a site has no children in MJCF: they go in its body
                self._emit(child, body, local, model)
                self.vrep_parent(child)

    def _shape(self, obj: TttObject, body, local: Pose, model: int, joint=None) -> None:
        d = obj.data
        if not d.static and joint is None and body is not self.spec.worldbody:
            # V-REP simulates a dynamic shape that hangs from no joint or force sensor freely, under
            # a static shape too (CoppeliaSim links shapes only through joints and force sensors)
            self.moved.add(obj.handle)
            self.report.add("dynamic shapes free of their parent (a top-level free body, as V-REP simulates them)", approximated=True)
            body, local = self.spec.worldbody, self.world_pose[obj.handle]
            self.vrep_parent(obj)
        b = body.add_body()
        b.name = obj.name
        b.pos, b.quat = local.pos, local.quat
        self.bodies[obj.handle] = b
        self.model_of[obj.handle] = model
        moving = joint is not None or (not d.static and body is self.spec.worldbody)
        if moving:
            if d.static or d.mass <= 0:
                _tiny_inertial(b)  # a kinematic part: no mass of its own in V-REP
            else:
                b.mass = d.mass
                b.inertia = inertia.repaired(self, obj.name, d.inertia)
                b.ipos, b.iquat = d.inertia_frame.pos, d.inertia_frame.quat
            b.explicitinertial = True
        if joint is not None:
            joint(b)
        elif not d.static and body is self.spec.worldbody:
            b.add_freejoint()
        contype, conaffinity = G.collision_bits(d)
        ground = d.static and not moving and self._static_chain(obj)  # fixed to the world: stiff contacts
        self.geoms.add(b, np.zeros(3), [1, 0, 0, 0], obj.name, d, contype, conaffinity,
                       visible=bool(obj.layers & 0xFF), ground=ground)
        for child in obj.children:
            self._emit(child, b, Pose(), model)

    def _static_chain(self, obj: TttObject) -> bool:
        """A static shape not moved by anything above it (welded to the world)."""
        while obj is not None:
            if obj.kind == "joint" or obj.kind == "force_sensor" or (obj.kind == "shape" and not obj.data.static):
                return False
            obj = self.scene.objects.get(obj.parent)
        return True

    def _joint(self, obj: TttObject, body, frame: Pose, model: int) -> None:
        j = obj.data
        displaced = compose(frame, joint_displacement(j.type, j.position))
        shapes = [c for c in obj.children if c.kind == "shape"]
        scripts = [c for c in obj.children if c.kind == "script"]  # 4.6+ script objects ride along
        if len(obj.children) - len(scripts) == 1 and shapes:
            child = shapes[0]
            rel = inverse(child.pose)  # the joint frame seen from the child's body
            axis = quat_to_mat(rel.quat) @ np.array([0.0, 0, 1])
            if abs(abs(float(rel.quat[0])) - 1.0) > 1e-9:  # MuJoCo keeps only its axis: its x, y here
                self.setting(obj.name, "frame=" + ",".join(f"{v:.9g}" for v in rel.quat))
            self._shape(child, body, compose(displaced, child.pose), model,
                        joint=lambda b: add_joint(self, obj, b, rel.pos, axis))
            self.wheels.append((obj, child, axis, rel.pos))  # a motored wheel carries its robot (wheel_contacts)
            for script in scripts:  # in the child's body, which the joint moves
                self._emit(script, self.bodies[child.handle], rel, model)
                self.vrep_parent(script)
            return
        # several children, or none that is a shape: an unnamed body at the displaced frame
        # carries the joint, its children inside
        b = body.add_body()
        b.pos, b.quat = displaced.pos, displaced.quat
        _tiny_inertial(b)
        add_joint(self, obj, b, np.zeros(3), np.array([0.0, 0, 1]))
        for child in obj.children:
            if child.kind == "shape":
                self._shape(child, b, child.pose, model, joint=lambda _b: None)
            else:
                self._emit(child, b, Pose(), model)

    def _force_sensor(self, obj: TttObject, body, frame: Pose, model: int) -> None:
        """A force sensor welds its child shape to its parent and measures between them: the
        site goes in the child's body, as CoppeliaSim's MuJoCo plugin puts it there
        (``CRigidBodyContainerDyn::_addObjectBranch``); it reads what hangs below it in V-REP's
        tree (``vrep_parent=``, :mod:`simx_server.sim.force_sensors`; docs/PORTING.md)."""
        shapes = [c for c in obj.children if c.kind == "shape"]
        host, site_pose = body, frame
        for child in obj.children:
            if child is shapes[0] if shapes else False:
                d = child.data
                b = body.add_body()
                b.name = child.name
                local = compose(frame, child.pose)
                b.pos, b.quat = local.pos, local.quat
                self.bodies[child.handle] = b
                self.model_of[child.handle] = model
                if not d.static:
                    b.mass, b.inertia = d.mass, inertia.repaired(self, child.name, d.inertia)
                    b.ipos, b.iquat = d.inertia_frame.pos, d.inertia_frame.quat
                    b.explicitinertial = True
                contype, conaffinity = G.collision_bits(d)
                self.geoms.add(b, np.zeros(3), [1, 0, 0, 0], child.name, d, contype, conaffinity,
                               visible=bool(child.layers & 0xFF))
                for grandchild in child.children:
                    self._emit(grandchild, b, Pose(), model)
                host, site_pose = b, inverse(child.pose)
                self.vrep_parent(child)  # the shape's body carries the sensor's site: V-REP's tree
            else:                        # has the sensor above the shape
                self._emit(child, body, frame, model)
                self.vrep_parent(child)
        self.vrep_parent(obj)  # always: the sensor measures what hangs below it in V-REP's tree
        site = host.add_site()
        site.name = obj.name
        site.pos, site.quat = site_pose.pos, site_pose.quat
        site.size = [max(obj.data.size / 2, 1e-3), 0, 0]
        site.group = 4
        for kind in (mujoco.mjtSensor.mjSENS_FORCE, mujoco.mjtSensor.mjSENS_TORQUE):
            sensor = self.spec.add_sensor()
            sensor.type = kind
            sensor.objtype = mujoco.mjtObj.mjOBJ_SITE
            sensor.objname = obj.name

    def _excludes(self) -> None:
        """V-REP's local respondable masks: two respondable shapes of one tree whose local
        masks share no bit do not collide. "One tree" as CoppeliaSim decides it: the same
        topmost ancestor (coppeliaSimLib ``CShape::getLastParentForLocalGlobalRespondable``
        walks up to the root, through model bases), so a gripper's touch sensors, model bases
        of their own, keep their pads' local masks with the fingers (the Panda's two pads, whose
        local masks share no bit, jammed the closed fingers together)."""
        objects = self.scene.objects
        shapes = [objects[h] for h in self.bodies if objects[h].data.respondable]
        roots: dict[int, int] = {}
        for shape in shapes:
            h, seen = shape.handle, set()
            while objects.get(h) is not None and objects[h].parent in objects and h not in seen:
                seen.add(h)
                h = objects[h].parent
            roots[shape.handle] = h
        n = 0
        for i, a in enumerate(shapes):
            for b in shapes[i + 1:]:
                if roots[a.handle] != roots[b.handle]:
                    continue
                if (a.data.respondable_mask & b.data.respondable_mask & 0xFF) == 0:
                    if n >= _MAX_EXCLUDES:
                        self.report.add("local respondable masks beyond the exclude bound")
                        self._n_excludes = n
                        return
                    e = self.spec.add_exclude()
                    e.bodyname1, e.bodyname2 = a.name, b.name
                    n += 1
        self._n_excludes = n

    def _static_parent_excludes(self) -> None:
        """No contact between a body that moves on joints and the static body its joints hang
        from (a drawer and its cabinet, a door and its frame, a robot's first link and its
        base): MuJoCo's own parent filter (``filterparent``) for a parent fixed to the world,
        which MuJoCo leaves out. CoppeliaSim's engines keep those contacts, but there they cost
        little: a contact whose normal the joint cannot move along (a drawer's side touching
        its cabinet, within 10 um in RLBench's drawers) gets only the impulse that corrects its
        overlap, and the part slides, held only by that contact's small friction. In MuJoCo's
        joint coordinates such a contact cannot be resolved: its friction pyramid's edges
        brake the joint (RLBench's 0.34 kg drawer moved 2 mm under 20 N in 0.5 s), or, without
        friction, push the part out at metres per second. The joint's limits stop the part, as
        they do in V-REP models; a joint without a motor (passive) keeps a dry friction
        (:func:`_parent_friction`) for the friction of the contacts left out, so that a part
        whose axis is off level by a hair (RLBench's drawers: 0.02 degrees) stays where it is
        until pushed, as in CoppeliaSim."""
        n = getattr(self, "_n_excludes", 0)
        done = {frozenset((e.bodyname1, e.bodyname2)) for e in self.spec.excludes}
        gravity = float(np.linalg.norm(self.spec.option.gravity))
        for body in self.spec.bodies:
            parent = body.parent
            if not body.joints or parent is None or parent.name in ("world", "") or not body.name \
                    or not _welded_to_world(parent):
                continue
            if len(body.joints) == 1 and "mode=passive" in self.settings.get(body.joints[0].name, []):
                _parent_friction(body, parent, gravity)
            if frozenset((parent.name, body.name)) in done:
                continue
            if n >= _MAX_EXCLUDES:
                self.report.add("jointed parts on static parents beyond the exclude bound (they may collide)")
                return
            e = self.spec.add_exclude()
            e.bodyname1, e.bodyname2 = parent.name, body.name
            n += 1
        self._n_excludes = n


def _parent_friction(body, parent, gravity: float) -> None:
    """Give the one passive joint of MjSpec ``body`` a small dry friction (``frictionloss``)
    for the friction of its contacts with ``parent`` that are left out: :data:`PARENT_FRICTION`
    of what its weight resting on ``parent`` would give, the contacts' friction coefficient
    (MuJoCo's, the larger of the two bodies' geoms') times the part's weight (N, a slide),
    times the lever from the axis to the part's centre of mass for a hinge (N m). Nothing for a
    part without mass or geoms. An approximation: in CoppeliaSim that friction comes from the
    small normal force that corrects the parts' overlap, which MuJoCo cannot give."""
    joint = body.joints[0]
    if joint.type not in (mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_HINGE):
        return
    mu = max([float(g.friction[0]) for g in list(body.geoms) + list(parent.geoms)], default=0.0)
    mass = float(body.mass) if body.explicitinertial else 0.0
    if not (mu > 0 and mass > 0 and math.isfinite(mu * mass)):
        return
    force = PARENT_FRICTION * mu * mass * gravity
    if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
        axis = np.asarray(joint.axis, float)
        axis = axis / max(float(np.linalg.norm(axis)), 1e-12)
        arm = np.asarray(body.ipos, float) - np.asarray(joint.pos, float)
        force *= float(np.linalg.norm(arm - np.dot(arm, axis) * axis))
    if force > 0:
        joint.frictionloss = force


def _welded_to_world(body) -> bool:
    """Whether the MjSpec body ``body`` moves with the world (no joint on it or above it)."""
    return not any(b.joints for b in bodies_up(body))


def _setting_safe(value: str) -> bool:
    return bool(value) and not any(c.isspace() or c == "=" for c in value)


def _tiny_inertial(b) -> None:
    """1 g and a small inertia for a moving body that has no mass in V-REP (MuJoCo needs one)."""
    b.mass, b.inertia = 1e-3, [1e-7, 1e-7, 1e-7]
    b.ipos, b.iquat = np.zeros(3), [1.0, 0, 0, 0]
    b.explicitinertial = True


def _compiled(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """A compiled copy of ``spec`` (ValueError with MuJoCo's message when it cannot be)."""
    try:
        return spec.copy().compile()
    except Exception as exc:  # MuJoCo's compile errors
        raise ValueError(str(exc)) from exc


def convert(scene: TttScene, out: Path, stem: str | None = None) -> tuple[Path, Report]:
    """Write ``out/<stem>.xml`` with ``meshes/`` and the scripts; returns its path and the
    report of what did not carry over.

    Raises:
        ValueError: MuJoCo cannot compile the result (its message).
    """
    from simx_server.scene.ttt.scripts import write_custom_data, write_scripts

    out.mkdir(parents=True, exist_ok=True)
    engine = settings.engine_timestep(scene)
    reason = settings.needs_fallback(scene)
    conv = Converter(scene, out, settings.FALLBACK_TIMESTEP if reason else None)
    write_scripts(conv)
    write_custom_data(conv)
    spec = conv.build()
    if reason is None and spec.option.timestep > settings.FALLBACK_TIMESTEP:
        reason = settings.stiff_spring(_compiled(spec))
        if reason is not None:  # built again: every stiffness is made for the smaller step
            conv = Converter(scene, out, settings.FALLBACK_TIMESTEP)
            write_scripts(conv)
            write_custom_data(conv)
            spec = conv.build()
    step = spec.option.timestep
    conv.report.physics.append(f"MuJoCo substeps of {step * 1000:.4g} ms, not the engine step's {engine * 1000:.4g} "
                               f"ms: {reason}" if step < engine else f"MuJoCo substeps of {step * 1000:.4g} ms, "
                               "the engine step's")
    xml = out / f"{stem or conv.spec.modelname}.xml"
    text = spec.to_xml().replace(f'meshdir="{out / "meshes"}"', 'meshdir="meshes"', 1)
    text = text.replace(f'texturedir="{out / "textures"}"', 'texturedir="textures"', 1)
    if "balanceinertia" not in text:  # MjSpec.to_xml leaves the compiler flag out
        text = text.replace("<compiler ", '<compiler balanceinertia="true" ', 1)
    xml.write_text(text)
    (out / "report.json").write_text(json.dumps(dict(conv.report.counts), indent=1))
    (out / "notes.json").write_text(json.dumps({"taken": conv.report.taken, "repaired": conv.report.repaired,
                                                "physics": conv.report.physics,
                                                "approximated": sorted(conv.report.approximated)}, indent=1))
    return xml, conv.report
