"""The objects of a ``.ttt``/``.ttm`` that keep their V-REP types on a MuJoCo site: V-REP's view
cameras (``CMA``, ``sim_object_camera_type`` 3) and old path objects (``PAT``,
``sim_object_path_type`` 8, V-REP 3.x up to CoppeliaSim 4.1; 4.3+ paths are dummies with custom
data, carried over as such).

Read as coppeliaSimLib serializes them:

* camera (``CCamera::serialize``): ``_p3``/``Cp3`` ortho view size and view angle (rad),
  ``_cp``/``Ccp`` near and far clipping planes (m), ``Ca3`` bit 1 perspective (older files:
  ``Cpm`` >= 0 perspective when nonzero); defaults those of ``CCamera::commonInit``.
* old path (``CPath_old::serialize``): its path container in ``Ntp`` (``CPathCont_old::serialize``):
  one ``Pat`` record per control point (``CSimplePathPoint_old::serialize``: ``_t2``/``At2`` pose
  x y z qw qx qy qz, Bezier factors before and after, Bezier point count, maximum relative
  velocity; ``_t3``/``At3`` on-spot distance; ``_t4``/``At4`` auxiliary flags and 4 channels),
  ``At2`` attributes (``sim_pathproperty_*``), ``_m2``/``Jm2`` position along the path, ``_v3``/
  ``Av3`` angle-to-distance coefficient and length calculation method, ``_v9``/``Av9`` on-spot
  distance coefficient; defaults those of ``CPathCont_old::CPathCont_old``.

The converter gives the site ``object_type=3``/``object_type=8`` (:mod:`simx_server.sim.world`
registers the type) and the camera's optics as ``camera=ANGLE,ORTHO,NEAR,FAR,PERSPECTIVE``, a
path's data a JSON file next to the scene named by ``path_data=FILE``
(:mod:`simx_server.sim.old_paths` reads it).
"""

from __future__ import annotations

import json
import math
import re
import struct
from dataclasses import dataclass, field

from simx_server.scene.ttt.records import Records

MAX_PATH_POINTS = 10_000  # control points of one old path kept (a bound on the file's claims)


@dataclass
class CameraData:
    """A V-REP camera's optics: view angle (rad), ortho view size (m), clipping planes (m)."""

    view_angle: float = math.radians(60.0)
    ortho_size: float = 2.0
    near: float = 0.05
    far: float = 30.0
    perspective: bool = True


@dataclass
class PathData:
    """An old path's container: control points (each ``[x, y, z, qw, qx, qy, qz, factor before,
    factor after, Bezier point count, max relative velocity, on-spot distance, aux flags, aux
    channels x4]``, in the path's frame), attributes, length method and coefficients, position."""

    points: list[list[float]] = field(default_factory=list)
    attributes: int = 1 | 2 | 8 | 128 | 1024 | 32  # CPathCont_old's default attributes
    length_method: int = 5  # sim_distcalcmethod_dl_if_nonzero
    angle_coeff: float = 0.1 / math.radians(90.0)
    on_spot_coeff: float = 1.0
    position: float = 0.0

    def to_json(self) -> str:
        return json.dumps({"points": self.points, "attributes": self.attributes, "length_method": self.length_method,
                           "angle_coeff": self.angle_coeff, "on_spot_coeff": self.on_spot_coeff,
                           "position": self.position})


def read_camera(r: Records) -> CameraData:
    """A camera's type records (``CCamera::serialize``)."""
    c = CameraData()
    p3 = r.floats("_p3", "Cp3", 2)
    if p3 is not None:
        c.ortho_size, c.view_angle = float(p3[0]), float(p3[1])
    cp = r.floats("_cp", "Ccp", 2)
    if cp is not None:
        c.near, c.far = float(cp[0]), float(cp[1])
    if r.get("Ca3") is not None:
        c.perspective = bool(r.byte("Ca3") & 2)
    elif r.get("Cpm") is not None:
        c.perspective = r.int("Cpm") != 0
    return c


def read_path(r: Records) -> PathData:
    """An old path's type records (``CPath_old::serialize``, its container in ``Ntp``)."""
    d = PathData()
    ntp = r.sub("Ntp")
    for tag, payload in ntp:
        if tag == "Pat" and len(d.points) < MAX_PATH_POINTS:
            d.points.append(_point(ntp.sub("Pat", payload)))
    d.attributes = ntp.int("At2", d.attributes)
    m2 = ntp.floats("_m2", "Jm2", 1)
    if m2 is not None:
        d.position = float(m2[0])
    for new, old in (("_v3", "Av3"),):
        payload = ntp.get(new, old)
        if payload is not None:
            fmt = "<di" if ntp.get(new) is not None else "<fi"
            if len(payload) >= struct.calcsize(fmt):
                coeff, method = struct.unpack_from(fmt, payload, 0)
                d.angle_coeff, d.length_method = float(coeff), int(method)
    v9 = ntp.floats("_v9", "Av9", 1)
    if v9 is not None:
        d.on_spot_coeff = float(v9[0])
    return d


def _point(p: Records) -> list[float]:
    pose, factors, count, velocity = [0.0, 0, 0, 1, 0, 0, 0], [0.5, 0.5], 15, 1.0
    for tag, fmt in (("_t2", "<7d2did"), ("At2", "<7f2fif")):
        payload = p.get(tag)
        if payload is not None and len(payload) >= struct.calcsize(fmt):
            v = struct.unpack_from(fmt, payload, 0)
            pose, factors, count, velocity = list(v[:7]), list(v[7:9]), int(v[9]), float(v[10])
            break
    on_spot = p.floats("_t3", "At3", 1)
    aux_flags, channels = 0, [0.0] * 4
    for tag, fmt in (("_t4", "<H4d"), ("At4", "<H4f")):
        payload = p.get(tag)
        if payload is not None and len(payload) >= struct.calcsize(fmt):
            v = struct.unpack_from(fmt, payload, 0)
            aux_flags, channels = int(v[0]), [float(x) for x in v[1:]]
            break
    values = [float(x) for x in pose + factors] + [float(count), velocity,
                                                   float(on_spot[0]) if on_spot is not None else 0.0,
                                                   float(aux_flags)] + channels
    return [v if math.isfinite(v) else 0.0 for v in values]


def add_kept_object(conv, obj) -> bool:
    """The settings of a camera or old path ``obj`` (its site added by the caller): its type, and
    a camera's optics or a path's data file. False for any other kind."""
    if obj.kind == "camera" and isinstance(obj.data, CameraData):
        c = obj.data
        values = [c.view_angle, c.ortho_size, c.near, c.far]
        values = [v if math.isfinite(v) else 0.0 for v in values]
        conv.setting(obj.name, "object_type=3",
                     "camera=" + ",".join(f"{v:.9g}" for v in values) + f",{int(c.perspective)}")
        conv.report.add("cameras (type and optics kept; a camera renders no view in simx)", approximated=True)
        return True
    if obj.kind == "path" and isinstance(obj.data, PathData):
        file = re.sub(r"[^A-Za-z0-9_.-]", "_", obj.name) + f"_{obj.handle}_path.json"
        if conv.out is not None:
            (conv.out / file).write_text(obj.data.to_json())
        conv.setting(obj.name, "object_type=8", f"path_data={file}")
        conv.report.add("old paths (control points kept; nothing follows a path by itself in simx)",
                        approximated=True)
        return True
    return False
