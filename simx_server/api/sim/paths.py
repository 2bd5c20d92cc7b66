"""CoppeliaSim 4.x's path helpers, collections and drawing objects kept as data (``sim.getPathLengths``,
``sim.createCollection``, ``sim.addDrawingObject`` and their kin).

* Paths are flat lists of configurations (``dof`` numbers each), as CoppeliaSim's Lua helpers
  take them: lengths along the path (Euclidean between the first 3 numbers of consecutive
  configurations), interpolation and resampling (linear or quadratic Bezier, plain, cyclic or
  quaternion numbers: :mod:`simx_server.sim.config_paths`, as CoppeliaSim's ``sim-1.lua``), the
  closest position to a point. ``createPath`` makes
  a dummy that carries its control points and the path through them (linear, ``subdiv``
  points per segment) as custom data ``PATHCTRLPT`` and ``PATH`` (packed doubles, as 4.3+ path
  objects do).
* Collections are sets of scene objects (:mod:`simx_server.sim.scene_collections`): those the
  scene declares (a ``.ttt`` file's, converted) and those made with ``createCollection`` /
  ``addItemToCollection`` (``sim.handle_single``, ``handle_tree``, ``handle_chain``,
  ``handle_all``); ``checkCollision`` / ``checkDistance`` take them as entities. Drawing objects
  keep their items (nothing is drawn headless). Handles of their own from 2,000,000 and 3,000,000.
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim.legacy_paths import create_old_path
from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text
from simx_server.sim import config_paths, scene_collections
from simx_server.sim.objects import WORLD

_DRAWINGS = 3_000_000
MAX_DRAWINGS, MAX_ITEMS = 1000, 100_000
HANDLE_ALL, HANDLE_TREE, HANDLE_CHAIN, HANDLE_SINGLE = -2, -6, -7, -8


def _path(path: Any, dof: int) -> np.ndarray:
    if isinstance(path, np.ndarray):
        path = path.tolist()
    if not isinstance(path, (list, tuple)) or dof < 1 or len(path) < dof or len(path) % dof:
        raise ArgumentError(f"path must be a flat table of configurations of {dof} numbers")
    return np.array([_num(v, "path[i]") for v in path]).reshape(-1, dof)


def _dof(path: Any, lengths: Any) -> int:
    n = len(lengths) if isinstance(lengths, (list, tuple, np.ndarray)) else 0
    if n < 1 or len(path) % n:
        raise ArgumentError("pathLengths must have one length per configuration of path")
    return len(path) // n


def _method(method: Any) -> dict | None:
    if method is not None and not isinstance(method, dict):
        raise ArgumentError("method must be a table ({type = 'linear'} or {type = 'quadraticBezier', strength = s})")
    return method


def _types(types: Any, dof: int) -> list[int] | None:
    if types is None:
        return None
    if not isinstance(types, (list, tuple)) or len(types) != dof:
        raise ArgumentError(f"types must hold {dof} integers (0 plain, 1 cyclic, 2 quaternion)")
    return [_int(v, "types[i]") for v in types]


# Path helpers, collections, drawing objects.

@sim_function("getPathLengths")
def getPathLengths(ctx: CallContext, path: Any, dof: Any, distCallback: Any = None) -> tuple[list[float], float]:  # noqa: N802, N803
    """``pathLengths, totalLength``: the length along the path at each configuration (the
    first 0), Euclidean between the first 3 numbers of consecutive configurations (CoppeliaSim's
    ``sim-1.lua``: metric 1 on the first 3, 0 on the others).

    Args:
        path: configurations of ``dof`` numbers each, flat.
        dof: numbers per configuration.
        distCallback: must be None.

    Returns:
        ``(lengths, total)``, in the path's units (m for positions).

    Raises:
        ArgumentError: a malformed path, or a distance callback.
    """
    if distCallback is not None:
        raise ArgumentError("getPathLengths with a distance callback: simx measures Euclidean lengths")
    lengths = config_paths.lengths(_path(path, _int(dof, "dof")))
    return lengths.tolist(), float(lengths[-1])


@sim_function("getPathInterpolatedConfig")
def getPathInterpolatedConfig(ctx: CallContext, path: Any, pathLengths: Any, t: Any, method: Any = None,  # noqa: N802, N803
                              types: Any = None) -> list[float]:
    """The configuration at length ``t`` along the path (clamped to its ends), as CoppeliaSim's
    ``sim-1.lua`` interpolates it (:func:`simx_server.sim.config_paths.interpolated`).

    Args:
        path: configurations, flat.
        pathLengths: :func:`getPathLengths`'s lengths.
        t: the length along the path.
        method: None, ``{type = 'linear'}`` or ``{type = 'quadraticBezier', strength = s}``, with
            ``closed`` / ``forceOpen``.
        types: one per number: 0 plain, 1 cyclic revolute, 2 quaternion (x y z w).

    Returns:
        One configuration.

    Raises:
        ArgumentError: a malformed path, mismatched lengths, or another interpolation.
    """
    pts = _path(path, _dof(path, pathLengths))
    times = np.array([_num(v, "pathLengths[i]") for v in pathLengths])
    return config_paths.interpolated(pts, times, _num(t, "t"), _method(method), _types(types, pts.shape[1])).tolist()


@sim_function("resamplePath")
def resamplePath(ctx: CallContext, path: Any, pathLengths: Any, finalConfigCnt: Any, method: Any = None,  # noqa: N802, N803
                 types: Any = None) -> list[float]:
    """``finalConfigCnt`` configurations evenly spaced along the path, flat.

    Args:
        path: configurations, flat.
        pathLengths: :func:`getPathLengths`'s lengths.
        finalConfigCnt: how many configurations, at least 2.
        method: as :func:`getPathInterpolatedConfig`'s.
        types: as :func:`getPathInterpolatedConfig`'s.

    Returns:
        ``finalConfigCnt`` configurations, flat.

    Raises:
        ArgumentError: a malformed path, a count out of range, or another interpolation.
    """
    n = _int(finalConfigCnt, "finalConfigCnt")
    if not 2 <= n <= MAX_ITEMS:
        raise ArgumentError(f"finalConfigCnt must lie in 2..{MAX_ITEMS}")
    pts = _path(path, _dof(path, pathLengths))
    lengths = np.array([_num(v, "pathLengths[i]") for v in pathLengths])
    return config_paths.resample(pts, lengths, n, _method(method), _types(types, pts.shape[1])).reshape(-1).tolist()


@sim_function("getClosestPosOnPath")
def getClosestPosOnPath(ctx: CallContext, path: Any, pathLengths: Any, absPt: Any) -> float:  # noqa: N802, N803
    """The length along the path (its first 3 numbers a position, m) closest to point ``absPt``.

    Args:
        path: configurations, flat.
        pathLengths: :func:`getPathLengths`'s lengths.
        absPt: a point (3 numbers, m).

    Returns:
        The length along the path, m.

    Raises:
        ArgumentError: a malformed path or mismatched lengths.
    """
    pts = _path(path, _dof(path, pathLengths))[:, :3]
    lengths = np.array([_num(v, "pathLengths[i]") for v in pathLengths])
    p = np.array([_num(v, "absPt[i]") for v in absPt][:3])
    best, where = np.inf, 0.0
    for i in range(len(pts) - 1):
        a, b = pts[i], pts[i + 1]
        ab = b - a
        f = 0.0 if not ab.any() else float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0, 1))
        d = float(np.linalg.norm(a + f * ab - p))
        if d < best:
            best, where = d, float(lengths[i] + f * (lengths[i + 1] - lengths[i]))
    return where


@sim_function("createPath")
def createPath(ctx: CallContext, ctrlPts: Any, options: Any = 0, subdiv: Any = 100, smoothness: Any = 1.0,  # noqa: N802, N803
               orientationMode: Any = 0, upVector: Any = None) -> int:  # noqa: N803
    """A 4.3+ path object, as CoppeliaSim's ``sim.createPath`` makes it: a dummy aliased ``Path``
    (where no other object has that name)
    carrying its control poses as custom data ``PATHCTRLPTS`` (and ``PATHCTRLPT``, the same) and
    the path through them as ``PATH`` (packed doubles, 7 per pose: x y z qx qy qz qw, in the
    path's frame), ``subdiv`` poses computed as its path model's script does
    (:func:`simx_server.sim.config_paths.through_control_points`). No control point dummies
    and no customization script are made. A number first is the old form,
    ``sim.createPath(attributes, intParams, floatParams, color)``, as ``sim.lua`` dispatches it:
    an old path object (:func:`~simx_server.api.sim.legacy_paths.create_old_path`).

    Args:
        ctrlPts: the control poses, 7 numbers each, flat, at least 2 (or the old form's attributes).
        options: bit 1 closed, bit 4 automatic orientation (others: display only).
        subdiv: poses of ``PATH``, 2..100,000.
        smoothness: the quadratic Bezier strength; 0: straight between the control points.
        orientationMode: with automatic orientation, 0..5 (x along the path, y up ... z along, y up).
        upVector: with automatic orientation, the up vector (default ``[0, 0, 1]``).

    Returns:
        The path dummy's handle.

    Raises:
        ArgumentError: malformed control points, ``subdiv`` out of range, or control points that
            all coincide.
    """
    if isinstance(ctrlPts, (int, float)) and not isinstance(ctrlPts, bool):  # the old form, as sim.lua's
        return create_old_path(ctx, ctrlPts, options, subdiv, smoothness)
    pts = _path(ctrlPts, 7)
    k = _int(subdiv, "subdiv")
    if len(pts) < 2 or not 2 <= k <= MAX_ITEMS:
        raise ArgumentError(f"createPath needs 2 control poses or more and subdiv in 2..{MAX_ITEMS}")
    up = np.array(_path(upVector, 3)[0] if upVector is not None else [0.0, 0, 1])
    dense = config_paths.through_control_points(pts, _int(options, "options"), k, _num(smoothness, "smoothness"),
                                                _int(orientationMode, "orientationMode"), up)
    h = ctx.sim.createDummy(0.04)
    try:
        ctx.sim.setObjectAlias(h, "Path")
    except ArgumentError:  # simx names objects uniquely: another object is named Path already
        pass
    pack = lambda a: struct.pack(f"<{a.size}d", *a.reshape(-1))  # noqa: E731
    ctx.sim.writeCustomDataBlockEx(h, "PATHCTRLPTS", pack(pts))
    ctx.sim.writeCustomDataBlockEx(h, "PATHCTRLPT", pack(pts))
    ctx.sim.writeCustomDataBlockEx(h, "PATH", pack(dense))
    return h


def store_of(ctx: CallContext, kind: str) -> dict:
    holder = ctx.holder
    store = getattr(holder, kind, None)
    if store is None:
        store = {}
        setattr(holder, kind, store)
    return store


@sim_function("createCollection")
def createCollection(ctx: CallContext, options: Any = 0) -> int:  # noqa: N802
    """An empty collection; its handle (from 2,000,000, after the scene's own).

    Args:
        options: ignored.

    Returns:
        The handle.

    Raises:
        ArgumentError: too many collections (MAX_COLLECTIONS).
    """
    return scene_collections.of(ctx.world).create()


@sim_function("addItemToCollection")
def addItemToCollection(ctx: CallContext, collectionHandle: Any, what: Any, objectHandle: Any, options: Any = 0) -> None:  # noqa: N802, N803
    """Add (``options`` bit 0: remove) ``sim.handle_single`` one object, ``handle_tree`` it and
    everything below it (bit 1: without it), ``handle_chain`` it and its ancestors (bit 1:
    without it), ``handle_all`` every object. As CoppeliaSim's ``sim.addItemToCollection``, the
    collection keeps the element, not the objects it stands for now: its members follow the
    scene's tree (an object later put under a ``handle_tree`` object is one of them).

    Args:
        collectionHandle: a collection's handle.
        what: ``sim.handle_single``, ``handle_tree``, ``handle_chain`` or ``handle_all``.
        objectHandle: the object (ignored for ``handle_all``).
        options: bit 0 remove, bit 1 without the object itself.

    Raises:
        UnknownObjectError: no such collection or object.
        ArgumentError: another ``what``.
    """
    collections = scene_collections.of(ctx.world)
    handle, kind, opts = _int(collectionHandle, "collectionHandle"), _int(what, "what"), _int(options, "options")
    collections.get(handle)  # no such collection: that error first
    if kind == HANDLE_ALL:
        collections.add(handle, "all", None, additive=not opts & 1)
        return
    h = ctx.world.get(ctx.h(objectHandle)).handle
    element = {HANDLE_SINGLE: "single", HANDLE_TREE: "tree", HANDLE_CHAIN: "chain"}.get(kind)
    if element is None:
        raise ArgumentError("what: sim.handle_single, handle_tree, handle_chain or handle_all")
    if opts & 2 and kind != HANDLE_SINGLE:
        element += "_without_base" if kind == HANDLE_TREE else "_without_tip"
    collections.add(handle, element, h, additive=not opts & 1)


@sim_function("getCollectionObjects")
def getCollectionObjects(ctx: CallContext, collectionHandle: Any) -> list[int]:  # noqa: N802, N803
    """The collection's objects: its elements in the scene's tree as it is now.

    Args:
        collectionHandle: a collection's handle.

    Returns:
        Object handles.

    Raises:
        UnknownObjectError: no such collection.
    """
    return scene_collections.of(ctx.world).present(_int(collectionHandle, "collectionHandle"))


@sim_function("destroyCollection")
def destroyCollection(ctx: CallContext, collectionHandle: Any) -> None:  # noqa: N802, N803
    """Forget a collection (``sim.destroyCollection``).

    Args:
        collectionHandle: a collection's handle.

    Raises:
        UnknownObjectError: no such collection.
    """
    scene_collections.of(ctx.world).remove(_int(collectionHandle, "collectionHandle"))


@sim_function("getCollectionHandle")
def getCollectionHandle(ctx: CallContext, collectionName: Any) -> int:  # noqa: N802, N803
    """The handle of the collection the scene declares as ``collectionName`` (CoppeliaSim's
    deprecated ``sim.getCollectionHandle``, V-REP 3.x's ``simGetCollectionHandle``).

    Args:
        collectionName: the name.

    Returns:
        The handle.

    Raises:
        UnknownObjectError: no such collection.
    """
    return scene_collections.of(ctx.world).handle(_text(collectionName, "collectionName"))


@sim_function("getCollectionName")
def getCollectionName(ctx: CallContext, collectionHandle: Any) -> str:  # noqa: N802, N803
    """The name of a collection (V-REP 3.x's ``simGetCollectionName``; "" for one made at run
    time).

    Args:
        collectionHandle: a collection's handle.

    Returns:
        The name.

    Raises:
        UnknownObjectError: no such collection.
    """
    return scene_collections.of(ctx.world).name(_int(collectionHandle, "collectionHandle"))


@sim_function("addDrawingObject")
def addDrawingObject(ctx: CallContext, objectType: Any, size: Any, duplicateTolerance: Any, parentObjectHandle: Any,  # noqa: N802, N803
                     maxItemCount: Any, color: Any = None) -> int:  # noqa: N803
    """A drawing object kept as data (headless: nothing drawn); its handle (from 3,000,000).

    Args:
        objectType: ``sim.drawing_*`` type and flags (kept).
        size: point size or line width (kept).
        duplicateTolerance: ignored.
        parentObjectHandle: an object's handle, or -1 (kept).
        maxItemCount: 1..MAX_ITEMS.
        color: ignored.

    Returns:
        The handle.

    Raises:
        UnknownObjectError: no such parent object.
        ArgumentError: MAX_DRAWINGS objects already, or ``maxItemCount`` out of range.
    """
    store = store_of(ctx, "drawings")
    if len(store) >= MAX_DRAWINGS:
        raise ArgumentError(f"at most {MAX_DRAWINGS} drawing objects")
    n = _int(maxItemCount, "maxItemCount")
    if not 0 < n <= MAX_ITEMS:
        raise ArgumentError(f"maxItemCount must lie in 1..{MAX_ITEMS}")
    parent = ctx.h(parentObjectHandle, "parentObjectHandle")
    if parent != WORLD:
        ctx.world.get(parent)
    h = max(store, default=_DRAWINGS - 1) + 1
    store[h] = {"type": _int(objectType, "objectType"), "size": _num(size, "size"), "max": n, "items": [],
                "parent": parent}
    return h


@sim_function("addDrawingObjectItem")
def addDrawingObjectItem(ctx: CallContext, drawingObjectHandle: Any, itemData: Any) -> int:  # noqa: N802, N803
    """Append an item (its numbers); nil clears the object. Past ``maxItemCount`` the oldest
    goes (CoppeliaSim's cyclic buffer). Returns 1.

    Args:
        drawingObjectHandle: a drawing object's handle.
        itemData: the item's numbers, or None.

    Returns:
        1.

    Raises:
        UnknownObjectError: no such drawing object.
    """
    d = store_of(ctx, "drawings").get(_int(drawingObjectHandle, "drawingObjectHandle") & 0x3FFFFF)  # without sim.handleflag_* bits
    if d is None:
        raise UnknownObjectError(f"no drawing object {drawingObjectHandle}")
    if itemData is None:
        d["items"].clear()
        return 1
    d["items"].append([_num(v, "itemData[i]") for v in itemData][:64])
    del d["items"][:-d["max"]]
    return 1


@sim_function("removeDrawingObject")
def removeDrawingObject(ctx: CallContext, drawingObjectHandle: Any) -> None:  # noqa: N802, N803
    """Remove one (``sim.handle_all``: every one).

    Args:
        drawingObjectHandle: a drawing object's handle, or ``sim.handle_all``.

    Raises:
        UnknownObjectError: no such drawing object.
    """
    h, store = _int(drawingObjectHandle, "drawingObjectHandle"), store_of(ctx, "drawings")
    if h == HANDLE_ALL:
        store.clear()
    elif store.pop(h, None) is None:
        raise UnknownObjectError(f"no drawing object {h}")


