"""MjSpec tools of scene editing (:mod:`simx_server.scene.editor`): pose maths, names and V-REP's
copy suffixes, element references and ``simx:`` settings, cloning and placing elements,
MuJoCo's warnings while editing, assets read into memory.

These work on a ``mujoco.MjSpec`` (or a compiled model) alone, never on the live scene.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import struct
import warnings
from pathlib import Path

import mujoco
import numpy as np

from simx_server.sim.objects import without_scripts
from simx_server.sim.world import JOINT, LIGHT, SHAPE, VISION_SENSOR, World
from simx_server.sim.objects import SITES
from simx_wire.protocol import UnsupportedError

log = logging.getLogger("simx.editing")  # the editor's log: MuJoCo's warnings while editing


#: Spec element lists: tree elements, assets, the rest.
_TREE_LISTS = ("bodies", "joints", "geoms", "sites", "cameras", "lights", "frames")
_ASSET_LISTS = ("materials", "textures", "meshes", "hfields", "skins")
_OTHER_LISTS = ("actuators", "sensors", "equalities", "tendons", "excludes", "pairs", "texts",
                "numerics", "tuples", "keys", "flexes")
_ALL_LISTS = _TREE_LISTS + _ASSET_LISTS + _OTHER_LISTS
#: Lists whose length an element move must not change (a lost reference is a lost element).
_REFERRING_LISTS = ("actuators", "sensors", "equalities", "tendons", "excludes", "pairs", "texts")
#: V-REP object type -> spec list / accessor of the element behind it.
_KIND = {SHAPE: "body", JOINT: "joint", VISION_SENSOR: "camera", LIGHT: "light", **dict.fromkeys(SITES, "site")}
_MJ_OBJ = {"body": mujoco.mjtObj.mjOBJ_BODY, "joint": mujoco.mjtObj.mjOBJ_JOINT,
           "site": mujoco.mjtObj.mjOBJ_SITE, "camera": mujoco.mjtObj.mjOBJ_CAMERA,
           "light": mujoco.mjtObj.mjOBJ_LIGHT}
#: Element kind -> model fields of its placement in its body and of that body.
_FRAMES = {"body": ("body_pos", "body_quat", "body_parentid"), "site": ("site_pos", "site_quat", "site_bodyid"),
           "camera": ("cam_pos", "cam_quat", "cam_bodyid"), "light": ("light_pos", "light_dir", "light_bodyid")}
#: Temporary name suffix while an element is moved (removed before compiling).
_MARK = "@simx-moving"
#: Attributes never copied when an element is cloned attribute by attribute.
_CLONE_SKIP = {"id", "name", "signature", "info", "parent", "frame", "classname", "compiler", "alt"}
_QUAT = mujoco.mjtOrientation.mjORIENTATION_QUAT


# --------------------------------------------------------------------------- poses
def _qmul(a, b) -> np.ndarray:
    out = np.empty(4)
    mujoco.mju_mulQuat(out, np.asarray(a, float), np.asarray(b, float))
    return out


def _qinv(q) -> np.ndarray:
    out = np.empty(4)
    mujoco.mju_negQuat(out, np.asarray(q, float))
    return out


def _rotate(q, v) -> np.ndarray:
    out = np.empty(3)
    mujoco.mju_rotVecQuat(out, np.asarray(v, float), np.asarray(q, float))
    return out


def _compose(a: tuple, b: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Pose ``a * b`` (poses are ``(pos, quat)``)."""
    return a[0] + _rotate(a[1], b[0]), _qmul(a[1], b[1])


def _inverse(a: tuple) -> tuple[np.ndarray, np.ndarray]:
    qi = _qinv(a[1])
    return -_rotate(qi, a[0]), qi


def _body_world(world: World, body: int) -> tuple[np.ndarray, np.ndarray]:
    d = world.data
    return d.xpos[body].copy(), d.xquat[body].copy()


# --------------------------------------------------------------------------- spec helpers
def _elements(spec: mujoco.MjSpec, lists=_ALL_LISTS):
    for name in lists:
        yield from getattr(spec, name)


def _names(spec: mujoco.MjSpec, lists=_ALL_LISTS) -> set[str]:
    return {e.name for e in _elements(spec, lists) if getattr(e, "name", "")} - {"world"}


def _object_names(spec: mujoco.MjSpec) -> set[str]:
    return _names(spec, ("bodies", "joints", "sites", "cameras", "lights"))


def _subtree_names(body) -> set[str]:
    names = {body.name} if body.name else set()
    for t in (mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_JOINT, mujoco.mjtObj.mjOBJ_GEOM,
              mujoco.mjtObj.mjOBJ_SITE, mujoco.mjtObj.mjOBJ_CAMERA, mujoco.mjtObj.mjOBJ_LIGHT,
              mujoco.mjtObj.mjOBJ_FRAME):
        names.update(e.name for e in body.find_all(t) if e.name)
    return names


def _subtree_objects(body) -> list[str]:
    """Names of the V-REP objects in a body subtree (bodies, joints, sites, cameras, lights)."""
    out = [body.name] if body.name else []
    for t in (mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_JOINT, mujoco.mjtObj.mjOBJ_SITE,
              mujoco.mjtObj.mjOBJ_CAMERA, mujoco.mjtObj.mjOBJ_LIGHT):
        out.extend(e.name for e in body.find_all(t) if e.name and e.name != body.name)
    return out


def vrep_suffix(incoming: set[str], taken: set[str], trigger: set[str] | None = None) -> str:
    """V-REP's copy suffix: ``""`` when no incoming name (or no ``trigger`` name) is taken, else
    the first ``#n`` that makes every incoming name free.

    Args:
        incoming: names of the objects being added.
        taken: names already in the scene.
        trigger: the names whose clash calls for a suffix (default: ``incoming``).

    Returns:
        ``""`` or ``"#n"``.
    """
    if not (incoming if trigger is None else trigger) & taken:
        return ""
    n = 0
    while any(f"{x}#{n}" in taken for x in incoming):
        n += 1
    return f"#{n}"


def _free_name(base: str, taken: set[str]) -> str:
    """``base`` if free, else ``base#0``, ``base#1``, ..."""
    return base + vrep_suffix({base}, taken)


def _strip_mark(spec: mujoco.MjSpec, mark: str = _MARK) -> None:
    """Remove ``mark`` from every name and name reference that ends with it."""
    cache: dict[type, list[str]] = {}
    for e in _elements(spec):
        attrs = cache.get(type(e))
        if attrs is None:
            attrs = []
            for a in dir(e):
                if a.startswith("_"):
                    continue
                try:
                    v = getattr(e, a)
                except Exception:  # write-only properties
                    continue
                if isinstance(v, str) or (isinstance(v, list) and v and all(isinstance(x, str) for x in v)):
                    attrs.append(a)
            cache[type(e)] = attrs
        for a in attrs:
            v = getattr(e, a)
            if isinstance(v, str):
                if v.endswith(mark):
                    setattr(e, a, v[: -len(mark)])
            elif any(x.endswith(mark) for x in v):
                setattr(e, a, [x[: -len(mark)] if x.endswith(mark) else x for x in v])


def _delete_references(spec: mujoco.MjSpec, kind: str, name: str) -> None:
    """Delete the actuators, sensors and constraints that refer to a joint, site or camera
    (``MjSpec.delete`` does that for bodies, not for single elements)."""
    obj = _MJ_OBJ[kind]
    trn = {"joint": (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT),
           "site": (mujoco.mjtTrn.mjTRN_SITE, mujoco.mjtTrn.mjTRN_SLIDERCRANK)}.get(kind, ())
    doomed = []
    for a in spec.actuators:
        if (a.trntype in trn and a.target == name) or (kind == "site" and name in (a.refsite, a.slidersite)):
            doomed.append(a)
    for s in spec.sensors:
        if (s.objtype == obj and s.objname == name) or (s.reftype == obj and s.refname == name):
            doomed.append(s)
    for eq in spec.equalities:
        if name in (eq.name1, eq.name2) and (
                (kind == "joint" and eq.type == mujoco.mjtEq.mjEQ_JOINT)
                or (kind == "site" and eq.objtype == mujoco.mjtObj.mjOBJ_SITE)):
            doomed.append(eq)
    for e in doomed:
        spec.delete(e)


def _delete_settings(spec: mujoco.MjSpec, names) -> None:
    for n in names:
        t = spec.text(f"simx:{n}")
        if t is not None:
            spec.delete(t)


def _copy_settings(spec: mujoco.MjSpec, mapping: dict[str, str]) -> None:
    """Give copies the ``simx:`` settings of their originals (without child scripts)."""
    for old, new in mapping.items():
        t = spec.text(f"simx:{old}")
        if t is None:
            continue
        rest = without_scripts(t.data)
        if rest:
            spec.add_text(name=f"simx:{new}", data=rest)


def _own_pose(spec: mujoco.MjSpec, el) -> tuple[np.ndarray, np.ndarray]:
    """An element's own pose attributes (pos, orientation) as (pos, quat)."""
    if el.alt.type == _QUAT:
        q = np.asarray(el.quat, float)
    else:
        c = el.compiler if getattr(el, "compiler", None) is not None else spec.compiler
        q = np.asarray(spec.resolve_orientation(c.degree, c.eulerseq, el.alt), float)
    return np.asarray(el.pos, float), q / np.linalg.norm(q)


def _set_local_pose(spec, el, desired: tuple, current: tuple) -> None:
    """Make the compiled pose of ``el`` relative to its body ``desired``.

    ``current`` is its compiled pose now; the difference to its own attributes is the frame
    it sits in (``<frame>`` elements), which stays.
    """
    if el.frame is not None:
        frame = _compose(current, _inverse(_own_pose(spec, el)))
        desired = _compose(_inverse(frame), desired)
    el.pos = desired[0]
    el.quat = desired[1] / np.linalg.norm(desired[1])
    el.alt.type = _QUAT


def _clone(kind: str, src, body, name: str):
    """A copy of a site, camera or light, attribute by attribute, in ``body``."""
    add = {"site": body.add_site, "camera": body.add_camera, "light": body.add_light}[kind]
    dst = add(default=src.classname)
    copy_attributes(src, dst)
    dst.name = name
    return dst


def copy_attributes(src, dst) -> None:
    """Every plain attribute of the ``MjSpec`` element (or default's element) ``src`` onto
    ``dst``: not its identity (name, id, class, parent, frame) nor what is read-only or derived.

    Args:
        src: the element copied from.
        dst: an element of the same kind, changed in place.
    """
    for a in dir(src):
        if a.startswith("_") or a in _CLONE_SKIP:
            continue
        value = getattr(src, a)
        if callable(value):
            continue
        with contextlib.suppress(Exception):  # read-only or derived attributes
            setattr(dst, a, value)


@contextlib.contextmanager
def _quiet_mujoco():
    """Route MuJoCo's warnings to the log while editing (not to stdout and MUJOCO_LOG.TXT).

    Attaching with an empty prefix (names kept as they are) always warns that the spec may
    not save back to XML; simx never saves it, so that warning is dropped. A loaded model whose
    options (integrator, cone, clipping planes ...) differ from the scene's takes the scene's, as
    a model loaded into a V-REP scene does: MuJoCo's "attach conflict" warnings say so for every
    converted ``.ttm``, and go to the debug log.
    """
    previous = mujoco.get_mju_user_warning()

    def handler(message: str) -> None:
        if "Attach conflict" in message:
            log.debug("MuJoCo: %s", message.strip())
        elif "empty prefix" not in message:
            log.warning("MuJoCo: %s", message.strip())

    mujoco.set_mju_user_warning(handler)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*empty prefix.*")
            warnings.filterwarnings("ignore", message=".*without asset dict.*")
            warnings.filterwarnings("ignore", message="(?s).*Attach conflict.*")
            yield
    finally:
        mujoco.set_mju_user_warning(previous)


def _embed_assets(spec: mujoco.MjSpec, counter: list[int]) -> dict[str, bytes]:
    """Read the files a spec's meshes, height fields, skins and textures name, and point those
    elements at in-memory copies: later compiles need no file (a transferred model may be
    erased right after loading). Returns the new ``spec.assets`` entries; files that cannot
    be read are left to the compiler to report."""
    out = {}
    root = Path(spec.modelfiledir or ".")
    for lst, folder in (("meshes", spec.meshdir), ("hfields", spec.meshdir), ("skins", spec.meshdir),
                        ("textures", spec.texturedir)):
        for el in getattr(spec, lst):
            name = getattr(el, "file", "")
            if not name:
                continue
            path = Path(name)
            if not path.is_absolute():
                path = root / (folder or "") / path
            try:
                data = path.read_bytes()
            except OSError:
                continue
            counter[0] += 1
            key = f"simx-asset-{counter[0]}-{path.name}"
            out[key] = data
            el.file = key
    return out


def _one_line(exc: Exception) -> str:
    return "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())


def _poses(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    return {f: getattr(model, f).copy() for fields in _FRAMES.values() for f in fields[:2]}


def _rename_assets(child: mujoco.MjSpec, taken: set[str]) -> None:
    """Rename a model's assets whose names are taken in the scene, and their references."""
    refs = {"materials": ("material",), "textures": ("texture",), "meshes": ("meshname",),
            "hfields": ("hfieldname",), "skins": ()}
    for lst, attrs in refs.items():
        for asset in getattr(child, lst):
            old = asset.name
            if not old or old not in taken:
                continue
            new = _free_name(old, taken | _names(child))
            asset.name = new
            for e in _elements(child, _TREE_LISTS + _ASSET_LISTS + _OTHER_LISTS):
                for a in attrs:
                    if getattr(e, a, None) == old:
                        setattr(e, a, new)
                if lst == "textures" and isinstance(e, mujoco.MjsMaterial):
                    tex = list(e.textures)
                    if old in tex:
                        e.textures = [new if t == old else t for t in tex]


#: How far behind a flat mesh its back face lies (m): a volume MuJoCo can compile.
FLAT_MESH_BACK = 1e-4


def solid_mesh(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and faces MuJoCo can compile for a mesh that CoppeliaSim takes as it is: a flat
    mesh (a wall, a floor tile, one triangle: MuJoCo needs four vertices not in one plane for
    its convex hull) gets a back face FLAT_MESH_BACK behind it, the same triangles reversed, so
    that it has a volume; points on a line give None.

    Args:
        vertices: (n, 3) m, n >= 3.
        faces: (t, 3) vertex indices.

    Returns:
        ``(vertices, faces)``, the flat mesh's doubled, or None.
    """
    v, f = np.asarray(vertices, float), np.asarray(faces)
    if len(v) < 3 or len(f) < 1 or not np.all(np.isfinite(v)):
        return None
    centred = v - v.mean(axis=0)
    scale = max(1e-9, float(np.abs(centred).max()))
    _, sv, vt = np.linalg.svd(centred, full_matrices=False)
    if sv[1] <= 1e-7 * scale:  # all on a line
        return None
    if len(sv) > 2 and sv[-1] > 1e-7 * scale:
        return v, f
    normal = vt[-1] if len(vt) > 2 else np.cross(vt[0], vt[1])
    return np.vstack([v, v - FLAT_MESH_BACK * normal]), np.vstack([f, f[:, ::-1] + len(v)])


def set_mesh_data(spec: mujoco.MjSpec, mesh: mujoco.MjsMesh, vertices: np.ndarray, faces: np.ndarray) -> None:
    """Give ``mesh`` these vertices and triangles as an in-memory MuJoCo binary mesh file
    (``.msh``: four int32 counts, float32 vertices, int32 faces; ``spec.assets``, named after its
    content), not as ``uservert``/``userface``: MuJoCo's mesh cache keeps a processed file mesh,
    so each later compile of the scene (every edit) finds it there (a 200,000-triangle mesh: 0.1
    s instead of 1.9 s of each compile), and ``MjSpec.to_xml`` (``sim.saveScene``) writes a file
    name instead of formatting the numbers with the interpreter held. The compiled mesh is the
    same: ``uservert`` is float32 too.

    Args:
        spec: the spec that holds ``mesh``.
        mesh: its mesh element.
        vertices: (n, 3) m.
        faces: (t, 3) vertex indices.
    """
    v = np.ascontiguousarray(vertices, dtype="<f4").reshape(-1, 3)
    f = np.ascontiguousarray(faces, dtype="<i4").reshape(-1, 3)
    data = struct.pack("<4i", len(v), 0, 0, len(f)) + v.tobytes() + f.tobytes()
    key = f"simx-mesh-{hashlib.blake2b(data, digest_size=12).hexdigest()}.msh"
    if key not in (spec.assets or {}):
        spec.assets = {**(spec.assets or {}), key: data}
    mesh.file = key


def set_setting(spec: mujoco.MjSpec, name: str, key: str, value: str | None) -> None:
    """Set ``key=value`` in the ``simx:NAME`` settings text of the spec (None: remove the key).

    Args:
        spec: the scene's spec.
        name: the object's name.
        key: the setting (``vrep_parent``, ...).
        value: its value, or None to remove it.
    """
    t = spec.text(f"simx:{name}")
    items = [i for i in (t.data.split() if t is not None else []) if i.partition("=")[0] != key]
    if value is not None:
        items.append(f"{key}={value}")
    if t is None and items:
        spec.add_text(name=f"simx:{name}", data=" ".join(items))
    elif t is not None and items:
        t.data = " ".join(items)
    elif t is not None:
        spec.delete(t)


def free_at_root(spec: mujoco.MjSpec, name: str, pose: tuple, vrep_parent: str) -> mujoco.MjsBody:
    """Move body ``name`` (with its subtree) from where it hangs to the world's root with a free
    joint, at ``pose``, keeping V-REP's parent in its ``vrep_parent=`` setting: how V-REP
    simulates a dynamic shape that no joint or force sensor links to its parent (a free body).

    Args:
        spec: the scene's spec.
        name: the body's name.
        pose: (pos (3,), quat (4,)) in the world, m.
        vrep_parent: the name of its parent in V-REP's tree (``-1``: the world).

    Returns:
        The moved body.

    Raises:
        UnsupportedError: the move would lose actuators, sensors, equalities... that refer to
            elements of the subtree.
    """
    counts = {n: len(getattr(spec, n)) for n in _REFERRING_LISTS}
    body = spec.body(name)
    moved = spec.worldbody.add_frame().attach_body(body, "", _MARK)
    spec.delete(body)
    _strip_mark(spec)
    lost = [n for n in _REFERRING_LISTS if len(getattr(spec, n)) < counts[n]]
    if lost:
        raise UnsupportedError(f"freeing {name!r} from {vrep_parent!r} would lose {', '.join(lost)}")
    moved.pos, moved.quat = pose
    moved.alt.type = _QUAT
    moved.add_freejoint()
    set_setting(spec, name, "vrep_parent", vrep_parent)
    return moved
