"""CoppeliaSim 4.x's ``sim`` functions of signals, sensors, object parameters and the simulation
state.

They read the simulation through :meth:`CallContext.simulation
<simx_server.api.context.CallContext.simulation>` (a
:class:`~simx_server.scene.simulation.Simulation`) and the sensor functions of
:mod:`simx_server.sim.sensors` (``force_sensor_reading``, ``proximity_reading``, ``get_int_param``,
``set_int_param``, ``get_float_param``, ``set_float_param``, ``override_image``) and
:mod:`simx_server.sim.vision` (``VisionSensors.image``), so that scripts and remote clients read
the same values. Names, arguments and returns follow CoppeliaSim 4.x's documentation; the V-REP
3.x names that differ (``getObjectInt32Parameter`` ...) keep their 3.x returns.
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import quote
from simx_server.api.sim.core import _int, _num, _text
from simx_server.api.signals import Signals
from simx_server.sim import object_params, proximity, sensors
from simx_server.sim.render_thread import wait_for
from simx_server.sim.state import RunState

#: CoppeliaSim's simulation states (``sim.getSimulationState``), as ``sim.NAME`` constants.
SIMULATION_STATES = {n[4:]: v for n, v in C.VREP_CONSTANTS.items() if n.startswith("sim_simulation_")}
#: ``sim.handleflag_greyscale``: added to a vision sensor's handle, a greyscale image.
HANDLEFLAG_GREYSCALE = C.SCRIPT_ONLY["sim_handleflag_greyscale"]
#: Constants this module adds to ``sim.*`` (besides the legacy ``sim_*`` ones).
CONSTANTS: dict[str, int] = {**SIMULATION_STATES, "handleflag_greyscale": HANDLEFLAG_GREYSCALE}


def _signal_name(name: Any) -> str:
    return _text(name, "signal name")


def _pair(value: Any, what: str) -> tuple[int, int]:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ArgumentError(f"{what} must be a table of 2 integers, got {quote(value)}")
    return _int(value[0], f"{what}[1]"), _int(value[1], f"{what}[2]")


# Signals, sensors, object parameters and the simulation state.

@sim_function("setInt32Signal")
def setInt32Signal(ctx: CallContext, name: Any, value: Any) -> None:  # noqa: N802 (CoppeliaSim's names)
    """Set integer signal ``name`` (CoppeliaSim 4's name of ``setIntegerSignal``); a client's
    ``simxGetIntegerSignal`` reads it. The value must be an integer (a float with no
    fractional part is taken) that fits in 64 bits; signals set by scripts are cleared
    when the simulation stops.

    Args:
        name: the signal's name (str or bytes).
        value: an integer.

    Raises:
        ArgumentError: a bad name, or a value that is not a 64-bit integer.
    """
    ctx.signals.set(Signals.INT, _signal_name(name), value, by_script=True)


@sim_function("getInt32Signal")
def getInt32Signal(ctx: CallContext, name: Any) -> int | None:  # noqa: N802
    """Integer signal ``name``; nil (None) when it is not set.

    Args:
        name: the signal's name.

    Returns:
        The value, or None.
    """
    return ctx.signals.get(Signals.INT, _signal_name(name))


@sim_function("clearInt32Signal")
def clearInt32Signal(ctx: CallContext, name: Any = None) -> None:  # noqa: N802
    """Clear integer signal ``name`` (every integer signal when nil).

    Args:
        name: the signal's name, or None for all.
    """
    ctx.signals.clear(Signals.INT, None if name is None else _signal_name(name))


@sim_function("readForceSensor")
def readForceSensor(ctx: CallContext, handle: Any) -> tuple[int, list[float], list[float]]:  # noqa: N802
    """``result, forceVector, torqueVector`` of a force sensor (a site with MuJoCo force and
    torque sensors): result bit 0 = data available, bit 1 = broken; force (N) and torque
    (N·m) in the sensor's frame, as ``simxReadForceSensor`` reads them. A hanging 2 kg
    payload reads about 19.6 N along gravity. Errors: not a force sensor.

    Args:
        handle: a force sensor's handle.

    Returns:
        ``(result, [fx, fy, fz], [tx, ty, tz])``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a force sensor.
    """
    state, force, torque = sensors.force_sensor_reading(ctx.simulation("readForceSensor"), ctx.h(handle))
    return state, force, torque


@sim_function("readProximitySensor")
def readProximitySensor(ctx: CallContext, handle: Any) -> tuple[int, float, list[float], int, list[float]]:  # noqa: N802
    """``result, distance, detectedPoint, detectedObjectHandle, detectedSurfaceNormalVector``
    (CoppeliaSim 4): result 1 when something is detected, else 0 (then distance 0, the
    point and normal zero and the handle -1); distance in m, point and normal in the
    sensor's frame (the ray runs along its z axis), the handle that of the shape hit (-1
    for geometry of the world body).

    Args:
        handle: a proximity sensor's handle.

    Returns:
        ``(result, distance, [x, y, z], handle, [nx, ny, nz])``.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a proximity sensor.
    """
    detected, point, hit, normal = proximity.proximity_reading(ctx.simulation("readProximitySensor"),
                                                             ctx.h(handle))
    return int(detected), float(np.linalg.norm(point)), point, hit, normal


def image_job(ctx: CallContext, what: str, handle: int, grey: bool) -> Callable[[], np.ndarray]:
    """The job giving the sensor's image (:meth:`VisionSensors.image_job`), or the image a
    passive sensor was given."""
    sim = ctx.simulation(what)
    img = sensors.override_image(sim, handle, grey)  # a passive sensor shows what was written
    return sim.vision.image_job(handle, grey) if img is None else (lambda: img)


def depth_job(ctx: CallContext, what: str, handle: int, metres: bool) -> Callable[[], np.ndarray]:
    """The job giving the sensor's depth (:meth:`VisionSensors.depth_job`): 0..1 between the
    clipping planes, or (``metres``) distances in m, (h, w), rows bottom-up."""
    vision = ctx.simulation(what).vision
    spec, depth = vision.spec(handle), vision.depth_job(handle)
    if not metres:
        return depth
    near, far = spec.near, spec.far
    return lambda: near + depth() * (far - near)


def rendered(ctx: CallContext, what: str, job: Callable[[], Any]) -> Any:
    """``job()``'s value, computed on the request render thread after the frames it uses:
    waited for, or (:attr:`CallContext.defer_renders`) a :class:`~simx_server.sim.vision.Deferred` of it."""
    vision = ctx.simulation(what).vision
    if ctx.defer_renders:
        return vision.rendered(job)
    return wait_for(vision.after(job), f"sim.{what}")


def crop(img: np.ndarray, x: Any, y: Any, w: Any, h: Any) -> np.ndarray:
    x, y, w, h = (_int(v, n) for v, n in ((x, "posX"), (y, "posY"), (w, "sizeX"), (h, "sizeY")))
    rows, cols = img.shape[:2]
    if w == 0 and h == 0:
        w, h = cols - x, rows - y
    if x < 0 or y < 0 or w <= 0 or h <= 0 or x + w > cols or y + h > rows:
        raise ArgumentError(f"the window at ({x}, {y}) of size {w}x{h} is not inside the "
                            f"{cols}x{rows} image")
    return img[y:y + h, x:x + w]


@sim_function("getVisionSensorImg")
def getVisionSensorImg(ctx: CallContext, handle: Any, options: Any = 0, rgbaCutOff: Any = 0,  # noqa: N802, N803
                       pos: Any = None, size: Any = None) -> tuple[bytes, list[int]]:
    """``image, resolution`` (CoppeliaSim 4.4+): the image as a buffer of uint8 RGB pixels
    (``options`` bit 0: one grey byte per pixel), rows bottom-up as V-REP's, and
    ``{width, height}`` of it. ``pos``/``size`` ``{x, y}`` cut a window (from the bottom
    left corner; size {0, 0}: the whole image). ``rgbaCutOff`` is accepted and ignored
    (no alpha channel). Errors: not a vision sensor, other option bits, a window outside.

    Args:
        handle: a vision sensor's handle.
        options: bit 0: grey.
        rgbaCutOff: ignored.
        pos: ``[x, y]`` of the window's bottom-left pixel, or None.
        size: ``[width, height]`` of the window in pixels, or None.

    Returns:
        ``(bytes, [width, height])`` (a Deferred reply over ZMQ, rendered on the render thread).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
        ArgumentError: other option bits, or a window outside the image.
    """
    opts = _int(options, "options")
    if opts & ~1:
        raise UnsupportedError(f"getVisionSensorImg options {opts}: only bit 0 (greyscale) is supported")
    _num(rgbaCutOff, "rgbaCutOff")
    px, py = (0, 0) if pos is None else _pair(pos, "pos")
    sx, sy = (0, 0) if size is None else _pair(size, "size")
    image = image_job(ctx, "getVisionSensorImg", ctx.h(handle), bool(opts & 1))

    def finish() -> tuple[bytes, list[int]]:
        img = crop(image(), px, py, sx, sy)
        return img.tobytes(), [int(img.shape[1]), int(img.shape[0])]

    return rendered(ctx, "getVisionSensorImg", finish)


@sim_function("getVisionSensorImage")
def getVisionSensorImage(ctx: CallContext, handle: Any, posX: Any = 0, posY: Any = 0, sizeX: Any = 0,  # noqa: N802, N803
                         sizeY: Any = 0, returnType: Any = 0) -> list[float] | bytes:  # noqa: N803
    """The image (V-REP 3.x / CoppeliaSim 4 before 4.4): a table of floats 0..1, three per
    pixel (RGB), rows bottom-up; ``returnType`` 1: a buffer of uint8 instead. Adding
    ``sim.handleflag_greyscale`` to the handle gives one value per pixel. ``posX/posY,
    sizeX/sizeY``: a window (0, 0, 0, 0: the whole image).

    Args:
        handle: a vision sensor's handle, plus ``sim.handleflag_greyscale`` for grey.
        posX: the window's first column, pixels.
        posY: its first row from the bottom, pixels.
        sizeX: its width, pixels (0: the whole image).
        sizeY: its height, pixels.
        returnType: 0 floats, 1 a uint8 buffer.

    Returns:
        Floats in 0..1, or bytes.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a vision sensor.
        ArgumentError: a ``returnType`` other than 0 or 1, or a window outside the image.
    """
    h = ctx.h(handle, "sensorHandle")
    grey = h >= 0 and bool(h & HANDLEFLAG_GREYSCALE)
    if grey:
        h &= ~HANDLEFLAG_GREYSCALE
    kind = _int(returnType, "returnType")
    if kind not in (0, 1):
        raise ArgumentError(f"returnType must be 0 (floats) or 1 (bytes), got {kind}")
    image = image_job(ctx, "getVisionSensorImage", ctx.h(h), grey)

    def finish() -> list[float] | bytes:
        img = crop(image(), posX, posY, sizeX, sizeY)
        if kind == 1:
            return img.tobytes()
        return (img.reshape(-1).astype(np.float64) / 255.0).tolist()

    return rendered(ctx, "getVisionSensorImage", finish)


@sim_function("getObjectInt32Param")
def getObjectInt32Param(ctx: CallContext, handle: Any, parameter: Any) -> int:  # noqa: N802
    """Integer parameter ``parameter`` (``sim.jointintparam_motor_enabled``,
    ``sim.visionintparam_resolution_x`` ...) of an object, as ``simxGetObjectIntParameter``
    reads it (CoppeliaSim 4). Errors: a parameter simx does not support (named).

    Args:
        handle: the object's handle.
        parameter: the parameter's id.

    Returns:
        The value (:func:`simx_server.sim.object_params.get_int_param`).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        UnsupportedError: an id simx does not answer.
    """
    return object_params.get_int_param(ctx.simulation("getObjectInt32Param"), ctx.h(handle),
                                 _int(parameter, "parameterID"))


@sim_function("setObjectInt32Param")
def setObjectInt32Param(ctx: CallContext, handle: Any, parameter: Any, value: Any) -> None:  # noqa: N802
    """Set an integer parameter (CoppeliaSim 4), as ``simxSetObjectIntParameter``:
    ``sim.jointintparam_ctrl_enabled`` 0/1 switches velocity / position control.

    Args:
        handle: the object's handle.
        parameter: the parameter's id.
        value: an integer.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        ArgumentError: a value out of range.
        UnsupportedError: an id or value simx cannot set.
    """
    object_params.set_int_param(ctx.simulation("setObjectInt32Param"), ctx.h(handle),
                          _int(parameter, "parameterID"), _int(value, "parameter"))


@sim_function("getObjectFloatParam")
def getObjectFloatParam(ctx: CallContext, handle: Any, parameter: Any) -> float:  # noqa: N802
    """Float parameter of an object (CoppeliaSim 4), as ``simxGetObjectFloatParameter``
    (velocities 11-14 in m/s and rad/s, bounding box 15-20 in m, clipping planes ...).

    Args:
        handle: the object's handle.
        parameter: the parameter's id.

    Returns:
        The value (:func:`simx_server.sim.object_params.get_float_param`).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        UnsupportedError: an id simx does not answer.
    """
    return object_params.get_float_param(ctx.simulation("getObjectFloatParam"), ctx.h(handle),
                                   _int(parameter, "parameterID"))


@sim_function("setObjectFloatParam")
def setObjectFloatParam(ctx: CallContext, handle: Any, parameter: Any, value: Any) -> None:  # noqa: N802
    """Set a float parameter (CoppeliaSim 4), as ``simxSetObjectFloatParameter``.

    Args:
        handle: the object's handle.
        parameter: the parameter's id.
        value: a number (m, rad, kg, a gain).

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: the id is of another object type.
        ArgumentError: a value out of range.
        UnsupportedError: a read-only or unknown id.
    """
    object_params.set_float_param(ctx.simulation("setObjectFloatParam"), ctx.h(handle),
                            _int(parameter, "parameterID"), _num(value, "parameter"))


@sim_function("getObjectInt32Parameter")
def getObjectInt32Parameter(ctx: CallContext, handle: Any, parameter: Any) -> tuple[int, int]:  # noqa: N802
    """V-REP 3.x: ``result, value``; result 0 (value 0) for a parameter simx does not support.

    Args:
        handle: the object's handle.
        parameter: the parameter's id.

    Returns:
        ``(result, value)``.
    """
    try:
        return 1, getObjectInt32Param(ctx, handle, parameter)
    except UnsupportedError:
        return 0, 0


@sim_function("setObjectInt32Parameter")
def setObjectInt32Parameter(ctx: CallContext, handle: Any, parameter: Any, value: Any) -> int:  # noqa: N802
    """V-REP 3.x: returns 1.

    Args:
        handle: the object's handle.
        parameter: the parameter's id.
        value: an integer.

    Returns:
        1.
    """
    setObjectInt32Param(ctx, handle, parameter, value)
    return 1


@sim_function("getObjectFloatParameter")
def getObjectFloatParameter(ctx: CallContext, handle: Any, parameter: Any) -> tuple[int, float]:  # noqa: N802
    """V-REP 3.x: ``result, value``; result 0 (value 0) for a parameter simx does not support.

    Args:
        handle: the object's handle.
        parameter: the parameter's id.

    Returns:
        ``(result, value)``.
    """
    try:
        return 1, getObjectFloatParam(ctx, handle, parameter)
    except UnsupportedError:
        return 0, 0.0


@sim_function("setObjectFloatParameter")
def setObjectFloatParameter(ctx: CallContext, handle: Any, parameter: Any, value: Any) -> int:  # noqa: N802
    """V-REP 3.x: returns 1.

    Args:
        handle: the object's handle.
        parameter: the parameter's id.
        value: a number.

    Returns:
        1.
    """
    setObjectFloatParam(ctx, handle, parameter, value)
    return 1


@sim_function("getSimulationState")
def getSimulationState(ctx: CallContext) -> int:  # noqa: N802
    """CoppeliaSim's simulation state: ``sim.simulation_advancing_running`` (0x11) while it
    runs, ``sim.simulation_paused`` (0x08) while paused, ``sim.simulation_stopped`` (0)
    while stopped, ``sim.simulation_advancing_firstafterstop`` (0x10) in the ``sysCall_init``
    of a start and ``sim.simulation_advancing_lastbeforestop`` (0x16) in ``sysCall_cleanup``.

    Returns:
        The state.
    """

    sim = ctx.simulation("getSimulationState")
    if getattr(sim.scripts, "stopping", False):  # sysCall_cleanup
        return SIMULATION_STATES["simulation_advancing_lastbeforestop"]
    if sim.state is RunState.RUNNING:
        return SIMULATION_STATES["simulation_advancing_running"]
    if sim.state is RunState.PAUSED:
        return SIMULATION_STATES["simulation_paused"]
    script = sim.scripts.scripts.get(ctx.owner)
    if script is not None and script.running:  # start: the scripts' init runs before RUNNING
        return SIMULATION_STATES["simulation_advancing_firstafterstop"]
    return SIMULATION_STATES["simulation_stopped"]



