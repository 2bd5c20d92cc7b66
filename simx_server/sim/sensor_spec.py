"""A vision sensor's static properties (:class:`SensorSpec`): resolution, near and far clipping,
image kind, render mode, filter chain, V-REP's options (ignore RGB / depth, basic statistics,
background colour), and the byte sizes of its image and depth buffer, read from the MuJoCo
camera and its ``simx:NAME`` custom text (:func:`sensor_spec`). Rendering is
:mod:`simx_server.sim.vision`.
"""

from __future__ import annotations

import dataclasses

import mujoco

from simx_server.sim import handle_render
from simx_server.sim.physics import check_resolution
from simx_server.sim.vision_filters import Step, parse_chain

DEFAULT_RESOLUTION = (256, 256)
DEFAULT_NEAR, DEFAULT_FAR = 0.01, 10.0

@dataclasses.dataclass
class SensorSpec:
    """Static properties of one vision sensor."""

    camera: int
    width: int
    height: int
    near: float  # m
    far: float  # m
    depth_image: bool
    shadows: bool = False
    reflections: bool = False
    render_mode: int = handle_render.OPENGL  # sim_visionintparam_render_mode; 2: colour-coded handles
    filters: tuple[Step, ...] = ()  # the filter chain (simx_server.sim.vision_filters)
    ignore_rgb: bool = False  # V-REP's "ignore RGB info": the image is the background colour
    ignore_depth: bool = False  # "ignore depth info": the depth buffer is all 1 (far)
    basic_stats: bool = True  # V-REP's default packet is computed (else it is empty)
    #: the background colour, bytes (V-REP's value x 255.1): what an ignore-RGB sensor shows and
    #: what a sensor shows where no object is (None: MuJoCo's sky box, black for ignore-RGB)
    background: tuple[int, int, int] | None = None
    #: windowed size (pixels; no effect headless), the orthographic size kept while perspective
    #: (m), the perspective fovy kept while orthographic (deg): simx_server.sim.vision_params
    windowed: tuple[int, int] = (0, 0)
    #: ``sim_visionintparam_disabled_light_components`` (1006): bit 1 the lights' diffuse, bit 2
    #: their specular, left out of the sensor's images (coppeliaSimLib ``_activateNonAmbientLights``)
    disabled_light_components: int = 0
    ortho_size: float | None = None
    persp_fovy: float | None = None

    @property
    def pixels(self) -> int:
        """Pixels of one frame: resX * resY."""
        return self.width * self.height

    def image_size(self, grey: bool) -> int:
        """Bytes of one image (``simxGetVisionSensorImage`` / ``simxSetVisionSensorImage``): one
        byte per pixel when ``grey``, three (RGB) otherwise.

        Args:
            grey: one byte per pixel.

        Returns:
            Bytes.
        """
        return self.pixels * (1 if grey else 3)

    def depth_size(self) -> int:
        """Bytes of one depth buffer (``simxGetVisionSensorDepthBuffer``): a float32 per pixel.

        Returns:
            Bytes.
        """
        return self.pixels * 4


def _flag(settings: dict[str, str], key: str, sensor: str) -> bool:
    """A ``true``/``false`` custom-text setting (default false); ValueError names the sensor."""
    value = settings.get(key, "false").lower()
    if value not in ("true", "false"):
        raise ValueError(f"vision sensor {sensor!r}: {key}={value!r} must be true or false")
    return value == "true"


def sensor_spec(model: mujoco.MjModel, obj) -> SensorSpec:
    """The static properties of vision sensor ``obj`` (a world.SceneObject of the camera): the
    camera's resolution (DEFAULT_RESOLUTION when the MJCF leaves it at 1x1), near/far clipping
    (m) and image kind from its ``simx:`` text. Raises ValueError for a bad setting.

    Args:
        model: the compiled model.
        obj: the sensor's scene object.

    Returns:
        Its :class:`SensorSpec`.
    """
    w, h = (int(x) for x in model.cam_resolution[obj.mj_id])
    if (w, h) == (1, 1):
        w, h = DEFAULT_RESOLUTION
    check_resolution(w, h, f"vision sensor {obj.name!r}")  # World checked it at load too
    s = obj.settings
    return SensorSpec(obj.mj_id, w, h, float(s.get("near", DEFAULT_NEAR)), float(s.get("far", DEFAULT_FAR)),
                      s.get("image", "rgb") == "depth",
                      shadows=_flag(s, "shadows", obj.name), reflections=_flag(s, "reflections", obj.name),
                      render_mode=handle_render.parse_mode(s, obj.name),
                      filters=parse_chain(s.get("filters", ""), obj.name),
                      ignore_rgb=_flag(s, "ignore_rgb", obj.name), ignore_depth=_flag(s, "ignore_depth", obj.name),
                      basic_stats=s.get("basic_stats", "true").lower() != "false",
                      background=_colour(s["background"], obj.name) if "background" in s else None)


def _colour(text: str, sensor: str) -> tuple[int, int, int]:
    """``background=r,g,b`` (0..1 each) as V-REP's bytes (value x 255.1, truncated)."""
    try:
        rgb = [float(c) for c in text.split(",")]
    except ValueError:
        rgb = []
    if len(rgb) != 3 or not all(0.0 <= c <= 1.0 for c in rgb):
        raise ValueError(f"vision sensor {sensor!r}: background={text[:40]!r} must be three numbers 0..1")
    return tuple(int(c * 255.1) for c in rgb)
