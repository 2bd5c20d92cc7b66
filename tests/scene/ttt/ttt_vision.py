"""Synthetic ``.ttt`` vision sensors for the filter tests: a sensor record (``RSN``) with V-REP's
options and filter components (``Cfr`` of ``Sfr``), written as coppeliaSimLib's
``CVisionSensor::serialize`` and ``CSimpleFilter::serialize`` read them."""

from __future__ import annotations


import tttwriter as W
from tttwriter import f32, i32, lst, rec

DOWN = (0.0, 1.0, 0.0, 0.0)  # a sensor's +z (its view) pointing down: 180 degrees about x


def component(kind: int, bytes_=(), ints=(), floats=(), enabled: bool = True) -> bytes:
    """One filter component (``Sfr``): type ``kind`` (sim_filtercomponent_*) and parameters."""
    items = [rec("Sft", i32(kind, -1, -1)), rec("Sfv", i32(0)), rec("Cfn", W.string(""))]
    if bytes_:
        items.append(rec("Pab", i32(len(bytes_)) + bytes(bytes_)))
    if ints:
        items.append(rec("Pai", i32(len(ints), *ints)))
    if floats:
        items.append(rec("Paf", i32(len(floats)) + f32(*floats)))
    items.append(rec("Sfe", bytes([1 if enabled else 0])))
    return rec("Sfr", lst(*items))


def vision_sensor(handle: int, name: str, components=(), pos=(0, 0, 1.5), res=(64, 48), ortho: float | None = None,
                  angle: float = 1.0472, near: float = 0.1, far: float = 2.0, va2: int = 0, background=(0, 0, 0),
                  render_mode: int = 0, quat=DOWN, va3: int = 0) -> bytes:
    """A vision sensor looking down from ``pos`` (``quat``: another orientation); perspective
    unless ``ortho`` (m) is given; ``va2``: bits 1 ignore RGB, 2 ignore depth, 4 no basic
    statistics; ``va3``: more bits (7: the environment's background)."""
    va3 |= 0 if ortho is not None else 1
    typed = lst(rec("Ccp", f32(ortho or 1.0, angle, near, far)), rec("Res", i32(*res)), rec("Va3", bytes([va3])),
                rec("Va2", bytes([va2])), rec("Db2", f32(*background)), rec("Rmd", i32(render_mode)),
                rec("Cfr", lst(*components)))
    return rec("RSN", W.common(handle, -1, name, pos, quat) + typed)


def scene(*sensors: bytes) -> bytes:
    """A floor (top at z = 0) with a tower 0.25 x 0.25 x 0.6 m centred at x = 0.1, y = 0.05, and
    ``sensors``."""
    return W.ttt_file(
        rec("SIM", lst(rec("Sts", f32(0.05)))) + rec("DYN", lst(rec("En2", i32(0) + f32(0, 0, -9.81)))) +
        W.cuboid_shape(1, -1, "Floor", (3, 3, 0.1), (0, 0, -0.05), dynamic=False) +
        W.cuboid_shape(2, -1, "Tower", (0.25, 0.25, 0.6), (0.1, 0.05, 0.3), dynamic=False) + b"".join(sensors))


