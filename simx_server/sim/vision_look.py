"""V-REP's lighting for vision sensors: what a scene asks for with
``<custom><text name="simx:scene:vision" data="look=vrep"/></custom>`` (docs/PORTING.md, "What V-REP's
look becomes"). ``look=mujoco`` (the default) keeps MuJoCo's look; scenes converted from a
``.ttt``/``.ttm`` file ask for V-REP's.

V-REP renders a vision sensor with OpenGL's fixed-function lighting (coppeliaSimLib
``CVisionSensor::renderForDetection``: the scene's ambient light and its lights, no camera
headlight; ``CColorObject::setDefaultValues``: a shape's default specular 0.25, shininess 48).
MuJoCo's classic renderer uses the same equation; with ``look=vrep`` a sensor's frame is drawn
with, on top of the scene's own lights and materials:

* the headlight's ambient only (the scene's ambient light: ``<headlight ambient=.../>``; its
  diffuse and specular are 0), as V-REP's global ambient light;
* V-REP's default material on geoms that have no material of their own (specular 0.25,
  shininess 48/128, no emission; MuJoCo's defaults are 0.5 and 0.5);
* OpenGL's distant viewer, which V-REP leaves on (coppeliaSimLib never sets
  ``GL_LIGHT_MODEL_LOCAL_VIEWER``: ``initGl_ifNeeded`` in ``gui/rendering/rendering.cpp`` and
  ``COffscreenGlContext`` set ``GL_LIGHT_MODEL_TWO_SIDE`` only, so OpenGL's initial ``GL_FALSE``
  holds): specular highlights are computed for a view along the sensor's axis, uniform on a flat
  surface across the whole image, in perspective sensors too. MuJoCo's renderer turns the local
  viewer on in every ``mjr_render`` (``initLights`` in ``render_gl3.c``), after which it draws each
  geom with a display list of its ``MjrContext``; :func:`distant_viewer` gives the context lists
  that turn it off again before they draw the geom's own (a light-model change is recorded in a
  display list and runs where the list is called).
"""

from __future__ import annotations

import logging

import mujoco

from simx_server.sim import shape_looks
from simx_server.sim.objects import text_of

log = logging.getLogger("simx.vision")

#: The custom text a scene's look is read from, and its values.
TEXT = "simx:scene:vision"
LOOKS = ("mujoco", "vrep")
_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)  # an int: comparing with MuJoCo's enum costs 1.4 us a geom
#: V-REP's default colour object (``CColorObject::setDefaultValues``): specular level, shininess 0-1.
DEFAULT_SPECULAR, DEFAULT_SHININESS = 0.25, 48 / 128
#: The ``MjrContext`` display lists MuJoCo draws geoms with (``base*`` first list, ``range*`` count).
_GEOM_LISTS = ("Builtin", "Plane", "Mesh", "HField")

_cache: dict[int, tuple[mujoco.MjModel, bool, bool]] = {}


def scene_look(model: mujoco.MjModel) -> str:
    """The look the scene asks for (``simx:scene:vision`` text, ``look=``), ``mujoco`` by default.

    Args:
        model: the compiled scene.

    Returns:
        ``"mujoco"`` or ``"vrep"``.

    Raises:
        ValueError: another value (the scene is refused when it loads).
    """
    raw = text_of(model, TEXT)
    if raw is None:
        return "mujoco"
    items = dict(item.split("=", 1) for item in raw.split() if "=" in item)
    look = items.get("look", "mujoco")
    if look not in LOOKS:
        raise ValueError(f"custom text {TEXT!r}: look={look[:40]!r} is not one of {', '.join(LOOKS)}")
    return look


def _of(model: mujoco.MjModel) -> tuple[bool, bool]:
    """(V-REP's look, some geom has no material) of ``model``, cached by the model (render thread)."""
    hit = _cache.get(id(model))
    if hit is None or hit[0] is not model:
        if len(_cache) >= 2:  # the two render threads' models; older scenes are not kept alive
            _cache.clear()
        hit = _cache[id(model)] = (model, scene_look(model) == "vrep", bool((model.geom_matid < 0).any()))
    return hit[1], hit[2]


def apply(scene: mujoco.MjvScene, model: mujoco.MjModel, disabled: int = 0) -> None:
    """Set a sensor's scene (``update_scene`` done, an RGB frame) to V-REP's look where the model
    asks for it; then, in either look, give the geoms the specular and emission colours and the
    shininess that ``sim.setShapeColor`` set (:mod:`simx_server.sim.shape_looks`), and leave out
    the light components the sensor disables (``sim_visionintparam_disabled_light_components``:
    bit 1 the lights' diffuse, bit 2 their specular; ``_activateNonAmbientLights``).

    Args:
        scene: the renderer's scene, updated for the sensor's camera.
        model: the model drawn.
        disabled: the sensor's disabled light components.
    """
    vrep, bare = _of(model)
    if vrep:
        _vrep_look(scene, model, bare)
    shape_looks.apply(scene, model)
    if disabled & 6:
        for i in range(scene.nlight):
            light = scene.lights[i]
            if not light.headlight:  # the headlight's ambient is V-REP's ambient light, left on
                if disabled & 2:
                    light.diffuse[:] = 0.0
                if disabled & 4:
                    light.specular[:] = 0.0


def _vrep_look(scene: mujoco.MjvScene, model: mujoco.MjModel, bare: bool) -> None:
    """V-REP's look (:func:`apply`): the headlight's ambient only, V-REP's default material on
    geoms without one (``bare``: the model has some)."""
    for i in range(scene.nlight):
        light = scene.lights[i]
        if light.headlight:
            light.diffuse[:] = 0.0
            light.specular[:] = 0.0
    if bare:
        for i in range(scene.ngeom):
            g = scene.geoms[i]
            if g.matid < 0 and g.objtype == _GEOM and model.geom_matid[g.objid] < 0:
                g.specular, g.shininess, g.emission = DEFAULT_SPECULAR, DEFAULT_SHININESS, 0.0


def asks_vrep(model: mujoco.MjModel) -> bool:
    """Whether ``model``'s sensors are drawn with V-REP's look (cached by the model).

    Args:
        model: the compiled scene.

    Returns:
        True for ``look=vrep``.
    """
    return _of(model)[0]


def distant_viewer(context: mujoco.MjrContext) -> list[tuple[str, int, int]]:
    """Make ``context`` draw its geoms with OpenGL's distant viewer, as V-REP's sensors are drawn:
    each geom display list (builtin shapes, planes, meshes, height fields) gets a new list that sets
    ``GL_LIGHT_MODEL_LOCAL_VIEWER`` to ``GL_FALSE`` and calls the original; the context's ``base*``
    then names the new lists. Depth and segmentation frames draw unlit: the setting changes nothing
    there. Call with the context's GL context current; undo with :func:`restore` before the
    ``MjrContext`` is freed (``mjr_freeContext`` deletes the lists its ``base*`` name).

    Args:
        context: a new ``MjrContext`` (its lists as ``mjr_makeContext`` made them).

    Returns:
        ``[(kind, original first list, new first list)]``, for :func:`restore`.
    """
    from OpenGL import GL  # after the GL context: mujoco chose PyOpenGL's platform (EGL, OSMesa)

    made: list[tuple[str, int, int]] = []
    try:
        for kind in _GEOM_LISTS:
            base, count = getattr(context, "base" + kind), getattr(context, "range" + kind)
            if count <= 0:
                continue
            first = int(GL.glGenLists(count))
            if first == 0:
                raise RuntimeError(f"glGenLists({count}) gave no lists")
            made.append((kind, base, first))
            for i in range(count):
                GL.glNewList(first + i, GL.GL_COMPILE)
                GL.glLightModeli(GL.GL_LIGHT_MODEL_LOCAL_VIEWER, GL.GL_FALSE)
                GL.glCallList(base + i)
                GL.glEndList()
            setattr(context, "base" + kind, first)
    except Exception as exc:  # the frames keep MuJoCo's local viewer
        restore(context, made)
        log.warning("vision sensors: OpenGL's distant viewer not set (%s: %s): specular highlights "
                    "as MuJoCo's local viewer sees them", type(exc).__name__, exc)
        return []
    return made


def restore(context: mujoco.MjrContext, made: list[tuple[str, int, int]]) -> None:
    """Give ``context`` back the lists :func:`distant_viewer` replaced and delete its own (GL
    context current).

    Args:
        context: the ``MjrContext``.
        made: what :func:`distant_viewer` returned.
    """
    from OpenGL import GL

    for kind, base, first in made:
        setattr(context, "base" + kind, base)
        try:
            GL.glDeleteLists(first, getattr(context, "range" + kind))
        except Exception:  # a context the driver tore down: its lists went with it
            pass
