"""simVision's measurements of the work image, each ``trigger, packedPacket[, colours]``: the
binary image's moments, blobs, changed pixels (:mod:`simx_server.sim.vision_blobs`), and points
from a depth map (:mod:`simx_server.sim.vision_points`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import simvision_function
from simx_server.api.sim.core import HANDLE_MASK
from simx_server.api.simvision.work import as_count, colour, flag, packed, sensor, simulation, state, step
from simx_server.base.arguments import as_integer, as_number
from simx_server.sim import vision_params, vision_points
from simx_wire.protocol import ArgumentError

#: ``sim.handleflag_abscoords``: points in the world's frame.
ABS_COORDS = 0x800000
#: The most points of one ``coordinatesFromWorkImg`` / ``velodyneDataFromWorkImg``.
MAX_POINTS = 4_000_000


@simvision_function()
def binaryWorkImg(ctx: CallContext, visionSensorHandle: Any, threshold: Any, oneProportion: Any, oneTol: Any,  # noqa: N802, N803
                  xCenter: Any, xCenterTol: Any, yCenter: Any, yCenterTol: Any, orient: Any, orientTol: Any,  # noqa: N803
                  roundness: Any, enableTrigger: Any, overlayColor: Any = None) -> tuple[bool, bytes]:  # noqa: N803
    """The work image made binary at ``threshold`` (intensity), and ``trigger, packedPacket``:
    the packet is the white part's proportion, centre x and y (0..1, y from the bottom), the
    orientation of its second moments (rad) and roundness; with ``enableTrigger`` the sensor
    triggers when each is within its tolerance of the value given (roundness at most
    ``roundness``). ``overlayColor`` ``{r, g, b}``: the orientation and centre are drawn."""
    values = [as_number(v, n) for v, n in ((threshold, "threshold"), (oneProportion, "oneProportion"),
                                           (oneTol, "oneTol"), (xCenter, "xCenter"), (xCenterTol, "xCenterTol"),
                                           (yCenter, "yCenter"), (yCenterTol, "yCenterTol"), (orient, "orient"),
                                           (orientTol, "orientTol"), (roundness, "roundness"))]
    overlay = colour(overlayColor, "overlayColor") or ()
    _, res = step(ctx, visionSensorHandle, "binaryWorkImg", *values, flag(enableTrigger, "enableTrigger"), *overlay)
    return res.trigger, packed(res.packets[0])


@simvision_function()
def blobDetectionOnWorkImg(ctx: CallContext, visionSensorHandle: Any, threshold: Any, minBlobSize: Any,  # noqa: N802, N803
                           modifyWorkImage: Any, overlayColor: Any = None) -> tuple[bool, bytes]:  # noqa: N803
    """Blobs of pixels of intensity >= ``threshold`` (8-connected), those under ``minBlobSize``
    (a fraction of the image) blacked out; ``false, packedPacket``: ``[count, 6, then per blob
    relative size, orientation (rad), centre x, y, width, height (0..1)]``. ``modifyWorkImage``:
    each blob painted in one of simVision's colours, the rest black; ``overlayColor``: each
    blob's box drawn."""
    overlay = colour(overlayColor, "overlayColor") or ()
    _, res = step(ctx, visionSensorHandle, "blobDetectionOnWorkImg", as_number(threshold, "threshold"),
                  as_number(minBlobSize, "minBlobSize"), flag(modifyWorkImage, "modifyWorkImage"), *overlay)
    return False, packed(res.packets[0])


@simvision_function()
def changedPixelsOnWorkImg(ctx: CallContext, visionSensorHandle: Any, threshold: Any) -> tuple:  # noqa: N802, N803
    """Pixels whose intensity changed by ``threshold`` (relative) since buffer 2 recorded it:
    white (brighter) or black (darker), the others grey; ``false, packedPacket`` of ``[+1 or -1,
    x, y]`` per changed pixel (no packet when none changed)."""
    _, res = step(ctx, visionSensorHandle, "changedPixelsOnWorkImg", as_number(threshold, "threshold"))
    return (False, packed(res.packets[0])) if res.packets else (False,)


def _view(ctx: CallContext, raw: Any, what: str, counts: Any) -> tuple[int, vision_points.View, tuple[int, int]]:
    """The sensor (the handle without ``sim.handleflag_abscoords``), what its points need, and the
    point counts."""
    h = as_integer(raw, "visionSensorHandle")
    absolute = h >= 0 and bool(h & ABS_COORDS)
    h = sensor(ctx, h & HANDLE_MASK if h >= 0 else h)
    if not isinstance(counts, (list, tuple)) or len(counts) != 2:
        raise ArgumentError(f"{what}: the point counts must be a table of 2 integers, got {counts!r}")
    nx, ny = as_count(counts[0], "xPointCount"), as_count(counts[1], "yPointCount")
    if nx * ny > MAX_POINTS:
        raise ArgumentError(f"{what}: {nx} x {ny} points, more than {MAX_POINTS}")
    sim = simulation(ctx, what)
    spec = sim.vision.spec(h)
    perspective, angle, size = vision_params.view(sim, h)
    pose = None
    if absolute:
        p, r = ctx.world.frame(h)
        pose = np.column_stack([r, p])
    return h, vision_points.View(perspective, spec.near, spec.far, angle, size, pose), (nx, ny)


@simvision_function()
def coordinatesFromWorkImg(ctx: CallContext, visionSensorHandle: Any, xyPointCount: Any,  # noqa: N802, N803
                           evenlySpacedInAngularSpace: Any, returnColorData: Any = False) -> tuple:  # noqa: N803
    """The work image read as a depth map: ``false, packedPacket[, colours]`` of an ``{x, y}``
    grid of points across the view: ``[xCount, yCount, then x, y, z, distance per point]`` in
    the sensor's frame (the handle plus ``sim.handleflag_abscoords``: the world's), rows from
    the bottom; evenly spaced in angle or in the image plane; ``colours``: buffer 1's RGB bytes
    of each point, when asked and buffer 1 was used."""
    return _grid(ctx, visionSensorHandle, xyPointCount, flag(evenlySpacedInAngularSpace, "evenlySpacedInAngularSpace"),
                 returnColorData)


def _grid(ctx: CallContext, raw: Any, counts: Any, angular: bool, colours: Any) -> tuple:
    what = "coordinatesFromWorkImg"
    h, view, (nx, ny) = _view(ctx, raw, what, counts)
    work, b1 = _copies(ctx, h, what, colours)
    packet, rgb = vision_points.coordinates(work, b1, (nx, ny), angular, view)
    return (False, packed(packet), rgb) if rgb else (False, packed(packet))


def _copies(ctx: CallContext, h: int, what: str, colours: Any) -> tuple[np.ndarray, np.ndarray | None]:
    """The work image and (for colours) buffer 1, copied under the state's lock."""
    st = state(ctx, h, what)
    with st.lock:
        b1 = st.buffers[0]
        return st.work.copy(), (b1.copy() if flag(colours, "returnColorData") and b1 is not None else None)


@simvision_function()
def velodyneDataFromWorkImg(ctx: CallContext, visionSensorHandle: Any, xyPointCount: Any, vAngle: Any,  # noqa: N802, N803
                            returnColorData: Any = False) -> tuple:  # noqa: N803
    """The work image read as a perspective depth map, as one sensor of a rotating scanner:
    ``false, packedPacket[, colours]`` of ``xCount`` columns across the view of ``yCount`` rays
    each over ``vAngle`` rad vertically (``[xCount, yCount, then x, y, z, distance per point]``,
    column after column); ``colours`` as :func:`coordinatesFromWorkImg`'s."""
    what = "velodyneDataFromWorkImg"
    h, view, (nx, ny) = _view(ctx, visionSensorHandle, what, xyPointCount)
    work, b1 = _copies(ctx, h, what, returnColorData)
    packet, rgb = vision_points.velodyne(work, b1, (nx, ny), as_number(vAngle, "vAngle"), view)
    return (False, packed(packet), rgb) if rgb else (False, packed(packet))
