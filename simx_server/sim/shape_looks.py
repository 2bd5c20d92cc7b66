"""A shape's colour components that MuJoCo keeps no per-geom field for: its specular colour, its
emission colour and its shininess, as V-REP's colour object holds them (coppeliaSimLib
``CColorObject``: ambient-diffuse ``_colors[0:3]``, specular ``[6:9]``, emission ``[9:12]``,
``_shininess``; ``makeColorCurrent`` draws every shape with the three colours and the
shininess).

MuJoCo draws a geom with its material's specular level, shininess and emission multiple, or
defaults where it has none. ``sim.setShapeColor`` (:mod:`simx_server.api.sim.shape_import`) sets
one component of a shape's geoms at run time, as ``CColorObject::setColor`` does, and leaves the
others: a geom's ambient-diffuse colour is its ``geom_rgba`` (the material, whose colour would
hide it, is dropped: its specular, shininess and emission are kept here first); the specular and
emission colours are kept here, per geom, by model. Each frame a vision sensor draws, the renderer
gives the geoms kept here those values (:func:`apply`, from :mod:`simx_server.sim.vision_look`):
MuJoCo's specular is a level (the colour's mean) and its emission a multiple of the geom's colour
(the multiple closest to the emission colour), as a converted scene's materials are
(:class:`simx_server.scene.ttt.looks.Materials`).
"""

from __future__ import annotations

import weakref

import mujoco
import numpy as np

#: Colour components of ``sim.setShapeColor`` kept here (``sim.colorcomponent_specular``, ``_emission``).
SPECULAR, EMISSION = 2, 3


class GeomLooks:
    """The kept components of a model's geoms, NaN where a geom has none of its own.

    Args:
        ngeom: the model's geom count.
    """

    def __init__(self, ngeom: int) -> None:
        self.specular = np.full((ngeom, 3), np.nan)
        self.emission = np.full((ngeom, 3), np.nan)
        self.shininess = np.full(ngeom, np.nan)  # OpenGL's exponent, 0-128

    def kept(self) -> np.ndarray:
        """Which geoms have a component of their own.

        Returns:
            (ngeom,) bool.
        """
        return ~(np.isnan(self.specular[:, 0]) & np.isnan(self.emission[:, 0]) & np.isnan(self.shininess))


_LOOKS: "weakref.WeakKeyDictionary[mujoco.MjModel, GeomLooks]" = weakref.WeakKeyDictionary()


def of(model: mujoco.MjModel) -> GeomLooks | None:
    """The kept components of ``model``'s geoms, None where none was kept.

    Args:
        model: the model.

    Returns:
        The :class:`GeomLooks`, or None.
    """
    return _LOOKS.get(model)


def made(model: mujoco.MjModel) -> GeomLooks:
    """The kept components of ``model``'s geoms, made (none kept) where there were none.

    Args:
        model: the model.

    Returns:
        The :class:`GeomLooks`.
    """
    looks = _LOOKS.get(model)
    if looks is None:
        looks = _LOOKS[model] = GeomLooks(model.ngeom)
    return looks


def keep_material(model: mujoco.MjModel, geom: int) -> None:
    """Before a geom loses its material: keep what the material gave it that its ``rgba`` does
    not hold (specular level, shininess, emission colour), unless the geom has its own already.

    Args:
        model: the model.
        geom: the geom's id.
    """
    mat = int(model.geom_matid[geom])
    if mat < 0:
        return
    looks = made(model)
    if np.isnan(looks.specular[geom, 0]):
        looks.specular[geom] = float(model.mat_specular[mat])
    if np.isnan(looks.shininess[geom]):
        looks.shininess[geom] = float(model.mat_shininess[mat]) * 128.0
    if np.isnan(looks.emission[geom, 0]):
        looks.emission[geom] = float(model.mat_emission[mat]) * model.mat_rgba[mat, :3]


def set_component(model: mujoco.MjModel, geom: int, component: int, rgb) -> None:
    """A geom's specular or emission colour (``CColorObject::setColor``).

    Args:
        model: the model.
        geom: the geom's id.
        component: SPECULAR or EMISSION.
        rgb: 3 values in 0..1.
    """
    keep_material(model, geom)
    looks = made(model)
    (looks.specular if component == SPECULAR else looks.emission)[geom] = rgb


def component(model: mujoco.MjModel, geom: int, component: int, default_specular: float) -> list[float]:
    """A geom's specular or emission colour as it is drawn: its own, else its material's, else
    the default (``default_specular`` grey, no emission).

    Args:
        model: the model.
        geom: the geom's id.
        component: SPECULAR or EMISSION.
        default_specular: the specular level of a geom without material in this scene's look.

    Returns:
        RGB, 0..1.
    """
    looks = of(model)
    own = None if looks is None else (looks.specular if component == SPECULAR else looks.emission)[geom]
    if own is not None and not np.isnan(own[0]):
        return [float(v) for v in own]
    mat = int(model.geom_matid[geom])
    if component == SPECULAR:
        level = float(model.mat_specular[mat]) if mat >= 0 else default_specular
        return [level] * 3
    if mat < 0:
        return [0.0, 0.0, 0.0]
    return [float(v) for v in float(model.mat_emission[mat]) * model.mat_rgba[mat, :3]]


def emission_multiple(colour: np.ndarray, emission: np.ndarray) -> float:
    """MuJoCo's emission (a multiple ``e`` of the geom's colour) closest to an emission colour
    (least squares; 0 for a black colour).

    Args:
        colour: the geom's RGB.
        emission: the emission RGB.

    Returns:
        ``e`` >= 0.
    """
    norm = float(colour @ colour)
    return max(float(colour @ emission) / norm, 0.0) if norm > 0 else 0.0


def apply(scene: mujoco.MjvScene, model: mujoco.MjModel) -> bool:
    """Give the scene's geoms (``update_scene`` done) the components kept for them.

    Args:
        scene: the renderer's scene.
        model: the model drawn.

    Returns:
        Whether any geom has components kept (the scene was gone through).
    """
    looks = of(model)
    if looks is None:
        return False
    for i in range(scene.ngeom):
        g = scene.geoms[i]
        if g.objtype != mujoco.mjtObj.mjOBJ_GEOM or not 0 <= g.objid < len(looks.shininess):
            continue
        spec, emis, shine = looks.specular[g.objid], looks.emission[g.objid], looks.shininess[g.objid]
        if not np.isnan(spec[0]):
            g.specular = float(np.mean(spec))
        if not np.isnan(shine):
            g.shininess = float(shine) / 128.0
        if not np.isnan(emis[0]):
            g.emission = emission_multiple(np.asarray(g.rgba[:3], float), emis)
    return True


def entry(looks: GeomLooks, geom: int) -> np.ndarray:
    """One geom's kept components as one array (specular RGB, emission RGB, shininess; NaN: none),
    for :func:`put` into another model (a scene edit's recompile, :mod:`simx_server.scene.kept_state`).

    Args:
        looks: a model's kept components.
        geom: the geom's id there.

    Returns:
        (7,) float.
    """
    return np.concatenate([looks.specular[geom], looks.emission[geom], [looks.shininess[geom]]])


def put(model: mujoco.MjModel, geom: int, value: np.ndarray) -> None:
    """Give a geom of ``model`` the components :func:`entry` took.

    Args:
        model: the model (a newly compiled one).
        geom: the geom's id.
        value: what :func:`entry` returned.
    """
    looks = made(model)
    looks.specular[geom], looks.emission[geom], looks.shininess[geom] = value[0:3], value[3:6], value[6]
