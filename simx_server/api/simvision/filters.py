"""simVision's filters of the work image: geometry (shift, rotate, resize), convolutions, cuts,
intensity and colour operations (:mod:`simx_server.sim.vision_filters`); the argument-free ones
(flips, sharpen, normalize) are registered with the buffers in :mod:`.work`."""

from __future__ import annotations

from typing import Any


from simx_server.api.context import CallContext
from simx_server.api.registry import simvision_function
from simx_server.api.simvision.work import flag, step
from simx_server.base.arguments import as_integer, as_number, as_vector
from simx_server.sim.vision_params import gaussian_kernel
from simx_wire.protocol import ArgumentError

#: The most passes of a convolution (each is a pass over the whole image).
MAX_PASSES = 256


@simvision_function()
def shiftWorkImg(ctx: CallContext, visionSensorHandle: Any, shift: Any, wrapAround: Any) -> bool:  # noqa: N802, N803
    """Shifts the work image by ``{x, y}`` (fractions of its width and height, rounded to whole
    pixels); what leaves one side comes back on the other when ``wrapAround``, else black; false."""
    x, y = as_vector(shift, 2, "shift")
    step(ctx, visionSensorHandle, "shiftWorkImg", x, y, flag(wrapAround, "wrapAround"))
    return False


@simvision_function()
def rotateWorkImg(ctx: CallContext, visionSensorHandle: Any, rotationAngle: Any) -> bool:  # noqa: N802, N803
    """Rotates the work image about its centre by ``rotationAngle`` (rad, counter-clockwise as
    seen), each pixel taking the nearest source pixel (black outside); false."""
    step(ctx, visionSensorHandle, "rotateWorkImg", as_number(rotationAngle, "rotationAngle"))
    return False


@simvision_function()
def resizeWorkImg(ctx: CallContext, visionSensorHandle: Any, scaling: Any) -> bool:  # noqa: N802, N803
    """Scales the work image about its centre by ``{x, y}`` (nearest pixel, black outside); false.

    Raises:
        ArgumentError: a zero scale.
    """
    sx, sy = as_vector(scaling, 2, "scaling")
    if sx == 0.0 or sy == 0.0:
        raise ArgumentError("scaling must not be 0")
    step(ctx, visionSensorHandle, "resizeWorkImg", sx, sy)
    return False


def _matrix(ctx: CallContext, handle: Any, n: int, passes: Any, multiplier: Any, matrix: Any) -> bool:
    count = as_integer(passes, "passes")
    if count > MAX_PASSES:
        raise ArgumentError(f"passes must be at most {MAX_PASSES}, got {count}")
    mult = as_number(multiplier, "multiplier")
    if isinstance(matrix, (list, tuple)) and len(matrix) >= n * n:
        kernel = as_vector(list(matrix)[:n * n], n * n, "matrix")
    else:  # the plug-in's default (no matrix, or a short one)
        kernel = gaussian_kernel(n).tolist()
    step(ctx, handle, f"matrix{n}x{n}OnWorkImg", count, mult, *kernel)
    return False


@simvision_function()
def matrix3x3OnWorkImg(ctx: CallContext, visionSensorHandle: Any, passes: Any, multiplier: Any,  # noqa: N802, N803
                       matrix: Any = None) -> bool:
    """Convolves the work image ``passes`` times with ``matrix`` (9 values, row after row, x
    multiplier; default: a Gaussian blur), at the borders with the pixels inside scaled up, then
    clamps to 0..1; false."""
    return _matrix(ctx, visionSensorHandle, 3, passes, multiplier, matrix)


@simvision_function()
def matrix5x5OnWorkImg(ctx: CallContext, visionSensorHandle: Any, passes: Any, multiplier: Any,  # noqa: N802, N803
                       matrix: Any = None) -> bool:
    """As :func:`matrix3x3OnWorkImg` with a 5x5 matrix (25 values); false."""
    return _matrix(ctx, visionSensorHandle, 5, passes, multiplier, matrix)


@simvision_function()
def edgeDetectionOnWorkImg(ctx: CallContext, visionSensorHandle: Any, threshold: Any) -> bool:  # noqa: N802, N803
    """White where the intensity of simVision's 3x3 edge kernel's response passes ``threshold``,
    black elsewhere; false."""
    step(ctx, visionSensorHandle, "edgeDetectionOnWorkImg", as_number(threshold, "threshold"))
    return False


@simvision_function()
def rectangularCutWorkImg(ctx: CallContext, visionSensorHandle: Any, sizes: Any, copyToBuffer1: Any) -> bool:  # noqa: N802, N803
    """Blacks the work image outside a centred rectangle of ``{x, y}`` (fractions of the image);
    with ``copyToBuffer1`` buffer 1 gets what was cut (black elsewhere); false."""
    x, y = as_vector(sizes, 2, "sizes")
    step(ctx, visionSensorHandle, "rectangularCutWorkImg", x, y, flag(copyToBuffer1, "copyToBuffer1"))
    return False


@simvision_function()
def circularCutWorkImg(ctx: CallContext, visionSensorHandle: Any, radius: Any, copyToBuffer1: Any) -> bool:  # noqa: N802, N803
    """Blacks the work image outside a centred circle of ``radius`` (a fraction of half the
    smaller side); with ``copyToBuffer1`` buffer 1 gets what was cut; false."""
    step(ctx, visionSensorHandle, "circularCutWorkImg", as_number(radius, "radius"), flag(copyToBuffer1, "copyToBuffer1"))
    return False


@simvision_function()
def intensityScaleOnWorkImg(ctx: CallContext, visionSensorHandle: Any, start: Any, end: Any, greyScale: Any) -> bool:  # noqa: N802, N803
    """Each pixel's intensity mapped to ``start + intensity * (end - start)``, shown grey
    (``greyScale``) or on simVision's colour scale (black, blue, red, yellow); false."""
    step(ctx, visionSensorHandle, "intensityScaleOnWorkImg", as_number(start, "start"), as_number(end, "end"),
         flag(greyScale, "greyScale"))
    return False


@simvision_function()
def selectiveColorOnWorkImg(ctx: CallContext, visionSensorHandle: Any, color: Any, colorTolerance: Any,  # noqa: N802, N803
                            rgb: Any, keep: Any, removedPartToBuffer1: Any) -> bool:
    """Keeps (``keep``) or removes (blacks) the pixels within ``colorTolerance`` of ``color``,
    in RGB or (``rgb`` false) hue, saturation, lightness (hue wraps around); with
    ``removedPartToBuffer1`` buffer 1 gets what was removed; false."""
    step(ctx, visionSensorHandle, "selectiveColorOnWorkImg", *as_vector(color, 3, "color"),
         *as_vector(colorTolerance, 3, "colorTolerance"), flag(rgb, "rgb"), flag(keep, "keep"),
         flag(removedPartToBuffer1, "removedPartToBuffer1"))
    return False


@simvision_function()
def scaleAndOffsetWorkImg(ctx: CallContext, visionSensorHandle: Any, preOffset: Any, scaling: Any,  # noqa: N802, N803
                          postOffset: Any, rgb: Any) -> bool:
    """Each channel (RGB, or with ``rgb`` false hue, saturation, lightness) becomes
    ``postOffset + (value + preOffset) * scaling``, clamped to 0..1; false."""
    step(ctx, visionSensorHandle, "scaleAndOffsetWorkImg", *as_vector(preOffset, 3, "preOffset"),
         *as_vector(scaling, 3, "scaling"), *as_vector(postOffset, 3, "postOffset"), flag(rgb, "rgb"))
    return False


@simvision_function()
def colorSegmentationOnWorkImg(ctx: CallContext, visionSensorHandle: Any, maxColorColorDistance: Any) -> bool:  # noqa: N802, N803
    """Scanning from the bottom row, each pixel takes the first colour met so far within
    ``maxColorColorDistance`` (RGB) of its own, else keeps its own and joins the colours; false.

    Raises:
        ArgumentError: so many colours that simx's bound on the work is passed.
    """
    try:
        step(ctx, visionSensorHandle, "colorSegmentationOnWorkImg",
             as_number(maxColorColorDistance, "maxColorColorDistance"))
    except ValueError as exc:
        raise ArgumentError(str(exc)) from None
    return False
