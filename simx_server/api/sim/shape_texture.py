"""The texture of a shape for ``sim.getShapeViz``: its first textured geom's RGB texture image
(MuJoCo's ``tex_data``, as RGBA bytes, rows as MuJoCo stores them) and the mesh's texture
coordinates (``mesh_texcoord``), in CoppeliaSim's ``texture`` map of ``sim.getShapeViz``
(``texture``, ``resolution``, ``coordinates``, ``applyMode``, ``options``, ``id``); and
``sim.applyTexture``, an image put on a mesh with coordinates per triangle corner."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.base import limits as L
from simx_server.base.arguments import as_bytes, as_integer
from simx_server.sim.objects import SHAPE
from simx_server.sim.spec_tools import _names, vrep_suffix
from simx_wire.protocol import ArgumentError

_RGB = int(mujoco.mjtTextureRole.mjTEXROLE_RGB)


def _texture_id(m: mujoco.MjModel, mat: int) -> int:
    ids = np.atleast_1d(m.mat_texid[mat])
    if ids.size > _RGB and ids[_RGB] >= 0:
        return int(ids[_RGB])
    found = [int(t) for t in ids if t >= 0]
    return found[0] if found else -1


def texture_of(m: mujoco.MjModel, body: int) -> dict[str, Any] | None:
    """The texture map of the first geom of ``body`` with a textured material, or None."""
    for g in np.flatnonzero(m.geom_bodyid == body):
        mat = int(m.geom_matid[g])
        tex = _texture_id(m, mat) if mat >= 0 else -1
        if tex < 0:
            continue
        w, h, nc = int(m.tex_width[tex]), int(m.tex_height[tex]), int(m.tex_nchannel[tex])
        adr = int(m.tex_adr[tex])
        pixels = np.asarray(m.tex_data[adr:adr + w * h * nc], dtype=np.uint8).reshape(h, w, nc)
        if nc == 3:
            pixels = np.concatenate([pixels, np.full((h, w, 1), 255, np.uint8)], axis=2)
        coords: list[float] = []
        if int(m.geom_type[g]) == int(mujoco.mjtGeom.mjGEOM_MESH):
            mesh = int(m.geom_dataid[g])
            tadr, tnum = int(m.mesh_texcoordadr[mesh]), int(m.mesh_texcoordnum[mesh])
            if tadr >= 0:
                coords = m.mesh_texcoord[tadr:tadr + tnum].reshape(-1).astype(float).tolist()
        return {"texture": pixels[:, :, :4].tobytes(), "resolution": [w, h], "coordinates": coords,
                "applyMode": 0, "options": 0, "id": tex}
    return None


@sim_function("applyTexture")
def applyTexture(ctx: CallContext, shapeHandle: Any, textureCoordinates: Any, texture: Any,  # noqa: N802, N803
                 textureResolution: Any, options: Any = 0) -> int:
    """Put an image on a shape of one mesh with a texture coordinate pair per triangle corner;
    the new texture's id. As coppeliaSimLib ``simApplyTexture_internal``: the shape's former
    texture goes; ``textureCoordinates`` holds 2 numbers per index of the mesh (6 per triangle);
    ``texture`` is ``w x h`` RGB bytes, RGBA with ``options`` bit 4 (16); bit 5 (32) flips it
    horizontally, bit 6 (64) vertically (``CTextureObject::setImage``: rows reversed); bit 0 (no
    interpolation) and bit 1 (decal) are checked. The mesh is made anew (its vertices and
    triangles as compiled, at the same place) with these coordinates, under a material of its
    own (the geom's colour kept). Rows and coordinates are as :func:`texture_of` reads them, so
    ``sim.getShapeViz``'s texture applied back changes nothing.

    ``sim.applyTexture``.

    Args:
        shapeHandle: a shape of one mesh geom.
        textureCoordinates: 6t numbers (u, v per triangle corner).
        texture: the image, w*h*3 (or *4) bytes or byte values, rows first.
        textureResolution: ``[w, h]``, pixels.
        options: bits as said.

    Returns:
        The texture's id.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a shape.
        ArgumentError: sizes that do not fit; a compound shape or one that is not a mesh.
        UnsupportedError: no simulation behind the caller.
    """
    obj = ctx.world.get(ctx.h(shapeHandle, "shapeHandle"), SHAPE)
    opts = as_integer(options, "options")
    m = ctx.world.model
    geoms = np.flatnonzero(m.geom_bodyid == obj.mj_id)
    if len(geoms) != 1 or int(m.geom_type[geoms[0]]) != int(mujoco.mjtGeom.mjGEOM_MESH):
        raise ArgumentError(f"applyTexture: {obj.name!r} is not a shape of one mesh (CoppeliaSim: "
                            "a compound shape cannot take a texture this way)")
    g = int(geoms[0])
    mesh = int(m.geom_dataid[g])
    faces = m.mesh_face[m.mesh_faceadr[mesh]:m.mesh_faceadr[mesh] + m.mesh_facenum[mesh]].copy()
    verts = m.mesh_vert[m.mesh_vertadr[mesh]:m.mesh_vertadr[mesh] + m.mesh_vertnum[mesh]].copy()
    try:
        uv = np.asarray(textureCoordinates, dtype=float).reshape(-1)
        w, h = (as_integer(x, "textureResolution[i]") for x in textureResolution)
    except (TypeError, ValueError):
        raise ArgumentError("applyTexture: textureCoordinates must be numbers, textureResolution [w, h]") from None
    if uv.size != faces.size * 2 or not np.all(np.isfinite(uv)):
        raise ArgumentError(f"applyTexture: {faces.size * 2} texture coordinates (2 per index of {obj.name!r}'s "
                            f"mesh), got {uv.size}")
    if not (w > 0 and h > 0 and w * h <= L.MAX_TEXTURE_PIXELS):
        raise ArgumentError(f"applyTexture: a resolution of at most {L.MAX_TEXTURE_PIXELS} pixels "
                            "(limits.MAX_TEXTURE_PIXELS)")
    channels = 4 if opts & 16 else 3
    pixels = np.frombuffer(as_bytes(texture, "texture", byte_values=True), np.uint8)
    if pixels.size != w * h * channels:
        raise ArgumentError(f"applyTexture: the texture must be {w}x{h}x{channels} bytes, got {pixels.size}")
    image = pixels.reshape(h, w, channels)
    if opts & 32:
        image = image[:, ::-1]
    if opts & 64:
        image = image[::-1]
    sim = ctx.simulation("applyTexture")
    pos, quat, rgba = m.geom_pos[g].tolist(), m.geom_quat[g].tolist(), m.geom_rgba[g].tolist()

    def change(spec: mujoco.MjSpec):
        geom = list(spec.body(obj.name).geoms)[0]
        base = f"{obj.name}_applied"
        name = base + vrep_suffix({base, base + "_mesh", base + "_material"}, _names(spec))
        tex = spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=w, height=h,
                               nchannel=channels)
        tex.data = np.ascontiguousarray(image).tobytes()
        mat = spec.add_material(name=name + "_material", rgba=rgba)  # the shape's colour, read and shown
        textures = list(mat.textures)
        textures[_RGB] = tex.name
        mat.textures = textures
        new = spec.add_mesh(name=name + "_mesh")
        old = spec.mesh(geom.meshname)
        if old is not None:
            new.inertia = old.inertia
        new.uservert, new.userface = verts.reshape(-1).tolist(), faces.reshape(-1).tolist()
        new.usertexcoord = uv.tolist()
        new.userfacetexcoord = list(range(faces.size))
        geom.meshname, geom.material, geom.rgba = new.name, mat.name, rgba
        geom.pos, geom.quat = pos, quat
        return lambda: int(mujoco.mj_name2id(sim.world.model, mujoco.mjtObj.mjOBJ_TEXTURE, name))

    return int(sim.editor._edit(change))
