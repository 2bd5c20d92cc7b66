"""V-REP's collision objects and distance objects (named measurement pairs: ``Distance#``,
``targetCollision#``...) of a ``.ttt``, as the ``simx.collision:NAME`` / ``simx.distance:NAME``
custom texts simx serves (:mod:`simx_server.sim.collisions`: ``simxGetCollisionHandle``,
``simxReadDistance``, ``simHandleDistance``...).

Records (top-level ``COL`` / ``DST``, read as CoppeliaSim's ``CCollisionObject_old::serialize``
and ``CDistanceObject_old::serialize`` load them): ``Inx`` = entity 1, entity 2, the object's own
handle (i32 each); ``Nme`` its name; a distance object's ``Var`` bit 0 with ``_rh`` (f64) /
``Trh`` (f32): its threshold. An entity is an object's handle, a collection's (from 2,000,000:
``CScene`` maps it through the collection's ``Gix``), or, for entity 2, -1: all other objects.
"""

from __future__ import annotations

from dataclasses import dataclass

from simx_server.scene.ttt.records import Records

COLLECTION_START = 2_000_000  # V-REP's first collection handle (SIM_IDSTART_COLLECTION)
ALL_OTHERS = -1


@dataclass
class Measurement:
    """A collision (``kind`` "collision") or distance ("distance") object of the file: its name,
    its entities' handles in the file (entity2 -1: all other objects) and a distance
    threshold (m) where one is enabled."""

    kind: str
    name: str
    entity1: int
    entity2: int
    threshold: float | None = None


def read(r: Records, kind: str) -> Measurement | None:
    """One ``COL`` (``kind`` "collision") or ``DST`` ("distance") record list; None without
    its ``Inx`` or name (nothing a program could ask for).

    Raises:
        SceneFileError: a string that runs beyond its record.
    """
    inx = r.ints("Inx", 3)
    name = r.string("Nme")
    if inx is None or not name:
        return None
    threshold = None
    if kind == "distance" and r.byte("Var") & 1:
        value = r.floats("_rh", "Trh", 1)
        threshold = float(value[0]) if value is not None else None
    return Measurement(kind, name, int(inx[0]), int(inx[1]), threshold)


def _entity(conv, handle: int, collections: dict[int, str]) -> str | None:
    """The text of an entity: an object's name, ``collection:NAME``, or None (not in the scene)."""
    if handle >= COLLECTION_START:
        name = collections.get(handle)
        return f"collection:{name}" if name else None
    obj = conv.scene.objects.get(handle)
    return obj.name if obj is not None else None


def add(conv) -> None:
    """Declare the file's collision and distance objects in ``conv.spec`` (texts
    ``simx.collision:NAME`` / ``simx.distance:NAME`` with ``entity1= entity2=``); an object
    whose entity is missing, or whose names simx's settings cannot hold, is reported."""
    collections = {c.handle: c.name for c in conv.scene.collections if c.handle >= 0 and c.name}
    seen: set[str] = set()
    for m in conv.scene.measurements:
        e1 = _entity(conv, m.entity1, collections)
        e2 = "all" if m.entity2 == ALL_OTHERS else _entity(conv, m.entity2, collections)
        key = f"simx.{m.kind}:{m.name}"
        if e1 is None or e2 is None or not _safe(m.name, e1, e2) or key in seen:
            conv.report.add(f"{m.kind} objects whose entities are not in the scene")
            continue
        seen.add(key)
        text = conv.spec.add_text()
        text.name = key
        text.data = f"entity1={e1} entity2={e2}"
        if m.threshold is not None:
            conv.report.add("distance objects' thresholds (simx measures every distance)")


def _safe(*values: str) -> bool:
    return all(v and not any(c.isspace() or c == "=" for c in v) for v in values)

