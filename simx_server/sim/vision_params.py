"""Vision-sensor parameters beyond the optics V-REP's legacy API answered: windowed size,
entity to render, perspective or orthographic projection, orthographic size.

``sim_visionintparam_windowed_size_x``/``_y`` (1004/1005, int) are the size of the window a
CoppeliaSim sensor can show its image in: kept, with no effect headless (0: full screen).
``sim_visionintparam_entity_to_render`` (1008): -1 (everything) only; MuJoCo renders the whole
scene. ``sim_visionintparam_disabled_light_components`` (1006): bit 1 (2) leaves the lights'
diffuse colours out of the sensor's images, bit 2 (4) their specular colours (coppeliaSimLib
``_activateNonAmbientLights`` reads the sensor's ``getDisabledColorComponents``; not saved with the
scene, kept when the simulation stops, as ``CViewableBase`` keeps it).
``sim_visionintparam_perspective_operation`` (1018): 1 perspective, 0 orthographic
(MuJoCo's ``cam_projection``). ``sim_visionfloatparam_ortho_size`` (1005, float): the view's
size along its larger side (m), MuJoCo's orthographic ``fovy`` being the vertical extent. A
perspective sensor keeps the orthographic size it is given for when it turns orthographic,
and its angle while orthographic; a sensor that turns orthographic with no size given sees at
1 m what it saw in perspective (CoppeliaSim's ``CVisionSensor::setPerspectiveOperation`` keeps
both values on the sensor). Run-time changes are undone when the simulation stops, as the
clipping planes (the model is reloaded).

:func:`gaussian_kernel` is the default kernel of the 3x3 and 5x5 matrix filters, which a
``.ttt`` sensor's filter and simVision's matrix calls both start from.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.sim.state import SimulationView

WINDOWED_X, WINDOWED_Y, ENTITY, PERSPECTIVE = 1004, 1005, 1008, 1018
ORTHO_SIZE, DISABLED_LIGHT_COMPONENTS = 1005, 1006
INT_IDS = (WINDOWED_X, WINDOWED_Y, ENTITY, PERSPECTIVE, DISABLED_LIGHT_COMPONENTS)
FLOAT_IDS = (ORTHO_SIZE,)
_ORTHO = int(mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC)
_PERSP = int(mujoco.mjtProjection.mjPROJ_PERSPECTIVE)


def _spec(sim: SimulationView, handle: int):
    return sim.vision.spec(handle)


def _ortho(sim: SimulationView, spec) -> bool:
    return int(sim.world.model.cam_projection[spec.camera]) == _ORTHO


def _larger_side(spec) -> float:
    """Factor from MuJoCo's vertical extent to V-REP's size along the larger side."""
    return spec.width / spec.height if spec.width > spec.height else 1.0


def get_int(sim: SimulationView, handle: int, pid: int) -> int:
    """Int parameter 1004, 1005, 1008 or 1018 of vision sensor ``handle`` (see the module).

    Args:
        sim: the simulation.
        handle: the vision sensor's handle.
        pid: the parameter id.

    Returns:
        The value.
    """
    spec = _spec(sim, handle)
    if pid in (WINDOWED_X, WINDOWED_Y):
        return int(spec.windowed[0 if pid == WINDOWED_X else 1])
    if pid == DISABLED_LIGHT_COMPONENTS:
        return int(spec.disabled_light_components)
    if pid == ENTITY:
        return -1
    return 0 if _ortho(sim, spec) else 1


def set_int(sim: SimulationView, handle: int, pid: int, value: int) -> None:
    """Set int parameter 1004, 1005, 1006, 1008 or 1018 of vision sensor ``handle``.

    Args:
        sim: the simulation.
        handle: the vision sensor's handle.
        pid: the parameter id.
        value: the new value.

    Raises:
        ArgumentError: a negative window size, a projection other than 0 or 1.
        UnsupportedError: an entity to render other than -1.
    """
    spec = _spec(sim, handle)
    m = sim.world.model
    if pid in (WINDOWED_X, WINDOWED_Y):
        if value < 0:
            raise ArgumentError(f"windowed size must be >= 0, got {value}")
        size = list(spec.windowed)
        size[0 if pid == WINDOWED_X else 1] = int(value)
        spec.windowed = (size[0], size[1])
        return
    if pid == DISABLED_LIGHT_COMPONENTS:
        spec.disabled_light_components = int(value)
        sim.world.version += 1  # the sensor's image changes
        return
    if pid == ENTITY:
        if value != -1:
            raise UnsupportedError("sim_visionintparam_entity_to_render (1008): simx renders the whole scene "
                                   "(-1) only; MuJoCo has no per-object render selection")
        return
    if value not in (0, 1):
        raise ArgumentError(f"sim_visionintparam_perspective_operation (1018): 0 or 1, got {value}")
    if value == (0 if _ortho(sim, spec) else 1):
        return
    cam = spec.camera
    if value == 0:  # to orthographic: keep the angle, take the kept size (or the view at 1 m)
        spec.persp_fovy = float(m.cam_fovy[cam])
        size = spec.ortho_size
        if size is None:
            size = 2 * math.tan(math.radians(float(m.cam_fovy[cam])) / 2) * _larger_side(spec)
        m.cam_projection[cam] = _ORTHO
        m.cam_fovy[cam] = size / _larger_side(spec)
    else:
        spec.ortho_size = float(m.cam_fovy[cam]) * _larger_side(spec)
        m.cam_projection[cam] = _PERSP
        m.cam_fovy[cam] = spec.persp_fovy if spec.persp_fovy is not None else 60.0
    sim.world.version += 1


def get_float(sim: SimulationView, handle: int, pid: int) -> float:
    """``sim_visionfloatparam_ortho_size`` (m) of vision sensor ``handle``.

    Args:
        sim: the simulation.
        handle: the vision sensor's handle.
        pid: the parameter id.

    Returns:
        The value.

    Raises:
        UnsupportedError: a perspective sensor given no orthographic size (the scene's is not kept).
    """
    spec = _spec(sim, handle)
    if _ortho(sim, spec):
        return float(sim.world.model.cam_fovy[spec.camera]) * _larger_side(spec)
    if spec.ortho_size is None:
        raise UnsupportedError("sim_visionfloatparam_ortho_size (1005): this perspective sensor has no "
                               "orthographic size in simx until one is set")
    return float(spec.ortho_size)


def set_float(sim: SimulationView, handle: int, pid: int, value: float) -> None:
    """Set ``sim_visionfloatparam_ortho_size`` (m, > 0) of vision sensor ``handle``.

    Args:
        sim: the simulation.
        handle: the vision sensor's handle.
        pid: the parameter id.
        value: the new value.

    Raises:
        ArgumentError: not a positive finite number.
    """
    if not (math.isfinite(value) and value > 0):
        raise ArgumentError(f"sim_visionfloatparam_ortho_size (1005): must be > 0 (m), got {value}")
    spec = _spec(sim, handle)
    if _ortho(sim, spec):
        sim.world.model.cam_fovy[spec.camera] = value / _larger_side(spec)
        sim.world.version += 1
    else:
        spec.ortho_size = float(value)


#: CoppeliaSim's values for a sensor never given them (``CVisionSensor``): 60 degrees, 0.1 m.
DEFAULT_ANGLE, DEFAULT_ORTHO_SIZE = math.radians(60.0), 0.1


def view(sim: SimulationView, handle: int) -> tuple[bool, float, float]:
    """A vision sensor's projection as CoppeliaSim keeps it (a vision callback's ``inData``,
    ``simVision``'s points): ``(perspective, angle, ortho size)``, the angle (rad) and size (m)
    along the image's larger side, both kept whatever the projection (one never given is
    CoppeliaSim's default, :data:`DEFAULT_ANGLE`, :data:`DEFAULT_ORTHO_SIZE`).

    Args:
        sim: the simulation.
        handle: a vision sensor's handle.

    Returns:
        ``(perspective, angle, ortho_size)``.
    """
    spec = _spec(sim, handle)
    fovy = float(sim.world.model.cam_fovy[spec.camera])
    if _ortho(sim, spec):
        size = fovy * _larger_side(spec)
        fovy = spec.persp_fovy if spec.persp_fovy is not None else None
    else:
        size = spec.ortho_size if spec.ortho_size is not None else DEFAULT_ORTHO_SIZE
    if fovy is None:
        return False, DEFAULT_ANGLE, size
    half = math.radians(fovy) / 2  # MuJoCo's fovy is vertical; V-REP's angle spans the larger side
    angle = 2 * math.atan(math.tan(half) * spec.width / spec.height) if spec.width > spec.height else 2 * half
    return not _ortho(sim, spec), angle, size


def gaussian_kernel(n: int) -> np.ndarray:
    """CoppeliaSim's default n x n blur of its 3x3 and 5x5 matrix filters (``setFilterType``,
    simVision's ``matrix3x3OnWorkImg``/``matrix5x5OnWorkImg``): a Gaussian of sigma 2 pixels.

    Args:
        n: 3 or 5.

    Returns:
        (n * n,) row after row, summing to 1.
    """
    r = np.arange(n) - n // 2
    v = np.exp(-(r[None, :] ** 2 + r[:, None] ** 2) / 8.0)
    return (v / v.sum()).ravel()
