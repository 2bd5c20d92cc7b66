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
* for an orthographic sensor, the viewer far away along its axis, as OpenGL's default distant
  viewer that V-REP leaves on (MuJoCo's renderer sets a local viewer, so that specular
  highlights on a flat surface vary across the image where V-REP's are uniform). A perspective
  sensor keeps MuJoCo's local viewer: its highlights are where a viewer at the sensor sees them.
"""

from __future__ import annotations

import mujoco

#: The custom text a scene's look is read from, and its values.
TEXT = "simx:scene:vision"
LOOKS = ("mujoco", "vrep")
#: V-REP's default colour object (``CColorObject::setDefaultValues``): specular level, shininess 0-1.
DEFAULT_SPECULAR, DEFAULT_SHININESS = 0.25, 48 / 128
#: How far back an orthographic sensor's viewer goes, in multiples of its far clipping distance:
#: at 2x, a point at the edge of the view is seen under a fraction of a degree (specular within
#: about 1 % of V-REP's), and the sky box (drawn at 0.7x the far distance around the viewer)
#: still fills the view.
_DISTANT = 2.0

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
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, TEXT)
    if i < 0:
        return "mujoco"
    adr, size = model.text_adr[i], model.text_size[i]
    items = dict(item.split("=", 1) for item in bytes(model.text_data[adr:adr + size - 1]).decode().split()
                 if "=" in item)
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


def apply(scene: mujoco.MjvScene, model: mujoco.MjModel) -> None:
    """Set a sensor's scene (``update_scene`` done, an RGB frame) to V-REP's look where the model
    asks for it; nothing otherwise.

    Args:
        scene: the renderer's scene, updated for the sensor's camera.
        model: the model drawn.
    """
    vrep, bare = _of(model)
    if not vrep:
        return
    for i in range(scene.nlight):
        light = scene.lights[i]
        if light.headlight:
            light.diffuse[:] = 0.0
            light.specular[:] = 0.0
    if bare:
        for i in range(scene.ngeom):
            g = scene.geoms[i]
            if g.matid < 0 and g.objtype == mujoco.mjtObj.mjOBJ_GEOM and model.geom_matid[g.objid] < 0:
                g.specular, g.shininess, g.emission = DEFAULT_SPECULAR, DEFAULT_SHININESS, 0.0
    for cam in scene.camera:
        if cam.orthographic:
            back = _DISTANT * cam.frustum_far
            cam.pos[:] = [p - back * f for p, f in zip(cam.pos, cam.forward)]
            cam.frustum_near += back
            cam.frustum_far += back
