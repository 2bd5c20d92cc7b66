"""The texture of a shape for ``sim.getShapeViz``: its first textured geom's RGB texture image
(MuJoCo's ``tex_data``, as RGBA bytes, rows as MuJoCo stores them) and the mesh's texture
coordinates (``mesh_texcoord``), in CoppeliaSim's ``texture`` map of ``sim.getShapeViz``
(``texture``, ``resolution``, ``coordinates``, ``applyMode``, ``options``, ``id``)."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

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
