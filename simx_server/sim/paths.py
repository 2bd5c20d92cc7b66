"""CoppeliaSim 4.3+ object paths (``sim.getObject``) over simx's object tree.

CoppeliaSim 4.3 replaced unique object names with *aliases* that several objects may share, and
``sim.getObject(path [, {index=n}])`` finds objects by a path of aliases. simx keeps V-REP's
unique names (the MJCF's, ``name#N`` where kinds share a name: :mod:`simx_server.sim.naming`);
an object's **alias** is its name without V-REP's copy suffix ``#N`` (``joint#2`` -> ``joint``),
so that a scene may give seven joints the alias ``joint`` as ``joint``, ``joint#0`` ...
``joint#5``. A path segment matches an object whose alias or whole name it names. A converted
``.ttt`` keeps CoppeliaSim's own aliases and tree: an object's ``simx:`` settings ``alias=A`` (its
alias where it is not its name, ``suctionPadSensor`` -> ``Sensor``) and ``vrep_parent=NAME``
(its parent in CoppeliaSim's tree where the MJCF's differs: a force sensor's child shape, the
objects on a force sensor, a free dynamic shape; ``-1`` the world) are what paths walk.

Paths (CoppeliaSim's manual, "Accessing scene objects programmatically"):

* ``/A/B/C``: an object ``C`` below an object ``B`` below an object ``A``, each anywhere below
  the previous one (intermediate levels may be left out: ``/UR5/UR5_joint3``); ``/A`` alone is
  any object ``A`` of the scene;
* ``.`` the calling script's object, ``./B`` below it; ``..`` its parent (``../..`` the
  grandparent, ``../B`` below the parent; coppeliaSimLib
  ``CSceneObjectContainer::_getObjectFromSimplePath``); ``:`` the script's model base (the
  nearest object at or above the script's with the ``model_base=1`` setting, which a converted
  ``.ttt`` gives its model bases; else the script object's topmost ancestor below the world),
  ``:/B`` below it, ``::`` the model base above that one; for code with no
  object (a remote client) ``./B`` and ``:/B`` start from the scene root;
* ``A[n]``: the n-th (0-based) of the matching objects that lie on the shallowest level where
  any matches, in tree order (``/Cuboid[0]`` is the first top-level ``Cuboid``);
  ``A{n}``: the n-th of all matching objects, in tree order;
* ``*`` and ``?`` in a segment are wildcards (``/Mobile*``);
* ``index`` (the ``{index=n}`` option): the n-th object that matches the whole path, in depth-first
  tree order (a chain's joints in chain order); without it, the first.

A string that starts with none of ``/ . :`` is a V-REP name, found as ``simxGetObjectHandle``
finds it (:meth:`World.resolve`). No MuJoCo here: only the registry's names and parents.
"""

from __future__ import annotations

import fnmatch
import re
from typing import Any

from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base.arguments import quote
from simx_server.sim.objects import WORLD

#: The scene (a :class:`simx_server.sim.world.World`, which resolves 4.x paths through this module:
#: typed loosely here so that the two modules do not import each other).
World = Any

_SUFFIX = re.compile(r"#\d+$")
_SEGMENT = re.compile(r"^(?P<alias>[^\[\]{}]+)(?:\[(?P<level>\d+)\]|\{(?P<scene>\d+)\})?$")
#: Longest path accepted (characters) and most segments.
MAX_PATH = 1000
MAX_SEGMENTS = 64


def alias(name: str) -> str:
    """The CoppeliaSim alias of a V-REP name: the name without a copy suffix ``#N``.

    Args:
        name: a V-REP object name.

    Returns:
        The alias.
    """
    return _SUFFIX.sub("", name)


def object_alias(obj: Any) -> str:
    """The alias of a scene object: its ``alias=`` setting (a converted 4.3+ ``.ttt``), else
    :func:`alias` of its name.

    Args:
        obj: a :class:`~simx_server.sim.objects.SceneObject`.

    Returns:
        The alias.
    """
    return obj.settings.get("alias") or alias(obj.name)


def path_parent(world: World, obj: Any) -> int:
    """The object's parent in paths: its ``vrep_parent=`` setting when that names an object
    (``-1``: the world), else its parent.

    Args:
        world: the world.
        obj: a scene object.

    Returns:
        The parent's handle, or -1 (the world).
    """
    name = obj.settings.get("vrep_parent")
    if name is None:
        return obj.parent
    if name == "-1":
        return WORLD
    other = world.by_name.get(name)
    return other.handle if other is not None and other.handle != obj.handle else obj.parent


def tree_order(world: World) -> tuple[list[int], dict[int, int], dict[int, int], dict[int, int]]:
    """``(handles in depth-first preorder, position of each in it, end of its subtree there
    (exclusive), its depth: 1 for the world's children)``.

    Args:
        world: the world.

    Returns:
        ``(order, position, end, depth)``.
    """
    children: dict[int, list[int]] = {WORLD: []}
    for h, obj in world.objects.items():  # handles count up in tree order, edits append
        children.setdefault(h, [])
        children.setdefault(path_parent(world, obj), []).append(h)
    order: list[int] = []
    depth: dict[int, int] = {}
    end: dict[int, int] = {}
    roots = list(children[WORLD])
    while True:
        stack: list[tuple[int, int, bool]] = [(h, 1, False) for h in reversed(roots)]
        while stack:
            h, d, closing = stack.pop()
            if closing:
                end[h] = len(order)
                continue
            if h in depth:  # a cycle of vrep_parent settings comes back round
                continue
            order.append(h)
            depth[h] = d
            stack.append((h, d, True))
            stack.extend((c, d + 1, False) for c in reversed(children.get(h, [])))
        if len(order) == len(world.objects):
            break
        # ``vrep_parent`` settings that form a cycle: what they cut off hangs from the world
        roots = [next(h for h in world.objects if h not in depth)]
    position = {h: i for i, h in enumerate(order)}
    return order, position, end, depth


def _model_base(world: World, handle: int) -> int:
    """The model ``handle`` is in: the nearest object at or above it with the ``model_base=1``
    setting (a converted ``.ttt``'s model bases), else its topmost ancestor below the world."""
    h = handle
    while h != WORLD:
        if world.objects[h].settings.get("model_base") == "1":
            return h
        h = path_parent(world, world.objects[h])
    top = handle
    while path_parent(world, world.objects[top]) != WORLD:
        top = path_parent(world, world.objects[top])
    return top


def _matches(pattern: str, obj: Any) -> bool:
    name, short = obj.name, object_alias(obj)
    if "*" in pattern or "?" in pattern:
        return fnmatch.fnmatchcase(short, pattern) or fnmatch.fnmatchcase(name, pattern)
    return pattern == name or pattern == short


def find(world: World, path: str, index: int = -1, proxy: int | None = None) -> list[int]:
    """Handles of the objects ``path`` names, in depth-first tree order (``index`` >= 0: only the
    index-th of them, or none). ``proxy``: the calling script's object (``.`` and ``:``); None
    for unassociated code (a remote client), where ``./X``, ``./X[i]`` and ``:/X`` start from the
    scene root, as CoppeliaSim resolves them for code with no object (``.`` alone names nothing).

    Raises ArgumentError for a path that is not one (empty segments, bad brackets, too long).

    Implements CoppeliaSim 4.3+'s object paths (``sim.getObject``): ``/A/B``, ``./X``, ``:/X``,
    ``A[n]``, ``{n}``, ``*`` wildcards; a bare name is looked up as a V-REP name.

    Args:
        world: the world.
        path: the path.
        index: >= 0: only the index-th match; -1: all.
        proxy: the calling script's object, or None.

    Returns:
        Handles, possibly none.

    Raises:
        ArgumentError: not a path.
    """
    if not isinstance(path, str):
        raise ArgumentError(f"object path must be a string, got {type(path).__name__}")
    if len(path) > MAX_PATH:
        raise ArgumentError(f"object path of {len(path)} characters refused: at most {MAX_PATH}")
    if path[:1] not in ("/", ".", ":"):
        try:
            found = [world.resolve(path).handle]
        except UnknownObjectError:
            found = []
        return found if index <= 0 else []
    order, position, end, depth = tree_order(world)
    if path[0] == "/":
        base, rest = WORLD, path[1:]
    elif path.startswith(".."):  # the script object's parent, "../.." its grandparent, "../X" below it
        base, rest = (WORLD if proxy is None else proxy), path
        while rest.startswith(".."):
            if base == WORLD:
                return []
            base, rest = path_parent(world, world.objects[base]), rest[2:]
            if rest == "":
                return [base] if index <= 0 and base != WORLD else []
            if not rest.startswith("/"):
                raise ArgumentError(f"object path {quote(path)}: after .. comes / (../sibling) or nothing")
            rest = rest[1:]
    else:
        base = WORLD if proxy is None else proxy  # unassociated code (a remote client): the scene root
        rest = path[1:]
        if path[0] == ":" and base != WORLD:
            base = _model_base(world, base)
            if rest.startswith(":"):  # '::': the model above the script's model
                rest = rest[1:]
                up = path_parent(world, world.objects[base])
                base = _model_base(world, up) if up != WORLD else base
        if rest == "":
            return [base] if index <= 0 and base != WORLD else []
        if not rest.startswith("/"):
            raise ArgumentError(f"object path {quote(path)}: after . or : comes / (./child)")
        rest = rest[1:]
    segments = rest.split("/")
    if len(segments) > MAX_SEGMENTS or any(s == "" for s in segments):
        raise ArgumentError(f"object path {quote(path)} is not a path: /A/B/C, no empty part, at most "
                            f"{MAX_SEGMENTS} parts")
    current = [base]
    for seg in segments:
        m = _SEGMENT.match(seg)
        if m is None:
            raise ArgumentError(f"object path {quote(path)}: {quote(seg)} is not ALIAS, ALIAS[n] or ALIAS{{n}}")
        pattern = m.group("alias")
        nxt: list[int] = []
        reach = -1  # bases inside an earlier base's subtree add nothing: each object is visited once
        for b in current:  # in tree order
            lo, hi = (0, len(order)) if b == WORLD else (position[b] + 1, end[b])
            if lo < reach:
                continue
            reach = hi
            hits = [h for h in order[lo:hi] if _matches(pattern, world.objects[h])]
            if m.group("level") is not None and hits:
                top = min(depth[h] for h in hits)
                n = int(m.group("level"))
                hits = [h for h in hits if depth[h] == top][n:n + 1]
            nxt.extend(hits)
        if m.group("scene") is not None:
            n = int(m.group("scene"))
            nxt = nxt[n:n + 1]
        current = nxt
        if not current:
            return []
    return current[index:index + 1] if index >= 0 else current


def find_one(world: World, path: str, index: int = -1, proxy: int | None = None) -> int:
    """The handle of the object ``path`` names (the first, or the ``index``-th); raises
    UnknownObjectError naming the path when there is none (ArgumentError as :func:`find`).

    Args:
        world: the world.
        path: the path (as :func:`find`).
        index: >= 0: the index-th match; -1: the first.
        proxy: the calling script's object, or None.

    Returns:
        A handle.

    Raises:
        UnknownObjectError: no object matches.
        ArgumentError: not a path.
    """
    found = find(world, path, index, proxy)
    if not found:
        which = f" with index {index}" if index >= 0 else ""
        raise UnknownObjectError(f"object {quote(path)}{which} does not exist in scene {world.scene_name}")
    return found[0]


def _children(world: World, parent: int) -> list[int]:
    """The children of ``parent`` in paths' tree (-1: the world), in handle order."""
    return [h for h, o in world.objects.items() if path_parent(world, o) == parent]


def alias_with_order(world: World, handle: int) -> str:
    """``alias[n]``: the object's alias, with its order among its siblings of the same alias
    where it is not unique there (coppeliaSimLib ``CSceneObject::getObjectAliasAndOrderIfRequired``
    and ``handleOrderIndexOfChildren``).

    Args:
        world: the world.
        handle: an object's handle.

    Returns:
        The alias, ``[n]`` appended where siblings share it.
    """
    obj = world.objects[handle]
    short = object_alias(obj)
    same = [h for h in _children(world, path_parent(world, obj)) if object_alias(world.objects[h]) == short]
    return short if len(same) < 2 else f"{short}[{same.index(handle)}]"


def full_path(world: World, handle: int) -> str:
    """``/A/B/alias``: every ancestor's :func:`alias_with_order` (coppeliaSimLib
    ``CSceneObject::getObjectAlias_fullPath``).

    Args:
        world: the world.
        handle: an object's handle.

    Returns:
        The path.
    """
    parts, h = [], handle
    while h != WORLD and len(parts) <= len(world.objects):
        parts.append(alias_with_order(world, h))
        h = path_parent(world, world.objects[h])
    return "/" + "/".join(reversed(parts))


def short_path(world: World, handle: int) -> str:
    """The shortest alias path that still names the object: from the object up, an ancestor is
    kept where it is a model base or where leaving it out would name another object (coppeliaSimLib
    ``CSceneObject::getObjectAlias_shortPath``; past 8 levels, :func:`full_path`).

    Args:
        world: the world.
        handle: an object's handle.

    Returns:
        The path, e.g. ``/UR3/openCloseJoint``.
    """
    path = "/" + alias_with_order(world, handle)
    kept = 1
    h = path_parent(world, world.objects[handle])
    while h != WORLD:
        if kept > 8:
            return full_path(world, handle)
        up = path_parent(world, world.objects[h])
        found = find(world, path if up == WORLD else "." + path, -1, None if up == WORLD else up)
        if world.objects[h].settings.get("model_base") == "1" or found[:1] != [handle]:
            path = "/" + alias_with_order(world, h) + path
            kept += 1
        h = up
    return path


def index_path(world: World, handle: int, models: int) -> str:
    """``/parentModel{1}/alias{3}``: the object's alias, after those of up to ``models`` model
    bases above it, each with its index among every object its path so far names (``{0}`` left
    out where it is the only one; coppeliaSimLib ``CSceneObject::getObjectPathAndIndex``).

    Args:
        world: the world.
        handle: an object's handle.
        models: how many model bases above it to name (``getObjectAlias`` options 6-9: 0, 1, 2, all).

    Returns:
        The path.
    """
    chain, p = [handle], path_parent(world, world.objects[handle])
    for _ in range(models):
        while p != WORLD and world.objects[p].settings.get("model_base") != "1":
            p = path_parent(world, world.objects[p])
        if p == WORLD:
            break
        chain.append(p)
        p = path_parent(world, world.objects[p])
    path = ""
    for h in reversed(chain):
        path += "/" + object_alias(world.objects[h])
        found = find(world, path)
        index = found.index(h) if h in found else 0
        if index or len(found) > 1:
            path += f"{{{index}}}"
    return path
