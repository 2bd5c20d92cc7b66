"""CoppeliaSim 4.x's graph streams and curves kept as data (``sim.addGraphStream``,
``sim.setGraphStreamValue``, ``sim.getGraphCurve`` ...).

A graph in simx is a dummy (the ``.ttt`` loader turns CoppeliaSim's graph objects into sites;
any dummy may serve). ``sim.setGraphStreamValue`` records the stream's value at the current
simulation time (a second value at the same time replaces the first), which CoppeliaSim's main
script does at ``sim.handleGraph`` each step. ``sim.getGraphCurve`` reads a time stream
(``graphType`` 0: x the times, y the values after the stream's transformation:
``sim.stream_transf_raw``, ``derivative``, ``integral``, ``cumulative``, then ``mult``,
``off`` and a moving average of ``movAvgPeriod`` values) or an x/y curve (``graphType`` 1: two
streams' transformed values at their common times); ``duplicateGraphCurveToStatic`` freezes a
copy. Nothing is drawn headless.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import paths as _paths
from simx_wire.protocol import ArgumentError, UnknownObjectError, UnsupportedError
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text
from simx_server.sim.objects import DUMMY

MAX_STREAMS, MAX_VALUES = 256, 1_000_000


def _transformed(s: dict) -> tuple[np.ndarray, np.ndarray]:
    t, y = np.array(s["t"], float), np.array(s["y"], float)
    kind = s["transf"]
    if kind == 1 and len(t) > 1:  # derivative: backward differences, the first value 0
        y = np.concatenate([[0.0], np.diff(y) / np.maximum(np.diff(t), 1e-12)])
    elif kind == 1:
        y = np.zeros_like(y)
    elif kind == 2 and len(t):  # integral: trapezoids from the first time
        y = np.concatenate([[0.0], np.cumsum((y[1:] + y[:-1]) / 2 * np.diff(t))])
    elif kind == 3:
        y = np.cumsum(y)
    y = y * s["mult"] + s["off"]
    n = s["avg"]
    if n > 1 and len(y):
        c = np.cumsum(np.concatenate([[0.0], y]))
        idx = np.arange(1, len(y) + 1)
        lo = np.maximum(idx - n, 0)
        y = (c[idx] - c[lo]) / (idx - lo)
    return t, y


# Graph streams and curves.

def _graph(ctx: CallContext, handle: Any) -> dict:
    h = ctx.world.get(ctx.h(handle, "graphHandle"), DUMMY).handle
    return _paths.store_of(ctx, "graphs").setdefault(h, {"streams": {}, "curves": {}, "next": 0})


def _stream(ctx: CallContext, graph: dict, stream_id: Any) -> dict:
    s = graph["streams"].get(_int(stream_id, "streamId"))
    if s is None:
        raise UnknownObjectError(f"no graph stream {stream_id}")
    return s


@sim_function("addGraphStream")
def addGraphStream(ctx: CallContext, graphHandle: Any, streamName: Any, unit: Any, options: Any = 0,  # noqa: N802, N803
                   color: Any = None, cyclicRange: Any = np.pi) -> int:  # noqa: N803
    """A new, empty time stream on the graph; its id.

    ``sim.addGraphStream``.

    Args:
        graphHandle: the graph's handle.
        streamName: the stream's name.
        unit: its unit's text.
        options: kept.
        color: RGB 0..1, or None (red).
        cyclicRange: kept (rad).

    Returns:
        The stream's id.

    Raises:
        ObjectTypeError: ``graphHandle`` is not a graph (simx's graphs are dummies).
        ArgumentError: MAX_STREAMS streams already, or a bad argument.
    """
    g = _graph(ctx, graphHandle)
    if len(g["streams"]) >= MAX_STREAMS:
        raise ArgumentError(f"at most {MAX_STREAMS} streams per graph")
    sid = g["next"]
    g["next"] += 1
    g["streams"][sid] = {"name": _text(streamName, "streamName"), "unit": _text(unit, "unit"),
                         "options": _int(options, "options"), "color": list(color or [1.0, 0.0, 0.0]),
                         "cyclic": _num(cyclicRange, "cyclicRange"), "t": [], "y": [], "transf": 0,
                         "mult": 1.0, "off": 0.0, "avg": 1}
    return sid


@sim_function("setGraphStreamValue")
def setGraphStreamValue(ctx: CallContext, graphHandle: Any, streamId: Any, value: Any) -> None:  # noqa: N802, N803
    """Record ``value`` for the current simulation time.

    ``sim.setGraphStreamValue``.

    Args:
        graphHandle: the graph's handle.
        streamId: the stream's id.
        value: the value (in the stream's unit).

    Raises:
        ObjectTypeError: ``graphHandle`` is not a graph (simx's graphs are dummies).
        UnknownObjectError: no such stream.
        ArgumentError: MAX_VALUES values already, or not a number.
    """
    s = _stream(ctx, _graph(ctx, graphHandle), streamId)
    t, v = float(ctx.world.time), _num(value, "value")
    if s["t"] and s["t"][-1] == t:
        s["y"][-1] = v
        return
    if len(s["t"]) >= MAX_VALUES:
        raise ArgumentError(f"a graph stream holds at most {MAX_VALUES} values")
    s["t"].append(t)
    s["y"].append(v)


@sim_function("setGraphStreamTransformation")
def setGraphStreamTransformation(ctx: CallContext, graphHandle: Any, streamId: Any, trType: Any, mult: Any = 1.0,  # noqa: N802, N803
                                 off: Any = 0.0, movAvgPeriod: Any = 1) -> None:  # noqa: N803
    """How the stream's values are read (see the module's text).

    ``sim.setGraphStreamTransformation``.

    Args:
        graphHandle: the graph's handle.
        streamId: the stream's id.
        trType: a ``sim.stream_transf_*`` (0..3).
        mult: factor.
        off: offset.
        movAvgPeriod: samples, at least 1.

    Raises:
        ObjectTypeError: ``graphHandle`` is not a graph (simx's graphs are dummies).
        UnknownObjectError: no such stream.
        ArgumentError: an unknown type or period.
    """
    s = _stream(ctx, _graph(ctx, graphHandle), streamId)
    kind, n = _int(trType, "trType"), _int(movAvgPeriod, "movAvgPeriod")
    if kind not in (0, 1, 2, 3) or n < 1:
        raise ArgumentError("trType must be a sim.stream_transf_* (0..3) and movAvgPeriod at least 1")
    s.update(transf=kind, mult=_num(mult, "mult"), off=_num(off, "off"), avg=n)


@sim_function("addGraphCurve")
def addGraphCurve(ctx: CallContext, graphHandle: Any, curveName: Any, dim: Any, streamIds: Any, defaultValues: Any,  # noqa: N802, N803
                  unitStr: Any, options: Any = 0, color: Any = None, curveWidth: Any = 2) -> int:  # noqa: N803
    """An x/y curve (``dim`` 2) of two streams; its id. 3D curves: UnsupportedError (their
    points cannot be read back through ``getGraphCurve``'s x/y data).

    ``sim.addGraphCurve``.

    Args:
        graphHandle: the graph's handle.
        curveName: the curve's name.
        dim: 2.
        streamIds: 2 stream ids (x, y).
        defaultValues: ignored.
        unitStr: its unit's text.
        options: kept.
        color: RGB 0..1, or None (yellow).
        curveWidth: pixels, kept.

    Returns:
        The curve's id.

    Raises:
        ObjectTypeError: ``graphHandle`` is not a graph (simx's graphs are dummies).
        UnsupportedError: ``dim`` other than 2.
        ArgumentError: not 2 stream ids.
        UnknownObjectError: no such stream.
    """
    g = _graph(ctx, graphHandle)
    if _int(dim, "dim") != 2:
        raise UnsupportedError("addGraphCurve: simx keeps 2D curves (dim 2)")
    ids = [_int(v, "streamIds[i]") for v in (streamIds or [])][:2]
    if len(ids) != 2:
        raise ArgumentError("streamIds must hold 2 stream ids")
    for i in ids:
        _stream(ctx, g, i)
    cid = g["next"]
    g["next"] += 1
    g["curves"][cid] = {"name": _text(curveName, "curveName"), "streams": ids, "unit": _text(unitStr, "unitStr"),
                        "options": _int(options, "options"), "color": list(color or [1.0, 1.0, 0.0]),
                        "width": _int(curveWidth, "curveWidth"), "static": None}
    return cid


def _curve_data(ctx: CallContext, g: dict, c: dict) -> tuple[np.ndarray, np.ndarray]:
    if c["static"] is not None:
        return c["static"]
    (tx, x), (ty, y) = (_transformed(_stream(ctx, g, i)) for i in c["streams"])
    _, ix, iy = np.intersect1d(tx, ty, return_indices=True)
    return x[ix], y[iy]


@sim_function("getGraphCurve")
def getGraphCurve(ctx: CallContext, graphHandle: Any, graphType: Any, curveIndex: Any) -> tuple:  # noqa: N802, N803
    """``label, attributes, curveColor, xData, yData, minMax, curveId, curveWidth`` of the
    ``curveIndex``-th time stream (``graphType`` 0) or x/y curve (1); minMax: min and max of
    x then y.

    ``sim.getGraphCurve``.

    Args:
        graphHandle: the graph's handle.
        graphType: 0 or 1.
        curveIndex: 0-based.

    Returns:
        The 8-tuple: str, int, 3 floats, n floats, n floats, 4 floats, int, int.

    Raises:
        ObjectTypeError: ``graphHandle`` is not a graph (simx's graphs are dummies).
        UnsupportedError: another ``graphType``.
        ArgumentError: an index past the last.
    """
    g, kind, i = _graph(ctx, graphHandle), _int(graphType, "graphType"), _int(curveIndex, "curveIndex")
    if kind == 0:
        items = list(g["streams"].items())
    elif kind == 1:
        items = list(g["curves"].items())
    else:
        raise UnsupportedError("getGraphCurve: simx keeps time streams (0) and x/y curves (1)")
    if not 0 <= i < len(items):
        raise ArgumentError(f"curveIndex {i}: the graph has {len(items)} of that type")
    cid, c = items[i]
    x, y = _transformed(c) if kind == 0 else _curve_data(ctx, g, c)
    mm = [float(x.min()), float(x.max()), float(y.min()), float(y.max())] if len(x) else [0.0] * 4
    return (c["name"], c["options"], c["color"], x.tolist(), y.tolist(), mm + [0.0, 0.0], cid,
            c.get("width", 2))


@sim_function("duplicateGraphCurveToStatic")
def duplicateGraphCurveToStatic(ctx: CallContext, graphHandle: Any, curveId: Any, curveName: Any = "") -> int:  # noqa: N802, N803
    """A static copy (no longer updated) of a stream's time curve or of an x/y curve; its id.

    ``sim.duplicateGraphCurveToStatic``.

    Args:
        graphHandle: the graph's handle.
        curveId: a stream's or curve's id.
        curveName: the copy's name (``""``: from the source's).

    Returns:
        The copy's id.

    Raises:
        ObjectTypeError: ``graphHandle`` is not a graph (simx's graphs are dummies).
        UnknownObjectError: no such stream or curve.
    """
    g, cid = _graph(ctx, graphHandle), _int(curveId, "curveId")
    if cid in g["curves"]:
        src = g["curves"][cid]
        data = _curve_data(ctx, g, src)
    elif cid in g["streams"]:
        src = g["streams"][cid]
        data = _transformed(src)
    else:
        raise UnknownObjectError(f"no graph curve or stream {cid}")
    new = g["next"]
    g["next"] += 1
    g["curves"][new] = {"name": _text(curveName, "curveName") or f"{src['name']} (static)", "streams": [],
                        "unit": src["unit"], "options": src["options"], "color": src["color"],
                        "width": src.get("width", 2), "static": (data[0].copy(), data[1].copy())}
    return new


@sim_function("destroyGraphCurve")
def destroyGraphCurve(ctx: CallContext, graphHandle: Any, curveId: Any) -> None:  # noqa: N802, N803
    """Remove a curve or a stream (and the curves built on it); -1: every one.

    ``sim.destroyGraphCurve``.

    Args:
        graphHandle: the graph's handle.
        curveId: a stream's or curve's id, or -1.

    Raises:
        ObjectTypeError: ``graphHandle`` is not a graph (simx's graphs are dummies).
        UnknownObjectError: no such stream or curve.
    """
    g, cid = _graph(ctx, graphHandle), _int(curveId, "curveId")
    if cid == -1:
        g["streams"].clear()
        g["curves"].clear()
    elif g["curves"].pop(cid, None) is None:
        if g["streams"].pop(cid, None) is None:
            raise UnknownObjectError(f"no graph curve or stream {cid}")
        g["curves"] = {k: c for k, c in g["curves"].items() if cid not in c["streams"]}


