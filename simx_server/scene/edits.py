"""Object edits of the scene editor, in V-REP's terms: load a model (``simxLoadModel``), remove
objects and models, create dummies, copy and paste, change parents (``simxSetObjectParent``).
A mixin of :class:`simx_server.scene.editor.Editor`, whose ``_edit`` compiles each change on a
copy of the scene's ``MjSpec`` (a failed edit changes nothing); the naming, tree and trust rules
are in that module's docstring.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import NamedTuple

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, ObjectTypeError, RemoteError, UnsupportedError
from simx_server.base.arguments import quote
from simx_server.base import scene_guard as guard
from simx_server.base.mesh_counts import spec_mesh_counts
from simx_server.scene import conversions, grasping, loose_links, model_files, model_scripts, model_tree
from simx_server.sim.spec_tools import (
    _KIND,
    _MARK,
    _OTHER_LISTS,
    _QUAT,
    _REFERRING_LISTS,
    _TREE_LISTS,
    _body_world,
    _clone,
    _compose,
    _copy_settings,
    _delete_references,
    _delete_settings,
    _embed_assets,
    _free_name,
    _inverse,
    _names,
    _object_names,
    _one_line,
    _rename_assets,
    _rotate,
    _set_local_pose,
    _strip_mark,
    _subtree_names,
    _subtree_objects,
    set_setting,
    vrep_suffix,
)
from simx_server.sim import grasps, kept_objects, properties
from simx_server.sim.urdf import load_spec
from simx_server.sim.vision_results import Deferred
from simx_server.sim.objects import subtree
from simx_server.sim.world import FORCE_SENSOR, JOINT, SHAPE, WORLD

log = logging.getLogger("simx.editing")


class PreparedModel(NamedTuple):
    """A model read for loading (:meth:`ObjectEdits.prepare_model`): made on any thread, handed
    to the simulation thread once, never shared before."""

    file: Path  #: the MJCF file read
    label: str  #: the path the client gave, quoted
    spec: mujoco.MjSpec  #: the model's spec, its files in memory, its script settings taken out
    assets: dict[str, bytes]  #: those files, by the names the spec gives them
    scripts: tuple = ()  #: its scripts (:func:`model_scripts.take`), attached with it
    client: bool = False  #: a client's file (its scripts run only with ``--allow-remote-code``)
    files: tuple = ()  #: its objects' path and custom data (:func:`model_files.take`)


class ObjectEdits:
    """The object commands of the :class:`~simx_server.scene.editor.Editor` (which provides ``sim``, ``files``, ``_edit``, ``_taken``, ``_spec_element``, ``resolve``, ``_client_spec``)."""

    edits: int  #: the editor's count of the calls that reached it

    # --------------------------------------------------------------- commands
    def load_model(self, path: str, options: int, defer: bool = False) -> int | Deferred:
        """``simxLoadModel``: attach an MJCF model's world children; returns its base handle.

        ``defer``: a ``.ttm`` file is converted off the simulation thread, where the model's
        spec is also parsed and compiled once alone (:meth:`prepare_model`: its meshes then
        wait in MuJoCo's cache under the names the scene's compile looks up), and the load
        completes later (:mod:`simx_server.scene.conversions`): returns the Deferred of the
        handle."""
        self.edits += 1
        model = self.sim.world.model
        # the scene's meshes now, read here (its thread), to bound a client's load: one a client
        # asks for or of a client's file; the operator's own loads are not bounded
        meshes = (model.nmeshvert, model.nmeshface) if self.files.caller or options & 1 else None
        if defer:
            label = quote(path)
            root = self.files.folder(self.files.caller) if options & 1 else None  # the sender's folder
            pending = conversions.later(self.sim, self.files, path, options, self._finish_model,
                                        lambda xml: self.prepare_model(xml, label, root, meshes=meshes))
            if pending is not None:
                return pending
        file = self.resolve(path, options)
        root = self.files.root_of(file) if options & 1 else None
        return self._attach_model(self.prepare_model(file, quote(path), root, warm=False, meshes=meshes))

    def _finish_model(self, ready) -> int:
        if isinstance(ready, BaseException):
            raise ready
        return self._attach_model(ready)

    def prepare_model(self, file, label: str, root=None, warm: bool = True,
                      meshes: tuple[int, int] | None = None) -> PreparedModel:
        """The part of a model load that touches nothing of the live scene, on any thread: the
        model's ``MjSpec`` parsed (a client's file measured first: ``root``, the sender's
        folder, as :meth:`_client_spec`), its files read into memory under names of their own
        (:func:`_embed_assets`), its scripts dropped; ``warm``: compiled once alone and
        dropped, which leaves its meshes processed (convex hulls, inertia) in MuJoCo's cache
        under those names, so that the scene's compile on the simulation thread finds them
        there (before, a 100-shape model's meshes, compiled from memory, held that thread
        1.3-2.3 s). As CoppeliaSim's ``CFileOperations::loadModel`` reads the file whole before
        it adds the model to the scene.

        Args:
            file: the MJCF (or URDF) file, resolved; a ``.ttm``'s conversion.
            label: the path as the client gave it, quoted, for messages.
            root: the client's folder for a client's file; None for a server-side file.
            warm: compile the model alone once (off the simulation thread only).
            meshes: the scene's mesh vertices and faces when the load was asked for: a model
                that would put it past ``MAX_SCENE_MESH_*`` is refused here, before any compile
                (the attach checks again, :func:`scene_guard.check_mesh_growth`).

        Raises:
            RemoteError: ``cannot load model <label>: ...`` (MuJoCo's parse message or a bound).
        """
        if root is not None:  # a client's model: measured, its files confined to its folder
            child = self._client_spec(file, f"model {label}", None, root)
        else:
            try:
                child = load_spec(file)  # (MuJoCo's warnings: physics.SINK, on any thread)
            except ValueError as exc:
                raise RemoteError(f"cannot load model {label}: {_one_line(exc)}") from None
        child_assets = _embed_assets(child, self._asset_counter)
        child.assets = {**(child.assets or {}), **child_assets}
        if meshes is not None:  # the scene's mesh totals bound it (a client's scene)
            counts = [spec_mesh_counts(mesh, child.assets) for mesh in child.meshes]
            try:
                guard.check_mesh_totals(meshes, (sum(c[0] for c in counts), sum(c[1] for c in counts)),
                                        "the scene with it")
            except RemoteError as exc:
                raise RemoteError(f"cannot load model {label}: {exc}") from None
        scripts = model_scripts.take(child, Path(file).parent, label, self._scrub)  # attached with the model
        files = model_files.take(child, Path(file).parent, label, self._scrub)  # its paths', custom data
        if warm and (child.meshes or child.textures):
            try:  # MuJoCo releases the GIL while it compiles; the attach's compile reports errors
                child.copy().compile()
            except Exception as exc:
                log.debug("warming MuJoCo's cache with model %s: %s", label, exc)
        return PreparedModel(file, label, child, child_assets, tuple(scripts), root is not None, tuple(files))

    def _attach_model(self, prepared: PreparedModel) -> int:
        """Attach a prepared model (:meth:`prepare_model`) to the scene, on the simulation
        thread (one compile of the scene with it, :meth:`_edit`); the handle of its root, V-REP's
        model base (:func:`model_tree.root_name`: a ``.ttm``'s root object, an MJCF model's
        first top-level object, which becomes a model base), as ``simLoadModel`` returns it."""
        file, path, child, child_assets = prepared[:4]
        first = child.worldbody.first_body()
        if first is not None and not first.name:
            first.name = child.modelname or file.stem
        root, is_base = model_tree.root_name(child)
        if root is None:
            raise ArgumentError(f"model {path} has no body nor named site, camera or light")
        given = [""]  # the suffix the model's names get

        def change(spec: mujoco.MjSpec):
            taken = self._taken(spec)
            suffix = given[0] = vrep_suffix(_names(child), taken, trigger=_names(child, _TREE_LISTS + _OTHER_LISTS))
            if suffix:
                model_tree.suffix_settings(child, suffix)
            else:
                _rename_assets(child, taken)
            had = set(spec.assets or ())
            spec.attach(child, frame=spec.worldbody.add_frame(), prefix="", suffix=suffix)
            for key in set(spec.assets or ()) - had:  # MuJoCo's copies of the child's files, their
                spec.assets.pop(key)                  # keys suffixed: the elements read child_assets'
            spec.assets = {**(spec.assets or {}), **child_assets}
            if not is_base:  # a loaded model's root is a model base in CoppeliaSim
                set_setting(spec, root + suffix, "model_base", "1")
            return lambda: self.sim.world.resolve(root + suffix).handle

        handle = self._edit(change, bounded=bool(self.files.caller) or prepared.client)
        model_files.attach(self.sim, prepared.files, given[0])
        model_scripts.attach(self.sim, prepared.scripts, given[0], prepared.client, path)
        self.sim.selection = [handle]  # V-REP selects the loaded model's base
        log.info("loaded model %s: base %r (handle %d)", file.name, self.sim.world.get(handle).name, handle)
        return handle

    def remove_object(self, handle: int) -> None:
        """``simxRemoveObject``: a shape goes with its body subtree; a joint's body stays in place;
        the assets only they used go too (:func:`model_tree.remove`)."""
        def change(spec: mujoco.MjSpec):
            kind, el, obj = self._spec_element(spec, handle)
            if kind == "joint":
                before = _object_names(spec)
                self._remove_joint(spec, el, obj)
                _delete_settings(spec, before - _object_names(spec))
            else:
                model_tree.remove(spec, self.sim.world, [obj])

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

    def remove_model(self, handle: int) -> int:
        """``simxRemoveModel`` / ``sim.removeModel``: remove a model, its base and every object
        below it in V-REP's tree (:func:`~simx_server.sim.objects.subtree`: objects hung by ``vrep_parent=``
        too), with the unnamed bodies that carried only them, their settings, the assets only
        they used, and their scripts (``sysCall_cleanup``), as ``simRemoveModel_internal``
        (``addModelObjects``, ``eraseObjects``). A shape that is no model base is accepted as
        the base of its tree (simx's earlier rule: an MJCF scene's bodies carry no model flag).

        Returns:
            The number of objects removed.

        Raises:
            ArgumentError: the world.
            ObjectTypeError: an object other than a shape that is no model base.
            UnknownObjectError: no such object.
        """
        if handle == WORLD:
            raise ArgumentError("the world (-1) cannot be removed")
        world = self.sim.world
        obj = world.get(handle)
        if obj.type != SHAPE and properties.model_property(world, handle) & properties.NOT_MODEL == properties.NOT_MODEL:
            raise ObjectTypeError(f"{obj.name!r} is not a model base (sim.removeModel removes a model from its base)")
        objects = subtree(world, handle)
        self._edit(lambda spec: model_tree.remove(spec, world, objects, carriers=True))
        return len(objects)

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
        """``simxCopyPasteObjects``: copy shapes (body subtrees), dummies, sensors and lights (an old
        path with its current points, a camera with its optics)."""
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
                copies = [world.resolve(new_name[o.name]).handle for o in objs]
                kept_objects.copied(world, [(o.handle, h) for o, h in zip(objs, copies)])  # paths, cameras
                model_scripts.copy(self.sim, [(world.by_name[a].handle, world.by_name[b].handle)
                                              for a, b in new_name.items() if a in world.by_name and b in world.by_name])
                return copies
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

    def _carrier(self, spec: mujoco.MjSpec, parent):
        """The spec body that carries object ``parent``: the shape's own, or the one its element
        is in (also an unnamed one, such as a converted joint's)."""
        if parent.type == SHAPE:
            return spec.body(parent.name)
        kind = _KIND.get(parent.type)
        el = getattr(spec, kind)(parent.name) if kind is not None else None
        if el is None:
            raise UnsupportedError(f"{parent.name!r} is not in the scene's MjSpec: it cannot be a parent here")
        return el.parent

    def _parent_in_body(self, parent: int, body: int) -> tuple:
        """The frame of object ``parent`` (-1: the world) in MuJoCo body ``body``'s frame, as
        ``(pos, quat)``: identity for a shape (its body), the world, and an object another body
        carries (a shape's own joint, which moves with it)."""
        world = self.sim.world
        if parent == WORLD or world.get(parent).type == SHAPE or world.get(parent).body != body:
            return np.zeros(3), np.array([1.0, 0, 0, 0])
        p, r = world.frame(parent)
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, np.ascontiguousarray(r).reshape(9))
        return _compose(_inverse(_body_world(world, body)), (np.asarray(p, float), q))

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
        """``simxSetObjectParent`` / ``sim.setObjectParent``: move a body subtree (or a site,
        camera, light) under any object or the world, keeping its world pose
        (``keep_in_place``) or its pose relative to its parent.

        A dynamic shape (a free body) stays a child of the world in MuJoCo, held to its new
        parent by a weld (:mod:`simx_server.scene.grasping`: grasping, and releasing to -1).
        A moving shape put under a joint or force sensor that has a child already becomes a
        free body (:mod:`simx_server.scene.loose_links`: such a parent links nothing).
        As in CoppeliaSim (``CSceneObject::setParent``), any object may be a parent: a shape is
        its body; a dummy, sensor, camera, light or joint is carried by a body in MuJoCo, and
        the child goes into that body (for a joint: the body it moves), at the parent object's
        frame, with ``vrep_parent=`` recording V-REP's parent for ``sim.getObjectParent``. A
        force sensor always gets that setting: it then measures what hangs below it in V-REP's
        tree, not its site's body (:mod:`simx_server.sim.force_sensors`).

        Raises:
            ArgumentError: the world, or a parent inside the child's subtree.
            UnsupportedError: a joint as the child (it belongs to its body), or a move MuJoCo
                cannot make (references lost).
        """
        world = self.sim.world
        if handle == WORLD:
            raise ArgumentError("the world (-1) cannot be re-parented")
        obj = world.get(handle)
        if obj.type == JOINT:
            raise UnsupportedError(f"joint {obj.name!r} belongs to its body in MuJoCo: re-parent the body")
        new_parent = world.get(parent) if parent != WORLD else None
        if new_parent is not None:
            if parent == handle or (obj.type == SHAPE and any(a.handle == handle for a in self._ancestors(new_parent))):
                raise ArgumentError(f"{new_parent.name!r} is {obj.name!r} or one of its descendants")
            parent_body = new_parent.mj_id if new_parent.type == SHAPE else new_parent.body
        else:
            parent_body = 0
        m = world.model
        if obj.type == SHAPE and obj.parent != parent and grasps.moves(m, obj.mj_id) and \
                loose_links.links_nothing(world, new_parent, handle):
            loose_links.let_go_of_others(world, new_parent, handle)  # a second child: no link at all
            return loose_links.free(self, obj, new_parent, keep_in_place)
        if obj.type == SHAPE and grasps.is_free(m, obj.mj_id) and (new_parent is not None or obj.name in world.grasps):
            return grasping.hold(self, obj, new_parent, keep_in_place)  # a dynamic shape: held by a weld
        old_body = int(m.body_parentid[obj.mj_id]) if obj.type == SHAPE else obj.body
        if obj.parent == parent:
            return  # V-REP's parent already: nothing moves (CoppeliaSim's setParent does nothing)
        if obj.type == SHAPE and parent_body in (old_body, obj.mj_id) and (
                keep_in_place or _same_pose(self._parent_in_body(parent, parent_body),
                                            self._parent_in_body(obj.parent, old_body))):
            # MuJoCo's tree holds it as it is: hung from another object of the same body (a
            # joint's other child, a force sensor), or from a force sensor whose site it carries
            # (the sensor's child side is this shape). Only V-REP's tree changes; its pose stays.
            tree_only = None if new_parent is not None and new_parent.type == SHAPE and \
                parent_body == old_body else (new_parent.name if new_parent is not None else "-1")
            self._edit(lambda spec: set_setting(spec, obj.name, "vrep_parent", tree_only))
            return
        vrep_parent = None if new_parent is None or new_parent.type == SHAPE else new_parent.name
        if obj.type == FORCE_SENSOR:  # always: its child side is then V-REP's (sim/force_sensors.py)
            vrep_parent = "-1" if new_parent is None else new_parent.name
        kind = _KIND[obj.type]
        if kind == "light":
            local = (m.light_pos[obj.mj_id].copy(), m.light_dir[obj.mj_id].copy())
        else:
            pos, quat = {"body": (m.body_pos, m.body_quat), "site": (m.site_pos, m.site_quat),
                         "camera": (m.cam_pos, m.cam_quat)}[kind]
            local = (pos[obj.mj_id].copy(), quat[obj.mj_id].copy())
        if keep_in_place:  # the same world pose, seen from the new body
            to_new = _compose(_inverse(_body_world(world, parent_body)), _body_world(world, old_body))
        else:  # the same pose relative to the (V-REP) parent: old parent's frame -> new parent's
            to_new = _compose(self._parent_in_body(parent, parent_body),
                              _inverse(self._parent_in_body(obj.parent, old_body)))
        if kind == "light":
            local = (to_new[0] + _rotate(to_new[1], local[0]), _rotate(to_new[1], local[1]))
        else:
            local = _compose(to_new, local)

        def change(spec: mujoco.MjSpec):
            kind_, el, _ = self._spec_element(spec, handle)
            target = spec.worldbody if parent_body == 0 else self._carrier(spec, new_parent)
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
            set_setting(spec, obj.name, "vrep_parent", vrep_parent)
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


def _same_pose(a: tuple, b: tuple) -> bool:
    """Whether two ``(pos, quat)`` frames are one (within 1e-9 m, 1e-9 rad)."""
    return bool(np.allclose(a[0], b[0], atol=1e-9) and abs(abs(float(np.dot(a[1], b[1]))) - 1) < 1e-12)
