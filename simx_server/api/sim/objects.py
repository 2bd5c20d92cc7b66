"""CoppeliaSim 4.x's ``sim`` calls on scene objects: the tree, paths and aliases, poses and
matrices, velocities, scene edits (forces: :mod:`simx_server.api.sim.forces`).

Scene edits (``createDummy``, ``setObjectParent``, ``setObjectName``/``setObjectAlias``)
go through the scene editor (:class:`simx_server.scene.editor.Editor`), as ``simxCreateDummy`` and
``simxSetObjectParent`` do: the edited MjSpec is compiled and swapped in, handles stay valid.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import core as _core
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, UnknownObjectError
from simx_server.base import limits as L
from simx_server.base.arguments import quote
from simx_server.api.sim.core import _int, _num, _text, _vector
from simx_server.sim import kinematics, paths
from simx_server.api.object_rename import rename
from simx_server.sim.world import WORLD, matrix_from_euler, matrix_from_quaternion

#: ``sim.handle_scene``: the base of ``getObjectsInTree`` that means the whole scene.
HANDLE_SCENE = -12
#: Constants this module adds to ``sim.*`` (besides the legacy ``sim_*`` ones).
CONSTANTS: dict[str, int] = {"handle_scene": HANDLE_SCENE}
_NAME = re.compile(r"[A-Za-z0-9_]+(#[0-9]+)?")  # V-REP's name characters, optional #n suffix
_NOT_ALIAS = re.compile(r"[^A-Za-z0-9_]")  # CoppeliaSim replaces these with '_' in aliases


# The object tree, matrices, velocities and scene edits.

@sim_function("getObject")
def getObject(ctx: CallContext, path: Any, options: Any = None) -> int:  # noqa: N802
    """CoppeliaSim 4.3's lookup by object path (:mod:`simx_server.sim.paths`): a V-REP name,
    an absolute ``/A/B`` path of aliases (each anywhere below the previous one; ``A[n]``,
    ``A{n}``, wildcards), ``"."`` (the script's object) or a path below it (``"./arm/joint"``),
    ``":"`` / ``":/B"`` from the script's model base. ``options`` ``{noError = true}`` answers -1
    instead of an error for an unknown object; ``{index = n}`` takes the n-th (0-based) of
    the objects the path matches, in tree order; ``{proxy = h}``: relative paths start from
    object ``h`` instead of the caller's (coppeliaSimLib ``simGetObject_internal``; an absolute
    ``/A`` path ignores it).

    Args:
        path: a name or path.
        options: ``{noError = true, index = n, proxy = h}``, or None.

    Returns:
        The handle, or -1 (``noError``).

    Raises:
        UnknownObjectError: no such object (without ``noError``), or no proxy object ``h``.
        ArgumentError: a path that is not a string.
    """
    p = _text(path, "object path")
    opts = options if isinstance(options, dict) else {}
    index = _int(opts.get("index", -1), "index")
    proxy = opts.get("proxy", -1)  # simGetObject_internal: the object '.' and ':' start from
    base = ctx.path_base() if proxy in (-1, None) else ctx.world.get(_int(proxy, "proxy")).handle
    found = paths.find(ctx.world, p, index, base)
    if found:
        return found[0]
    if opts.get("noError"):
        return -1
    which = f" with index {index}" if index >= 0 else ""
    raise UnknownObjectError(f"object {quote(p)}{which} does not exist in scene {ctx.world.scene_name}")


@sim_function("getObjectAlias")
def getObjectAlias(ctx: CallContext, handle: Any, options: Any = -1) -> str:  # noqa: N802 (CoppeliaSim's names)
    """The object's alias or alias path, as coppeliaSimLib ``simGetObjectAlias_internal``:
    ``options`` -1 the alias (in simx the name less its ``#N``, or a converted 4.3+ ``.ttt``'s
    own alias: :func:`simx_server.sim.paths.object_alias`), 0 the alias with its order among
    same-alias siblings (``joint[1]``), 1 the shortest path that names it (``/UR3/openCloseJoint``),
    2 the full path, 3 the alias where unique in the scene else 4: ``alias__HANDLE__``, 5 the
    short path shortened for printing (``/A/ ... /alias``), 6-9 the alias with its ``{n}`` index
    after 0, 1, 2 or all of the model bases above it (``/Robot{1}/finger{3}``).

    Args:
        handle: the object's handle, or ``sim.handle_self``.
        options: -1 to 9.

    Returns:
        The alias or path.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: another ``options``.
    """
    obj = ctx.world.get(ctx.h(handle))
    w, opt = ctx.world, _int(options, "options")
    short = paths.object_alias(obj)
    if opt == -1:
        return short
    if opt == 0:
        return paths.alias_with_order(w, obj.handle)
    if opt == 1:
        return paths.short_path(w, obj.handle)
    if opt == 2:
        return paths.full_path(w, obj.handle)
    if opt == 3 and len(paths.find(w, "/" + short)) < 2:
        return short
    if opt in (3, 4):
        return f"{short}__{obj.handle}__"
    if opt == 5:
        path = paths.short_path(w, obj.handle)
        parts = path.split("/")
        return path if len(path) <= 40 or len(parts) < 4 else f"/{parts[1]}/ ... /{parts[-1]}"
    if opt in (6, 7, 8, 9):
        return paths.index_path(w, obj.handle, {6: 0, 7: 1, 8: 2, 9: len(w.objects)}[opt])
    raise ArgumentError(f"getObjectAlias options {opt}: CoppeliaSim's are -1 to 9")


@sim_function("setObjectName")
def setObjectName(ctx: CallContext, handle: Any, name: Any) -> None:  # noqa: N802
    """Rename an object (V-REP 3.x / CoppeliaSim 4.0-4.2): a client then finds it under
    ``name`` with ``simxGetObjectHandle``; its handle stays. ``name``: letters, digits and
    ``_``, an optional ``#n`` suffix, at most ``limits.MAX_SCRIPT_OBJECT_NAME`` (128) characters,
    not taken by another object (names are global in V-REP); otherwise an error, nothing changes.

    Args:
        handle: the object's handle, or ``sim.handle_self``.
        name: the new name.

    Raises:
        ArgumentError: a bad or taken name, or the world.
        UnknownObjectError: no such object.
        UnsupportedError: an object MuJoCo cannot rename, or no simulation behind the script.
    """
    text = _text(name, "objectName")
    if len(text) > L.MAX_SCRIPT_OBJECT_NAME or not _NAME.fullmatch(text):
        raise ArgumentError(f"object name {quote(text)} must be 1 to {L.MAX_SCRIPT_OBJECT_NAME} letters, "
                            "digits or '_', "
                            "with an optional '#n' suffix")
    rename(ctx.simulation("setObjectName"), ctx.h(handle), text)


@sim_function("setObjectAlias")
def setObjectAlias(ctx: CallContext, handle: Any, alias: Any, options: Any = 0) -> None:  # noqa: N802
    """Rename an object (CoppeliaSim 4.3): characters other than letters, digits and ``_``
    become ``_``, as CoppeliaSim does; at most ``limits.MAX_SCRIPT_OBJECT_NAME`` (128) characters,
    not the name of another object (an error: simx names are unique, as V-REP's were).

    Args:
        handle: the object's handle, or ``sim.handle_self``.
        alias: the new alias.
        options: checked.

    Raises:
        ArgumentError: an empty, long or taken alias, or the world.
        UnknownObjectError: no such object.
        UnsupportedError: an object MuJoCo cannot rename, or no simulation behind the script.
    """
    text = _text(alias, "alias")
    _int(options, "options")
    if not text or len(text) > L.MAX_SCRIPT_OBJECT_NAME:
        raise ArgumentError(f"alias {quote(text)} must have 1 to {L.MAX_SCRIPT_OBJECT_NAME} characters")
    rename(ctx.simulation("setObjectAlias"), ctx.h(handle), _NOT_ALIAS.sub("_", text))


@sim_function("setObjectParent")
def setObjectParent(ctx: CallContext, handle: Any, parent: Any, keepInPlace: Any = True) -> None:  # noqa: N802, N803
    """Hang an object from ``parent`` (-1: the world; any object, as coppeliaSimLib's
    ``CSceneObject::setParent``: see ``Editor.set_parent``), keeping its world pose when
    ``keepInPlace`` (else its pose relative to the parent), as ``simxSetObjectParent``.

    Args:
        handle: the object's handle, or ``sim.handle_self``.
        parent: the new parent's handle, -1 or ``sim.handle_self``.
        keepInPlace: bool or 0/1.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a parent inside the object's own subtree.
        UnsupportedError: no simulation behind the script.
    """
    sim = ctx.simulation("setObjectParent")
    p = ctx.h(parent, "parentObjectHandle")
    p = ctx.owner if p == C.sim_handle_self else p
    keep = keepInPlace if isinstance(keepInPlace, bool) else bool(_int(keepInPlace, "keepInPlace"))
    sim.editor.set_parent(ctx.h(handle), p, keep)


@sim_function("getObjectsInTree")
def getObjectsInTree(ctx: CallContext, base: Any, objectType: Any = C.sim_handle_all,  # noqa: N802, N803
                     options: Any = 0) -> list[int]:
    """Handles of the objects in the tree below ``base`` (``sim.handle_scene``: the whole
    scene), depth first in tree order, the base first; ``objectType`` filters
    (``sim.handle_all``: any type); ``options`` bit 0 leaves out the base, bit 1 keeps only
    its direct children.

    Args:
        base: the tree's base, or ``sim.handle_scene``.
        objectType: a ``sim.object_*_type``, or ``sim.handle_all``.
        options: bits 0 and 1.

    Returns:
        The handles.

    Raises:
        UnknownObjectError: no such object.
    """
    b = ctx.h(base, "treeBaseHandle")
    otype, opts = _int(objectType, "objectType"), _int(options, "options")
    world = ctx.world
    children: dict[int, list[int]] = {}
    for o in world.objects.values():
        children.setdefault(o.parent, []).append(o.handle)
    if b == HANDLE_SCENE:
        top, out = WORLD, []
    else:
        top = world.get(ctx.h(b, "treeBaseHandle")).handle
        out = [] if opts & 1 else [top]
    stack = list(reversed(children.get(top, [])))  # depth first, in tree order
    while stack:
        h = stack.pop()
        out.append(h)
        if not opts & 2:
            stack.extend(reversed(children.get(h, [])))
    return [h for h in out if otype == C.sim_handle_all or world.objects[h].type == otype]


@sim_function("getObjectPosition")
def getObjectPosition(ctx: CallContext, handle: Any, relative_to: Any = -1) -> list[float]:  # noqa: N802
    """Position (m) relative to ``relative_to`` (-1 world, the default since CoppeliaSim 4.5;
    ``sim.handle_parent``; any object). A joint's position is its base frame's; a joint as
    ``relative_to`` counts by its moved frame, or by its base frame for
    ``handle + sim.handleflag_reljointbaseframe`` and for scripts saved before CoppeliaSim 4.0.1
    (:func:`~simx_server.api.sim.core.pose_handles`; coppeliaSimLib ``simGetObjectPosition_internal``).

    Args:
        handle: the object's handle.
        relative_to: another object's handle, -1 or ``sim.handle_parent``.

    Returns:
        ``[x, y, z]`` in m.
    """
    h, rel, base, _ = _core.pose_handles(ctx, handle, relative_to)
    return ctx.world.position(h, rel, base)


@sim_function("getObjectOrientation")
def getObjectOrientation(ctx: CallContext, handle: Any, relative_to: Any = -1) -> list[float]:  # noqa: N802
    """Euler angles alpha, beta, gamma (rad), R = Rx(alpha) Ry(beta) Rz(gamma), relative to
    ``relative_to`` (default: the world, as CoppeliaSim 4.5).

    Args:
        handle: the object's handle.
        relative_to: another object's handle, -1 or ``sim.handle_parent``.

    Returns:
        ``[alpha, beta, gamma]`` in rad.
    """
    h, rel, base, _ = _core.pose_handles(ctx, handle, relative_to)
    return ctx.world.orientation(h, rel, base)


@sim_function("getObjectQuaternion")
def getObjectQuaternion(ctx: CallContext, handle: Any, relative_to: Any = -1) -> list[float]:  # noqa: N802
    """Orientation as a quaternion (x, y, z, w) relative to ``relative_to`` (default: the world);
    ``handle + sim.handleflag_wxyzquat`` gives (w, x, y, z) (coppeliaSimLib
    ``simGetObjectQuaternion_internal``).

    Args:
        handle: the object's handle, plus ``sim.handleflag_*`` (:func:`~simx_server.api.sim.core.pose_handles`).
        relative_to: another object's handle, -1 or ``sim.handle_parent``.

    Returns:
        ``[x, y, z, w]``, unit length.
    """
    h, rel, base, flags = _core.pose_handles(ctx, handle, relative_to)
    q = ctx.world.quaternion(h, rel, base)
    return [q[3], *q[:3]] if flags & _core.HANDLEFLAG_WXYZQUAT else q


def order(relative_to: Any, value: Any) -> tuple[Any, Any]:
    """``(relativeTo, value)`` of a setter called ``(h, relativeTo, value)`` (V-REP, CoppeliaSim
    before 4.5) or ``(h, value [, relativeTo])`` (CoppeliaSim 4.5+): the table tells."""
    if isinstance(relative_to, (list, tuple, np.ndarray)):
        return (-1 if value is None else value), relative_to
    return relative_to, value


@sim_function("setObjectPosition")
def setObjectPosition(ctx: CallContext, handle: Any, relative_to: Any, position: Any = None) -> None:  # noqa: N802
    """Move an object to ``position`` (m) in the frame of ``relative_to``; arguments
    ``(h, relativeTo, position)`` or, as CoppeliaSim 4.5, ``(h, position [, relativeTo])``.
    A joint is placed by its base frame; a joint as ``relative_to`` counts by its moved frame,
    or by its base frame for ``h + sim.handleflag_reljointbaseframe`` and for scripts saved
    before CoppeliaSim 4.0.1 (:func:`~simx_server.api.sim.core.pose_handles`; coppeliaSimLib
    ``simSetObjectPosition_internal``).

    Args:
        handle: the object's handle.
        relative_to: a handle (-1, ``sim.handle_parent``), or the position (4.5's order).
        position: ``[x, y, z]`` in m, or the handle (4.5's order; default -1).
    """
    rel, value = order(relative_to, position)
    _core.set_pose(ctx, handle, rel, position=_vector(value, 3, "position"))


@sim_function("setObjectOrientation")
def setObjectOrientation(ctx: CallContext, handle: Any, relative_to: Any, euler: Any = None) -> None:  # noqa: N802
    """Turn an object to Euler angles (rad) in the frame of ``relative_to``; both argument
    orders, as :func:`setObjectPosition`.

    Args:
        handle: the object's handle.
        relative_to: a handle, or the angles (4.5's order).
        euler: ``[alpha, beta, gamma]`` in rad, or the handle (4.5's order).
    """
    rel, value = order(relative_to, euler)
    _core.set_pose(ctx, handle, rel, rotation=matrix_from_euler(*_vector(value, 3, "eulerAngles")))


@sim_function("setObjectQuaternion")
def setObjectQuaternion(ctx: CallContext, handle: Any, relative_to: Any, quaternion: Any = None) -> None:  # noqa: N802
    """Turn an object to quaternion (x, y, z, w) in the frame of ``relative_to``; both
    argument orders, as :func:`setObjectPosition`; ``handle + sim.handleflag_wxyzquat`` takes
    (w, x, y, z).

    Args:
        handle: the object's handle.
        relative_to: a handle, or the quaternion (4.5's order).
        quaternion: ``[x, y, z, w]``, or the handle (4.5's order).
    """
    rel, value = order(relative_to, quaternion)
    q = _vector(value, 4, "quaternion")
    if _core.pose_handles(ctx, handle, rel)[3] & _core.HANDLEFLAG_WXYZQUAT:  # (w, x, y, z)
        q = [*q[1:], q[0]]
    _core.set_pose(ctx, handle, rel, rotation=matrix_from_quaternion(*q))


@sim_function("getObjectMatrix")
def getObjectMatrix(ctx: CallContext, handle: Any, relative_to: Any = -1) -> list[float]:  # noqa: N802
    """The object's pose as 12 numbers, row by row: ``[Xx Yx Zx Px  Xy Yy Zy Py  Xz Yz Zz Pz]``
    (rotation columns X, Y, Z; position in m) relative to ``relative_to`` (-1 world,
    ``sim.handle_parent``).

    Args:
        handle: the object's handle.
        relative_to: another object's handle, -1 or ``sim.handle_parent``.

    Returns:
        12 floats.
    """
    h, rel, base, _ = _core.pose_handles(ctx, handle, relative_to)
    p, r = ctx.world.relative_frame(h, rel, base)
    (xx, yx, zx), (xy, yy, zy), (xz, yz, zz) = r.tolist()
    px, py, pz = p.tolist()
    return [xx, yx, zx, px, xy, yy, zy, py, xz, yz, zz, pz]


@sim_function("setObjectMatrix")
def setObjectMatrix(ctx: CallContext, handle: Any, relative_to: Any, matrix: Any = None) -> None:  # noqa: N802
    """Place an object by a 12-number matrix (see :func:`getObjectMatrix`) relative to
    ``relative_to``. Both argument orders work: ``(h, relativeTo, matrix)`` (CoppeliaSim
    4.0-4.4) and ``(h, matrix [, relativeTo])`` (4.5+). The rotation part must be a rotation
    (orthonormal within 1e-3; it is re-orthonormalised); the rules of setObjectPosition hold.

    Args:
        handle: the object's handle.
        relative_to: a handle, or the matrix (4.5's order).
        matrix: 12 numbers, or the handle (4.5's order).

    Raises:
        ArgumentError: not 12 numbers, or not a rotation.
    """
    relative_to, matrix = order(relative_to, matrix)
    values = np.array(_vector(matrix, 12, "matrix")).reshape(3, 4)
    r = values[:, :3]
    if np.abs(r @ r.T - np.eye(3)).max() > 1e-3 or np.linalg.det(r) <= 0:
        raise ArgumentError("the matrix's first three columns are not a rotation (orthonormal, determinant 1)")
    u, _, vt = np.linalg.svd(r)
    _core.set_pose(ctx, handle, relative_to, position=values[:, 3].tolist(), rotation=u @ vt)


@sim_function("getObjectVelocity")
def getObjectVelocity(ctx: CallContext, handle: Any) -> tuple[list[float], list[float]]:  # noqa: N802
    """``linearVelocity, angularVelocity`` of the object's origin in world axes (m/s, rad/s),
    as ``simxGetObjectVelocity``.

    Args:
        handle: the object's handle.

    Returns:
        ``([vx, vy, vz], [wx, wy, wz])``.
    """
    v, w = kinematics.object_velocity(ctx.simulation("getObjectVelocity"), ctx.h(handle))
    return v.tolist(), w.tolist()


@sim_function("createDummy")
def createDummy(ctx: CallContext, size: Any = 0.005, color: Any = None) -> int:  # noqa: N802
    """A new dummy (a sphere site of diameter ``size`` m) at the world origin, as
    ``simxCreateDummy``; returns its handle (named ``Dummy``, ``Dummy0``...). ``size``
    defaults to 0.005 m (CoppeliaSim 4.x); ``color``: nil
    or 12 numbers 0..1 (ambient/diffuse, specular, emission RGB; the first three colour it).

    ``sim.createDummy``.

    Args:
        size: m.
        color: 12 numbers in 0..1, or None.

    Returns:
        The dummy's handle.

    Raises:
        ArgumentError: a size that is not positive, or colours out of 0..1.
        UnsupportedError: no simulation behind the script.
    """
    s = _num(size, "size")
    colors = None
    if color is not None:
        values = _vector(color, 12, "color")
        if any(not 0.0 <= v <= 1.0 for v in values):
            raise ArgumentError("color components must lie in 0..1")
        colors = [round(v * 255) for v in values]
    return ctx.simulation("createDummy").editor.create_dummy(s, colors)


@sim_function("getObjectUid")
def getObjectUid(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """The object's unique id: simx's handles are never given twice, so the handle.

    ``sim.getObjectUid``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.

    Returns:
        The handle.

    Raises:
        UnknownObjectError: no such object.
    """
    return ctx.world.get(ctx.h(objectHandle)).handle


@sim_function("getObjectFromUid")
def getObjectFromUid(ctx: CallContext, uid: Any, options: Any = None) -> int:  # noqa: N802
    """The object of a unique id (its handle); -1 with ``{noError = true}``, else an error.

    ``sim.getObjectFromUid``.

    Args:
        uid: the unique id.
        options: ``{noError = true}``, or None.

    Returns:
        The handle, or -1.

    Raises:
        UnknownObjectError: no such object (without ``noError``).
    """
    h = _int(uid, "uid")
    if h in ctx.world.objects:
        return h
    if isinstance(options, dict) and options.get("noError"):
        return -1
    return ctx.world.get(h).handle
