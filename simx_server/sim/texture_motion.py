"""A shape's texture parameters at run time: ``sim.shapefloatparam_texture_x/y/z`` (3006-3008, m),
``_texture_a/b/g`` (3009-3011, rad) and ``_texture_scaling_x/y`` (3012-3013, m), which V-REP's
conveyor belts set at each step to slide the belt's texture (``texture_x = t * velocity``).

CoppeliaSim (coppeliaSimLib ``simSetObjectFloatParam_internal``) sets the texture's pose relative
to the shape and its scaling, and ``CTextureProperty::getTextureCoordinates`` computes the
coordinates again from them, for a texture mapped by projection; coordinates the shape keeps
(``_fixedTextureCoordinates``, an imported mesh's) do not move. A converted ``.ttt`` records
how such a texture is mapped (the ``texture_map=`` setting of its shape: mapping, scaling and
pose, :mod:`simx_server.scene.ttt.geoms`); here the texture coordinates of the shape's first
textured mesh (MuJoCo's ``mesh_texcoord``, one pair per triangle corner) follow a new position or
scaling of a planar mapping (``u = a / sx + 0.5``, ``v = b / sy + 0.5``, ``a, b`` the corner in
the texture's frame), and the render threads upload the mesh again before their next frame
(:func:`uploads`). A texture rotated at run time, a cube mapping's new pose and a shape without
a recorded mapping keep their coordinates (said once in the log); the values set are kept and
read back. The coordinates stay where they were moved when the simulation stops, as CoppeliaSim
keeps a shape's texture settings.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import weakref

import mujoco
import numpy as np

from simx_server.sim.objects import SceneObject
from simx_server.sim.rotations import euler_from_matrix, matrix_from_quaternion

__all__ = ["IDS", "get", "set_value", "uploads"]

#: ``sim.shapefloatparam_texture_x`` ... ``_texture_scaling_y``.
IDS = range(3006, 3014)
_PLANE = 0
_MESH = int(mujoco.mjtGeom.mjGEOM_MESH)
log = logging.getLogger("simx.sim")
_told: set[str] = set()


@dataclasses.dataclass
class _Texture:
    """The texture of a shape's first textured mesh: its mapping and its values now."""

    mode: int
    values: np.ndarray  # (8,) x y z, alpha beta gamma, scaling x y: what 3006-3013 read
    start: np.ndarray  # (8,) the values the coordinates were computed with
    rotation: np.ndarray  # (3, 3) the texture frame's rotation in the shape's frame
    mesh: int  # MuJoCo mesh id, -1 without a mapping
    coords: np.ndarray  # (k, 2) the mesh's texture coordinates as compiled


#: model -> {shape name -> _Texture}; model -> (version, mesh ids moved) for the render threads.
_STATES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_UPLOADS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _texture(world, obj: SceneObject) -> _Texture:
    states = _STATES.setdefault(world.model, {})
    t = states.get(obj.name)
    if t is not None:
        return t
    m = world.model
    raw = obj.settings.get("texture_map", "")
    try:
        v = [float(x) for x in raw.split(",")]
    except ValueError:
        v = []
    geoms = [g for g in np.flatnonzero(m.geom_bodyid == obj.mj_id)
             if int(m.geom_type[g]) == _MESH and m.geom_matid[g] >= 0 and (m.mat_texid[m.geom_matid[g]] >= 0).any()]
    if len(v) != 10 or not geoms or not all(math.isfinite(x) for x in v) or min(v[1], v[2]) <= 0:
        t = _Texture(-1, np.zeros(8), np.zeros(8), np.eye(3), -1, np.zeros((0, 2)))
    else:
        mesh = int(m.geom_dataid[geoms[0]])
        adr, num = int(m.mesh_texcoordadr[mesh]), int(m.mesh_texcoordnum[mesh])
        qw, qx, qy, qz = v[6:10]
        rot = matrix_from_quaternion(qx, qy, qz, qw)
        values = np.array([*v[3:6], *euler_from_matrix(rot), v[1], v[2]])
        t = _Texture(int(v[0]), values, values.copy(), rot, mesh if adr >= 0 else -1,
                     m.mesh_texcoord[adr:adr + num].copy() if adr >= 0 else np.zeros((0, 2)))
    states[obj.name] = t
    return t


def get(world, obj: SceneObject, pid: int) -> float | None:
    """A texture parameter of a shape (3006-3013): the value last set, else the file's.

    Args:
        world: the World.
        obj: a shape.
        pid: 3006-3013.

    Returns:
        The value (m or rad); None for a shape without a recorded mapping (simx does not keep
        where another texture lies).
    """
    t = _texture(world, obj)
    return None if t.mesh < 0 else float(t.values[pid - IDS[0]])


def set_value(world, obj: SceneObject, pid: int, value: float) -> None:
    """Set a texture parameter of a shape (see the module): a planar mapping's coordinates follow
    its position and scaling.

    Args:
        world: the World.
        obj: a shape.
        pid: 3006-3013.
        value: m (position, scaling) or rad (angles); a scaling must be positive.
    """
    t = _texture(world, obj)
    k = pid - IDS[0]
    if k >= 6 and value <= 0:
        return  # CTextureProperty::setTextureScaling keeps a positive scaling
    t.values[k] = value
    if t.mesh < 0 or t.mode != _PLANE or np.any(t.values[3:6] != t.start[3:6]):
        why = ("has no texture mapped by projection" if t.mesh < 0 else
               "has a texture not mapped on a plane" if t.mode != _PLANE else "had its texture turned")
        if obj.name not in _told:
            _told.add(obj.name)
            log.info("shape %r %s: its texture coordinates stay where they are in simx", obj.name, why)
        return
    _move(world.model, t)


def _move(m: mujoco.MjModel, t: _Texture) -> None:
    """The planar mapping's coordinates at the texture's position and scaling now (MuJoCo keeps
    ``1 - v``)."""
    s0, s = t.start[6:8], t.values[6:8]
    shift = t.rotation.T @ (t.values[:3] - t.start[:3])  # the texture's move, in its own frame
    a = (t.coords[:, 0] - 0.5) * s0[0] - shift[0]
    b = (0.5 - t.coords[:, 1]) * s0[1] - shift[1]
    adr = int(m.mesh_texcoordadr[t.mesh])
    m.mesh_texcoord[adr:adr + len(t.coords), 0] = a / s[0] + 0.5
    m.mesh_texcoord[adr:adr + len(t.coords), 1] = 0.5 - b / s[1]
    version, meshes = _UPLOADS.get(m, (0, frozenset()))
    _UPLOADS[m] = (version + 1, meshes | {t.mesh})


def uploads(m: mujoco.MjModel) -> tuple[int, frozenset[int]]:
    """What the render threads upload again (``mujoco.mjr_uploadMesh``) for ``m``: the version of
    the texture coordinates moved at run time and the meshes they belong to.

    Args:
        m: a model.

    Returns:
        ``(version, mesh ids)``: (0, empty) when none moved.
    """
    return _UPLOADS.get(m, (0, frozenset()))
