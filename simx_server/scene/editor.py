"""Scene editing: V-REP's model and scene commands on a live ``MjSpec`` of the scene.

The :class:`Editor` keeps one ``mujoco.MjSpec`` of the loaded scene (parsed from the scene
file when the editor or the scene is created; mesh, height-field, skin and texture files are
read into memory then, so that later compiles need no file). Each edit works on a copy of that
spec, compiles it to a new ``MjModel`` and hands it to :meth:`World.replace_model`, which keeps
every object that is still there (matched by name): its handle, joint positions and
velocities, free bodies' poses, motors' mode/targets/maximum force and the simulation time.
Objects that commands placed while the simulation runs (``World.set_pose``) stay where they
are until it stops, and what commands changed in the model (colours, masses, sizes, limits,
view angles: :mod:`simx_server.scene.kept_state`) and the objects' special properties stay too. A failed edit changes nothing. Vision sensors are rebuilt after each edit
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
  refer to them). A model load returns the model's root, a model base; removing a model takes
  every object below its base in V-REP's tree, also those MuJoCo hangs elsewhere
  (``vrep_parent=``), and every removal takes the meshes, textures and materials that only the
  removed elements used (:mod:`simx_server.scene.model_tree`).
* Scripts come with objects, as in CoppeliaSim: a loaded model's and a copy's run as the
  scene's own (their V-REP 3.x lookups find their own objects by the name suffix,
  ``sim.getObjectHandle``; :mod:`simx_server.scene.model_scripts`), and a removed object's end
  (``sysCall_cleanup``).
* Files sent with ``simxTransferFile`` go to a transfer folder private to this server
  process (``scene_guard.make_transfer_folder``: 0700, removed by :meth:`Editor.close` or at
  exit, never named in replies); names that leave it are refused, and its size is bounded.
* Trust: a scene or model loaded from the transfer folder (options bit 0) is a client's: its
  files must lie in the transfer folder, its size is bounded before MuJoCo parses it, its
  scripts run only with ``--allow-remote-code`` (a client's scene is refused without it, a
  client's model loads without them). Server-side paths (options 0) are loaded only
  from the operator's scene folder and ``--scene-path`` folders, never from a transfer folder
  of any server. A client's edits may not grow the scene past ``MAX_SCENE_BODIES``/``MAX_SCENE_ELEMENTS``
  nor add meshes past ``MAX_SCENE_MESH_VERTICES``/``MAX_SCENE_MESH_FACES``, nor its cost past
  ``MAX_ARENA_BYTES``/``MAX_STEP_WORK``/``MAX_SCENE_CONTACTS``; the operator's own are not bounded.

The MjSpec tools (pose maths, names, references, cloning) are in :mod:`simx_server.sim.spec_tools`,
the command handlers (``EDITING_HANDLERS``) in :mod:`simx_server.commands.editing`.

Runs on the simulation thread, like every handler, except :meth:`Editor.prepare_scene` and
``prepare_model`` (any thread: a deferred load's conversion thread), which build a new world or
model spec and share nothing with the live simulation until the simulation thread takes it.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any, Callable, NamedTuple

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, RemoteError, UnsupportedError
from simx_server.base import limits
from simx_server.base import scene_guard as guard
from simx_server.base.arguments import quote
from simx_server.scene import conversions, custom_data, kept_state, scene_file
from simx_server.scene.client_files import ClientFiles
from simx_server.scene.edits import ObjectEdits
from simx_server.scene.ttt import cache as ttt_cache
from simx_server.scripts.scene_scripts import Scripts
from simx_server.sim import motor_spec
from simx_server.sim.spec_tools import (
    _FRAMES,
    _KIND,
    _MJ_OBJ,
    _embed_assets,
    _names,
    _one_line,
    _poses,
    _quiet_mujoco,
)
from simx_server.sim.state import RunState, SimulationView
from simx_server.sim.urdf import load_spec
from simx_server.sim.vision import VisionSensors
from simx_server.sim.vision_results import Deferred
from simx_server.sim.world import WORLD, World

log = logging.getLogger("simx.editing")

_EMPTY_SCENE = '<mujoco model="empty">\n  <worldbody/>\n</mujoco>\n'


def refresh_vision(sim: SimulationView) -> None:
    """New vision sensors for the changed model; they take over the render thread, whose
    renderers are rebuilt for the new model at once, on that thread. While the simulation is
    stopped (a scene load) this waits for them: the first image after the start is at once."""

    sim.vision = VisionSensors(sim.world, previous=sim.vision)
    if sim.state is RunState.STOPPED:
        sim.vision.wait_ready(limits.VISION_READY_TIMEOUT)


# --------------------------------------------------------------------------- editor
class Editor(ObjectEdits):
    """Scene editing for one :class:`SimulationView` (``sim.editor = Editor(sim)``).

    Owns the transfer folder through :class:`ClientFiles` (``<tmp>/simx-<pid>-<start>-*``,
    0700); :meth:`close` removes it, and so does the interpreter's exit. ``scene_paths`` are the
    ``--scene-path`` folders: with the folder of the scene the server started with, the only
    places server-side paths (options 0) are loaded from.
    """

    def __init__(self, sim: SimulationView, scene_paths=()):
        self.sim = sim
        self.files = ClientFiles(sim.world.scene_path, scene_paths)  # the transfer folder, trusted folders
        self._spec: mujoco.MjSpec | None = None
        self._spec_world: World | None = None  # the world (scene) the spec describes
        self._baseline: dict[str, np.ndarray] | None = None  # poses as last compiled
        self._baseline_state: dict[str, np.ndarray] | None = None  # other kept fields as last compiled
        self._placed: set[tuple[str, str]] = set()
        self._renamed: dict[str, str] = {}
        self._asset_counter = [0]  # numbers in-memory asset names
        #: Calls that reached the editor (an edit, a scene load or close), counted as they come:
        #: a door charges a call that moved it as a scene edit (``EDIT_SHARE``), whatever its name.
        self.edits = 0
        self._parse_now()

    def _parse_now(self) -> None:
        """Parse the scene file at once, while it matches the loaded world (just loaded: its
        poses are the file's, the edit baseline, without compiling the file a second time)."""
        try:
            self._live_spec(fresh=True)
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

    def transfer_file(self, name: str, data: Any, later: bool = False) -> Any:
        """``simxTransferFile`` (see :meth:`ClientFiles.transfer_file`): None, or with ``later``
        the Future of the write."""
        return self.files.transfer_file(name, data, later)

    def erase_file(self, name: str) -> None:
        """``simxEraseFile``: delete a transferred file."""
        self.files.erase_file(name)

    def resolve(self, path: Any, options: int) -> Path:
        """The file a LoadScene/LoadModel names (see :meth:`ClientFiles.resolve`)."""
        return self.files.resolve(path, options, self.sim.world.scene_path)

    def scene_origin(self) -> Path:
        """The ``.ttt``/``.ttm`` the loaded scene was converted from (its own path otherwise)."""
        return ttt_cache.origin(self.sim.world.scene_path)

    def public(self, path: Path) -> str:
        """``path`` as a client may see it (never the transfer folder's path)."""
        return self.files.public(path)

    def _scrub(self, text: str) -> str:
        return self.files.scrub(text)

    def _client_spec(self, file: Path, what: str, dt: float | None, root: Path | None = None) -> mujoco.MjSpec:
        """Parse a client-sent MJCF file, measured before and after parsing (scene_guard); any
        thread given ``root``, the sending client's folder (else the simulation thread's files
        tell it). MuJoCo's warnings go to physics.SINK (the process-wide handler is not swapped)."""
        root = root if root is not None else self.files.root_of(file)
        guard.check_client_file(file, root, what)
        try:
            spec = load_spec(file, root=root)  # a URDF's meshes: confined before looked up
        except ValueError as exc:
            raise RemoteError(f"cannot load {what}: {self._scrub(_one_line(exc))}") from None
        guard.check_spec(spec, what, root=root, dt=dt)
        return spec

    # ------------------------------------------------------------------- spec
    def _live_spec(self, fresh: bool = False) -> mujoco.MjSpec:
        """The scene's spec for edits, parsed once per world. ``fresh``: the world was just
        loaded from the file, so its poses are the compiled file's (the baseline for
        :meth:`_runtime_placements`); compiling the spec again for them cost 0.2 s of every
        server start (the UR5 scene's meshes, embedded in memory, miss MuJoCo's cache)."""
        world = self.sim.world
        if self._spec is None or self._spec_world is not world:
            try:
                with _quiet_mujoco():
                    spec = load_spec(world.scene_path)
                    spec.assets = {**(spec.assets or {}), **_embed_assets(spec, self._asset_counter)}
                    compiled = world.model if fresh else spec.compile()
                    baseline = _poses(compiled)
            except ValueError as exc:
                raise UnsupportedError(f"scene {world.scene_name} cannot be edited: "
                                       f"{_one_line(exc)}") from None
            self._spec, self._spec_world, self._baseline = spec, world, baseline
            self._baseline_state = kept_state.snapshot(compiled)
        return self._spec

    def scene_files(self, stem: str) -> tuple[str, dict[str, bytes]]:
        """The scene as it is now, to save (``sim.saveScene``): its MJCF text and the files it
        names, by name, to write next to it (:func:`scene_file.scene_files`; ``stem``: the saved
        file's name without ``.xml``).

        Raises:
            UnsupportedError: MuJoCo cannot write the scene, or a script's file cannot be read.
        """
        return scene_file.scene_files(self.sim, stem)

    def prepare_save(self, stem: str) -> tuple[dict[str, bytes], Callable[[], str]]:
        """:meth:`scene_files` with the MJCF text left to make, by any thread
        (:func:`scene_file.prepare`): ``(files, text)``."""
        return scene_file.prepare(self.sim, stem)

    def prepare_model_save(self, body: str, stem: str) -> tuple[dict[str, bytes], Callable[[], str]]:
        """The files of the model of shape ``body`` (``sim.saveModel``), its text left to make
        (:func:`scene_file.prepare_model`): ``(files, text)``."""
        return scene_file.prepare_model(self.sim, body, stem)

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
                if kind == "site":
                    m.site_sameframe[i] = 0  # else MuJoCo keeps a site compiled at its body's origin there
        for name, (pos, quat) in mocap.items():
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
            if b >= 0 and m.body_mocapid[b] >= 0:
                d.mocap_pos[m.body_mocapid[b]], d.mocap_quat[m.body_mocapid[b]] = pos, quat
        if placements or mocap:
            mujoco.mj_forward(m, d)

    def _edit(self, change: Callable[[mujoco.MjSpec], Any], bounded: bool | None = None) -> Any:
        """Apply ``change`` to a copy of the spec, compile, swap the model in; all or nothing.

        ``change`` returns an optional callable run after the swap (on the new world). ``bounded``
        (default: a client's request is being served) checks the scene's growth against
        ``MAX_SCENE_*`` first, and the edited model's cost (``World.replace_model``); the
        operator's own edits (in process, its scripts) are not bounded.
        """
        self.edits += 1
        world = self.sim.world
        with _quiet_mujoco():
            live = self._live_spec()
            before = guard.element_counts(live)
            spec = live.copy()
            spec.copy_during_attach = True
            self._placed: set[tuple[str, str]] = set()  # (kind, name) the change placed itself
            self._renamed: dict[str, str] = {}  # old name -> new, of what the change renamed
            try:
                after = change(spec)
            except ValueError as exc:  # MjSpec refuses the operation (attach, delete)
                raise UnsupportedError(f"MuJoCo cannot make this edit: {self._scrub(_one_line(exc))}") from None
            kept = kept_state.renamed(kept_state.changes(world.model, self._baseline_state), self._renamed)
            # contact bits switched at run time go into the spec: MuJoCo makes a mesh's convex hull
            # (its collision polygons) only for a mesh a collidable geom uses when it compiles
            kept_state.write(spec, [k for k in kept if k[0] in kept_state.CONTACT_FIELDS])
            bounded = bool(self.files.caller) if bounded is None else bounded
            if bounded:
                guard.check_growth(before, spec)
                guard.check_mesh_growth(world.model, live, spec)
            try:
                model = motor_spec.compile_spec(spec)  # joints without an actuator get a motor
            except ValueError as exc:
                raise UnsupportedError("MuJoCo cannot compile the edited scene: "
                                       f"{self._scrub(_one_line(exc))}") from None
        placements, mocap = self._runtime_placements(), self._mocap_poses()
        baseline, baseline_state = _poses(model), kept_state.snapshot(model)
        world.replace_model(model, bounded=bounded)
        self._spec, self._baseline, self._baseline_state = spec, baseline, baseline_state
        self._restore_placements(placements, mocap, self._placed)
        if kept_state.restore(world.model, kept, {name for _, name in self._placed}):
            kept_state.settle(world)
        world.changed()
        refresh_vision(self.sim)
        self.sim.scripts.drop_removed()  # a removed object's scripts end (sysCall_cleanup)
        self.sim.selection = [h for h in self.sim.selection if h in world.objects]  # removed ones leave it
        return after() if callable(after) else after

    def _taken(self, spec: mujoco.MjSpec) -> set[str]:
        """Names a new element may not have: the spec's and the V-REP names, which differ for
        elements that share a name with one of another kind (see simx_server.sim.naming)."""
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

    def load_scene(self, path: str, options: int, defer: bool = False) -> Deferred | None:
        """``simxLoadScene``: replace the scene (simulation stopped only); handles restart.

        ``defer``: a ``.ttt`` file is converted off the simulation thread, and MuJoCo's parse
        and compile of the converted file and the new :class:`World` are made there too
        (:meth:`prepare_scene`); the simulation thread then only swaps the scene in
        (:meth:`_swap_scene`) and the load completes (:mod:`simx_server.scene.conversions`):
        returns its Deferred (None when loaded at once)."""

        self.edits += 1
        self._check_stopped()
        if defer:
            label, dt, now = quote(path), self._load_dt(), self.sim.world.requested_dt
            root = self.files.folder(self.files.caller) if options & 1 else None  # the sender's folder
            pending = conversions.later(self.sim, self.files, path, options, self._finish_scene,
                                        lambda xml: self.prepare_scene(xml, label, dt, root, now, warm=True))
            if pending is not None:
                return pending
        self._load_scene_file(self.resolve(path, options), path, options)
        return None

    def _finish_scene(self, ready: Any) -> None:
        """The simulation thread's part of a deferred load: ``ready`` is what
        :meth:`prepare_scene` made, or the exception it raised."""
        if isinstance(ready, BaseException):
            raise ready
        self._check_stopped()
        self._swap_scene(ready)

    def _check_stopped(self) -> None:
        if self.sim.state is not RunState.STOPPED:
            raise RemoteError("stop the simulation first: call sim.stopSimulation() (simxStopSimulation) before, "
                              "or start simx-server with --stopped (CoppeliaSim starts stopped; docs/ZMQ.md)")

    def _load_dt(self) -> float | None:
        """The step a loaded scene gets: ``--dt``, else (None) the new scene's saved step, as
        V-REP loads a scene's settings."""
        sim = self.sim
        return getattr(sim, "dt_override", sim.world.requested_dt)

    def _load_scene_file(self, file: Path, path: str, options: int) -> None:
        """Load the resolved scene ``file`` (MJCF) that ``path`` named."""
        self._check_stopped()
        root = self.files.root_of(file) if options & 1 else None  # a client's scene: measured
        self._swap_scene(self.prepare_scene(file, quote(path), self._load_dt(), root, self.sim.world.requested_dt))

    def close_scene(self) -> None:
        """``simxCloseScene``: stop the simulation and replace the scene with an empty one."""
        self.edits += 1
        self.sim.stop()
        empty = self.files_dir / ".simx" / "empty.xml"
        empty.parent.mkdir(exist_ok=True)
        empty.write_text(_EMPTY_SCENE)
        self._swap_scene(self.prepare_scene(empty, "empty", self._load_dt()))

    def prepare_scene(self, file: Path, label: str, dt: float | None, root: Path | None = None,
                      step: float | None = None, warm: bool = False) -> PreparedScene:
        """The part of a scene load that touches nothing of the live simulation, on any thread:
        the client's file measured (``root``: the sending client's folder, as
        :meth:`_client_spec`), MuJoCo's parse and compile of ``file`` into a new :class:`World`,
        its custom data, and the ``MjSpec`` that later edits start from (its poses as compiled:
        the new world's). Nothing made here is seen by the simulation until
        :meth:`_swap_scene` (one thread owns a model once it is live). As CoppeliaSim's
        ``CFileOperations::loadScene`` reads the whole file before it replaces the scene.

        Args:
            file: the MJCF (or URDF) file, resolved; a ``.ttt``'s conversion.
            label: the path as the client gave it, quoted, for messages.
            dt: the step (s), None: the scene's saved step.
            root: the client's folder for a client's file (bounds checked, a bounded World);
                None for a server-side file.
            step: the live scene's step (s), which a client's file is measured against
                (``scene_guard.check_spec``), read on the simulation thread.
            warm: compile the edits' spec once (off the simulation thread only): its meshes
                and textures, read into memory under names of their own, are then in MuJoCo's
                cache for the first edit, which otherwise compiles them afresh on the
                simulation thread (a dummy created after loading 100 shapes on one
                190,000-triangle mesh: 1.96 s, 0.30 s warmed).

        Raises:
            RemoteError: ``cannot load scene <label>: ...`` (MuJoCo's message, or the bound
                the file exceeds).
        """
        spec = None
        try:
            if root is not None:  # a client's scene: measured before MuJoCo parses and compiles it
                spec = self._client_spec(file, f"scene {label}", step, root)
            name = ttt_cache.origin(file).name if file.name != ttt_cache.origin(file).name else None
            world = World(file, dt, bounded=spec is not None, name=name)  # a client's scene: bounded
            blocks = custom_data.load(world)
        except (ValueError, RemoteError) as exc:
            raise self._load_error(exc, file, label) from None
        editing = None
        try:
            # (MuJoCo's warnings go to physics.SINK, as the World's: _quiet_mujoco swaps the
            # process-wide handler, which only the simulation thread may do)
            if spec is None:
                spec = load_spec(world.scene_path)
            spec.assets = {**(spec.assets or {}), **_embed_assets(spec, self._asset_counter)}
            # the world's model is the file's, compiled: its poses are the edits' baseline
            editing = (spec, _poses(world.model), kept_state.snapshot(world.model))
        except ValueError as exc:
            log.warning("scene %s cannot be edited: %s", label, _one_line(exc))
        if warm and editing is not None and (spec.meshes or spec.textures):
            try:  # edits compile the spec's in-memory files: their first compile, here (GIL released)
                spec.copy().compile()
            except Exception as exc:  # an edit's compile says what is wrong
                log.debug("warming MuJoCo's cache with scene %s: %s", label, exc)
        return PreparedScene(file, label, world, blocks, editing)

    def _load_error(self, exc: Exception, file: Path, label: str) -> RemoteError:
        text = self._scrub(_one_line(exc))
        text = text.removeprefix(f"cannot load scene {self.public(file)}: ")  # World's own prefix
        return RemoteError(f"cannot load scene {label}: {text}")

    def _swap_scene(self, prepared: PreparedScene) -> None:
        """Make ``prepared`` (:meth:`prepare_scene`) the scene, on the simulation thread: its
        scripts (customization scripts begin, the old scene's end), custom data, vision
        sensors (the render thread's renderers handed over), a fresh selection and sensor state.

        Raises:
            RemoteError: a script of the scene cannot be loaded; nothing changed then.
        """
        sim, file, world = self.sim, prepared.file, prepared.world
        old = sim.scripts
        # A scene in a transfer folder (any server's) brings no code, unless --allow-remote-code.
        untrusted = guard.transfer_folders(self.files_dir, *([file.parent] if guard.is_transferred(file) else []))
        try:
            scripts = Scripts(world, sim.signals, allow_remote_code=old.allow_remote_code,
                              allow_unsafe_lua=old.allow_unsafe_lua, untrusted=untrusted, simulation=sim,
                              allow_python_scripts=old.allow_python_scripts)
        except (ValueError, RemoteError) as exc:
            raise self._load_error(exc, file, prepared.label) from None
        old.close()  # the old scene's customization scripts end, the new one's begin
        sim.world, sim.scripts = world, scripts
        self.files.scene_installed(file)  # a client's folder that holds it stays while it is loaded
        custom_data.install(sim, prepared.blocks)
        scripts.open()
        refresh_vision(sim)
        sim.sensors = type(sim.sensors)()  # per-scene sensor state (probes, passive images) starts afresh
        self._spec = self._spec_world = self._baseline = self._baseline_state = None
        if prepared.editing is not None:
            self._spec, self._baseline, self._baseline_state = prepared.editing
            self._spec_world = world
        sim.selection = []
        log.info("scene %s loaded: %d objects", prepared.label, len(world.objects))


class PreparedScene(NamedTuple):
    """A loaded scene not yet live (:meth:`Editor.prepare_scene`): made on any thread, handed
    to the simulation thread once (:meth:`Editor._swap_scene`), never shared before."""

    file: Path  #: the MJCF file loaded
    label: str  #: the path the client gave, quoted
    world: World  #: the new world (model, data, objects)
    blocks: dict[int, dict[str, bytes]]  #: its custom data (custom_data.load)
    editing: tuple | None  #: (spec, poses, kept state) for edits; None: the scene cannot be edited
