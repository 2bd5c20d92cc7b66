"""CoppeliaSim 4.x's image files, object queries and application services: ``saveImage`` /
``loadImage`` (OpenCV; a client writes into its own folder and reads from it and the scene folders:
client_files), ``getObjectAliasRelative``, ``getModelBB``, ``getObjectChildPose`` /
``setObjectChildPose`` (a joint's intrinsic motion), ``removeReferencedObjects``,
``createPureShape`` (V-REP's older ``createPrimitiveShape``), ``getThreadId``.

Images are uint8 buffers with rows bottom-up, as ``getVisionSensorImg`` returns them; files
are written and read top-down (the picture the right way up).
"""

from __future__ import annotations

import math
import threading
from pathlib import Path
from typing import Any

import cv2
import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import core as _core
from simx_server.api.sim import file_writes, misc as _misc
from simx_server.api.sim import objects as _objects
from simx_server.api.sim import shapes as _shapes
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_bytes as _bytes, as_integer as _int, as_number as _num, as_text as _text
from simx_server.base.arguments import as_vector as _vector
from simx_server.sim.objects import JOINT, SHAPE, WORLD
from simx_server.sim.rotations import matrix_from_quaternion

_IMAGE_FORMATS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
MAX_IMAGE_SIDE = 8192
#: ``sim.createPureShape``'s primitive types (0 cuboid, 1 sphere, 2 cylinder, 3 cone) -> ``sim.primitiveshape_*``.
_PURE = {0: 3, 1: 4, 2: 5, 3: 6}
#: The special properties a new pure shape goes without (collidable 1, measurable 2, detectable
#: 496, renderable 512: ``addPrimitiveShape``'s ``propToRemove``).
_PURE_CLEARED = 1 | 2 | 496 | 512
_SHAPE_RESPONDABLE = 3004  # sim.shapeintparam_respondable


def _channels(options: int) -> int:
    return 1 if options & 2 else 4 if options & 1 else 3


# Image files, object queries and application services.

def image_file(ctx: CallContext, filename: str, writing: bool) -> Path:
    """The image file a call writes or reads: a client's (or a script's acting for one) in its
    own folder, reads also from the scene folders; the operator's scripts' in the scene
    folders (:meth:`ClientFiles.target <simx_server.scene.client_files.ClientFiles.target>`,
    :meth:`ClientFiles.source <simx_server.scene.client_files.ClientFiles.source>`)."""
    what = "saveImage" if writing else "loadImage"
    sim = ctx.simulation(what)
    if not filename or "\x00" in filename or Path(filename).suffix.lower() not in _IMAGE_FORMATS:
        raise ArgumentError(f"give an image file name ending in one of {', '.join(_IMAGE_FORMATS)}")
    files = sim.editor.files
    key = files.writer(_misc.script_path(ctx))
    if writing:
        return files.target(filename, key, f"sim.{what}")
    return files.source(filename, key, f"sim.{what}")


@sim_function("saveImage")
def saveImage(ctx: CallContext, image: Any, resolution: Any, options: Any, filename: Any, quality: Any = -1) -> bytes:  # noqa: N802
    """Write an image (``resolution`` x, y; ``options`` bit 0: RGBA, bit 1: greyscale, else
    RGB) as an image file, or, when ``filename`` is just a format (``".png"``, ``".jpg"``),
    return the encoded file as a buffer. ``quality`` 0..100 (JPEG; -1: OpenCV's default).

    ``sim.saveImage``.

    Args:
        image: w*h*n bytes, rows bottom-up.
        resolution: ``[w, h]``, pixels.
        options: bit 0 RGBA, bit 1 greyscale.
        filename: a file name (a client: relative, in its own folder), or a format such as
            ``".png"``.
        quality: 0..100, or -1.

    Returns:
        The encoded file (format only), else ``b""``.

    Raises:
        ArgumentError: an image that does not match its resolution, or an unknown format; a
            client's name outside its folder.
        RemoteError: the operator's file outside the scene folders; past the client's budget.
        UnsupportedError: a format OpenCV cannot encode.
    """
    opts, name, q = _int(options, "options"), _text(filename, "filename"), _int(quality, "quality")
    w, h = (_int(v, "resolution[i]") for v in (resolution or [])[:2]) if resolution and len(resolution) >= 2 \
        else (0, 0)
    n = _channels(opts)
    raw = _bytes(image, "image")
    if not (0 < w <= MAX_IMAGE_SIDE and 0 < h <= MAX_IMAGE_SIDE) or len(raw) != w * h * n:
        raise ArgumentError(f"image must hold {w}x{h}x{n} bytes (resolution at most {MAX_IMAGE_SIDE})")
    img = np.frombuffer(raw, np.uint8).reshape(h, w, n)[::-1]
    img = {1: img[:, :, 0], 3: cv2.cvtColor(img, cv2.COLOR_RGB2BGR), 4: cv2.cvtColor(img, cv2.COLOR_RGBA2BGRA)}[n]
    ext = name.lower() if name.startswith(".") else Path(name).suffix.lower()
    if ext not in _IMAGE_FORMATS:
        raise ArgumentError(f"give an image file name ending in one of {', '.join(_IMAGE_FORMATS)}")
    params = [cv2.IMWRITE_JPEG_QUALITY, max(0, min(100, q))] if ext in (".jpg", ".jpeg") and q >= 0 else []

    def encoded() -> bytes:
        ok, data = cv2.imencode(ext, img, params)
        if not ok:
            raise UnsupportedError(f"OpenCV cannot encode {ext} images")
        return bytes(data.tobytes())

    if name.startswith("."):
        return encoded()
    file, files = image_file(ctx, name, True), ctx.simulation("saveImage").editor.files
    return file_writes.write_files(ctx, files.writer(_misc.script_path(ctx)), lambda: [(file, encoded(), name)], b"")  # type: ignore[no-any-return]


@sim_function("loadImage")
def loadImage(ctx: CallContext, options: Any, filename: Any) -> tuple[bytes, list[int]]:  # noqa: N802
    """``image, resolution`` of an image file, or of an encoded image given as a buffer
    (bytes, or ``options`` bit 1 with a string): RGB, or RGBA with ``options`` bit 0; rows
    bottom-up.

    ``sim.loadImage``.

    Args:
        options: bit 0 RGBA, bit 1 ``filename`` is the encoded image.
        filename: a file name (the scene folders, or the client's own folder: relative names
            are its own file where it has one), or the encoded bytes.

    Returns:
        ``(image, [w, h])``: w*h*3 (or 4) bytes and pixels.

    Raises:
        ArgumentError: not an image OpenCV can read.
        RemoteError: a file outside the scene folders and the client's own folder.
    """
    opts = _int(options, "options")
    if isinstance(filename, (bytes, bytearray)) or opts & 2:
        data = _bytes(filename, "serializedImage")
    else:
        data = image_file(ctx, _text(filename, "filename"), False).read_bytes()
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise ArgumentError("not an image OpenCV can read")
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGRA)
    elif img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2BGRA)
    img = cv2.cvtColor(img.astype(np.uint8), cv2.COLOR_BGRA2RGBA if opts & 1 else cv2.COLOR_BGRA2RGB)
    return np.ascontiguousarray(img[::-1]).tobytes(), [int(img.shape[1]), int(img.shape[0])]


@sim_function("getObjectAliasRelative")
def getObjectAliasRelative(ctx: CallContext, handle: Any, baseHandle: Any, options: Any = -1) -> str:  # noqa: N802, N803
    """The object's path relative to ``baseHandle`` (``./link/joint``, the form
    ``sim.getObject`` resolves with ``proxy``); an object outside the base's tree, or a base of
    ``sim.handle_world``: its full path as ``getObjectAlias(handle, 2)``.

    ``sim.getObjectAliasRelative``.

    Args:
        handle: the object's handle, or ``sim.handle_self``.
        baseHandle: the base object's handle.
        options: checked.

    Returns:
        The path.

    Raises:
        UnknownObjectError: no such object.
    """
    obj = ctx.world.get(ctx.h(handle))
    base = ctx.h(baseHandle, "baseHandle")
    _int(options, "options")
    if obj.handle == base:
        return "."
    parts, h = [], obj.handle
    while h not in (WORLD, base):
        parts.append(ctx.world.objects[h].name)
        h = ctx.world.objects[h].parent
    if h == WORLD:
        return ctx.sim.getObjectAlias(obj.handle, 2)
    return "./" + "/".join(reversed(parts))


@sim_function("getModelBB")
def getModelBB(ctx: CallContext, handle: Any) -> list[float]:  # noqa: N802
    """Size ``[x, y, z]`` (m) of the box, in the object's frame, around every shape of its
    tree (the model's), as CoppeliaSim 4.7's ``sim.getModelBB``.

    ``sim.getModelBB``.

    Args:
        handle: the model's base object, or ``sim.handle_self``.

    Returns:
        3 floats, m.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: no shape in its tree.
    """
    h = ctx.h(handle)
    ctx.world.get(h)
    rot, pos = _frame_of(ctx, h)
    pts = []
    for shape in ctx.sim.getObjectsInTree(h, SHAPE, 0):
        r, p = _frame_of(ctx, shape)
        pts.append(((_shapes.corners(ctx, ctx.world.objects[shape].mj_id) @ r.T + p) - pos) @ rot)
    if not pts:
        raise ArgumentError(f"object {h} has no shape in its tree")
    allp = np.vstack(pts)
    return (allp.max(axis=0) - allp.min(axis=0)).tolist()


def _frame_of(ctx: CallContext, handle: int) -> tuple[np.ndarray, np.ndarray]:
    m = np.array(ctx.sim.getObjectMatrix(handle, -1), dtype=float).reshape(3, 4)
    return m[:, :3], m[:, 3]


@sim_function("getObjectPose")
def getObjectPose(ctx: CallContext, objectHandle: Any, relativeToObjectHandle: Any = -1) -> list[float]:  # noqa: N802, N803
    """``[x, y, z, qx, qy, qz, qw]`` of an object relative to another (-1: the world); the
    handle's flags as :func:`~simx_server.api.sim.core.pose_handles` reads them
    (``sim.handleflag_wxyzquat``: ``qw, qx, qy, qz``).

    ``sim.getObjectPose`` (coppeliaSimLib ``simGetObjectPose_internal``).

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        relativeToObjectHandle: -1 (world), ``sim.handle_parent`` or an object.

    Returns:
        7 floats: m and a unit quaternion.

    Raises:
        UnknownObjectError: no such object.
    """
    h, rel, base, flags = _core.pose_handles(ctx, objectHandle, relativeToObjectHandle)
    p, q = ctx.world.pose(h, rel, base)
    return p + ([q[3], *q[:3]] if flags & _core.HANDLEFLAG_WXYZQUAT else q)


@sim_function("setObjectPose")
def setObjectPose(ctx: CallContext, objectHandle: Any, relativeTo: Any, pose: Any = None) -> None:  # noqa: N802, N803
    """Place an object by a 7-number pose; ``(h, pose [, relativeTo])`` (4.5+) or
    ``(h, relativeTo, pose)``; the rules of ``setObjectPosition`` hold.

    ``sim.setObjectPose``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        relativeTo: -1 (world), ``sim.handle_parent`` or an object; or the pose (4.5+ order).
        pose: 7 numbers (m and a quaternion), or the frame (4.5+ order).

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not 7 numbers, or an object that cannot be placed.
    """
    rel, value = _objects.order(relativeTo, pose)
    v = _vector(value, 7, "pose")
    q = v[3:] if not _core.pose_handles(ctx, objectHandle, rel)[3] & _core.HANDLEFLAG_WXYZQUAT else [*v[4:], v[3]]
    _core.set_pose(ctx, objectHandle, rel, position=v[:3], rotation=matrix_from_quaternion(*q))


@sim_function("getObjectChildPose")
def getObjectChildPose(ctx: CallContext, objectHandle: Any) -> list[float]:  # noqa: N802, N803
    """The pose (x, y, z, qx, qy, qz, qw; m) of a joint's child frame in the joint's frame: its
    intrinsic motion (a hinge's rotation about z, a slide's translation along z, a ball's
    rotation). Other objects: ArgumentError.

    ``sim.getObjectChildPose``.

    Args:
        objectHandle: a joint's handle, or ``sim.handle_self``.

    Returns:
        7 floats: m and a unit quaternion.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not a joint.
        UnsupportedError: a free joint.
    """
    obj = ctx.world.get(ctx.h(objectHandle, "objectHandle"))
    if obj.type != JOINT:
        raise ArgumentError(f"{obj.name!r} is not a joint: only a joint has a child pose in simx")
    m, d = ctx.world.model, ctx.world.data
    kind, adr = int(m.jnt_type[obj.mj_id]), int(m.jnt_qposadr[obj.mj_id])
    J = mujoco.mjtJoint
    if kind == J.mjJNT_HINGE:
        a = float(d.qpos[adr])
        return [0.0, 0.0, 0.0, 0.0, 0.0, float(np.sin(a / 2)), float(np.cos(a / 2))]
    if kind == J.mjJNT_SLIDE:
        return [0.0, 0.0, float(d.qpos[adr]), 0.0, 0.0, 0.0, 1.0]
    if kind == J.mjJNT_BALL:
        w, x, y, z = (float(v) for v in d.qpos[adr:adr + 4])
        return [0.0, 0.0, 0.0, x, y, z, w]
    raise UnsupportedError(f"{obj.name!r} is a free joint: its motion is its body's pose")


@sim_function("setObjectChildPose")
def setObjectChildPose(ctx: CallContext, objectHandle: Any, pose: Any) -> None:  # noqa: N802, N803
    """Set a joint's intrinsic motion from a child pose (see :func:`getObjectChildPose`): a
    hinge takes the rotation's angle about z, a slide the z translation, a ball the rotation.

    ``sim.setObjectChildPose``.

    Args:
        objectHandle: a joint's handle, or ``sim.handle_self``.
        pose: 7 numbers, m and a quaternion.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not a joint, not 7 numbers, or a zero quaternion.
        UnsupportedError: a free joint.
    """
    obj = ctx.world.get(ctx.h(objectHandle, "objectHandle"))
    if obj.type != JOINT:
        raise ArgumentError(f"{obj.name!r} is not a joint: only a joint has a child pose in simx")
    if not isinstance(pose, (list, tuple)) or len(pose) < 7:
        raise ArgumentError("pose must hold 7 numbers (x, y, z, qx, qy, qz, qw)")
    p = np.array([float(v) for v in pose[:7]])
    m, d = ctx.world.model, ctx.world.data
    kind, adr = int(m.jnt_type[obj.mj_id]), int(m.jnt_qposadr[obj.mj_id])
    J = mujoco.mjtJoint
    if kind == J.mjJNT_HINGE:
        ctx.sim.setJointPosition(obj.handle, float(2 * np.arctan2(p[5], p[6])))
    elif kind == J.mjJNT_SLIDE:
        ctx.sim.setJointPosition(obj.handle, float(p[2]))
    elif kind == J.mjJNT_BALL:
        q = np.array([p[6], p[3], p[4], p[5]])
        if not np.linalg.norm(q) > 0:
            raise ArgumentError("the pose's quaternion must not be zero")
        d.qpos[adr:adr + 4] = q / np.linalg.norm(q)
        mujoco.mj_kinematics(m, d)
        ctx.world.version += 1
    else:
        raise UnsupportedError(f"{obj.name!r} is a free joint: set its body's pose")


@sim_function("checkProximitySensorEx")
def checkProximitySensorEx(ctx: CallContext, sensorHandle: Any, entityHandle: Any, mode: Any, threshold: Any,  # noqa: N802, N803
                           maxAngle: Any) -> tuple[int, float, list[float], int, list[float]]:  # noqa: N803
    """``result, distance, detectedPoint, detectedObjectHandle, normalVector`` (sensor frame) of
    the sensor's ray(s) against ``entityHandle`` (``sim.handle_all``: any shape), counting a
    detection only within ``threshold`` m and, with ``mode`` bit 3, where the surface faces the
    sensor within ``maxAngle`` (rad). ``mode`` bit 0 asks for front faces (what MuJoCo's rays
    see); back faces alone (bit 1 without bit 0): UnsupportedError. Bit 2 (fast) changes
    nothing: the rays are exact.

    ``sim.checkProximitySensorEx``.

    Args:
        sensorHandle: a proximity sensor's handle.
        entityHandle: an object, or ``sim.handle_all``.
        mode: detection bits.
        threshold: m.
        maxAngle: rad.

    Returns:
        ``(result, distance, detectedPoint, detectedObjectHandle, normalVector)``: int, m, 3 floats
        (m), int, 3 floats.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a proximity sensor.
        UnsupportedError: back faces only (mode bit 0 clear).
    """
    opts, limit, angle = _int(mode, "mode"), _num(threshold, "threshold"), _num(maxAngle, "maxAngle")
    if not opts & 1:
        raise UnsupportedError("checkProximitySensorEx: MuJoCo's rays detect front faces only (set mode bit 0)")
    res, dist, point, hit, normal = ctx.sim.readProximitySensor(ctx.h(sensorHandle, "sensorHandle"))
    entity = ctx.h(entityHandle, "entityHandle")
    none = (0, 0.0, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0])
    if not res or dist > limit or (entity != -2 and hit != ctx.world.get(entity).handle):
        return none
    if opts & 8 and math.acos(max(-1.0, min(1.0, -float(normal[2])))) > angle:
        return none
    return res, dist, point, hit, normal


@sim_function("removeReferencedObjects")
def removeReferencedObjects(ctx: CallContext, objectHandle: Any, tag: Any = "") -> None:  # noqa: N802, N803
    """Remove from the scene the objects ``objectHandle`` references under ``tag``
    (``sim.setReferencedHandles``), then forget the references.

    ``sim.removeReferencedObjects``.

    Args:
        objectHandle: the referring object.
        tag: the tag (``""``: the default one).

    Raises:
        UnknownObjectError: no such object.
        UnsupportedError: no simulation behind the script.
    """
    sim = ctx.simulation("removeReferencedObjects")
    refs = ctx.sim.getReferencedHandles(objectHandle, tag)
    for h in refs:
        if h in ctx.world.objects:  # gone already with a removed parent: skip
            sim.editor.remove_object(h)
    ctx.sim.setReferencedHandles(objectHandle, [], tag)


@sim_function("createPureShape")
def createPureShape(ctx: CallContext, primitiveType: Any, options: Any, sizes: Any, mass: Any,  # noqa: N802, N803
                    precision: Any = None) -> int:
    """V-REP's ``simCreatePureShape``: ``primitiveType`` 0 cuboid, 1 sphere, 2 cylinder, 3 cone
    (refused: MuJoCo has no cone); ``options`` bit 3 (8): respondable, bit 4 (16): static;
    ``sizes`` x, y, z (m; a cuboid of z 0 is a plane, see ``createPrimitiveShape``); ``mass``
    (kg); ``precision`` (tessellation) has no meaning for MuJoCo's exact primitives.

    As CoppeliaSim 4.1's (``simCreatePureShape_internal`` -> ``CAddOperations::addPrimitiveShape``
    with ``dynamic`` set, coppeliaSimLib ``menusAndSimilar/addOperations.cpp``), the new shape is
    neither collidable, measurable, detectable nor renderable (its special properties cleared:
    ``sim.setObjectSpecialProperty`` gives them back); PyRep's ``Shape.create`` then sets
    renderable as asked.

    Args:
        primitiveType: 0-3.
        options: bit 3 (8): respondable; bit 4 (16): static.
        sizes: 3 numbers, m.
        mass: kg, clamped to [1e-6, 1e4] as CoppeliaSim 4.1 does.
        precision: ignored.

    Returns:
        The shape's handle.

    Raises:
        ArgumentError: an unknown type, sizes out of range, a mass that is not a number.
        UnsupportedError: a cone, or no simulation behind the script.
    """
    kind, opts = _int(primitiveType, "primitiveType"), _int(options, "options")
    if kind not in _PURE:
        raise ArgumentError("primitiveType must be 0 (cuboid), 1 (sphere), 2 (cylinder) or 3 (cone)")
    # 4.1 clamps the mass to [1e-6, 1e4] kg (tt::getLimitedFloat): RLBench's wipe_desk asks for 0
    kg = min(max(_num(mass, "mass"), 1e-6), 1e4)
    h = ctx.sim.createPrimitiveShape(_PURE[kind], sizes, 2 if opts & 16 else 0)
    ctx.sim.setShapeMass(h, kg)
    if not opts & 8:
        ctx.sim.setObjectInt32Param(h, _SHAPE_RESPONDABLE, 0)
    ctx.sim.setObjectSpecialProperty(h, int(ctx.sim.getObjectSpecialProperty(h)) & ~_PURE_CLEARED)
    return h


@sim_function("getThreadId")
def getThreadId(ctx: CallContext) -> int:  # noqa: N802
    """The id of the server thread running the call (Python's ``threading.get_ident``).

    ``sim.getThreadId``.

    Returns:
        The thread id.
    """
    return threading.get_ident()


