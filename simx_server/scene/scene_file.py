"""The files of a saved scene (``sim.saveScene``, ``PyRep.export_scene``): the MJCF of the scene
as it is now and every file it names, so that the saved scene loads back with the same objects,
names, poses, meshes, scripts and ``simx:`` settings.

CoppeliaSim's XML export writes the scene's meshes as files of their own next to it, named
after it (``CFileOperations::saveScene``: ``<stem>_...``); so does this: ``<stem>_<asset>`` for
the meshes, textures, height fields and skins the live spec holds in memory, and
``<stem>_<object>_child.lua`` (``_customization``, ``_parameters.json``, ``_custom.json``,
``_path.json``) for each object's scripts, script parameters, custom data blocks and old path,
which the ``simx:`` settings then name (docs/SCRIPTS.md). What is saved is the scene now: the
objects where they are (a body at its current pose relative to its parent, a joint's current
position its reference, ``ref``, so that the scene reopens in this configuration, as a
CoppeliaSim scene saves its joints' positions), the scripts and data that models brought and
scripts wrote.

MuJoCo's ``MjSpec.to_xml`` alone loses part of a spec made by edits: a model attached under an
empty prefix leaves its default class nameless (an empty nested ``<default>``, which MuJoCo then
refuses) and the writer compares elements with the wrong class; the compiler's
``balanceinertia`` is not written. Here every default class of the saved copy takes the main
class's values (each element's own values are resolved already: the file writes them) and a name,
and ``balanceinertia`` is written (it changes only inertias that break A + B >= C, which could
not compile without it).
"""

from __future__ import annotations

import base64
import contextlib
import json
import re
import warnings
from typing import Callable

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.scene import kept_state
from simx_server.sim import kept_objects
from simx_server.sim.objects import parse_settings, without_scripts
from simx_server.sim.spec_tools import _compose, _inverse, _one_line, _quiet_mujoco, _set_local_pose, copy_attributes

# MjSpec.to_xml warns of every model attached with an empty prefix (simx attaches so: names kept),
# which the files here put right (see above); on the files' thread no catch_warnings (not
# thread-safe) can drop it, so it is dropped for good.
warnings.filterwarnings("ignore", message=".*empty prefix.*")

#: Settings that name a file of the scene's folder, written afresh for the saved scene.
_FILE_SETTINGS = ("custom_data", "path_data")
#: Default class members that hold an element kind's defaults.
_DEFAULT_KINDS = ("actuator", "camera", "equality", "flex", "geom", "joint", "light", "material", "mesh",
                  "pair", "site", "tendon", "texture")
_HINGE_SLIDE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name) or "object"


def scene_files(sim, stem: str) -> tuple[str, dict[str, bytes]]:
    """The saved scene: its MJCF text and the files it names (file name -> bytes, all in the
    folder of the MJCF file, whose name without ``.xml`` is ``stem``).

    Args:
        sim: the :class:`~simx_server.scene.simulation.Simulation` (its editor's live spec, its
            world, scripts and custom data).
        stem: the saved file's name without its extension (the files' prefix).

    Returns:
        ``(xml_text, files)``.

    Raises:
        UnsupportedError: MuJoCo cannot write the scene, or a script's file can no longer be read.
    """
    files, text = prepare(sim, stem)
    with _quiet_mujoco():
        return text(), files


def prepare(sim, stem: str) -> tuple[dict[str, bytes], Callable[[], str]]:
    """:func:`scene_files` in two parts: what reads the scene, now (a copy of its spec placed as
    the scene is, the files it names), and its MJCF text, a function that reads only that copy:
    any thread may call it (``MjSpec.to_xml`` compiles the copy; the files' thread does for a
    client, ``sim.saveScene``).

    Returns:
        ``(files, text)``: file name -> bytes, and the function that makes the MJCF text.

    Raises:
        UnsupportedError: a script's file can no longer be read; ``text()``: MuJoCo cannot
            write the scene.
    """
    world = sim.world
    prefix = _safe(stem) + "_"
    with _quiet_mujoco():
        live = sim.editor._live_spec()
        spec = live.copy()
        files: dict[str, bytes] = {}
        _place_as_now(sim.editor, spec, world)
        kept_state.write(spec, kept_state.changes(world.model, sim.editor._baseline_state))
        _assets(spec, live, prefix, files)
        _settings(sim, spec, prefix, files)
        _flatten_defaults(spec)
    return files, lambda: mjcf_text(spec)


def prepare_model(sim, body: str, stem: str) -> tuple[dict[str, bytes], Callable[[], str]]:
    """A model's files (``sim.saveModel``), as :func:`prepare`'s: the body subtree of shape
    ``body`` in an MJCF of its own, and the files its meshes and textures hold in memory
    (``<stem>_<asset>``, as a saved scene's), its text made by ``text()`` on any thread.

    Raises:
        ArgumentError: no such body in the scene's spec.
        UnsupportedError: MuJoCo cannot make the model; ``text()``: MuJoCo cannot write it.
    """
    with _quiet_mujoco():
        # a copy: attaching the live spec's body would tie the scene's spec to the model's
        # (every later saveScene and edit then failed: "attached by reference to a parent spec")
        live = sim.editor._live_spec()
        spec = live.copy()
        found = spec.body(body)
        if found is None:
            raise ArgumentError(f"{body!r} is not a shape (a body) to save as a model")
        model = mujoco.MjSpec()
        model.assets = dict(spec.assets or {})
        try:
            model.worldbody.add_frame().attach_body(found, "", "")
        except ValueError as exc:
            raise UnsupportedError(f"MuJoCo cannot write this model as MJCF: {_one_line(exc)}") from None
        files: dict[str, bytes] = {}
        _assets(model, live, _safe(stem) + "_", files)
    return files, lambda: mjcf_text(model)


def mjcf_text(spec: mujoco.MjSpec) -> str:
    """``spec``'s MJCF (``MjSpec.to_xml``) with what MuJoCo's writer loses put back (the default
    classes' names, ``balanceinertia``: see the module's text).

    Raises:
        UnsupportedError: MuJoCo cannot write it.
    """
    try:  # MuJoCo's warnings go to the process's handler (simx's log): set by one thread only
        text = spec.to_xml()
    except ValueError as exc:
        raise UnsupportedError(f"MuJoCo cannot write this scene as MJCF: {_one_line(exc)}") from None
    text = _name_defaults(text)
    if "balanceinertia" not in text:
        text = re.sub(r"<compiler\b", '<compiler balanceinertia="true"', text, count=1)
        if "balanceinertia" not in text:
            text = re.sub(r"(<mujoco\b[^>]*>)", r'\1\n  <compiler balanceinertia="true"/>', text, count=1)
    return text


# ------------------------------------------------------------------------------------ poses
def _place_as_now(editor, spec: mujoco.MjSpec, world) -> None:
    """Each body of ``spec`` where it is now relative to its parent (its hinge and slide joints'
    positions now their references), and each site, camera and light where the live model has
    it (commands place them there: ``World.set_pose``)."""
    m, d = world.model, world.data
    base = editor._baseline
    if base is None or any(getattr(m, f).shape != base[f].shape for f in base):
        return  # not the model this spec compiled to: its poses cannot be matched
    mujoco.mj_kinematics(m, d)
    for body in spec.bodies:
        if not body.name or body.name == "world":
            continue
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body.name)
        if i <= 0:
            continue
        p = int(m.body_parentid[i])
        here = _compose(_inverse((d.xpos[p], d.xquat[p])), (d.xpos[i], d.xquat[i]))
        _set_local_pose(spec, body, here, (base["body_pos"][i], base["body_quat"][i]))
        for j in range(m.body_jntadr[i], m.body_jntadr[i] + m.body_jntnum[i]):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            el = spec.joint(name) if name else None
            if el is not None and int(m.jnt_type[j]) in _HINGE_SLIDE:
                q = float(d.qpos[m.jnt_qposadr[j]])
                own = getattr(el, "compiler", None) or spec.compiler  # a model attached in degrees keeps them
                el.ref = float(np.degrees(q)) if int(m.jnt_type[j]) == _HINGE_SLIDE[0] and own.degree else q
    for kind, obj, fpos, frot in (("site", mujoco.mjtObj.mjOBJ_SITE, "site_pos", "site_quat"),
                                  ("camera", mujoco.mjtObj.mjOBJ_CAMERA, "cam_pos", "cam_quat")):
        for el in getattr(spec, kind + "s"):
            i = mujoco.mj_name2id(m, obj, el.name) if el.name else -1
            if i < 0:
                continue
            pos, rot = getattr(m, fpos)[i], getattr(m, frot)[i]
            if np.any(pos != base[fpos][i]) or np.any(rot != base[frot][i]):
                _set_local_pose(spec, el, (pos.copy(), rot.copy()), (base[fpos][i], base[frot][i]))
    for el in spec.lights:
        i = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_LIGHT, el.name) if el.name else -1
        if i >= 0 and el.frame is None and (np.any(m.light_pos[i] != base["light_pos"][i])
                                            or np.any(m.light_dir[i] != base["light_dir"][i])):
            el.pos, el.dir = m.light_pos[i].copy(), m.light_dir[i].copy()


# ----------------------------------------------------------------------------------- assets
def _assets(spec: mujoco.MjSpec, live: mujoco.MjSpec, prefix: str, files: dict[str, bytes]) -> None:
    """The files the spec's meshes, textures, height fields and skins hold in memory, written as
    ``<prefix><name>`` next to the scene (the compiler's folders then the scene's own)."""
    held = dict(live.assets or {})
    spec.compiler.meshdir = ""
    spec.compiler.texturedir = ""
    names: dict[str, str] = {}
    for lst in ("meshes", "textures", "hfields", "skins"):
        for el in getattr(spec, lst):
            key = getattr(el, "file", "")
            if not key or key not in held:
                continue
            if key not in names:
                names[key] = prefix + _safe(key)
                files[names[key]] = bytes(held[key])
            el.file = names[key]
            own = getattr(el, "compiler", None)  # an attached model's elements keep its folders
            if own is not None:
                with contextlib.suppress(Exception):
                    own.meshdir, own.texturedir = "", ""
    spec.assets = dict(files)  # to_xml compiles the spec: it finds them under their new names


# --------------------------------------------------------------------------------- settings
def _settings(sim, spec: mujoco.MjSpec, prefix: str, files: dict[str, bytes]) -> None:
    """Each object's ``simx:`` settings with its scripts, script parameters, custom data blocks
    and old path as files of the saved scene (whatever folder they were read from, or brought
    by a loaded model, or written by scripts since)."""
    world = sim.world
    items: dict[str, list[str]] = {}
    for text in list(spec.texts):
        if not text.name.startswith("simx:") or text.name.startswith("simx:scene"):
            continue
        try:
            parse_settings(text.data)
        except ValueError:
            continue
        kept = [i for i in without_scripts(text.data).split() if i.partition("=")[0] not in _FILE_SETTINGS]
        items[text.name[5:]] = kept
    scripts = sim.scripts
    for table in (scripts.scripts, scripts.customization):
        for handle, script in table.items():
            obj = world.objects.get(handle)
            if obj is None:
                continue
            try:
                source = script.path.read_bytes()
            except OSError as exc:
                raise UnsupportedError(f"the {script.kind} script of {obj.name!r} cannot be saved: its file "
                                       f"cannot be read ({exc.strerror})") from None
            stem = prefix + _safe(obj.name) + "_" + script.kind
            file = stem + (script.path.suffix or ".lua")
            files[file] = source
            mine = items.setdefault(obj.name, [])
            mine.append(f"{script.kind}_script={file}")
            if script.kind == "child" and script.threaded:
                mine.append("threaded=1")
            if script.disabled:
                mine.append("script_disabled=1")
            if script.version is not None:
                mine.append(f"vrep_version={int(script.version)}")
            if script.timeout != scripts.timeout:
                mine.append(f"script_timeout={script.timeout!r}")
            if script.parameters:
                pfile = stem + "_parameters.json"
                files[pfile] = json.dumps([_parameter(p) for p in script.parameters], indent=1).encode()
                mine.append(f"script_parameters={pfile}")
    for handle, blocks in (getattr(sim, "custom_data", None) or {}).items():
        obj = world.objects.get(handle)
        if obj is None or not blocks:
            continue
        file = prefix + _safe(obj.name) + "_custom.json"
        files[file] = json.dumps({tag: base64.b64encode(bytes(v)).decode("ascii") for tag, v in blocks.items()},
                                 indent=1).encode()
        items.setdefault(obj.name, []).append(f"custom_data={file}")
    kept = getattr(world, "_kept_objects", None)
    for handle, path in (kept.paths.items() if kept is not None else ()):
        obj = world.objects.get(handle)
        if obj is None:
            continue
        file = prefix + _safe(obj.name) + "_path.json"
        files[file] = json.dumps(_path_data(path)).encode()
        items.setdefault(obj.name, []).append(f"path_data={file}")
    if kept is None:  # never asked for: the paths are the settings' files, read now
        for obj in world.objects.values():
            if obj.settings.get("path_data"):
                file = prefix + _safe(obj.name) + "_path.json"
                files[file] = json.dumps(_path_data(kept_objects._load_path(world, obj))).encode()
                items.setdefault(obj.name, []).append(f"path_data={file}")
    _properties(world, items)
    _sensors(sim, spec, items)
    for text in list(spec.texts):
        if text.name.startswith("simx:") and text.name[5:] in items:
            spec.delete(text)
    for name, values in items.items():
        if values:
            spec.add_text(name=f"simx:{name}", data=" ".join(values))


def _properties(world, items: dict[str, list[str]]) -> None:
    """The special and model property bits set at run time (``sim.setObjectSpecialProperty``,
    ``sim.setModelProperty``; a new pure shape's cleared ones) as the ``special=`` and
    ``model_property=`` settings the scene is read with (:mod:`simx_server.sim.properties`), as
    CoppeliaSim saves each object's ``Omp`` and ``Mpo`` records."""
    props = world.properties
    for store, key in ((props.special, "special"), (props.model, "model_property")):
        for handle, bits in store.items():
            obj = world.objects.get(handle)
            if obj is not None:
                mine = [i for i in items.get(obj.name, []) if i.partition("=")[0] != key]
                items[obj.name] = [*mine, f"{key}={int(bits)}"]


#: A vision sensor's render modes as its ``render_mode=`` setting writes them.
_RENDER_MODES = {0: "opengl", 2: "handles", 7: "opengl3", 8: "opengl3_windowed"}


def _sensors(sim, spec: mujoco.MjSpec, items: dict[str, list[str]]) -> None:
    """Each vision sensor's properties as they are now (``sim.setObjectInt32Param`` & co. change
    them after the scene loaded: RLBench's mask cameras are made colour-coded so) in its
    settings, its resolution on its camera."""
    vision = getattr(sim, "vision", None)
    for handle, s in (getattr(vision, "specs", None) or {}).items():
        obj = sim.world.objects.get(handle)
        cam = spec.camera(obj.name) if obj is not None else None
        if cam is None:
            continue
        cam.resolution = [int(s.width), int(s.height)]
        now = {"near": repr(float(s.near)), "far": repr(float(s.far)),
               "render_mode": _RENDER_MODES.get(int(s.render_mode), "opengl"),
               "image": "depth" if s.depth_image else "rgb", "shadows": str(bool(s.shadows)).lower(),
               "reflections": str(bool(s.reflections)).lower(), "ignore_rgb": str(bool(s.ignore_rgb)).lower(),
               "ignore_depth": str(bool(s.ignore_depth)).lower(), "basic_stats": str(bool(s.basic_stats)).lower()}
        if s.background is not None:
            now["background"] = ",".join(repr(min(1.0, (c + 0.5) / 255.1)) for c in s.background)  # bytes kept
        mine = [i for i in items.get(obj.name, []) if i.partition("=")[0] not in now and i.partition("=")[0] != "background"]
        items[obj.name] = mine + [f"{k}={v}" for k, v in now.items()]


def _parameter(p: dict) -> dict:
    out = {k: v for k, v in p.items() if k != "value"}
    value = p.get("value", "")
    if isinstance(value, (bytes, bytearray)):
        out["value_base64"] = base64.b64encode(bytes(value)).decode("ascii")
    else:
        out["value"] = value
    return out


def _path_data(path) -> dict:
    return {"points": np.asarray(path.points, float).tolist(), "attributes": int(path.attributes),
            "length_method": int(path.length_method), "angle_coeff": float(path.angle_coeff),
            "on_spot_coeff": float(path.on_spot_coeff), "position": float(path.position)}


# --------------------------------------------------------------------------------- defaults
def _name_defaults(text: str) -> str:
    """A name for each nested ``<default>`` that MuJoCo's writer left without one (an attached
    model's class that no element of the scene uses any more): MuJoCo refuses it."""
    taken = set(re.findall(r'<default class="([^"]*)"', text))
    count = [0]

    def named(match: re.Match) -> str:
        count[0] += 1
        if count[0] == 1:  # the top-level <default>: the main class
            return match.group(0)
        n = count[0]
        while f"simx_default_{n}" in taken:
            n += 1
        taken.add(f"simx_default_{n}")
        return f'<default class="simx_default_{n}"{match.group(1)}>'

    return re.sub(r"<default(/?)>", named, text)


def _flatten_defaults(spec: mujoco.MjSpec) -> None:
    """Give every default class but the main one the main class's values and a name (an
    attached model's class is nameless: MuJoCo refuses the empty ``<default>`` it writes).
    Elements keep their own values, which the file writes where they differ from the main
    class's."""
    main = spec.default
    seen: dict[int, object] = {}
    for lst in ("bodies", "joints", "geoms", "sites", "cameras", "lights", "materials", "textures", "meshes",
                "actuators", "tendons", "equalities", "pairs", "hfields", "skins", "flexes"):
        for el in getattr(spec, lst, ()):
            cls = getattr(el, "classname", None)
            if cls is not None and not isinstance(cls, str):
                seen.setdefault(id(cls), cls)
            child = getattr(el, "childclass", None)
            if child is not None and not isinstance(child, str) and child is not None:
                seen.setdefault(id(child), child)
    marker, own_name = "simx-main-default", main.name
    main.name = marker  # the main class itself, whatever wrapper reaches it
    n = 0
    for cls in seen.values():
        if cls.name == marker:
            continue
        for kind in _DEFAULT_KINDS:
            src, dst = getattr(main, kind, None), getattr(cls, kind, None)
            if src is None or dst is None:
                continue
            copy_attributes(src, dst)
        if not cls.name or cls.name == own_name:  # an attached model's main class
            n += 1
            while spec.find_default(f"simx_default_{n}") is not None:
                n += 1
            cls.name = f"simx_default_{n}"
    main.name = own_name
