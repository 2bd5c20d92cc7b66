"""V-REP's look in a converted scene: colour objects (materials), lights and the ambient light,
as MuJoCo's classic renderer gives them (docs/PORTING.md, "What V-REP's look becomes").

V-REP draws with OpenGL's fixed-function lighting (coppeliaSimLib ``makeColorCurrent`` and
``ogl::setMaterialColor``: the ambient-diffuse colour, the specular colour, the emission colour
and a shininess of 0-128; ``_activateNonAmbientLights``: each active light's diffuse and
specular colours, no ambient of its own, attenuation, spot cut-off and exponent;
``enableAmbientLight``: the scene's ambient light as the global ambient). MuJoCo's classic
renderer uses the same equation with these differences, which the conversion bridges:

* MuJoCo's material specular is a grey level and its emission a multiple of the material's
  colour: V-REP's specular colour becomes its mean, its emission colour the multiple of the
  diffuse colour closest to it (exact when the two are proportional, as a grey emission on a
  grey material); both are reported when the result differs.
* MuJoCo adds a camera headlight: it keeps only the headlight's ambient, which is the scene's
  ambient light (a directional light's ambient term is ``ambient x colour``, V-REP's global
  ambient term), its diffuse and specular are 0.
* MuJoCo's classic renderer draws no point light: an omnidirectional light is a spot light with
  a cut-off of 180 degrees, which OpenGL treats as omnidirectional (V-REP sets the same).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import mujoco
import numpy as np

from simx_server.scene.ttt.records import Records

#: V-REP's light types (``sim_light_omnidirectional`` ... ``sim_light_directional``).
OMNI, SPOT, DIRECTIONAL = 1, 2, 3
#: V-REP's ambient light when the file stores none (``CEnvironment::setUpDefaultValues``).
DEFAULT_AMBIENT = (0.2, 0.2, 0.2)
#: Materials a converted scene gets at most (MuJoCo's renderer: 999 beside a sky box; room left
#: for textures of the scene's own and scripts' shapes).
MAX_MATERIALS = 900
#: OpenGL lights MuJoCo draws with (GL_MAX_LIGHTS, 8), less the headlight that carries the ambient.
MAX_LIGHTS = 7


@dataclass(frozen=True)
class Look:
    """A V-REP colour object (``CColorObject``) as the renderer uses it.

    Attributes:
        diffuse: ambient-diffuse RGB, 0-1 (``_colors[0:3]``).
        specular: specular RGB, 0-1 (``_colors[6:9]``).
        emission: emission RGB, 0-1 (``_colors[9:12]``).
        shininess: OpenGL's specular exponent, 0-128.
        opacity: 1 unless the colour is translucent (then V-REP's opacity, 0-1).
        light: the light colour RGB of a light's colour object (``_colors[3:6]``).
    """

    diffuse: tuple[float, float, float] = (0.7, 0.7, 0.7)
    specular: tuple[float, float, float] = (0.25, 0.25, 0.25)
    emission: tuple[float, float, float] = (0.0, 0.0, 0.0)
    shininess: int = 48
    opacity: float = 1.0
    light: tuple[float, float, float] = (0.0, 0.0, 0.0)


def read_colour(r: Records, object_type: int = 0) -> Look | None:
    """The colour object in the record list ``r`` (``CColorObject::serialize``): ``Cl3`` holds
    the colours as V-REP uses them; files without it (before 3.1.3) keep ``Cl2``/``Cls``, which
    V-REP converts back (``object_type`` 0-2: ambient-diffuse = (stored + mean diffuse / 2) /
    0.85, scaled down so that no channel passes 1; 3, a light: its diffuse colour the mean of
    the stored one). None when the list has no colours.

    Args:
        r: the colour object's records (a shape mesh's ``Cl0``, a light's ``Cl2``).
        object_type: the ``objType`` V-REP serializes that colour with (0 shapes, 3 lights).
    """
    cl3 = r.floats(None, "Cl3", 15)
    if cl3 is not None:
        c = cl3
    else:
        old = r.floats(None, "Cl2", 15)
        if old is None:
            old = r.floats(None, "Cls", 12)
        if old is None:
            return None
        c = np.zeros(15)
        c[:len(old)] = old
        mean_diffuse = float(np.mean(c[3:6]))
        if object_type < 3:
            c[0:3] = (c[0:3] + mean_diffuse * 0.5) / 0.85
            if c[0:3].max() > 1.0:
                c[0:3] /= c[0:3].max()
            c[3:6] = 0.0
        elif object_type == 3:
            c[0:3] = 0.0
            c[3:6] = mean_diffuse
    if not np.all(np.isfinite(c)):
        return None
    c = np.clip(c, 0.0, 1.0)
    shininess = 48
    sh2 = r.ints("Sh2", 1)
    if sh2 is not None:
        shininess = int(sh2[0])
    elif r.ints("Shi", 1) is not None:
        shininess = max(48, int(r.ints("Shi", 1)[0]))
    opacity = r.floats(None, "Trf", 1)
    translucid = r.get("Var") is not None and not r.byte("Var") & 4
    alpha = float(np.clip(opacity[0], 0.0, 1.0)) if translucid and opacity is not None else 1.0
    rgb = lambda k: tuple(float(v) for v in c[k:k + 3])  # noqa: E731
    return Look(rgb(0), rgb(6), rgb(9), min(max(shininess, 0), 128), alpha, rgb(3))


@dataclass(frozen=True)
class LightData:
    """A V-REP light (``CLight::serialize``).

    Attributes:
        type: 1 omnidirectional, 2 spot, 3 directional.
        exponent: spot exponent; cutoff: spot cut-off angle, rad.
        attenuation: constant, linear, quadratic (OpenGL's; directional lights have none).
        active: on; local: lights only the cameras and sensors set to use local lights.
        diffuse, specular: the light's colours, RGB 0-1.
    """

    type: int = OMNI
    exponent: int = 5
    cutoff: float = math.pi / 2
    attenuation: tuple[float, float, float] = (0.25, 0.0, 0.1)
    active: bool = True
    local: bool = False
    diffuse: tuple[float, float, float] = (0.5, 0.5, 0.5)
    specular: tuple[float, float, float] = (0.5, 0.5, 0.5)


def read_light(r: Records) -> LightData:
    """A light's typed records: ``_p2``/``Cp2`` (type, spot exponent, size), ``_p3``/``Cp3``
    cut-off, ``_af``/``Caf`` attenuation, ``Cas`` bits (0 active, 1 local), ``Cl2`` the light's
    colour object. Missing records keep V-REP's defaults (``CLight::_commonInit``)."""
    kind, exponent = OMNI, 5
    for tag in ("_p2", "Cp2"):
        p = r.get(tag)
        if p is not None and len(p) >= 8:
            kind, exponent = struct.unpack_from("<ii", p, 0)
            break
    cut = r.floats("_p3", "Cp3", 1)
    att = r.floats("_af", "Caf", 3)
    cas = r.byte("Cas", 1)
    look = read_colour(r.sub("Cl2"), 3)
    out = LightData(kind, exponent, float(cut[0]) if cut is not None else math.pi / 2,
                    tuple(float(v) for v in att) if att is not None else (0.25, 0.0, 0.1),
                    bool(cas & 1), bool(cas & 2))
    if look is not None:
        out = LightData(out.type, out.exponent, out.cutoff, out.attenuation, out.active, out.local,
                        look.light, look.specular)
    return out


def read_ambient(r: Records, serialization: int = 22) -> np.ndarray | None:
    """The environment's ambient light (``CEnvironment::serialize``): ``Al2`` as it is; older
    files only ``Alc``, which holds half of it (V-REP doubles it, capped at 0.4); a file written
    before serialization 17 (V-REP's brighter default lights, before 3.0.5) has an ambient light
    whose mean passes 0.21 scaled by 0.675 (``utils::scaleLightDown_``). None when the file has
    neither record.

    Args:
        r: the environment's records.
        serialization: the serialization version of the file.
    """
    al2 = r.floats(None, "Al2", 3)
    if al2 is not None and np.all(np.isfinite(al2)):
        amb = np.clip(al2, 0.0, 1.0)
    else:
        alc = r.floats(None, "Alc", 3)
        if alc is None or not np.all(np.isfinite(alc)):
            return None
        amb = np.clip(alc * 2.0, 0.0, None)
        if amb.max() > 0.4:
            amb *= 0.4 / amb.max()
    if serialization < 17 and float(np.mean(amb)) > 0.21:
        amb = amb * 0.675
    return amb


def headlight(spec: mujoco.MjSpec, ambient) -> None:
    """MuJoCo's headlight as V-REP's global ambient light: ``ambient`` (RGB 0-1; None: V-REP's
    default), no diffuse nor specular (V-REP has no camera headlight)."""
    h = spec.visual.headlight
    h.active = 1
    h.ambient = list(ambient) if ambient is not None else list(DEFAULT_AMBIENT)
    h.diffuse = [0.0, 0.0, 0.0]
    h.specular = [0.0, 0.0, 0.0]


def add_light(conv, light: LightData, element) -> None:
    """Set the MJCF ``<light>`` ``element`` (its pos and dir already the V-REP light's position and
    +z axis) to V-REP's light: type, colours (no ambient), attenuation, cut-off, on/off; no shadow
    (V-REP's OpenGL sensors draw none). Local lights are off (they light only the sensors set to
    use local lights, reported)."""
    L = mujoco.mjtLightType
    element.castshadow = False
    element.ambient = [0.0, 0.0, 0.0]
    element.diffuse = list(light.diffuse)
    element.specular = list(light.specular)
    element.active = light.active and not light.local
    if light.local:
        conv.report.add("local lights (off: simx's sensors use the scene's lights)")
    if light.type == DIRECTIONAL:
        element.type = L.mjLIGHT_DIRECTIONAL
        return
    element.type = L.mjLIGHT_SPOT
    element.attenuation = [max(v, 0.0) if math.isfinite(v) else 0.0 for v in light.attenuation]
    if light.type == SPOT:
        element.cutoff = min(max(math.degrees(light.cutoff), 0.0), 89.0)  # V-REP's cap (rendering.cpp)
        element.exponent = float(max(light.exponent, 0))
    else:  # OpenGL's omnidirectional light: a cut-off of 180 degrees
        element.cutoff = 180.0
        element.exponent = 0.0


def count_lights(conv) -> None:
    """Report lights beyond what the renderer draws (MAX_LIGHTS active ones besides the
    headlight; V-REP drew up to 8)."""
    active = [o for o in conv.scene.objects.values()
              if o.kind == "light" and isinstance(o.data, LightData) and o.data.active and not o.data.local]
    if len(active) > MAX_LIGHTS:
        conv.report.add(f"active lights beyond the {MAX_LIGHTS}th (not drawn)", len(active) - MAX_LIGHTS)


def texture_colour(look: Look, mode: int) -> list[float]:
    """The RGBA a textured geom and its material get: V-REP draws a texture with OpenGL's
    texture environment mode (rendering.cpp ``_startTextureDisplay``): modulate (0, the default)
    multiplies it with the lit colour of the shape's material, as MuJoCo does, so the material
    keeps the shape's colour; the other modes (1 decal: the texture as it is) take white.

    Args:
        look: the mesh's colour object.
        mode: V-REP's apply mode.
    """
    colour = look.diffuse if mode != 1 else (1.0, 1.0, 1.0)
    return [*colour, look.opacity]


class Materials:
    """MuJoCo materials of V-REP colour objects: one per shape and look (a script's
    ``sim.setShapeAppearance`` changes one shape's materials, not its look-alikes'), at most
    MAX_MATERIALS (MuJoCo's renderer takes at most 999 materials beside a sky box: a geom for
    one per mesh, 1,207 in the kitchen scene, could not be drawn).

    Args:
        spec: the MjSpec being built; report: the converter's report.
    """

    def __init__(self, spec: mujoco.MjSpec, report) -> None:
        self.spec, self.report = spec, report
        self.names: dict[tuple, str] = {}

    def material(self, look: Look, texture: str | None = None, owner: str = "", mode: int = 0) -> str | None:
        """The name of the material of ``look`` for the shape ``owner`` (and of the texture
        ``texture`` in V-REP's apply ``mode``, see :func:`texture_colour`), made on first use;
        None beyond MAX_MATERIALS (reported: the geom keeps its colour, and sensors give it
        V-REP's default specular and shininess).

        Args:
            look: the mesh's colour object.
            texture: an MJCF texture name, or None.
            owner: the shape's name.
            mode: the texture's apply mode (``Apm``): 0 modulate, 1 decal, 2 add, 3 blend.
        """
        key = (owner, look, texture, mode if texture is not None else 0)
        name = self.names.get(key)
        if name is not None:
            return name
        if len(self.names) >= MAX_MATERIALS:
            self.report.add(f"shape looks beyond the {MAX_MATERIALS}th material (V-REP's default specular)", approximated=True)
            return None
        name = f"ttt_look{len(self.names) + 1}"
        mat = self.spec.add_material()
        mat.name = name
        rgba = texture_colour(look, mode if texture is not None else 0)
        mat.rgba = rgba
        mat.specular = float(np.mean(look.specular))
        if np.ptp(look.specular) > 1 / 255:
            self.report.add("specular colours that are not grey (their mean: MuJoCo's specular is a level)", approximated=True)
        mat.shininess = look.shininess / 128.0
        mat.emission = self._emission(np.asarray(rgba[:3]), np.asarray(look.emission))
        if texture is not None:
            mat.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = texture
            if mode == 1:  # decal: the texture unlit (emission 1 saturates the lit colour it multiplies)
                mat.emission, mat.specular = 1.0, 0.0
            elif mode not in (0, 1):
                self.report.add("textures added to or blended with the shape's colour (multiplied with it)", approximated=True)
        self.names[key] = name
        return name

    def _emission(self, colour: np.ndarray, emission: np.ndarray) -> float:
        """MuJoCo's emission is ``e x colour``: the ``e`` closest to V-REP's emission colour
        (least squares), reported where that is not the same colour (by more than 1 level)."""
        if not emission.any():
            return 0.0
        norm = float(colour @ colour)
        e = float(colour @ emission) / norm if norm > 0 else 0.0
        if np.abs(e * colour - emission).max() > 1 / 255:
            self.report.add("emission colours that are not a multiple of the shape's colour (the closest)", approximated=True)
        return max(e, 0.0)
