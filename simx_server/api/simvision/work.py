"""simVision's work image and buffers: reading the sensor into the work image, writing it back
(image or depth buffer), a uniform image, the buffers and their arithmetic; and the helpers every
``simVision`` function uses (the sensor, its work image, one step)."""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import simvision_function
from simx_server.api.sim import sensors as _sensors
from simx_server.base.arguments import as_integer, as_number, as_vector
from simx_server.sim import sensors, vision_filters as VF
from simx_server.sim.objects import VISION_SENSOR
from simx_server.sim.render_thread import wait_for
from simx_server.sim.state import SimulationView
from simx_wire.protocol import ArgumentError, UnsupportedError

NO_WORK_IMAGE = "Invalid handle or work image not initialized."  # the plug-in's message


def simulation(ctx: CallContext, what: str) -> SimulationView:
    """The simulation (UnsupportedError naming ``simVision.what`` without one)."""
    view = ctx.view
    if view is None:
        raise UnsupportedError(f"simVision.{what} needs the simulation: this script runs without one")
    return view


def sensor(ctx: CallContext, handle: Any) -> int:
    """A vision sensor's handle (``sim.handle_self``: the script's object); UnknownObjectError,
    ObjectTypeError otherwise."""
    return ctx.world.get(ctx.h(handle, "visionSensorHandle"), VISION_SENSOR).handle


def flag(value: Any, what: str) -> bool:
    """A boolean argument: a boolean (or a number, 0 false)."""
    if isinstance(value, bool):
        return value
    return as_number(value, what) != 0.0


def state(ctx: CallContext, handle: int, what: str) -> VF.FilterState:
    """The sensor's work image and buffers; ArgumentError (the plug-in's message) when it has no
    work image."""
    st = simulation(ctx, what).vision.work_state(handle)
    if st is None or st.work is None:
        raise ArgumentError(NO_WORK_IMAGE)
    return st


def step(ctx: CallContext, handle: Any, what: str, *args: float) -> tuple[int, VF.Filtered]:
    """Run the chain's step ``what`` on the sensor's work image: ``(sensor handle, result)``."""
    h = sensor(ctx, handle)
    st = state(ctx, h, what)
    try:
        return h, VF.run_step(st, VF.Step(what, tuple(float(a) for a in args)))
    except VF.NoWorkImageError:
        raise ArgumentError(NO_WORK_IMAGE) from None


def packed(values: list[float] | np.ndarray) -> bytes:
    """Float32 values (a list or an array) packed as ``sim.packFloatTable`` packs them."""
    return np.asarray(values, "<f4").tobytes()


def colour(value: Any, what: str) -> tuple[float, ...] | None:
    """An optional ``{r, g, b}`` (None when absent or not 3 values, as the plug-in ignores it)."""
    if value is None or not isinstance(value, (list, tuple)) or len(value) != 3:
        return None
    return tuple(as_vector(value, 3, what))


# ------------------------------------------------------------------ input and output
def _read(ctx: CallContext, handle: Any, what: str, depth: bool) -> None:
    h = sensor(ctx, handle)
    sim = simulation(ctx, what)
    rec = sim.vision.record(h)  # in a callback: the image it handles (and what callbacks wrote)
    if rec is not None:
        rgb, dmap = rec.rgb, rec.depth
    elif depth:
        rgb, dmap = None, wait_for(sim.vision.after(_sensors.depth_job(ctx, what, h, False)), f"simVision.{what}")
    else:
        rgb, dmap = wait_for(sim.vision.after(_sensors.image_job(ctx, what, h, False)), f"simVision.{what}"), None
    VF.run_step(sim.vision.work_state(h, create=True), VF.Step(what), rgb, dmap)


@simvision_function()
def sensorImgToWorkImg(ctx: CallContext, visionSensorHandle: Any) -> bool:  # noqa: N802, N803
    """The sensor's image (as the sensor shows it now: in its vision callback the image being
    handled) into the work image (made at the sensor's resolution); false."""
    _read(ctx, visionSensorHandle, "sensorImgToWorkImg", False)
    return False


@simvision_function()
def sensorDepthMapToWorkImg(ctx: CallContext, visionSensorHandle: Any) -> bool:  # noqa: N802, N803
    """The sensor's depth buffer (0..1 between its clipping planes) into the work image, grey; false."""
    _read(ctx, visionSensorHandle, "sensorDepthMapToWorkImg", True)
    return False


def _write(ctx: CallContext, handle: Any, what: str, remove: Any) -> None:
    h, res = step(ctx, handle, what)
    sim = simulation(ctx, what)
    spec, st = sim.vision.spec(h), sim.vision.work_state(h)
    if st.work.shape[:2] != (spec.height, spec.width):
        raise ArgumentError("Resolution mismatch.")
    rec = sim.vision.in_callback(h)
    if res.image is not None:
        if rec is not None:
            rec.rgb = res.image
        elif sensors.is_passive(sim, h):  # a passive sensor's new image (handled if it has callbacks)
            sensors.set_passive_image(sim, h, res.image.tobytes(), False)
        else:
            sim.vision.write(h, rgb=res.image, hooks=sensors.vision_hooks(sim, h))
    elif rec is not None:
        rec.depth = res.depth
    else:
        sim.vision.write(h, depth=res.depth)
    if flag(remove, "removeBuffer") and all(b is None for b in st.buffers):
        sim.vision.drop_work_state(h)


@simvision_function()
def workImgToSensorImg(ctx: CallContext, visionSensorHandle: Any, removeBuffer: Any = True) -> bool:  # noqa: N802, N803
    """The work image becomes the sensor's image (bytes = value x 255.1); in the sensor's vision
    callback, the image clients read after the handling. The work image is dropped unless
    ``removeBuffer`` is false or a buffer was used; false."""
    _write(ctx, visionSensorHandle, "workImgToSensorImg", removeBuffer)
    return False


@simvision_function()
def workImgToSensorDepthMap(ctx: CallContext, visionSensorHandle: Any, removeBuffer: Any = True) -> bool:  # noqa: N802, N803
    """The work image's intensity becomes the sensor's depth buffer (0..1); as
    :func:`workImgToSensorImg`; false."""
    _write(ctx, visionSensorHandle, "workImgToSensorDepthMap", removeBuffer)
    return False


@simvision_function()
def uniformImgToWorkImg(ctx: CallContext, visionSensorHandle: Any, color: Any) -> bool:  # noqa: N802, N803
    """Every pixel of the work image ``{r, g, b}`` (0..1); false."""
    step(ctx, visionSensorHandle, "uniformImgToWorkImg", *as_vector(color, 3, "color"))
    return False


def _plain(name: str, doc: str) -> None:
    """Register the step ``name`` without arguments as ``simVision.name``."""
    def function(ctx: CallContext, visionSensorHandle: Any) -> bool:  # noqa: N803
        step(ctx, visionSensorHandle, name)
        return False

    function.__name__ = function.__qualname__ = name
    function.__doc__ = doc + "; false."
    simvision_function(name)(function)


for _name, _doc in (
        ("workImgToBuffer1", "Copies the work image into buffer 1"),
        ("workImgToBuffer2", "Copies the work image into buffer 2"),
        ("buffer1ToWorkImg", "Copies buffer 1 (black if unused) into the work image"),
        ("buffer2ToWorkImg", "Copies buffer 2 (black if unused) into the work image"),
        ("swapBuffers", "Swaps buffers 1 and 2"),
        ("swapWorkImgWithBuffer1", "Swaps the work image and buffer 1"),
        ("addWorkImgToBuffer1", "Buffer 1 += work image (at most 1)"),
        ("subtractWorkImgFromBuffer1", "Buffer 1 -= work image (at least 0)"),
        ("addBuffer1ToWorkImg", "Work image += buffer 1 (at most 1)"),
        ("subtractBuffer1FromWorkImg", "Work image -= buffer 1 (at least 0)"),
        ("multiplyWorkImgWithBuffer1", "Work image *= buffer 1"),
        ("horizontalFlipWorkImg", "Mirrors the work image left-right"),
        ("verticalFlipWorkImg", "Mirrors the work image top-bottom"),
        ("sharpenWorkImg", "Sharpens the work image (simVision's 3x3 kernel, clamped to 0..1)"),
        ("normalizeWorkImg", "Stretches the work image's values to span 0..1")):
    _plain(_name, _doc)


def as_count(value: Any, what: str) -> int:
    """A positive count."""
    n = as_integer(value, what)
    if n < 1:
        raise ArgumentError(f"{what} must be at least 1, got {n}")
    return n
