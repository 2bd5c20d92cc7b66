"""A model's tree in V-REP's terms, on the scene's ``MjSpec``: the root object that a model load
returns (:func:`root_name`), the names its ``simx:`` settings give when the model's names get a
copy suffix (:func:`suffix_settings`), the objects of a model (:func:`simx_server.sim.objects.subtree`), and their removal
with the settings that name them and the assets that only they used (:func:`remove`).

V-REP's tree and MuJoCo's differ: a converted ``.ttm``'s root is often a dummy (a MuJoCo site),
and the shapes below it are bodies of the world whose ``vrep_parent=NAME`` settings hang them
from it (:func:`simx_server.sim.objects.apply_vrep_parents`). A model is what hangs below its
base in V-REP's tree, as CoppeliaSim's ``CSceneObjectContainer::addModelObjects`` gathers it
(``CSceneObject::getAllObjectsRecursive``) for ``simRemoveModel_internal``.
"""

from __future__ import annotations

import mujoco

from simx_server.sim import collisions, ik, scene_collections
from simx_server.sim.objects import SHAPE, SceneObject, parse_settings
from simx_server.sim.spec_tools import _KIND, _MJ_OBJ, _delete_references, _delete_settings, _object_names

_TOP_LISTS = ("bodies", "sites", "cameras", "lights")  # V-REP's handle order: bodies first
#: Elements that name assets: list -> the attributes that hold an asset's name, and that list.
_ASSET_REFS = {"geoms": (("meshname", "meshes"), ("hfieldname", "hfields"), ("material", "materials")),
               "sites": (("material", "materials"),), "tendons": (("material", "materials"),),
               "skins": (("material", "materials"),), "flexes": (("material", "materials"),)}
_ASSETS = ("meshes", "hfields", "materials", "textures")
_IK, _COLLECTION = "simx:" + ik.PREFIX, "simx:" + scene_collections.PREFIX
_MEASURES = tuple(collisions.PROBE_PREFIX.values())


def _ik_object_key(key: str) -> bool:
    """Whether an IK group's setting ``key`` names an object (``tip``, ``target2``, ``base``...)."""
    return key.rstrip("0123456789") in ("tip", "target", "base")


def _settings(spec: mujoco.MjSpec) -> dict[str, dict[str, str]]:
    """The ``simx:NAME`` settings of a spec's objects (texts that do not parse are left out:
    the compile with them says what is wrong)."""
    out = {}
    for t in spec.texts:
        if t.name.startswith("simx:"):
            try:
                out[t.name[5:]] = parse_settings(t.data)
            except ValueError:
                continue
    return out


def root_name(child: mujoco.MjSpec) -> tuple[str | None, bool]:
    """The root of a model (its spec, before it is attached): the model base that CoppeliaSim's
    ``simLoadModel`` returns (``CFileOperations::loadModel`` leaves it alone selected,
    ``removeFromSelectionAllExceptModelBase``; the API returns the last selected object).

    Of the model's top-level objects in V-REP's tree (elements of its world body whose
    ``vrep_parent=`` names none of its objects): the first with ``model_base=1`` (a ``.ttm``'s
    root), else the first (bodies before sites, cameras and lights, as handles are given).

    Args:
        child: the model's spec.

    Returns:
        ``(name, is_model_base)``; ``(None, False)`` when the model has no named top-level object.
    """
    settings, names = _settings(child), _object_names(child)
    wb = child.worldbody
    top = [e.name for lst in _TOP_LISTS for e in getattr(wb, lst)
           if e.name and settings.get(e.name, {}).get("vrep_parent") not in names - {e.name}]
    base = next((n for n in top if settings.get(n, {}).get("model_base") == "1"), None)
    if base is not None:
        return base, True
    return (top[0], False) if top else (None, False)


def _names_in(text: str, key: str, value: str, rename) -> str:
    """``value`` of setting ``key`` in text ``text`` with each object name it holds renamed."""
    if key == "vrep_parent" or (text.startswith(_IK) and _ik_object_key(key)):
        return rename(value)
    if key == "refs" or key.startswith("refs."):
        return ",".join(rename(n) for n in value.split(","))
    if text.startswith(_COLLECTION) and key == "items":
        out = []
        for item in value.split(","):
            kind, sep, name = item.partition(":")
            out.append(f"{kind}:{rename(name)}" if sep else item)
        return ",".join(out)
    if text.startswith(_MEASURES) and key in ("entity1", "entity2"):
        kind, sep, name = value.partition(":")
        return f"collection:{rename(name, collection=True)}" if sep and kind == "collection" else rename(value)
    return value


def suffix_settings(child: mujoco.MjSpec, suffix: str) -> None:
    """Give the object and collection names in a model's ``simx:`` settings (``vrep_parent=``,
    ``refs=``, IK groups' tips, targets and bases, collections' items, measurements' entities)
    the suffix that attaching it gives every name of the model, so that they name the model's own
    objects, not the scene's same-named ones (CoppeliaSim's loaded copies keep their handles'
    links). Names of objects outside the model are kept.

    Args:
        child: the model's spec, not yet attached (its texts are changed).
        suffix: the copy suffix (``#n``).
    """
    names = _object_names(child)
    collections = {t.name[len(_COLLECTION):] for t in child.texts if t.name.startswith(_COLLECTION)}

    def rename(name: str, collection: bool = False) -> str:
        return name + suffix if name in (collections if collection else names) else name

    for t in child.texts:
        if not t.name.startswith(("simx:", "simx.")):
            continue
        items = []
        for item in t.data.split():
            key, sep, value = item.partition("=")
            items.append(f"{key}={_names_in(t.name, key, value, rename)}" if sep else item)
        t.data = " ".join(items)


def remove(spec: mujoco.MjSpec, world, objects: list[SceneObject], carriers: bool = False) -> None:
    """Delete ``objects`` (of ``world``, compiled from ``spec``) from ``spec``: a shape with its
    body (and what MuJoCo's tree has below it), another object alone with the actuators, sensors
    and constraints that refer to it; then the ``simx:`` settings of every object gone, the
    collection elements, IK groups and measurements that name one, and the assets (meshes,
    height fields, materials, textures, the files read into memory for them) that only the
    deleted elements used: a removed model leaves nothing of itself in the scene. Assets that
    the scene's remaining elements use, and the scene's own that nothing used (a sky box), stay.

    Args:
        spec: a copy of the scene's spec (changed).
        world: the world the live model of ``spec`` is.
        objects: the objects to remove.
        carriers: also delete the unnamed bodies that carry only objects that go (a converted
            joint's, under ``sim.removeModel``); removing one object leaves them.
    """
    m = world.model
    parent = m.body_parentid
    handles = {o.handle for o in objects}
    doomed = {o.mj_id for o in objects if o.type == SHAPE}
    found: dict[int, tuple[SceneObject, int]] = {}  # unnamed body -> an object in it, levels up
    for o in objects if carriers else ():
        b, level = (int(parent[o.mj_id]) if o.type == SHAPE else o.body), 1  # el.parent: that body
        while b != 0 and not mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b):
            found.setdefault(b, (o, level))
            b, level = int(parent[b]), level + 1
    if found:
        inside: dict[int, set[int]] = {b: set() for b in found}  # the objects each one carries
        for o in world.objects.values():
            b = o.mj_id if o.type == SHAPE else o.body
            while b != 0:
                if b in inside:
                    inside[b].add(o.handle)
                b = int(parent[b])
        doomed |= {b for b in found if inside[b] <= handles}

    def under(b: int) -> bool:
        while b != 0:
            if b in doomed:
                return True
            b = int(parent[b])
        return False

    def element(o: SceneObject):
        kind = _KIND.get(o.type)
        name = mujoco.mj_id2name(m, _MJ_OBJ[kind], o.mj_id) if kind is not None else None
        return kind, name, (getattr(spec, kind)(name) if name else None)

    tops = []
    for b in doomed:
        if under(int(parent[b])):
            continue
        if b in found:  # unnamed: reached from an object it carries
            o, level = found[b]
            el = element(o)[2]
            for _ in range(level):
                el = el.parent if el is not None else None
        else:
            el = spec.body(mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or "")
        if el is not None:
            tops.append(el)
    before = _object_names(spec)
    used = _Assets()
    for o in objects:
        if o.type == SHAPE or under(o.body):
            continue
        kind, name, el = element(o)
        if el is None:
            continue
        _delete_references(spec, kind, name)
        used.note(el)
        spec.delete(el)
    for el in tops:
        for t in (mujoco.mjtObj.mjOBJ_GEOM, mujoco.mjtObj.mjOBJ_SITE):
            for e in el.find_all(t):
                used.note(e)
        spec.delete(el)
    gone = before - _object_names(spec)
    _delete_settings(spec, gone)
    _drop_mentions(spec, gone | {o.name for o in objects})
    used.prune(spec)


def _drop_mentions(spec: mujoco.MjSpec, gone: set[str]) -> None:
    """The scene's collection elements, IK groups and measurements that name a removed object
    leave with it (CoppeliaSim's containers' ``announceObjectWillBeErased``: a collection's
    elements of the object go, and so does a collection left empty; an IK element of the object
    goes, here its whole group); a measurement whose collection is gone goes too."""
    dropped: set[str] = set()
    for t in list(spec.texts):
        items = t.data.split()
        if t.name.startswith(_COLLECTION):
            kept = []
            for item in items:
                key, _, value = item.partition("=")
                if key == "items":  # +kind:NAME elements; +all and -all name no object
                    left = [e for e in value.split(",") if e and e.partition(":")[2] not in gone]
                    item = f"items={','.join(left)}" if left else ""
                if item:
                    kept.append(item)
            if not any(i.startswith("items=") for i in kept):
                dropped.add(t.name[len(_COLLECTION):])
                spec.delete(t)
            else:
                t.data = " ".join(kept)
        elif t.name.startswith(_IK) and any(
                _ik_object_key(i.partition("=")[0]) and i.partition("=")[2] in gone
                for i in items):
            spec.delete(t)
    for t in list(spec.texts):
        if t.name.startswith(_MEASURES) and any(
                i.partition("=")[2] in gone or i.partition("=")[2] in {f"collection:{c}" for c in dropped}
                for i in t.data.split() if i.startswith("entity")):
            spec.delete(t)


class _Assets:
    """The assets that deleted elements named (candidates), pruned once nothing else uses them."""

    def __init__(self):
        self.named: dict[str, set[str]] = {lst: set() for lst in _ASSETS}

    def note(self, el) -> None:
        """Remember the assets that element ``el`` (a geom or a site about to go) names."""
        lst = "geoms" if isinstance(el, mujoco.MjsGeom) else "sites" if isinstance(el, mujoco.MjsSite) else None
        for attr, assets in _ASSET_REFS.get(lst or "", ()):
            name = getattr(el, attr, "")
            if name:
                self.named[assets].add(name)

    def prune(self, spec: mujoco.MjSpec) -> None:
        """Delete the candidates that no element left uses (materials before their textures), and
        the in-memory files (``spec.assets``) of the deleted ones that no asset left reads."""
        if not any(self.named.values()):
            return
        for name in self.named["materials"]:
            mat = spec.material(name)
            if mat is not None:
                self.named["textures"].update(t for t in mat.textures if t)
        files: set[str] = set()
        for lists in (("meshes", "hfields", "materials"), ("textures",)):
            used = _used(spec)
            for lst in lists:
                find = getattr(spec, lst[:-2] if lst == "meshes" else lst[:-1])
                for name in self.named[lst] - used[lst]:
                    el = find(name)
                    if el is None or (lst == "textures" and el.type == mujoco.mjtTexture.mjTEXTURE_SKYBOX):
                        continue
                    files.update(_files(el))
                    spec.delete(el)
        if files and spec.assets:
            read = {f for lst in ("meshes", "hfields", "textures", "skins") for el in getattr(spec, lst)
                    for f in _files(el)}
            for key in files - read:  # (assigning spec.assets adds to it: entries are deleted)
                spec.assets.pop(key, None)


def _files(el) -> list[str]:
    out = [getattr(el, "file", "")] + list(getattr(el, "cubefiles", None) or [])
    return [f for f in out if f]


def _used(spec: mujoco.MjSpec) -> dict[str, set[str]]:
    """The assets that the spec's elements name, by list (textures: the materials')."""
    used: dict[str, set[str]] = {lst: set() for lst in _ASSETS}
    for lst, refs in _ASSET_REFS.items():
        for el in getattr(spec, lst):
            for attr, assets in refs:
                name = getattr(el, attr, "")
                if name:
                    used[assets].add(name)
    for mat in spec.materials:
        used["textures"].update(t for t in mat.textures if t)
    return used
