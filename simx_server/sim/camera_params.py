"""The object parameters of V-REP's view cameras (``sim_object_camera_type``), as coppeliaSimLib's
``simGetObjectFloatParam_internal`` / ``simSetObjectFloatParam_internal`` (and their int twins)
answer them: ``sim_camerafloatparam_perspective_angle`` (9001, rad), ``_ortho_size`` (9002, m),
``_near_clipping`` (9008, m), ``_far_clipping`` (9009, m), ``sim_cameraintparam_perspective_operation``
(9010, 1 perspective). Setting the view angle limits it to 1..135 degrees
(``CViewableBase::setViewAngle``), the ortho size to 0.001..200000 m (``setOrthoViewSize``);
setting a clipping plane changes nothing and succeeds, as in coppeliaSimLib (its setter reads the
planes back into the argument). A camera renders nothing in simx (no view of its own headless):
its optics are kept and answered.
"""

from __future__ import annotations

import math

from simx_wire.protocol import ArgumentError
from simx_server.sim import kept_objects

PERSPECTIVE_ANGLE, ORTHO_SIZE, NEAR, FAR, PERSPECTIVE = 9001, 9002, 9008, 9009, 9010
FLOAT_IDS = frozenset({PERSPECTIVE_ANGLE, ORTHO_SIZE, NEAR, FAR})
INT_IDS = frozenset({PERSPECTIVE})


def get_float(world, handle: int, pid: int) -> float:
    """A camera's float parameter ``pid`` (:data:`FLOAT_IDS`).

    Args:
        world: the world.
        handle: the camera's handle.
        pid: the parameter id.

    Returns:
        The value (rad or m).

    Raises:
        ObjectTypeError: ``handle`` is not a camera.
    """
    c = kept_objects.store(world).camera(handle)
    return float({PERSPECTIVE_ANGLE: c.view_angle, ORTHO_SIZE: c.ortho_size, NEAR: c.near, FAR: c.far}[pid])


def set_float(world, handle: int, pid: int, value: float) -> None:
    """Set a camera's float parameter ``pid`` (:data:`FLOAT_IDS`; clipping planes: unchanged).

    Args:
        world: the world.
        handle: the camera's handle.
        pid: the parameter id.
        value: rad or m.

    Raises:
        ObjectTypeError: not a camera. ArgumentError: a value that is not finite.
    """
    c = kept_objects.store(world).camera(handle)
    if not math.isfinite(value):
        raise ArgumentError(f"camera parameter {pid}: value must be finite, got {value!r}")
    if pid == PERSPECTIVE_ANGLE:
        c.view_angle = min(max(value, math.radians(1.0)), math.radians(135.0))
    elif pid == ORTHO_SIZE:
        c.ortho_size = min(max(value, 0.001), 200000.0)


def get_int(world, handle: int, pid: int) -> int:
    """A camera's int parameter ``pid`` (:data:`INT_IDS`).

    Args:
        world: the world.
        handle: the camera's handle.
        pid: the parameter id.

    Returns:
        1 perspective, 0 orthographic.

    Raises:
        ObjectTypeError: not a camera.
    """
    return int(kept_objects.store(world).camera(handle).perspective)


def set_int(world, handle: int, pid: int, value: int) -> None:
    """Set a camera's int parameter ``pid`` (:data:`INT_IDS`).

    Args:
        world: the world.
        handle: the camera's handle.
        pid: the parameter id.
        value: nonzero perspective, 0 orthographic.

    Raises:
        ObjectTypeError: not a camera.
    """
    kept_objects.store(world).camera(handle).perspective = value != 0
