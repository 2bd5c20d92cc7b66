"""Scene editing: V-REP's model and scene commands on a live ``MjSpec`` of the scene.

The :class:`Editor` keeps one ``mujoco.MjSpec`` of the loaded scene (parsed from the scene
file when the editor or the scene is created; mesh, height-field, skin and texture files are
read into memory then, so that later compiles need no file). Each edit works on a copy of that
spec, compiles it to a new ``MjModel`` and hands it to :meth:`World.replace_model`, which keeps
every object that is still there (matched by name): its handle, joint positions and
velocities, free bodies' poses, motors' mode/targets/maximum force and the simulation time.
Objects that commands placed while the simulation runs (``World.set_pose``) stay where they
are until it stops. A failed edit changes nothing. Vision sensors are rebuilt after each edit
(their renderers belong to the old model).

Rules, in V-REP's terms (docs/API.md lists them per command):

* Names. MuJoCo names are unique per element type, V-REP names across all objects. Elements
  that arrive (a loaded model, a copy) keep their names when none of them is taken in the
  scene; otherwise every name they bring gets one V-REP suffix ``#n``, the smallest ``n >= 0``
  that makes all of them new (``Box`` -> ``Box#0`` -> ``Box#1``; a copy of ``Box#0`` is
  ``Box#0#0``). A loaded model's assets (materials, textures, meshes, ...) whose names alone
  collide are renamed (``grey#0``) without renaming the model's objects.
* A shape is a MuJoCo body, and a body carries its child bodies: removing, copying or
  re-parenting a shape acts on its whole body subtree (with the joints, geoms, sites, cameras
  and lights inside, and the actuators, sensors, constraints and ``simx:`` settings that
  refer to them).
* Child scripts are not copied with objects, nor run for loaded models (their object
  lookups would address the original objects); a removed object's script is cleaned up.
* Files sent with ``simxTransferFile`` go to a transfer folder private to this server
  process (``scene_guard.make_transfer_folder``: 0700, removed by :meth:`Editor.close` or at
  exit, never named in replies); names that leave it are refused, and its size is bounded.
* Trust: a scene or model loaded from the transfer folder (options bit 0) is a client's: its
  files must lie in the transfer folder, its size is bounded before MuJoCo parses it, its child
  scripts run only with ``--allow-remote-code``. Server-side paths (options 0) are loaded only
  from the operator's scene folder and ``--scene-path`` folders, never from a transfer folder
  of any server. Edits may not grow the scene past ``MAX_SCENE_BODIES``/``MAX_SCENE_ELEMENTS``.

The MjSpec tools (pose maths, names, references, cloning) are in :mod:`simx_server.spec_tools`,
the command handlers (``EDITING_HANDLERS``) in :mod:`simx_server.editing_commands`.

Runs on the simulation thread, like every handler.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import mujoco
import numpy as np

from simx_client.protocol import ArgumentError, RemoteError, ScriptError, UnsupportedError
from simx_server import limits, motors
from simx_server import scene_guard as guard
from simx_server.arguments import quote
from simx_server.client_files import ClientFiles
from simx_server.editing_commands import EDITING_HANDLERS  # noqa: F401 (importers of this module use it)
from simx_server.scripts import Scripts
from simx_server.spec_tools import (_FRAMES, _KIND, _MARK, _MJ_OBJ, _OTHER_LISTS, _QUAT, _REFERRING_LISTS,
                                    _TREE_LISTS, _body_world, _clone, _compose, _copy_settings,
                                    _delete_references, _delete_settings, _elements, _embed_assets,
                                    _free_name, _inverse, _names, _object_names, _one_line, _poses,
                                    _quiet_mujoco, _rename_assets, _rotate, _set_local_pose, _strip_mark,
                                    _subtree_names, _subtree_objects, vrep_suffix)
from simx_server.urdf import load_spec
from simx_server.vision import VisionSensors
from simx_server.world import JOINT, SHAPE, WORLD, World

if TYPE_CHECKING:
    from simx_server.simulation import Simulation

log = logging.getLogger("simx.editing")

_EMPTY_SCENE = '<mujoco model="empty">\n  <worldbody/>\n</mujoco>\n'


def refresh_vision(sim: Simulation) -> None:
    """New vision sensors for the changed model; they take over the render thread, whose
    renderers are rebuilt for the new model at once, on that thread. While the simulation is
    stopped (a scene load) this waits for them: the first image after the start is at once."""
    from simx_server.simulation import RunState  # late: simulation imports this module

    sim.vision = VisionSensors(sim.world, previous=sim.vision)
    if sim.state is RunState.STOPPED:
        sim.vision.wait_ready(limits.VISION_READY_TIMEOUT)


# --------------------------------------------------------------------------- editor
class Editor:
    """Scene editing for one :class:`Simulation` (``sim.editor = Editor(sim)``).

    Owns the transfer folder through :class:`ClientFiles` (``<tmp>/simx-<pid>-<start>-*``,
    0700); :meth:`close` removes it, and so does the interpreter's exit. ``scene_paths`` are the
    ``--scene-path`` folders: with the folder of the scene the server started with, the only
    places server-side paths (options 0) are loaded from.
    """

    def __init__(self, sim: Simulation, scene_paths=()):
        self.sim = sim
        self.files = ClientFiles(sim.world.scene_path, scene_paths)  # the transfer folder, trusted folders
        self._spec: mujoco.MjSpec | None = None
        self._spec_world: World | None = None  # the world (scene) the spec describes
        self._baseline: dict[str, np.ndarray] | None = None  # poses as last compiled
        self._placed: set[tuple[str, str]] = set()
        self._asset_counter = [0]  # numbers in-memory asset names
        self._parse_now()

    def _parse_now(self) -> None:
        """Parse the scene file at once, while it matches the loaded world."""
        try:
            self._live_spec()
        except UnsupportedError as exc:
            log.warning("%s", exc)

    def close(self) -> None:
        """Remove the transfer folder; idempotent."""
        self.files.close()

    # ------------------------------------------------------------------ files
    @property
    def files_dir(self) -> Path:
        """The transfer folder (private to this server process)."""
        return self.files.files_dir

    def transfer_file(self, name: str, data: Any) -> None:
        """``simxTransferFile`` (see :meth:`ClientFiles.transfer_file`)."""
        self.files.transfer_file(name, data)

    def erase_file(self, name: str) -> None:
        """``simxEraseFile``: delete a transferred file."""
        self.files.erase_file(name)

    def resolve(self, path: Any, options: int) -> Path:
        """The file a LoadScene/LoadModel names (see :meth:`ClientFiles.resolve`)."""
        return self.files.resolve(path, options, self.sim.world.scene_path)

    def public(self, path: Path) -> str:
        """``path`` as a client may see it (never the transfer folder's path)."""
        return self.files.public(path)

    def _scrub(self, text: str) -> str:
        return self.files.scrub(text)

    def _client_spec(self, file: Path, what: str, dt: float | None) -> mujoco.MjSpec:
        """Parse a client-sent MJCF file, measured before and after parsing (scene_guard)."""
        guard.check_client_file(file, self.files_dir, what)
        try:
            with _quiet_mujoco():
                spec = load_spec(file, root=self.files_dir)  # a URDF's meshes: confined before looked up
        except ValueError as exc:
            raise RemoteError(f"cannot load {what}: {self._scrub(_one_line(exc))}") from None
        guard.check_spec(spec, what, root=self.files_dir, dt=dt)
        return spec

    # ------------------------------------------------------------------- spec
    def _live_spec(self) -> mujoco.MjSpec:
        world = self.sim.world
        if self._spec is None or self._spec_world is not world:
            try:
                with _quiet_mujoco():
                    spec = load_spec(world.scene_path)
                    spec.assets = {**(spec.assets or {}), **_embed_assets(spec, self._asset_counter)}
                    baseline = _poses(spec.compile())
            except ValueError as exc:
                raise UnsupportedError(f"scene {world.scene_path.name} cannot be edited: "
                                       f"{_one_line(exc)}") from None
            self._spec, self._spec_world, self._baseline = spec, world, baseline
        return self._spec

    def _runtime_placements(self) -> list[tuple]:
        """Objects that commands placed in the live model (``World.set_pose`` changes
        ``body_pos``, ``site_pos``... until the simulation stops): ``(kind, name, parent, pos, rot)``."""
        m, base = self.sim.world.model, self._baseline
        if base is None or any(getattr(m, f).shape != base[f].shape for f in base):
            return []
        out = []
        for kind, (fpos, frot, fparent) in _FRAMES.items():
            pos, rot = getattr(m, fpos), getattr(m, frot)
            for i in np.flatnonzero(np.any(pos != base[fpos], axis=1) | np.any(rot != base[frot], axis=1)):
                name = mujoco.mj_id2name(m, _MJ_OBJ[kind], int(i))
                parent = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(getattr(m, fparent)[i]))
                if name:
                    out.append((kind, name, parent, pos[i].copy(), rot[i].copy()))
        return out

    def _mocap_poses(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        m, d = self.sim.world.model, self.sim.world.data
        out = {}
        for b in np.flatnonzero(m.body_mocapid >= 0):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(b))
            if name:
                k = m.body_mocapid[b]
                out[name] = (d.mocap_pos[k].copy(), d.mocap_quat[k].copy())
        return out

    def _restore_placements(self, placements: list[tuple], mocap: dict, placed: set) -> None:
        """Put runtime placements back on the new model (same name, same parent body), except
        for the objects the edit placed itself. The new model's initial poses stay as compiled,
        so stopping the simulation still puts those objects back."""
        w = self.sim.world
        m, d = w.model, w.data
        for kind, name, parent, pos, rot in placements:
            if (kind, name) in placed:
                continue
            fpos, frot, fparent = _FRAMES[kind]
            i = mujoco.mj_name2id(m, _MJ_OBJ[kind], name)
            if i >= 0 and mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, int(getattr(m, fparent)[i])) == parent:
                getattr(m, fpos)[i], getattr(m, frot)[i] = pos, rot
        for name, (pos, quat) in mocap.items():
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
            if b >= 0 and m.body_mocapid[b] >= 0:
                d.mocap_pos[m.body_mocapid[b]], d.mocap_quat[m.body_mocapid[b]] = pos, quat
        if placements or mocap:
            mujoco.mj_forward(m, d)

    def _edit(self, change: Callable[[mujoco.MjSpec], Any]) -> Any:
        """Apply ``change`` to a copy of the spec, compile, swap the model in; all or nothing.

        ``change`` returns an optional callable run after the swap (on the new world).
        """
        world = self.sim.world
        with _quiet_mujoco():
            live = self._live_spec()
            before = guard.element_counts(live)
            spec = live.copy()
            spec.copy_during_attach = True
            self._placed: set[tuple[str, str]] = set()  # (kind, name) the change placed itself
            try:
                after = change(spec)
            except ValueError as exc:  # MjSpec refuses the operation (attach, delete)
                raise UnsupportedError(f"MuJoCo cannot make this edit: {self._scrub(_one_line(exc))}") from None
            guard.check_growth(before, spec)
            try:
                model = motors.compile_spec(spec)  # joints without an actuator get a motor
            except ValueError as exc:
                raise UnsupportedError("MuJoCo cannot compile the edited scene: "
                                       f"{self._scrub(_one_line(exc))}") from None
        placements, mocap = self._runtime_placements(), self._mocap_poses()
        baseline = _poses(model)
        world.replace_model(model)
        self._spec, self._baseline = spec, baseline
        self._restore_placements(placements, mocap, self._placed)
        refresh_vision(self.sim)
        self._drop_orphan_scripts()
        self.sim.selection = [h for h in self.sim.selection if h in world.objects]  # removed ones leave it
        return after() if callable(after) else after

    def _drop_orphan_scripts(self) -> None:
        scripts, world = self.sim.scripts, self.sim.world
        for handle in [h for h in scripts.scripts if h not in world.objects]:
            script = scripts.scripts.pop(handle)
            try:
                script.stop()  # sysCall_cleanup if it runs, then its state goes
            except ScriptError as exc:
                log.error("%s", exc)
            log.info("child script of removed object %r dropped", script.object_name)

    def _taken(self, spec: mujoco.MjSpec) -> set[str]:
        """Names a new element may not have: the spec's and the V-REP names, which differ for
        elements that share a name with one of another kind (see simx_server.naming)."""
        return _names(spec) | set(self.sim.world.by_name)

    def _spec_element(self, spec: mujoco.MjSpec, handle: int):
        """``(kind, element, SceneObject)`` of a handle; the world is refused."""
        if handle == WORLD:
            raise ArgumentError("the world (-1) cannot be edited")
        obj = self.sim.world.get(handle)
        kind = _KIND.get(obj.type)
        if kind is None:
            raise UnsupportedError(f"{obj.name!r} is not a MuJoCo element that can be edited")
        el = getattr(spec, kind)(obj.name)
        if el is None:  # an object the spec does not name (cannot happen for a spec-built world)
            raise UnsupportedError(f"object {obj.name!r} is not in the scene's MjSpec")
        return kind, el, obj

    # --------------------------------------------------------------- commands
    def load_model(self, path: str, options: int) -> int:
        """``simxLoadModel``: attach an MJCF model's world children; returns its base handle."""
        file = self.resolve(path, options)
        if options & 1:  # a client's model: measured, its files confined to the transfer folder
            child = self._client_spec(file, f"model {quote(path)}", None)
        else:
            try:
                with _quiet_mujoco():
                    child = load_spec(file)
            except ValueError as exc:
                raise RemoteError(f"cannot load model {quote(path)}: {_one_line(exc)}") from None
        child_assets = _embed_assets(child, self._asset_counter)
        child.assets = {**(child.assets or {}), **child_assets}
        base = child.worldbody.first_body()
        if base is not None and not base.name:
            base.name = child.modelname or file.stem
        for t in list(child.texts):  # child scripts of loaded models are not run
            if t.name.startswith("simx:") and "child_script=" in t.data:
                log.warning("model %s: child script of %r ignored", file.name, t.name[5:])
                rest = " ".join(i for i in t.data.split() if not i.startswith("child_script="))
                if rest:
                    t.data = rest
                else:
                    child.delete(t)

        def change(spec: mujoco.MjSpec):
            taken = self._taken(spec)
            suffix = vrep_suffix(_names(child), taken, trigger=_names(child, _TREE_LISTS + _OTHER_LISTS))
            if not suffix:
                _rename_assets(child, taken)
            spec.attach(child, frame=spec.worldbody.add_frame(), prefix="", suffix=suffix)
            spec.assets = {**(spec.assets or {}), **child_assets}
            if base is not None:
                return lambda: self.sim.world.resolve(base.name + suffix).handle
            first = next((e.name + suffix for e in _elements(child, ("sites", "cameras", "lights")) if e.name), None)
            if first is None:
                raise ArgumentError(f"model {quote(path)} has no body nor named site, camera or light")
            return lambda: self.sim.world.resolve(first).handle

        handle = self._edit(change)
        self.sim.selection = [handle]  # V-REP selects the loaded model's base
        log.info("loaded model %s: base %r (handle %d)", file.name, self.sim.world.get(handle).name, handle)
        return handle

    def remove_object(self, handle: int) -> None:
        """``simxRemoveObject``: a shape goes with its body subtree; a joint's body stays in place."""
        def change(spec: mujoco.MjSpec):
            kind, el, obj = self._spec_element(spec, handle)
            before = _object_names(spec)
            if kind == "joint":
                self._remove_joint(spec, el, obj)
            else:
                if kind != "body":
                    _delete_references(spec, kind, obj.name)
                spec.delete(el)
            _delete_settings(spec, before - _object_names(spec))

        self._edit(change)

    def _remove_joint(self, spec: mujoco.MjSpec, joint, obj) -> None:
        m = self.sim.world.model
        body = spec.body(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, obj.body) or "")
        _delete_references(spec, "joint", obj.name)
        spec.delete(joint)
        if body is not None and body.first_joint() is None:
            # a body without joints is welded where it is now, as V-REP keeps it in place
            w = self.sim.world
            parent = int(m.body_parentid[obj.body])
            here = _compose(_inverse(_body_world(w, parent)), _body_world(w, obj.body))
            _set_local_pose(spec, body, here, (m.body_pos[obj.body], m.body_quat[obj.body]))
            self._placed.add(("body", body.name))

    def remove_model(self, handle: int) -> None:
        """``simxRemoveModel``: remove the body subtree rooted at a shape."""
        if handle == WORLD:
            raise ArgumentError("the world (-1) cannot be removed")
        self.sim.world.get(handle, SHAPE)
        self.remove_object(handle)

    def create_dummy(self, size: float, colors: list[int] | None) -> int:
        """``simxCreateDummy``: a sphere site of diameter ``size`` at the world origin."""
        if not math.isfinite(size) or size <= 0:
            raise ArgumentError(f"dummy size must be positive, got {size!r}")
        rgba = [1.0, 0.8, 0.2, 1.0]
        if colors is not None:
            if (not isinstance(colors, list) or len(colors) != 12
                    or not all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c <= 255 for c in colors)):
                raise ArgumentError("colors must be None or 12 ints in 0..255")
            rgba = [c / 255.0 for c in colors[:3]] + [1.0]

        def change(spec: mujoco.MjSpec):
            name = _free_name("Dummy", self._taken(spec))
            spec.worldbody.add_site(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE,
                                    size=[size / 2, size / 2, size / 2], rgba=rgba)
            return lambda: self.sim.world.resolve(name).handle

        return self._edit(change)

    def copy_paste(self, handles: list[int]) -> list[int]:
        """``simxCopyPasteObjects``: copy shapes (body subtrees), dummies, sensors and lights."""
        world = self.sim.world
        objs = [world.get(h) for h in handles]
        unique = {o.handle: o for o in objs}.values()
        todo = [o for o in unique if not any(a.handle in handles for a in self._ancestors(o))]
        for o in objs:
            if o.type == JOINT and o in todo:
                raise UnsupportedError(f"joint {o.name!r} cannot be copied alone (a MuJoCo joint "
                                       "belongs to its body): copy its body")
        new_name: dict[str, str] = {}
        copied_bodies: list[tuple[str, str]] = []

        def change(spec: mujoco.MjSpec):
            for o in todo:
                kind, el, _ = self._spec_element(spec, o.handle)
                if kind == "body":
                    names = _subtree_objects(el)
                    suffix = vrep_suffix(_subtree_names(el), self._taken(spec))
                    self._copy_body(spec, el, o, suffix)
                    new_name.update({n: n + suffix for n in names})
                    copied_bodies.append((o.name, o.name + suffix))
                    _copy_settings(spec, {n: n + suffix for n in names})
                else:
                    name = _free_name(o.name, self._taken(spec))
                    dst = _clone(kind, el, el.parent, name)
                    self._place_like(spec, kind, dst, o)
                    new_name[o.name] = name
                    _copy_settings(spec, {o.name: name})

            def after():
                for src, dst in copied_bodies:
                    self._copy_state(src, dst)
                return [world.resolve(new_name[o.name]).handle for o in objs]
            return after

        return self._edit(change)

    def _ancestors(self, obj):
        world, h = self.sim.world, obj.parent
        while h != WORLD:
            parent = world.objects[h]
            yield parent
            h = parent.parent

    def _copy_body(self, spec: mujoco.MjSpec, el, obj, suffix: str) -> None:
        m, w = self.sim.world.model, self.sim.world
        b = obj.mj_id
        parent = el.parent
        copy = parent.add_frame().attach_body(el, "", suffix)
        if m.body_jntnum[b] >= 1 and m.jnt_type[m.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE:
            here = _body_world(w, b)  # a free body's copy starts where the original is now
        else:
            here = (m.body_pos[b].copy(), m.body_quat[b].copy())
        copy.pos, copy.quat = here[0], here[1]
        copy.alt.type = _QUAT

    def _place_like(self, spec, kind: str, dst, obj) -> None:
        m = self.sim.world.model
        i = obj.mj_id
        if kind == "light":
            dst.pos, dst.dir = m.light_pos[i].copy(), m.light_dir[i].copy()
            return
        pos, quat = {"site": (m.site_pos, m.site_quat), "camera": (m.cam_pos, m.cam_quat)}[kind]
        dst.pos, dst.quat = pos[i].copy(), quat[i].copy()
        dst.alt.type = _QUAT
        if kind == "site":
            dst.fromto = [math.nan, 0, 0, 0, 0, 0]
            dst.size = m.site_size[i].copy()

    def _copy_state(self, src: str, dst: str) -> None:
        """Joint positions and motors of a copied subtree from its original (same tree shape)."""
        w = self.sim.world
        m, d = w.model, w.data
        pairs = [(w.resolve(src).mj_id, w.resolve(dst).mj_id)]
        for a, b in pairs:  # grows while walking: children in model order
            kids_a = [c for c in range(m.nbody) if m.body_parentid[c] == a and c != 0]
            kids_b = [c for c in range(m.nbody) if m.body_parentid[c] == b and c != 0]
            pairs.extend(zip(kids_a, kids_b))
            for ja, jb in zip(range(m.body_jntadr[a], m.body_jntadr[a] + m.body_jntnum[a]),
                              range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])):
                qa, qb = m.jnt_qposadr[ja], m.jnt_qposadr[jb]
                nq = {0: 7, 1: 4}.get(int(m.jnt_type[ja]), 1)
                d.qpos[qb:qb + nq] = d.qpos[qa:qa + nq]
                ha = w.by_name.get(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, ja) or "")
                hb = w.by_name.get(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jb) or "")
                if ha and hb and ha.handle in w.motor_index and hb.handle in w.motor_index:
                    ia, ib = w.motor_index[ha.handle], w.motor_index[hb.handle]
                    w.motors.copy_state(ia, ib)
        w.motors.write_force_limits(m)
        mujoco.mj_forward(m, d)
        w.version += 1

    def set_parent(self, handle: int, parent: int, keep_in_place: bool) -> None:
        """``simxSetObjectParent``: move a body subtree (or a site, camera, light) to another
        body or the world, keeping its world pose or its pose relative to its parent."""
        world = self.sim.world
        if handle == WORLD:
            raise ArgumentError("the world (-1) cannot be re-parented")
        obj = world.get(handle)
        if obj.type == JOINT:
            raise UnsupportedError(f"joint {obj.name!r} belongs to its body in MuJoCo: re-parent the body")
        if parent != WORLD:
            new_parent = world.get(parent)
            if new_parent.type != SHAPE:
                raise UnsupportedError("MuJoCo objects can only hang from shapes (bodies) or the world (-1)")
            if parent == handle or (obj.type == SHAPE and any(a.handle == handle for a in self._ancestors(new_parent))):
                raise ArgumentError(f"{new_parent.name!r} is {obj.name!r} or one of its descendants")
            parent_body = new_parent.mj_id
        else:
            parent_body = 0
        m = world.model
        old_body = int(m.body_parentid[obj.mj_id]) if obj.type == SHAPE else obj.body
        if old_body == parent_body:
            return  # already there: both poses unchanged
        kind = _KIND[obj.type]
        if kind == "light":
            local = (m.light_pos[obj.mj_id].copy(), m.light_dir[obj.mj_id].copy())
        else:
            pos, quat = {"body": (m.body_pos, m.body_quat), "site": (m.site_pos, m.site_quat),
                         "camera": (m.cam_pos, m.cam_quat)}[kind]
            local = (pos[obj.mj_id].copy(), quat[obj.mj_id].copy())
        if keep_in_place:
            to_new = _compose(_inverse(_body_world(world, parent_body)), _body_world(world, old_body))
            if kind == "light":
                local = (to_new[0] + _rotate(to_new[1], local[0]), _rotate(to_new[1], local[1]))
            else:
                local = _compose(to_new, local)

        def change(spec: mujoco.MjSpec):
            kind_, el, _ = self._spec_element(spec, handle)
            target = spec.worldbody if parent_body == 0 else spec.body(world.get(parent).name)
            counts = {name: len(getattr(spec, name)) for name in _REFERRING_LISTS}
            if kind_ == "body":
                moved = target.add_frame().attach_body(el, "", _MARK)
            else:
                moved = _clone(kind_, el, target, obj.name + _MARK)
            spec.delete(el)
            _strip_mark(spec)
            lost = [n for n in _REFERRING_LISTS if len(getattr(spec, n)) < counts[n]]
            if lost:
                raise UnsupportedError(f"moving {obj.name!r} would lose {', '.join(lost)} that link it "
                                       "to the rest of the scene")
            self._placed.add((kind_, obj.name))
            if kind_ == "light":
                moved.pos, moved.dir = local
            else:
                moved.pos, moved.quat = local
                moved.alt.type = _QUAT
                if kind_ == "site":
                    moved.fromto = [math.nan, 0, 0, 0, 0, 0]
                    moved.size = m.site_size[obj.mj_id].copy()

        try:
            self._edit(change)
        except UnsupportedError as exc:
            if "free joint" in str(exc):
                raise UnsupportedError(f"{obj.name!r} has a free joint, and MuJoCo allows free joints "
                                       "only in children of the world") from None
            raise

    def load_scene(self, path: str, options: int) -> None:
        """``simxLoadScene``: replace the scene (simulation stopped only); handles restart."""
        from simx_server.simulation import RunState  # late: simulation may create the Editor

        if self.sim.state is not RunState.STOPPED:
            raise RemoteError("stop the simulation first")
        file = self.resolve(path, options)
        spec = None
        if options & 1:  # a client's scene: measured before MuJoCo parses and compiles it
            spec = self._client_spec(file, f"scene {quote(path)}", self.sim.world.requested_dt)
        self._install_scene(file, quote(path), spec)

    def close_scene(self) -> None:
        """``simxCloseScene``: stop the simulation and replace the scene with an empty one."""
        self.sim.stop()
        empty = self.files_dir / ".simx" / "empty.xml"
        empty.parent.mkdir(exist_ok=True)
        empty.write_text(_EMPTY_SCENE)
        self._install_scene(empty, "empty")

    def _install_scene(self, file: Path, label: str, spec: mujoco.MjSpec | None = None) -> None:
        """Load ``file`` as the scene; ``spec`` is its parse when the caller has it already
        (a client's scene, measured): MuJoCo's parse is most of a load's time."""
        sim = self.sim
        dt = sim.world.requested_dt
        old = sim.scripts
        # A scene in a transfer folder (any server's) brings no code, unless --allow-remote-code.
        untrusted = guard.transfer_folders(self.files_dir, *([file.parent] if guard.is_transferred(file) else []))
        try:
            world = World(file, dt)
            scripts = Scripts(world, sim.signals, allow_remote_code=old.allow_remote_code,
                              allow_unsafe_lua=old.allow_unsafe_lua, untrusted=untrusted, simulation=sim)
        except (ValueError, RemoteError) as exc:
            text = self._scrub(_one_line(exc))
            text = text.removeprefix(f"cannot load scene {self.public(file)}: ")  # World's own prefix
            raise RemoteError(f"cannot load scene {label}: {text}") from None
        sim.world, sim.scripts = world, scripts
        refresh_vision(sim)
        sim.sensors = type(sim.sensors)()  # per-scene sensor state (probes, passive images) starts afresh
        self._spec = self._spec_world = self._baseline = None
        if spec is not None:
            try:
                with _quiet_mujoco():
                    spec.assets = {**(spec.assets or {}), **_embed_assets(spec, self._asset_counter)}
                    self._spec, self._spec_world, self._baseline = spec, world, _poses(spec.compile())
            except ValueError as exc:
                log.warning("scene %s cannot be edited: %s", label, _one_line(exc))
        else:
            self._parse_now()
        sim.selection = []
        log.info("scene %s loaded: %d objects", label, len(world.objects))
