"""CoppeliaSim 4.x's shape appearance, textures and the object string and float-array
parameters.

* ``getShapeAppearance`` returns, per geom of the shape, its colour (RGBA 0..1) and, where it has
  a MuJoCo material, the material's specular, emission and shininess; ``setShapeAppearance``
  writes such a map back (the save / change / restore use of CoppeliaSim's), and
  ``setShapeMaterial`` copies another shape's appearance. A material shared by several geoms
  changes for all of them, as in MuJoCo.
* Textures are MuJoCo's compiled textures: ``getTextureId`` by name, ``getShapeTextureId`` (the
  RGB texture of the shape's first geom's material), ``readTexture`` (RGB bytes, rows bottom-up
  as simx's images), ``setShapeTexture`` (a material of the shape's own with the texture).
* ``getObjectStringParam``: ``sim.objstringparam_unique_id`` (the uid as text),
  ``sim.shapestringparam_colorname`` (the first geom's name, the name ``setShapeColor`` matches);
  ``getObjectFloatArrayParam``: ``sim.visionfarrayparam_viewfrustum`` (a vision sensor's 8
  frustum corners in its frame: near plane then far plane, each -x-y, +x-y, +x+y, -x+y).
"""

from __future__ import annotations

import math
from typing import Any

import cv2
import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import sensing as _sensing
from simx_server.api.sim import services as _services
from simx_wire.protocol import ArgumentError, UnknownObjectError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_text as _text
from simx_server.sim.objects import SHAPE
from simx_server.sim.spec_tools import _names, vrep_suffix

UNIQUE_ID, COLORNAME, COLOR_NAME, VIEWFRUSTUM, CAMERA_VIEWFRUSTUM = 35, 3032, 3023, 1019, 9013


def _rgb_role() -> int:
    return int(mujoco.mjtTextureRole.mjTEXROLE_RGB)


# Appearance, textures, string and float-array parameters.

def _shape_geoms(ctx: CallContext, handle: Any) -> np.ndarray:
    obj = ctx.world.get(ctx.h(handle, "shapeHandle"), SHAPE)
    return np.flatnonzero(ctx.world.model.geom_bodyid == obj.mj_id)


@sim_function("getShapeAppearance")
def getShapeAppearance(ctx: CallContext, handle: Any, opts: Any = None) -> dict:  # noqa: N802
    """``{"geoms": [{"name", "color" (RGBA 0..1), ["specular", "emission", "shininess"]}]}``.

    ``sim.getShapeAppearance``.

    Args:
        handle: a shape's handle.
        opts: ignored.

    Returns:
        The map.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
    """
    m = ctx.world.model
    out = []
    for g in _shape_geoms(ctx, handle):
        item = {"name": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or "",
                "color": m.geom_rgba[g].tolist()}
        mat = int(m.geom_matid[g])
        if mat >= 0:
            item.update(color=m.mat_rgba[mat].tolist(), specular=float(m.mat_specular[mat]),
                        emission=float(m.mat_emission[mat]), shininess=float(m.mat_shininess[mat]))
        out.append(item)
    return {"geoms": out}


@sim_function("setShapeAppearance")
def setShapeAppearance(ctx: CallContext, handle: Any, savedData: Any, opts: Any = None) -> int:  # noqa: N802, N803
    """Apply a map :func:`getShapeAppearance` returned (one entry per geom, in order);
    returns the shape's handle.

    ``sim.setShapeAppearance``.

    Args:
        handle: a shape's handle.
        savedData: the map.
        opts: ignored.

    Returns:
        The shape's handle.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: a map that does not fit the shape, or colours out of 0..1.
    """
    geoms = _shape_geoms(ctx, handle)
    items = savedData.get("geoms") if isinstance(savedData, dict) else None
    if not isinstance(items, list) or len(items) != len(geoms):
        raise ArgumentError(f"savedData must hold 'geoms' with {len(geoms)} entries (getShapeAppearance's map)")
    m = ctx.world.model
    for g, item in zip(geoms, items):
        rgba = item.get("color") if isinstance(item, dict) else None
        if not isinstance(rgba, (list, tuple)) or len(rgba) != 4 or not all(0 <= float(c) <= 1 for c in rgba):
            raise ArgumentError("each geom's color must be 4 numbers in 0..1")
        m.geom_rgba[g] = rgba
        mat = int(m.geom_matid[g])
        if mat >= 0:
            m.mat_rgba[mat] = rgba
            for key, field in (("specular", m.mat_specular), ("emission", m.mat_emission),
                               ("shininess", m.mat_shininess)):
                if key in item:
                    field[mat] = float(item[key])
    ctx.world.version += 1
    return ctx.h(handle, "shapeHandle")


@sim_function("setShapeMaterial")
def setShapeMaterial(ctx: CallContext, shapeHandle: Any, materialIdOrShapeHandle: Any) -> None:  # noqa: N802, N803
    """Give a shape the appearance of another shape (``materialIdOrShapeHandle``), geom by geom
    (the first geom's for any beyond the other's count).

    ``sim.setShapeMaterial``.

    Args:
        shapeHandle: the shape to change.
        materialIdOrShapeHandle: the shape to copy from.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: the source shape has no geom.
    """
    src = getShapeAppearance(ctx, materialIdOrShapeHandle)["geoms"]
    n = len(_shape_geoms(ctx, shapeHandle))
    if not src:
        raise ArgumentError("the source shape has no geom")
    setShapeAppearance(ctx, shapeHandle, {"geoms": [src[i] if i < len(src) else src[0] for i in range(n)]})


@sim_function("getTextureId")
def getTextureId(ctx: CallContext, textureName: Any) -> tuple[int, list[int]]:  # noqa: N802, N803
    """``textureId, resolution`` of the MuJoCo texture named ``textureName``.

    ``sim.getTextureId``.

    Args:
        textureName: the texture's name.

    Returns:
        ``(textureId, [w, h])``, pixels.

    Raises:
        UnknownObjectError: no such texture.
    """
    name = _text(textureName, "textureName")
    m = ctx.world.model
    t = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TEXTURE, name)
    if t < 0:
        raise UnknownObjectError(f"no texture named {name!r}")
    return t, [int(m.tex_width[t]), int(m.tex_height[t])]


@sim_function("getShapeTextureId")
def getShapeTextureId(ctx: CallContext, shapeHandle: Any) -> int:  # noqa: N802, N803
    """The RGB texture of the shape's first geom's material; -1 when it has none.

    ``sim.getShapeTextureId``.

    Args:
        shapeHandle: a shape's handle.

    Returns:
        The texture id, or -1.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
    """
    m = ctx.world.model
    for g in _shape_geoms(ctx, shapeHandle):
        mat = int(m.geom_matid[g])
        return int(m.mat_texid[mat][_rgb_role()]) if mat >= 0 else -1
    return -1


@sim_function("readTexture")
def readTexture(ctx: CallContext, textureId: Any, options: Any = 0, posX: Any = 0, posY: Any = 0,  # noqa: N802, N803
                sizeX: Any = 0, sizeY: Any = 0) -> bytes:  # noqa: N803
    """RGB bytes (rows bottom-up) of a texture or of a window ``posX..posX+sizeX`` x
    ``posY..posY+sizeY`` of it (0 sizes: the whole).

    ``sim.readTexture``.

    Args:
        textureId: the texture id.
        options: checked, ignored.
        posX: pixels.
        posY: pixels.
        sizeX: pixels (0: to the edge).
        sizeY: pixels (0: to the edge).

    Returns:
        sizeX*sizeY*3 bytes.

    Raises:
        UnknownObjectError: no such texture.
        ArgumentError: a window outside the texture.
    """
    m = ctx.world.model
    t = _int(textureId, "textureId")
    if not 0 <= t < m.ntex:
        raise UnknownObjectError(f"no texture {t}")
    _int(options, "options")
    w, h, n = int(m.tex_width[t]), int(m.tex_height[t]), int(m.tex_nchannel[t])
    adr = int(m.tex_adr[t])
    img = np.asarray(m.tex_data[adr:adr + w * h * n], np.uint8).reshape(h, w, n)[::-1]
    img = np.repeat(img, 3, axis=2) if n == 1 else img[:, :, :3]
    x, y, sx, sy = (_int(v, k) for v, k in ((posX, "posX"), (posY, "posY"), (sizeX, "sizeX"), (sizeY, "sizeY")))
    sx, sy = sx or w - x, sy or h - y
    if x < 0 or y < 0 or sx <= 0 or sy <= 0 or x + sx > w or y + sy > h:
        raise ArgumentError(f"the window lies outside the {w}x{h} texture")
    return np.ascontiguousarray(img[y:y + sy, x:x + sx]).tobytes()


@sim_function("createTexture")
def createTexture(ctx: CallContext, fileName: Any, options: Any, planeSizes: Any = None, scalingUV: Any = None,  # noqa: N802, N803
                  xy_g: Any = None, fixedResolution: Any = 0, resolution: Any = None) -> tuple[int, int, list[int]]:  # noqa: N803
    """``shapeHandle, textureId, resolution``: an image file (read under ``loadImage``'s
    confinement) made a MuJoCo texture, shown on a new static plane shape at the world origin
    of ``planeSizes`` x, y (m; nil: 1 m wide, the image's aspect) with the texture repeated
    ``scalingUV`` u, v times. ``options``, ``xy_g``, ``fixedResolution`` and ``resolution``
    (OpenGL texture settings) are checked and have no further effect.

    ``sim.createTexture``.

    Args:
        fileName: an image file.
        options: checked.
        planeSizes: ``[x, y]`` m, or None.
        scalingUV: ``[u, v]``, or None.
        xy_g: checked.
        fixedResolution: checked.
        resolution: checked.

    Returns:
        ``(shapeHandle, textureId, [w, h])``.

    Raises:
        ArgumentError: not an image, or sizes that are not positive.
        RemoteError: a file outside ``loadImage``'s folders.
        UnsupportedError: no simulation behind the script.
    """
    _int(options, "options")
    _int(fixedResolution, "fixedResolution")
    data = _services.image_file(ctx, _text(fileName, "fileName"), False).read_bytes()
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    if img is None:
        raise ArgumentError("not an image OpenCV can read")
    h, w = img.shape[:2]
    rgb = np.ascontiguousarray(cv2.cvtColor(img, cv2.COLOR_BGR2RGB))
    sx, sy = (float(v) for v in (planeSizes or [1.0, h / w])[:2])
    u, v = (float(x) for x in (scalingUV or [1.0, 1.0])[:2])
    if not (sx > 0 and sy > 0 and u > 0 and v > 0):
        raise ArgumentError("planeSizes and scalingUV must be positive")
    sim = ctx.simulation("createTexture")

    def change(spec: mujoco.MjSpec):
        suffix = vrep_suffix({"Texture_plane", "Texture"}, _names(spec) | set(sim.world.by_name))
        tex = spec.add_texture(name=f"Texture{suffix}", type=mujoco.mjtTexture.mjTEXTURE_2D, width=w, height=h,
                               nchannel=3)
        tex.data = rgb.tobytes()
        mat = spec.add_material(name=f"Texture{suffix}_material", texrepeat=[u, v])
        textures = list(mat.textures)
        textures[_rgb_role()] = tex.name
        mat.textures = textures
        body = spec.worldbody.add_body(name=f"Texture_plane{suffix}")
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[sx / 2, sy / 2, 0.0005], material=mat.name)
        return lambda: (sim.world.resolve(f"Texture_plane{suffix}").handle,
                        mujoco.mj_name2id(sim.world.model, mujoco.mjtObj.mjOBJ_TEXTURE, f"Texture{suffix}"))

    shape, texture = sim.editor._edit(change)
    return shape, texture, [w, h]


@sim_function("setShapeTexture")
def setShapeTexture(ctx: CallContext, shapeHandle: Any, textureId: Any, mappingMode: Any, options: Any,  # noqa: N802, N803
                    uvScaling: Any, position: Any = None, orientation: Any = None) -> None:
    """Put MuJoCo texture ``textureId`` on the shape's geoms (a material of its own with that
    RGB texture, repeated ``uvScaling`` u, v times) or, with -1, take their materials off
    (their colour kept). MuJoCo maps a texture by the geom's type: ``mappingMode``,
    ``position`` and ``orientation`` are checked and have no further effect.

    ``sim.setShapeTexture``.

    Args:
        shapeHandle: a shape's handle.
        textureId: a texture id, or -1.
        mappingMode: checked.
        options: checked.
        uvScaling: ``[u, v]``, positive.
        position: ignored.
        orientation: ignored.

    Raises:
        UnknownObjectError: no such object or texture.
        ObjectTypeError: not a shape.
        ArgumentError: a bad ``uvScaling``.
        UnsupportedError: a texture without a name, or no simulation behind the script.
    """
    geoms = _shape_geoms(ctx, shapeHandle)
    obj = ctx.world.objects[ctx.h(shapeHandle, "shapeHandle")]
    m = ctx.world.model
    t = _int(textureId, "textureId")
    _int(mappingMode, "mappingMode")
    _int(options, "options")
    if t != -1 and not 0 <= t < m.ntex:
        raise UnknownObjectError(f"no texture {t}")
    if not isinstance(uvScaling, (list, tuple)) or len(uvScaling) < 2 or not all(float(v) > 0 for v in uvScaling[:2]):
        raise ArgumentError("uvScaling must hold 2 positive numbers")
    colours = [(m.mat_rgba[m.geom_matid[g]] if m.geom_matid[g] >= 0 else m.geom_rgba[g]).tolist() for g in geoms]
    texture = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TEXTURE, t) if t != -1 else None
    if t != -1 and not texture:
        raise UnsupportedError("setShapeTexture: the texture has no name to refer to")
    sim = ctx.simulation("setShapeTexture")

    def change(spec: mujoco.MjSpec) -> None:
        body = spec.body(obj.name)
        sources = list(body.geoms)
        if len(sources) != len(geoms):
            raise ValueError(f"{obj.name!r}'s geoms do not match its compiled model")
        material = ""
        if texture:
            material = f"{obj.name}_{texture}_texture"
            mat = spec.material(material) or spec.add_material(name=material)
            textures = list(mat.textures)
            textures[_rgb_role()] = texture
            mat.textures = textures
            mat.texrepeat = [float(uvScaling[0]), float(uvScaling[1])]
        for geom, rgba in zip(sources, colours):
            geom.material = material
            geom.rgba = rgba

    sim.editor._edit(change)


@sim_function("getObjectStringParam")
def getObjectStringParam(ctx: CallContext, objectHandle: Any, parameterID: Any) -> str:  # noqa: N802, N803
    """A string parameter (see the module's text); others: UnsupportedError naming it.

    ``sim.getObjectStringParam``.

    Args:
        objectHandle: the object's handle, or ``sim.handle_self``.
        parameterID: a ``sim.objstringparam_*`` / ``sim.shapestringparam_*`` value.

    Returns:
        The string.

    Raises:
        UnknownObjectError: no such object.
        UnsupportedError: another parameter.
    """
    h, pid = ctx.h(objectHandle), _int(parameterID, "parameterID")
    obj = ctx.world.get(h)
    if pid == UNIQUE_ID:
        return str(obj.handle)
    if pid in (COLORNAME, COLOR_NAME):
        g = _shape_geoms(ctx, h)
        return (mujoco.mj_id2name(ctx.world.model, mujoco.mjtObj.mjOBJ_GEOM, int(g[0])) or "") if len(g) else ""
    raise UnsupportedError(f"string parameter {pid} of {obj.name!r}: not supported by simx")


@sim_function("getObjectFloatArrayParam")
def getObjectFloatArrayParam(ctx: CallContext, objectHandle: Any, parameterID: Any) -> list[float]:  # noqa: N802, N803
    """``sim.visionfarrayparam_viewfrustum``: 24 numbers (m, see the module's text).

    ``sim.getObjectFloatArrayParam``.

    Args:
        objectHandle: a vision sensor's handle.
        parameterID: ``sim.visionfarrayparam_viewfrustum``.

    Returns:
        24 floats: the near and far planes' corners in the sensor's frame, m.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
        UnsupportedError: another parameter, or no simulation behind the script.
    """
    pid = _int(parameterID, "parameterID")
    if pid not in (VIEWFRUSTUM, CAMERA_VIEWFRUSTUM):
        raise UnsupportedError(f"float array parameter {pid}: not supported by simx")
    h = _sensing.vision_of(ctx, objectHandle)
    spec = ctx.simulation("getObjectFloatArrayParam").vision.spec(h)
    m = ctx.world.model
    cam = ctx.world.objects[h].mj_id
    aspect = spec.width / spec.height
    out = []
    for z in (spec.near, spec.far):
        if int(m.cam_projection[cam]) == int(mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC):
            hy = float(m.cam_fovy[cam]) / 2
        else:
            hy = math.tan(math.radians(float(m.cam_fovy[cam])) / 2) * z
        hx = hy * aspect
        out += [-hx, -hy, z, hx, -hy, z, hx, hy, z, -hx, hy, z]
    return out


