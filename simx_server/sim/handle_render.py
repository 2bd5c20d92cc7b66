"""Vision-sensor render modes, and V-REP's "color coded handles" mode with MuJoCo's segmentation.

``sim_visionintparam_render_mode`` (1017) picks how a V-REP vision sensor renders:
0 OpenGL (the visible colours), 1 auxiliary channels, 2 colour-coded handles, 3 POV-Ray,
4 reserved, 5 external renderer, 6 external renderer (windowed), 7 OpenGL3, 8 OpenGL3
(windowed). simx renders 0 (its ordinary image), 7 and 8 (CoppeliaSim's OpenGL3 renderer draws the
same visible colours: simx's ordinary image too, headless) and 2; the others answer UnsupportedError.

In mode 2 every pixel is the handle of the shape it shows, as V-REP draws it
(``glColor3ub(h & 255, (h >> 8) & 255, (h >> 16) & 255)``): ``h = r + 256 g + 65536 b``.
V-REP clears the colour-coded image to white, so a pixel with no object decodes to
``BACKGROUND`` (0xFFFFFF = 16777215), never a real handle. Here the shape of a pixel is the
named body (simx's shape) that owns the MuJoCo geom seen there; a geom of an unnamed body
belongs to its nearest named ancestor body, as its pose does. Geoms of the world body (a floor
plane, for one) belong to no V-REP object and render as background, as do flexes and skins.

The image is MuJoCo's segmentation rendering (per pixel: object id and type) mapped through a
table from geom id to packed colour: one numpy gather per frame.
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_wire.protocol import UnsupportedError
from simx_server.sim.world import SHAPE, World

RENDER_MODE_PARAM = 1017  # sim_visionintparam_render_mode
OPENGL, COLOR_CODED = 0, 2
#: V-REP's render modes (simConst sim_rendermode_*).
MODE_NAMES = {
    0: "sim_rendermode_opengl", 1: "sim_rendermode_auxchannels", 2: "sim_rendermode_colorcoded",
    3: "sim_rendermode_povray", 4: "sim_rendermode_reserved", 5: "sim_rendermode_extrenderer",
    6: "sim_rendermode_extrendererwindowed", 7: "sim_rendermode_opengl3",
    8: "sim_rendermode_opengl3windowed",
}
OPENGL3, OPENGL3_WINDOWED = 7, 8
SUPPORTED = (OPENGL, COLOR_CODED, OPENGL3, OPENGL3_WINDOWED)
#: ``render_mode=`` values of a sensor's ``simx:`` custom text.
TEXT_VALUES = {"opengl": OPENGL, "0": OPENGL, "handles": COLOR_CODED, "colorcoded": COLOR_CODED,
               "2": COLOR_CODED, "opengl3": OPENGL3, "7": OPENGL3, "opengl3_windowed": OPENGL3_WINDOWED,
               "8": OPENGL3_WINDOWED}
BACKGROUND = 0xFFFFFF  # V-REP's clear colour in colour-coded mode: white
_GEOM = int(mujoco.mjtObj.mjOBJ_GEOM)  # an int: comparing an array with the enum is per element Python


def mode_name(mode: int) -> str:
    """How messages name a render mode: ``opengl (0)``, else ``render mode N``.

    Args:
        mode: a ``sim_visionintparam_render_mode`` value.

    Returns:
        The mode's name and number.
    """
    return f"{MODE_NAMES[mode]} ({mode})" if mode in MODE_NAMES else f"render mode {mode}"


def check_mode(mode: int) -> int:
    """``mode`` if simx renders it; UnsupportedError naming it otherwise.

    Args:
        mode: a ``sim_visionintparam_render_mode`` value (1017).

    Returns:
        ``mode``.

    Raises:
        UnsupportedError: a mode simx does not render (the message lists the supported ones).
    """
    if mode not in SUPPORTED:
        raise UnsupportedError(
            f"vision sensor {mode_name(mode)} is not supported by simx; supported: "
            + ", ".join(mode_name(m) for m in SUPPORTED))
    return mode


def parse_mode(settings: dict[str, str], sensor: str) -> int:
    """The ``render_mode`` of a sensor's custom text (default OpenGL); ValueError names the sensor.

    Args:
        settings: the sensor's ``simx:NAME`` settings.
        sensor: the sensor's name, for the message.

    Returns:
        The render mode (``sim_visionintparam_render_mode`` value).

    Raises:
        ValueError: a ``render_mode`` that is not one of TEXT_VALUES.
    """
    value = settings.get("render_mode", "opengl").lower()
    if value not in TEXT_VALUES:
        raise ValueError(f"vision sensor {sensor!r}: render_mode={value!r} must be one of "
                         f"{', '.join(sorted(TEXT_VALUES))}")
    return TEXT_VALUES[value]


def geom_colours(world: World) -> np.ndarray:
    """Packed colour (``r + 256 g + 65536 b``, uint32) of each geom, then BACKGROUND last: index
    -1 (MuJoCo's "no object") reads the background.

    Each geom has the colour of the shape (named body) it belongs to, or of its nearest shape
    ancestor; geoms of the world body are background.

    Args:
        world: the world.

    Returns:
        Array (ngeom + 1,) uint32.
    """
    m = world.model
    shape_of_body = {o.mj_id: o.handle for o in world.objects.values() if o.type == SHAPE}
    owner = np.full(m.nbody, BACKGROUND, dtype=np.uint32)
    for b in range(1, m.nbody):  # parents come before their children
        h = shape_of_body.get(b)
        owner[b] = (h & BACKGROUND) if h is not None else owner[m.body_parentid[b]]
    return np.append(owner[m.geom_bodyid], np.uint32(BACKGROUND))


def coded_image(segmentation: np.ndarray, colours: np.ndarray) -> np.ndarray:
    """(h, w, 3) uint8 colour-coded image from a segmentation frame ((h, w, 2) object id, type).

    Args:
        segmentation: (h, w, 2) int32 frame of MuJoCo's segmentation rendering.
        colours: :func:`geom_colours` of the model rendered.

    Returns:
        (h, w, 3) uint8 RGB, each pixel the low 24 bits of the object's handle.
    """
    ids = np.where(segmentation[..., 1] == _GEOM, segmentation[..., 0], -1)
    packed = colours[ids].astype("<u4", copy=False)
    return packed.view(np.uint8).reshape(*ids.shape, 4)[..., :3]


def decode(image: np.ndarray) -> np.ndarray:
    """Handles of a colour-coded (h, w, 3) uint8 image (BACKGROUND where no object is).

    Args:
        image: (h, w, 3) uint8 colour-coded image (``sim_visionintparam_render_mode`` 2).

    Returns:
        (h, w) int64 array of handles.
    """
    rgb = image.astype(np.int64)
    return rgb[..., 0] | (rgb[..., 1] << 8) | (rgb[..., 2] << 16)
