"""Object flags and dummy links of V-REP 3.x scenes' scripts: ``sim.getObjectSpecialProperty``
/ ``sim.setObjectSpecialProperty`` (V-REP 3.x's ``simGet/SetObjectSpecialProperty``, deprecated
in CoppeliaSim 4.x) and ``sim.getLinkDummy`` / ``sim.setLinkDummy``.

The special properties (collidable 1, measurable 2, detectable 16-256, renderable 512,
cuttable 1024, path planning ignored 2048) are V-REP's, kept per object and independent of
physical contact (respondable, MuJoCo's ``contype``/``conaffinity``): see
:mod:`simx_server.sim.properties` for who reads them. Every object has them, as in V-REP;
simx has no mills and no path planning, so the last two bits are kept and change nothing.

A dummy link is a MuJoCo weld between the two dummies' sites: the scene's own (a ``.ttt``'s dynamic
loop closures are converted to ``weld`` equalities), or one made at run time
(:mod:`simx_server.sim.dummy_links`); ``setLinkDummy(a, b)`` activates the one that joins them,
``setLinkDummy(a, -1)`` deactivates every equality of ``a``.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire import constants as C
from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_integer as _int
from simx_server.sim import dummy_links, properties




# Special properties and dummy links.

@sim_function("getObjectSpecialProperty")
def getObjectSpecialProperty(ctx: CallContext, objectHandle: Any) -> int:  # noqa: N802, N803
    """The object's special property bits: set by a script, else the scene's (a ``.ttt``'s
    ``Omp``), else V-REP's default for its type (a shape: collidable, measurable, detectable,
    renderable; others: 0). See :func:`simx_server.sim.properties.special`.

    ``sim.getObjectSpecialProperty`` / ``simGetObjectSpecialProperty``.

    Args:
        objectHandle: the object's handle.

    Returns:
        ``sim.objectspecialproperty_*`` bits.

    Raises:
        UnknownObjectError: no such object.
    """
    return properties.special(ctx.world, ctx.h(objectHandle, "objectHandle"))


@sim_function("setObjectSpecialProperty")
def setObjectSpecialProperty(ctx: CallContext, objectHandle: Any, property: Any) -> int:  # noqa: A002, N802, N803
    """Set the object's special property bits; returns 1. Collision and distance checks,
    proximity sensors and vision sensors follow them from now on; physical contact does not
    change (V-REP's respondable flag is another one).

    ``sim.setObjectSpecialProperty`` / ``simSetObjectSpecialProperty``
    (coppeliaSimLib ``CSceneObject::setLocalObjectSpecialProperty``).

    Args:
        objectHandle: the object's handle.
        property: ``sim.objectspecialproperty_*`` bits.

    Returns:
        1.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not an integer.
    """
    properties.set_special(ctx.world, ctx.h(objectHandle, "objectHandle"), _int(property, "property"))
    return 1


def _dummy_site(ctx: CallContext, handle: Any, what: str) -> int:
    obj = ctx.world.get(ctx.h(handle, what))
    if obj.type != C.sim_object_dummy_type:
        raise ArgumentError(f"{what}: object {obj.name!r} is not a dummy")
    return int(obj.mj_id)


def _site_links(ctx: CallContext, site: int) -> np.ndarray:
    m = ctx.world.model
    mine = (m.eq_objtype == mujoco.mjtObj.mjOBJ_SITE) & ((m.eq_obj1id == site) | (m.eq_obj2id == site))
    return np.flatnonzero(mine)


@sim_function("getLinkDummy")
def getLinkDummy(ctx: CallContext, dummyHandle: Any) -> int:  # noqa: N802, N803
    """The dummy ``dummyHandle`` is linked to (an active equality between their sites), -1
    when it is linked to none."""
    site = _dummy_site(ctx, dummyHandle, "dummyHandle")
    m, d = ctx.world.model, ctx.world.data
    for e in _site_links(ctx, site).tolist():
        if d.eq_active[e]:
            other = int(m.eq_obj2id[e] if m.eq_obj1id[e] == site else m.eq_obj1id[e])
            for o in ctx.world.objects.values():
                if o.type == C.sim_object_dummy_type and o.mj_id == other:
                    return o.handle
    return -1


@sim_function("setLinkDummy")
def setLinkDummy(ctx: CallContext, dummyHandle: Any, linkedDummyHandle: Any) -> int:  # noqa: N802, N803
    """Link two dummies (``-1``: unlink ``dummyHandle``); returns 1. A dummy is linked to one
    dummy at most: linking unlinks both dummies from any other. Two dummies the scene file links
    (a ``.ttt``'s dynamic loop closure: a weld between their sites) get that equality back; any
    other two get a weld made at run time (:mod:`simx_server.sim.dummy_links`: their sites'
    frames held together, V-REP's dynamic loop closure), as V-REP's suction cups link their dummy,
    moved onto the shape they grasp, to the cup's.

    ``sim.setLinkDummy`` / ``simSetLinkDummy`` (coppeliaSimLib ``CDummy::setLinkedDummyHandle``,
    loop-closure link type).

    Args:
        dummyHandle: a dummy's handle.
        linkedDummyHandle: another dummy's handle, or -1.

    Returns:
        1.

    Raises:
        UnknownObjectError: no such object.
        ArgumentError: not a dummy, or a dummy linked to itself.
        UnsupportedError: the scene cannot be edited to add the run-time welds (first link).
    """
    site = _dummy_site(ctx, dummyHandle, "dummyHandle")
    links = _site_links(ctx, site)
    if ctx.h(linkedDummyHandle, "linkedDummyHandle") == -1:
        dummy_links.unlink(ctx.world, links)
        return 1
    other = _dummy_site(ctx, linkedDummyHandle, "linkedDummyHandle")
    if other == site:
        raise ArgumentError("sim.setLinkDummy: a dummy cannot be linked to itself")
    m = ctx.world.model
    pair = [e for e in links.tolist() if {int(m.eq_obj1id[e]), int(m.eq_obj2id[e])} == {site, other}
            and not (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or "").startswith(dummy_links.PREFIX)]
    dummy_links.unlink(ctx.world, np.union1d(links, _site_links(ctx, other)))
    if pair:
        ctx.world.data.eq_active[pair] = 1
        return 1
    if dummy_links.free(ctx.world) < 0:  # a pool of welds, added once (one recompile), grown when all are in use
        names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, s) for s in (site, other)]
        ctx.simulation("setLinkDummy").editor._edit(lambda spec: dummy_links.add_pool(spec, *names))
        site, other = (mujoco.mj_name2id(ctx.world.model, mujoco.mjtObj.mjOBJ_SITE, n) for n in names)
    dummy_links.link(ctx.world, dummy_links.free(ctx.world), site, other)
    ctx.world.changed()
    return 1
