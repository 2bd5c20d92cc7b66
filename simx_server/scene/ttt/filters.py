"""A ``.ttt`` vision sensor's filter components (``Cfr``) and options, as the ``simx:NAME``
settings that :mod:`simx_server.sim.vision_filters` and :mod:`simx_server.sim.sensor_spec` read.

The records follow coppeliaSimLib's loaders: ``CComposedFilter::serialize`` (``Cfr``: one
``Sfr`` list per component) and ``CSimpleFilter::serialize`` (``Sft`` type, ``Pab``/``Pai``/
``Paf`` byte, int and float parameters over the defaults of ``CSimpleFilter::setFilterType``,
``Sfe`` bit 0 enabled); each component becomes the ``simVision`` call of
``CSimpleFilter::getCodeEquivalent``. ``CVisionSensor::serialize`` gives the options: ``Va2``
bits 1 ignore RGB, 2 ignore depth, 4 no basic statistics (V-REP's default packet); ``Va3`` bit 7
background = the environment's fog background colour (``Fbg``); ``Db2`` the default background
colour (what ``CVisionSensor`` clears its image to, ``_clearBuffers``); ``Rmd`` the render mode.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

import numpy as np

from simx_server.scene.ttt.records import Records
from simx_server.sim.vision_params import gaussian_kernel

#: V-REP's component type ids (simConst ``sim_filtercomponent_*``) that simx cannot apply.
UNSUPPORTED = {32: "correlation with buffer 1", 35: "image to coordinates", 37: "velodyne", -1: "plugin filter"}
#: Components without parameters: type id -> simVision function.
_PLAIN = {1: "sensorImgToWorkImg", 2: "sensorDepthMapToWorkImg", 4: "workImgToSensorImg",
          38: "workImgToSensorDepthMap", 5: "workImgToBuffer1", 6: "workImgToBuffer2", 7: "buffer1ToWorkImg",
          8: "buffer2ToWorkImg", 9: "swapBuffers", 10: "addBuffer1ToWorkImg", 11: "subtractBuffer1FromWorkImg",
          12: "multiplyWorkImgWithBuffer1", 13: "horizontalFlipWorkImg", 14: "verticalFlipWorkImg",
          20: "sharpenWorkImg", 24: "normalizeWorkImg", 29: "swapWorkImgWithBuffer1", 30: "addWorkImgToBuffer1",
          31: "subtractWorkImgFromBuffer1"}
MAX_COMPONENTS = 64


@dataclass
class FilterComponent:
    """One filter component: V-REP's type id (-1: a plugin's), enabled, and its parameters."""

    type: int
    enabled: bool = True
    bytes: list[int] = field(default_factory=list)
    ints: list[int] = field(default_factory=list)
    floats: list[float] = field(default_factory=list)


def _gaussian(n: int) -> list[float]:
    """``setFilterType``'s default n x n blur plus the multiplier 1."""
    return [*gaussian_kernel(n).tolist(), 1.0]


def _defaults(t: int) -> tuple[list[int], list[int], list[float]]:
    """``CSimpleFilter::setFilterType``'s default (bytes, ints, floats) of a component type."""
    table: dict[int, tuple[list[int], list[int], list[float]]] = {
        3: ([], [], [1.0, 1.0, 1.0]),
        15: ([], [], [math.radians(45.0)]),
        17: ([], [], [1.2, 1.2]),
        16: ([0], [], [0.5, 0.5]),
        18: ([], [1], _gaussian(3)),
        19: ([], [1], _gaussian(5)),
        21: ([], [], [0.1]),
        22: ([0], [], [0.9, 0.9]),
        23: ([0], [], [1.0]),
        25: ([], [1], [0.0, 1.0]),
        26: ([3], [], [0.5, 0.5, 0.5, 0.25, 0.25, 0.25]),
        27: ([2], [], [0.0, 0.0, 0.0, 1.2, 1.2, 1.2, 0.0, 0.0, 0.0]),
        28: ([12], [], [0.1, 0.0, 0.0, 0.0, 0.5, 0.25, 0.5, 0.25, 0.5, 0.25, 0.0, math.radians(90.01), 0.9]),
        33: ([], [], [0.3]),
        34: ([1], [], [0.1, 0.0]),
        36: ([], [], [0.1]),
    }
    b, i, f = table.get(t, ([], [], []))
    return list(b), list(i), list(f)


def _overwrite(values: list, payload, fmt: str) -> None:
    """``Pab``/``Pai``/``Paf``: an i32 count, then values overwriting the defaults in place
    (extra values ignored, as V-REP ignored them)."""
    if payload is None or len(payload) < 4:
        return
    n, = struct.unpack_from("<i", payload, 0)
    size = struct.calcsize(fmt)
    n = max(0, min(n, len(values), (len(payload) - 4) // size))
    for k in range(n):
        values[k] = struct.unpack_from(fmt, payload, 4 + k * size)[0]


def read_filters(r: Records) -> list[FilterComponent]:
    """The filter components of a vision sensor's type records (``Cfr``), in order.

    Args:
        r: the sensor's type records.

    Returns:
        Its components (empty when the file has none).

    Raises:
        SceneFileError: more than MAX_COMPONENTS components.
    """
    out: list[FilterComponent] = []
    if r.get("Cfr") is None:
        return out
    chain = r.sub("Cfr")
    for tag, payload in chain:
        if tag != "Sfr":
            continue
        if len(out) >= MAX_COMPONENTS:
            raise chain.error(tag, f"more than {MAX_COMPONENTS} filter components")
        s = chain.sub(tag, payload)
        t = s.int("Sft", -1)
        t = -1 if t >= 1000 or t < 1 else t  # plugin filters (sim_filtercomponent_customized)
        b, i, f = _defaults(t)
        _overwrite(b, s.get("Pab"), "<B")
        _overwrite(i, s.get("Pai"), "<i")
        _overwrite(f, s.get("Paf"), "<f")
        enabled = bool(s.byte("Sfe", 1) & 1) if s.get("Sfe") is not None else True
        out.append(FilterComponent(t, enabled, b, i, [float(v) for v in f]))
    return out


def _num(v: float) -> str:
    return f"{v:.7g}"  # the file's float32 values, as written (0.2, not 0.200000003)


def _call(name: str, *args: float) -> str:
    return f"{name}({','.join(_num(float(a)) for a in args)})" if args else name


def _step(c: FilterComponent) -> str | None:
    """The simVision call of one component (``getCodeEquivalent``), None if simx has none."""
    t, b, i, f = c.type, c.bytes, c.ints, c.floats
    if t in _PLAIN:
        return _PLAIN[t]
    bit = (lambda k: 1 if b and b[0] & k else 0)
    calls = {
        3: lambda: _call("uniformImgToWorkImg", *f[:3]),
        15: lambda: _call("rotateWorkImg", f[0]),
        16: lambda: _call("shiftWorkImg", f[0], f[1], 1 - bit(1)),
        17: lambda: _call("resizeWorkImg", f[0], f[1]),
        18: lambda: _call("matrix3x3OnWorkImg", i[0], f[9], *f[:9]),
        19: lambda: _call("matrix5x5OnWorkImg", i[0], f[25], *f[:25]),
        21: lambda: _call("edgeDetectionOnWorkImg", f[0]),
        22: lambda: _call("rectangularCutWorkImg", f[0], f[1], bit(1)),
        23: lambda: _call("circularCutWorkImg", f[0], bit(1)),
        25: lambda: _call("intensityScaleOnWorkImg", f[0], f[1], 1 - (i[0] & 1)),
        26: lambda: _call("selectiveColorOnWorkImg", *f[:6], bit(2), bit(1), bit(4)),
        27: lambda: _call("scaleAndOffsetWorkImg", *f[:9], bit(2)),
        28: lambda: _call("binaryWorkImg", f[0], *f[4:13], bit(4)),
        33: lambda: _call("colorSegmentationOnWorkImg", f[0]),
        34: lambda: _call("blobDetectionOnWorkImg", f[0], f[1], bit(1)),
        36: lambda: _call("changedPixelsOnWorkImg", f[0]),
    }
    make = calls.get(t)
    if make is None or not all(math.isfinite(v) for v in f):
        return None
    return make()


def chain_setting(components: list[FilterComponent]) -> tuple[str | None, list[str]]:
    """The ``filters=`` value of a chain and what simx cannot apply of it.

    V-REP's identity chain (original image, then to output) and a chain of disabled
    components give no setting. A chain with a component simx cannot apply is dropped whole
    (the sensor then shows its rendered image), and the component is named.

    Args:
        components: :func:`read_filters`'s result.

    Returns:
        ``(value or None, [names of components simx cannot apply])``.
    """
    active = [c for c in components if c.enabled]
    if [c.type for c in active] in ([], [1, 4]):
        return None, []
    steps, missing = [], []
    for c in active:
        step = _step(c)
        if step is None:
            missing.append(UNSUPPORTED.get(c.type, f"component {c.type}"))
        steps.append(step)
    if missing:
        return None, missing
    return ";".join(steps), []


def vision_settings(conv, v, name: str) -> list[str]:
    """The ``simx:NAME`` settings of a vision sensor's options and filters (the clipping planes
    and image kind are :func:`simx_server.scene.ttt.parts.add_sensor`'s); lines of the load
    report for what cannot carry over.

    Args:
        conv: the converter (its ``report`` and ``scene``).
        v: the sensor's VisionData.
        name: the sensor's name.

    Returns:
        ``key=value`` settings.
    """
    items = []
    value, missing = chain_setting(v.filters)
    if value is not None:
        items.append(f"filters={value}")
    for m in missing:
        conv.report.add(f"vision sensor filters: {m} (the sensor shows its unfiltered image)")
    if v.ignore_rgb:
        items.append("ignore_rgb=true")
    if v.ignore_depth:
        items.append("ignore_depth=true")
    if not v.basic_stats:
        items.append("basic_stats=false")
    if v.explicit:  # handled by sim.handleVisionSensor only (its vision callbacks)
        items.append("explicit=true")
    background = v.background
    if v.same_background:  # the environment's fog background colour (Fbg, default black)
        fog = conv.scene.fog_background
        background = fog if fog is not None else np.zeros(3)
    if background is None or not np.all(np.isfinite(background)):
        background = np.zeros(3)  # CVisionSensor's default: black
    items.append("background=" + ",".join(_num(float(c)) for c in np.clip(background, 0, 1)))
    if v.render_mode == 2:
        items.append("render_mode=handles")
    elif v.render_mode == 1:
        conv.report.add("vision sensors in OpenGL auxiliary-channel render mode (rendered in colour)", approximated=True)
    elif v.render_mode not in (0, 7, 8):
        conv.report.add("vision sensors rendered by POV-Ray or an external renderer (rendered with OpenGL)", approximated=True)
    return items
