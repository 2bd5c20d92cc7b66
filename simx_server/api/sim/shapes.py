"""CoppeliaSim 4.x's shape functions of ``sim`` on MuJoCo bodies: colours, bounding boxes, meshes
and primitive shapes (mass and inertia: :mod:`simx_server.api.sim.inertia`).

A V-REP shape is a MuJoCo body (:mod:`simx_server.sim.objects`); its geoms are its components.
Mass and inertia are the body's (``body_mass``, ``body_inertia`` in the principal frame
``body_ipos``/``body_iquat``); set ones are written to the model and to the scene's MjSpec, so
that they survive later edits. Colours are the geoms' ``rgba`` (or their material's).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import shape_texture
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_text as _text, as_vector as _vector
from simx_server.sim import friction, shape_looks, vision_look
from simx_server.sim.mechanisms import rigid_contact
from simx_server.sim.objects import DUMMY, LIGHT, SHAPE
from simx_server.sim.spec_tools import _names, vrep_suffix

#: CoppeliaSim's ``sim.primitiveshape_*`` -> (V-REP name, MuJoCo geom type).
PRIMITIVES = {1: ("Plane", mujoco.mjtGeom.mjGEOM_BOX), 2: ("Disc", mujoco.mjtGeom.mjGEOM_CYLINDER),
              3: ("Cuboid", mujoco.mjtGeom.mjGEOM_BOX), 4: ("Sphere", mujoco.mjtGeom.mjGEOM_ELLIPSOID),
              5: ("Cylinder", mujoco.mjtGeom.mjGEOM_CYLINDER), 8: ("Capsule", mujoco.mjtGeom.mjGEOM_CAPSULE)}
#: MuJoCo's default material specular level (what a geom without material is drawn with in MuJoCo's look).
MUJOCO_SPECULAR = 0.5
_THIN = 0.0005  # m: half thickness of a plane or a disc (MuJoCo has no zero-thickness solid)


def _geoms(world: Any, body: int) -> np.ndarray:
    return np.flatnonzero(world.model.geom_bodyid == body)


def _geom_pose(m: mujoco.MjModel, g: int) -> tuple[np.ndarray, np.ndarray]:
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, m.geom_quat[g])
    return m.geom_pos[g].copy(), rot.reshape(3, 3)


# Shape colours, bounding boxes, meshes, primitive shapes.

def shape_of(ctx: CallContext, handle: Any) -> Any:
    return ctx.world.get(ctx.h(handle, "shapeHandle"), SHAPE)


@sim_function("getShapeColor")
def getShapeColor(ctx: CallContext, shapeHandle: Any, colorName: Any, colorComponent: Any) -> tuple[int, list[float]]:  # noqa: N802, N803
    """``result, rgbData`` of the shape's first geom named ``colorName`` (any for nil or
    ``""``): component 0/1 ambient-diffuse/diffuse the RGB (its material's when it has one),
    2 specular and 3 emission the colours the vision sensors draw it with (those
    ``sim.setShapeColor`` set, else its material's, else the look's default:
    :mod:`simx_server.sim.shape_looks`), 4 transparency {1 - alpha}. result 0 when no geom matches.

    ``sim.getShapeColor``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        colorName: a geom's name, or None / ``""`` (any).
        colorComponent: 0-4 (``sim.colorcomponent_*``).

    Returns:
        ``(result, rgbData)``: 1 or 0, and 3 floats in 0..1 (1 for transparency).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: a component out of 0-4.
    """
    obj = shape_of(ctx, shapeHandle)
    name = None if colorName is None else _text(colorName, "colorName")
    component = _int(colorComponent, "colorComponent")
    m = ctx.world.model
    for g in _geoms(ctx.world, obj.mj_id):
        if name and mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(g)) != name:
            continue
        mat = int(m.geom_matid[g])
        rgba = m.mat_rgba[mat] if mat >= 0 else m.geom_rgba[g]
        if component in (0, 1):
            return 1, [float(v) for v in rgba[:3]]
        if component == 4:
            return 1, [1.0 - float(rgba[3])]
        if component in (shape_looks.SPECULAR, shape_looks.EMISSION):  # as the sensors draw it
            default = vision_look.DEFAULT_SPECULAR if vision_look.asks_vrep(m) else MUJOCO_SPECULAR
            return 1, shape_looks.component(m, int(g), component, default)
        raise ArgumentError(f"colorComponent {component}: 0-4 (sim.colorcomponent_*)")
    return 0, [0.0, 0.0, 0.0]


@sim_function("getObjectColor")
def getObjectColor(ctx: CallContext, objectHandle: Any, index: Any, colorComponent: Any) -> list[float] | None:  # noqa: N802, N803
    """Colour of a shape's ``index``-th geom (as :func:`getShapeColor`) or of a dummy (its
    site's rgba); nil (None) for an index past the last.

    ``sim.getObjectColor``.

    Args:
        objectHandle: a shape or dummy.
        index: 0-based geom index (a dummy has index 0).
        colorComponent: 0-4 (``sim.colorcomponent_*``).

    Returns:
        3 floats in 0..1 (1 for transparency), or None.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: neither a shape nor a dummy.
        UnsupportedError: an unnamed geom after the first.
    """
    obj = ctx.world.get(ctx.h(objectHandle))
    i, m = _int(index, "index"), ctx.world.model
    if obj.type == DUMMY:
        if i != 0:
            return None
        rgba = m.site_rgba[obj.mj_id]
        return [1.0 - float(rgba[3])] if _int(colorComponent, "colorComponent") == 4 else rgba[:3].tolist()
    geoms = _geoms(ctx.world, shape_of(ctx, objectHandle).mj_id)
    if not 0 <= i < len(geoms):
        return None
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(geoms[i]))
    if name is None and i > 0:
        raise UnsupportedError("getObjectColor of an unnamed geom after the first: name the geoms in the MJCF")
    return getShapeColor(ctx, objectHandle, name, colorComponent)[1]


@sim_function("setObjectColor")
def setObjectColor(ctx: CallContext, objectHandle: Any, index: Any, colorComponent: Any, rgbData: Any) -> bool:  # noqa: N802, N803
    """Colour of a shape's ``index``-th geom (as ``setShapeColor``); false past the last.

    ``sim.setObjectColor``.

    Args:
        objectHandle: a shape's handle.
        index: 0-based geom index.
        colorComponent: 0-4 (``sim.colorcomponent_*``).
        rgbData: 3 numbers in 0..1 (transparency: 1).

    Returns:
        True, or False past the last geom.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: a bad colour or component.
    """
    geoms = _geoms(ctx.world, shape_of(ctx, objectHandle).mj_id)
    i = _int(index, "index")
    if not 0 <= i < len(geoms):
        return False
    name = mujoco.mj_id2name(ctx.world.model, mujoco.mjtObj.mjOBJ_GEOM, int(geoms[i]))
    ctx.sim.setShapeColor(objectHandle, name or "", colorComponent, rgbData)
    return True


def corners(ctx: CallContext, body: int) -> np.ndarray:
    m = ctx.world.model
    out = []
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for g in _geoms(ctx.world, body):
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE:
            continue
        pos, rot = _geom_pose(m, int(g))
        if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:  # its vertices: a rotated box would overstate it
            mid = int(m.geom_dataid[g])
            out.append(m.mesh_vert[m.mesh_vertadr[mid]:m.mesh_vertadr[mid] + m.mesh_vertnum[mid]] @ rot.T + pos)
            continue
        center, half = m.geom_aabb[g][:3], m.geom_aabb[g][3:]
        out.append((center + signs * half) @ rot.T + pos)
    if not out:
        raise UnsupportedError("the shape has no bounded geom (a plane, or none)")
    return np.vstack(out)


@sim_function("getShapeBB")
def getShapeBB(ctx: CallContext, shapeHandle: Any) -> list[float]:  # noqa: N802, N803
    """Size ``[x, y, z]`` (m) of the shape's bounding box in its own frame.

    ``sim.getShapeBB``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.

    Returns:
        3 floats, m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
    """
    c = corners(ctx, shape_of(ctx, shapeHandle).mj_id)
    return (c.max(axis=0) - c.min(axis=0)).tolist()


@sim_function("getShapeMesh")
def getShapeMesh(ctx: CallContext, shapeHandle: Any) -> tuple[list[float], list[int], list[float]]:  # noqa: N802, N803
    """``vertices, indices, normals`` of the shape's mesh and box geoms in the shape's frame
    (m; 3 numbers per vertex, 3 indices per triangle, 9 normal numbers per triangle).
    UnsupportedError for a shape with other primitives (spheres, cylinders...: MuJoCo keeps
    no mesh of them).

    ``sim.getShapeMesh``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.

    Returns:
        ``(vertices, indices, normals)``: 3n floats (m), 3t ints, 9t floats.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        UnsupportedError: a geom other than a mesh or box, or no geom.
    """
    obj = shape_of(ctx, shapeHandle)
    m = ctx.world.model
    verts, faces = [], []
    for g in _geoms(ctx.world, obj.mj_id):
        pos, rot = _geom_pose(m, int(g))
        kind = int(m.geom_type[g])
        if kind == mujoco.mjtGeom.mjGEOM_MESH:
            mid = int(m.geom_dataid[g])
            v = m.mesh_vert[m.mesh_vertadr[mid]:m.mesh_vertadr[mid] + m.mesh_vertnum[mid]]
            f = m.mesh_face[m.mesh_faceadr[mid]:m.mesh_faceadr[mid] + m.mesh_facenum[mid]]
        elif kind == mujoco.mjtGeom.mjGEOM_BOX:
            s = m.geom_size[g]
            v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * s
            f = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                          [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]])
        else:
            raise UnsupportedError(f"getShapeMesh: geom {g} is a MuJoCo {mujoco.mjtGeom(kind).name}, "
                                   "which has no mesh (only mesh and box geoms)")
        base = sum(len(x) for x in verts)
        verts.append(v @ rot.T + pos)
        faces.append(np.asarray(f) + base)
    if not verts:
        raise UnsupportedError("the shape has no geom")
    v, f = np.vstack(verts), np.vstack(faces)
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return v.reshape(-1).tolist(), f.reshape(-1).astype(int).tolist(), np.repeat(n, 3, axis=0).reshape(-1).tolist()


@sim_function("getShapeGeomInfo")
def getShapeGeomInfo(ctx: CallContext, shapeHandle: Any) -> tuple[int, int, list[float]]:  # noqa: N802, N803
    """``result, pureType, dimensions``: result bit 0 compound (several geoms), bit 1 pure
    (one primitive); pureType a ``sim.primitiveshape_*``; dimensions the bounding box (m).

    ``sim.getShapeGeomInfo``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.

    Returns:
        ``(result, pureType, dimensions)``: int, int, 3 floats (m).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
    """
    obj = shape_of(ctx, shapeHandle)
    m = ctx.world.model
    geoms = _geoms(ctx.world, obj.mj_id)
    types = {mujoco.mjtGeom.mjGEOM_BOX: 3, mujoco.mjtGeom.mjGEOM_SPHERE: 4, mujoco.mjtGeom.mjGEOM_ELLIPSOID: 4,
             mujoco.mjtGeom.mjGEOM_CYLINDER: 5, mujoco.mjtGeom.mjGEOM_CAPSULE: 8, mujoco.mjtGeom.mjGEOM_PLANE: 1}
    pure = types.get(int(m.geom_type[geoms[0]]), 0) if len(geoms) == 1 else 0
    dims = getShapeBB(ctx, shapeHandle) if len(geoms) and pure != 1 else [0.0, 0.0, 0.0]
    return int(len(geoms) > 1) | (2 if pure else 0), pure, dims


@sim_function("getShapeViz")
def getShapeViz(ctx: CallContext, shapeHandle: Any, itemIndex: Any) -> dict:  # noqa: N802, N803
    """``{vertices, indices, normals, colors}`` of the shape's mesh (:func:`getShapeMesh`).

    ``sim.getShapeViz``.

    Args:
        shapeHandle: a shape's handle, or ``sim.handle_self``.
        itemIndex: ignored (the whole shape).

    Returns:
        A dict: ``vertices`` (3n floats, m), ``indices`` (3t ints), ``normals`` (9t floats),
        ``colors`` (9 floats, 0..1), and for a textured shape ``texture``
        (:mod:`.shape_texture`).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        UnsupportedError: a geom other than a mesh or box.
    """
    v, i, n = getShapeMesh(ctx, shapeHandle)
    _, rgb = getShapeColor(ctx, shapeHandle, None, 0)
    viz = {"vertices": v, "indices": i, "normals": n, "colors": rgb + rgb + rgb}
    texture = shape_texture.texture_of(ctx.world.model, shape_of(ctx, shapeHandle).mj_id)
    return viz if texture is None else {**viz, "texture": texture}


@sim_function("changeEntityColor")
def changeEntityColor(ctx: CallContext, entityHandle: Any, newColor: Any, colorComponent: Any = 0) -> list[dict]:  # noqa: N802, N803
    """Colour every geom of a shape and the shapes below it (RGB 0..1; component 0/1 the
    colour, 4 transparency); returns the original colours for :func:`restoreEntityColor`.

    ``sim.changeEntityColor``.

    Args:
        entityHandle: a shape's handle.
        newColor: 3 numbers in 0..1 (component 4: the first is the transparency).
        colorComponent: 0, 1 or 4.

    Returns:
        The saved colours (one dict per geom).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: a colour out of 0..1.
    """
    root = shape_of(ctx, entityHandle)
    m, world = ctx.world.model, ctx.world
    rgb = _vector(newColor, 3, "newColor")
    if not all(0 <= v <= 1 for v in rgb):
        raise ArgumentError("newColor components must lie in 0..1")
    shapes = [o for o in world.objects.values() if o.type == SHAPE and _in_tree(ctx, o.mj_id, root.mj_id)]
    saved = []
    for o in shapes:
        for g in _geoms(world, o.mj_id):
            saved.append({"geom": int(g), "rgba": m.geom_rgba[g].tolist(), "matid": int(m.geom_matid[g])})
            if _int(colorComponent, "colorComponent") == 4:
                m.geom_rgba[g][3] = 1.0 - rgb[0]
            else:
                m.geom_rgba[g][:3], m.geom_matid[g] = rgb, -1
    world.version += 1
    return saved


@sim_function("restoreEntityColor")
def restoreEntityColor(ctx: CallContext, originalColorData: Any) -> None:  # noqa: N802, N803
    """Put back the colours :func:`changeEntityColor` returned (until the scene is edited).

    ``sim.restoreEntityColor``.

    Args:
        originalColorData: the list :func:`changeEntityColor` returned.

    Raises:
        ArgumentError: not that list, or one that no longer fits the scene.
    """
    m = ctx.world.model
    for item in originalColorData or []:
        if not isinstance(item, dict) or not {"geom", "rgba", "matid"} <= set(item):
            raise ArgumentError("originalColorData must be what changeEntityColor returned")
        g = _int(item["geom"], "geom")
        if not 0 <= g < m.ngeom:
            raise ArgumentError("originalColorData does not fit the scene (edited since?)")
        m.geom_rgba[g], m.geom_matid[g] = _vector(item["rgba"], 4, "rgba"), _int(item["matid"], "matid")
    ctx.world.version += 1


def _in_tree(ctx: CallContext, body: int, root: int) -> bool:
    parents = ctx.world.model.body_parentid
    while body > 0:
        if body == root:
            return True
        body = int(parents[body])
    return False


@sim_function("getLightParameters")
def getLightParameters(ctx: CallContext, lightHandle: Any) -> tuple[int, list[float], list[float], list[float]]:  # noqa: N802, N803
    """``state, zero, diffusePart, specularPart`` of a light (MuJoCo's ``light_active``,
    ``light_diffuse``, ``light_specular``; the second, CoppeliaSim's ambient, is 0s).

    ``sim.getLightParameters``.

    Args:
        lightHandle: a light's handle.

    Returns:
        ``(state, zero, diffusePart, specularPart)``: 0/1 and three lists of 3 floats (0..1).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a light.
    """
    obj = ctx.world.get(ctx.h(lightHandle, "lightHandle"), LIGHT)
    m = ctx.world.model
    return (int(m.light_active[obj.mj_id]), [0.0, 0.0, 0.0], m.light_diffuse[obj.mj_id].tolist(),
            m.light_specular[obj.mj_id].tolist())


@sim_function("setLightParameters")
def setLightParameters(ctx: CallContext, lightHandle: Any, state: Any, zero: Any = None, diffusePart: Any = None,  # noqa: N802, N803
                       specularPart: Any = None) -> None:  # noqa: N803
    """Switch a light on (1) or off (0) and set its diffuse and specular colours (0..1; nil keeps).

    ``sim.setLightParameters``.

    Args:
        lightHandle: a light's handle.
        state: bit 0: on.
        zero: ignored (CoppeliaSim's ambient part).
        diffusePart: 3 numbers in 0..1, or None.
        specularPart: 3 numbers in 0..1, or None.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a light.
        ArgumentError: a colour out of 0..1.
    """
    obj = ctx.world.get(ctx.h(lightHandle, "lightHandle"), LIGHT)
    m = ctx.world.model
    m.light_active[obj.mj_id] = bool(_int(state, "state") & 1)
    for part, field in ((diffusePart, m.light_diffuse), (specularPart, m.light_specular)):
        if part is not None:
            values = _vector(part, 3, "colour")
            if not all(0 <= v <= 1 for v in values):
                raise ArgumentError("colour components must lie in 0..1")
            field[obj.mj_id] = values
    ctx.world.version += 1


@sim_function("copyPasteObjects")
def copyPasteObjects(ctx: CallContext, objectHandles: Any, options: Any = 0) -> list[int]:  # noqa: N802, N803
    """Copies of shapes (with their body subtrees), dummies, sensors and lights, as
    ``simxCopyPasteObjects``; the copies' handles.

    ``sim.copyPasteObjects``.

    Args:
        objectHandles: list of handles.
        options: checked, ignored.

    Returns:
        The copies' handles, in order.

    Raises:
        ArgumentError: not a list of integers.
        UnknownObjectError: no such object.
        UnsupportedError: an object simx cannot copy, or no simulation behind the script.
    """
    if not isinstance(objectHandles, (list, tuple)):
        raise ArgumentError("objectHandles must be a table of handles")
    _int(options, "options")
    return ctx.simulation("copyPasteObjects").editor.copy_paste([_int(h, "objectHandles[i]") for h in objectHandles])


@sim_function("createPrimitiveShape")
def createPrimitiveShape(ctx: CallContext, primitiveType: Any, sizes: Any, options: Any = 0) -> int:  # noqa: N802, N803
    """A new shape at the world origin: ``sim.primitiveshape_plane`` (1), ``disc`` (2),
    ``cuboid`` (3), ``spheroid`` (4), ``cylinder`` (5), ``capsule`` (8); ``sizes`` x, y, z (m,
    full extents; a cuboid of z 0 is a plane). A plane or disc is a box or cylinder 1 mm thick
    for MuJoCo, with a bounding box of no height (``flat=1``,
    :mod:`simx_server.sim.bounding_boxes`), as CoppeliaSim's. The shape is a dynamic, respondable free body of 1,000 kg/m³ (call
    ``sim.setShapeMass``); ``options`` bit 1 (value 2) makes it static. Cones and
    heightfields: UnsupportedError (MuJoCo has no cone geom). Returns its handle.

    ``sim.createPrimitiveShape``.

    Args:
        primitiveType: a ``sim.primitiveshape_*`` value.
        sizes: 3 numbers, m, each in (0, 1000] (a plane's z, a disc's y and z: anything).
        options: bit 1 (2): static.

    Returns:
        The shape's handle.

    Raises:
        UnsupportedError: a cone or heightfield, or no simulation behind the script.
        ArgumentError: sizes out of range.
    """
    kind = _int(primitiveType, "primitiveType")
    if kind not in PRIMITIVES:
        raise UnsupportedError(f"createPrimitiveShape type {kind}: simx makes planes, discs, cuboids, "
                               "spheroids, cylinders and capsules (MuJoCo has no cone geom)")
    x, y, z = _vector(sizes, 3, "sizes")
    if kind == 3 and z == 0:
        kind = 1  # a cuboid of no height is a plane
    flat = kind in (1, 2)  # a plane or a disc: no thickness, so no height in its bounding box
    if not all(0 < v <= 1000 for v in {1: (x, y), 2: (x,)}.get(kind, (x, y, z))):
        raise ArgumentError("sizes must lie in (0, 1000] m (a plane's z, a disc's y and z: any)")
    opts = _int(options, "options")
    base, gtype = PRIMITIVES[kind]
    size = {1: [x / 2, y / 2, _THIN], 2: [x / 2, _THIN, 0], 3: [x / 2, y / 2, z / 2], 4: [x / 2, y / 2, z / 2],
            5: [x / 2, z / 2, 0], 8: [x / 2, max(z / 2 - x / 2, 1e-4), 0]}[kind]
    if kind == 4 and x == y == z:
        gtype, size = mujoco.mjtGeom.mjGEOM_SPHERE, [x / 2, 0, 0]
    sim = ctx.simulation("createPrimitiveShape")

    def change(spec: mujoco.MjSpec):
        name = base + vrep_suffix({base}, _names(spec) | set(sim.world.by_name))
        body = spec.worldbody.add_body(name=name)
        if not opts & 2:
            body.add_freejoint()
        geom = body.add_geom(type=gtype, size=size, density=1000.0, rgba=[0.85, 0.85, 0.85, 1.0])
        friction.new_shape(spec, geom)  # CoppeliaSim's default material in a V-REP scene
        rigid_contact(geom, spec.option.timestep, bool(opts & 2))  # V-REP's, as a shape of a .ttt
        if flat:  # its bounding box has no height (simx_server.sim.bounding_boxes)
            spec.add_text(name=f"simx:{name}", data="flat=1")
        return lambda: sim.world.resolve(name).handle

    return sim.editor._edit(change)


