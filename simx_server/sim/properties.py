"""V-REP's object special properties: *collidable*, *measurable*, *detectable* (per proximity
sensor type) and *renderable*, kept per object and independent of *respondable* (MuJoCo's
``contype``/``conaffinity``, physical contact).

V-REP keeps them in each object's ``_localObjectSpecialProperty`` (coppeliaSimLib
``CSceneObject::serialize``, record ``Omp``; ``CSceneObject::getCumulativeObjectSpecialProperty``
lets a model base's ``sim.modelproperty_not_*`` bits override them). In simx:

* an object's bits come from its ``simx:`` setting ``special=N`` (a ``.ttt`` writes the file's
  value there), else V-REP's default for its type: a shape is collidable, measurable, detectable
  by every sensor type and renderable (``CShape``'s constructor), other objects have none;
* a model base's ``sim.modelproperty_not_collidable`` / ``_measurable`` / ``_renderable`` /
  ``_detectable`` / ``_visible`` bits (``model_property=N``, a ``.ttt``'s ``Mpo``, or
  ``sim.setModelProperty``) clear those flags for everything at and below it (:func:`cumulative`);
* ``sim.setObjectSpecialProperty`` changes them at run time (:func:`set_special`); the value
  stays with the object's handle through scene edits and through a stop, as in V-REP;
* collision and distance checks (:mod:`simx_server.sim.collisions`) test the geoms of the shapes
  that are collidable / measurable, whatever their ``contype`` (``mj_geomDistance`` needs none);
* proximity sensors (:mod:`simx_server.sim.proximity`) see only detectable shapes;
* a shape that is not renderable is not drawn in vision sensors: its visible geoms (MuJoCo groups
  0-2) are moved to group 3, which neither vision sensors nor the viewer draw.

Geoms of the world body (an MJCF floor) belong to no object: they are tested for collision and
distance when their ``contype``/``conaffinity`` say they collide, and always detected.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from simx_wire.protocol import ArgumentError
from simx_server.sim.objects import SHAPE

COLLIDABLE, MEASURABLE, RENDERABLE = 1, 2, 512
#: ``sim.objectspecialproperty_detectable_*`` by proximity sensor type; together ``_detectable_all``.
DETECTABLE = {"ultrasonic": 16, "infrared": 32, "laser": 64, "inductive": 128, "capacitive": 256}
DETECTABLE_ALL = 496
CUTTABLE, PATHPLANNING_IGNORED = 1024, 2048
ALL_BITS = COLLIDABLE | MEASURABLE | DETECTABLE_ALL | RENDERABLE | CUTTABLE | PATHPLANNING_IGNORED
#: V-REP's default for a new shape (``CShape::CShape``); every other object type has 0.
SHAPE_DEFAULT = COLLIDABLE | MEASURABLE | DETECTABLE_ALL | RENDERABLE
#: The MuJoCo geom group non-renderable shapes' visible geoms go to (not drawn by default).
HIDDEN_GROUP = 3


@dataclass
class ObjectProperties:
    """What a :class:`~simx_server.sim.world.World` keeps of its objects' special and model
    properties (``world.properties``; the world lives through scene edits, and so do these).

    Attributes:
        special: handle -> special property bits set at run time.
        model: handle -> model property bits set at run time.
        masks: ``(model, {bit: geom mask})``: :func:`geom_mask`'s cache for one compiled model.
        compiled_groups: ``(model, geom groups as compiled)``: :func:`apply_rendering`'s reference.
    """

    special: dict[int, int] = field(default_factory=dict)
    model: dict[int, int] = field(default_factory=dict)
    masks: tuple[Any, dict[int, np.ndarray]] | None = None
    compiled_groups: tuple[Any, np.ndarray] | None = None


def _store(world: Any) -> dict[int, int]:
    """handle -> bits set at run time (kept on the world, which edits keep)."""
    return world.properties.special


def special(world: Any, handle: int) -> int:
    """The special property bits of object ``handle``: set at run time, else its ``special=``
    setting, else V-REP's default for its type.

    ``sim.getObjectSpecialProperty`` (coppeliaSimLib ``CSceneObject::getLocalObjectSpecialProperty``).

    Args:
        world: the :class:`~simx_server.sim.world.World`.
        handle: an object's handle.

    Returns:
        ``sim.objectspecialproperty_*`` bits.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a ``special=`` setting that is not an integer.
    """
    obj = world.get(handle)
    bits = _store(world).get(obj.handle)
    if bits is not None:
        return bits
    raw = obj.settings.get("special")
    if raw is None:
        return SHAPE_DEFAULT if obj.type == SHAPE else 0
    try:
        return int(raw, 0) & ALL_BITS
    except ValueError:
        raise ArgumentError(f"object {obj.name!r}: special={raw!r} in its simx: settings is not an integer "
                            "(V-REP's sim.objectspecialproperty_* bits)") from None


#: ``sim.modelproperty_not_*`` bits of a model base -> the special bits they clear below it
#: (coppeliaSimLib ``CSceneObject::getCumulativeObjectSpecialProperty``); not_visible (256) hides
#: the model in every view, vision sensors included.
MODEL_OVERRIDES = {1: COLLIDABLE, 2: MEASURABLE, 4: RENDERABLE, 8: DETECTABLE_ALL, 256: RENDERABLE}
NOT_MODEL = 0xF000


def model_property(world: Any, handle: int) -> int:
    """The ``sim.modelproperty_*`` bits of object ``handle``: set at run time, else its
    ``model_property=`` setting (a ``.ttt``'s ``Mpo``), else 0 for a model base
    (``model_base=1``) and ``sim.modelproperty_not_model`` for any other object.

    ``sim.getModelProperty`` (coppeliaSimLib ``CSceneObject::getModelProperty``).

    Args:
        world: the world.
        handle: an object's handle.

    Returns:
        The bits.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: a ``model_property=`` setting that is not an integer.
    """
    obj = world.get(handle)
    bits = world.properties.model.get(obj.handle)
    if bits is not None:
        return bits
    raw = obj.settings.get("model_property")
    if raw is None:
        return 0 if obj.settings.get("model_base") == "1" else NOT_MODEL
    try:
        return int(raw, 0)
    except ValueError:
        raise ArgumentError(f"object {obj.name!r}: model_property={raw!r} in its simx: settings is not an "
                            "integer (V-REP's sim.modelproperty_* bits)") from None


def set_model_property(world: Any, handle: int, bits: int) -> None:
    """Set object ``handle``'s model property bits: bits with ``sim.modelproperty_not_model``
    make it no model base (only that bit is kept, CoppeliaSim's rule), others a model base whose
    ``not_*`` bits override the special properties of every object at and below it.

    ``sim.setModelProperty`` (coppeliaSimLib ``CSceneObject::setModelProperty``).

    Args:
        world: the world.
        handle: an object's handle.
        bits: ``sim.modelproperty_*`` bits.

    Raises:
        UnknownObjectError: no such object.
    """
    obj = world.get(handle)
    bits = int(bits)
    world.properties.model[obj.handle] = NOT_MODEL if bits & NOT_MODEL else bits
    world.properties.masks = None
    apply_rendering(world)


def cumulative(world: Any, handle: int) -> int:
    """The special bits that act on object ``handle``: its own less what the model bases at and
    above it override (coppeliaSimLib ``CSceneObject::getCumulativeObjectSpecialProperty``).

    Args:
        world: the world.
        handle: an object's handle.

    Returns:
        ``sim.objectspecialproperty_*`` bits.
    """
    bits = special(world, handle)
    h, seen = handle, set()
    while h != -1 and h not in seen:
        seen.add(h)
        prop = model_property(world, h)
        if prop & NOT_MODEL != NOT_MODEL:
            for flag, cleared in MODEL_OVERRIDES.items():
                if prop & flag:
                    bits &= ~cleared
        h = world.objects[h].parent
    return bits


def set_special(world: Any, handle: int, bits: int) -> None:
    """Set object ``handle``'s special property bits (unknown bits are dropped, as V-REP keeps
    only its own); a shape's renderable bit takes effect in vision sensors at once.

    ``sim.setObjectSpecialProperty`` (coppeliaSimLib ``CSceneObject::setLocalObjectSpecialProperty``).

    Args:
        world: the world.
        handle: an object's handle.
        bits: ``sim.objectspecialproperty_*`` bits.

    Raises:
        UnknownObjectError: no such object.
    """
    obj = world.get(handle)
    _store(world)[obj.handle] = int(bits) & ALL_BITS
    world.properties.masks = None
    if obj.type == SHAPE:
        apply_rendering(world)


def shape_geoms(m: Any, body: int) -> np.ndarray:
    """The geoms that stand for a shape (MuJoCo body ``body``) in collision, distance and
    detection: those that collide (``contype`` or ``conaffinity`` not 0) where it has any (an
    MJCF body's visual-only copies are left out), else all of its geoms.

    Args:
        m: the MuJoCo model.
        body: the body's id.

    Returns:
        Geom ids, shape (n,).
    """
    mine = m.geom_bodyid == body
    colliding = mine & ((m.geom_contype != 0) | (m.geom_conaffinity != 0))
    return np.flatnonzero(colliding if colliding.any() else mine)


def geom_mask(world: Any, bit: int) -> np.ndarray:
    """Mask (ngeom,) of the geoms of the shapes that have any of ``bit`` (collision, distance,
    detection), plus the world body's geoms (they belong to no object): its colliding ones for
    collision and distance, all of them for detection. Cached per model until a bit changes.

    Args:
        world: the world.
        bit: ``COLLIDABLE``, ``MEASURABLE``, or detectable bits.

    Returns:
        Boolean array of shape (ngeom,).
    """
    m = world.model
    cache = world.properties.masks
    if cache is None or cache[0] is not m:
        cache = world.properties.masks = (m, {})
    if bit in cache[1]:
        return cache[1][bit]
    mask = m.geom_bodyid == 0
    if bit & (COLLIDABLE | MEASURABLE):
        mask &= (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    for obj in world.objects.values():
        if obj.type == SHAPE and cumulative(world, obj.handle) & bit:
            mask[shape_geoms(m, obj.mj_id)] = True
    mask.flags.writeable = False
    cache[1][bit] = mask
    return mask


def apply_rendering(world: Any) -> None:
    """Put the visible geoms of non-renderable shapes in HIDDEN_GROUP and those of renderable
    ones back in the group the model was compiled with. Called when a model is installed (an
    edit compiles a new one) and when a renderable bit changes.

    Args:
        world: the world (its current model).
    """
    m = world.model
    kept = world.properties.compiled_groups
    if kept is None or kept[0] is not m or kept[1].shape != m.geom_group.shape:
        kept = world.properties.compiled_groups = (m, m.geom_group.copy())
    compiled = kept[1]
    groups = compiled.copy()
    for obj in world.objects.values():
        if obj.type == SHAPE and not cumulative(world, obj.handle) & RENDERABLE:
            geoms = np.flatnonzero((m.geom_bodyid == obj.mj_id) & (compiled <= 2))
            groups[geoms] = HIDDEN_GROUP
    m.geom_group[:] = groups
    world.version += 1  # cached renders are stale
