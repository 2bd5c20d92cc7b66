"""Dummy links made at run time (``sim.setLinkDummy(a, b)`` on two dummies the scene file did not
link): a weld between the two dummies' sites, made and released while the simulation runs, as
V-REP's dynamic loop closure of two dummies (``sim.dummylink_dynloopclosure``: the dummies'
frames held together, so the bodies that carry them move as one).

This is how V-REP's suction cups grasp (its model library's suction pad, the Baxter vacuum cup):
the cup's script moves one of its dummies onto the shape its proximity sensor detects
(``sim.setObjectParent(l, shape, true)``) and links it to the cup's other dummy; unlinking and
moving the dummy back lets the shape go.

MuJoCo's equalities are part of the model, so the welds are made ahead, inactive, as a pool
(``simx_link:K`` weld equalities between two sites, :func:`add_pool`, added through the scene
editor the first time a pool is needed: one recompile, then again only when all are in use); a
link takes a free one, writes its two sites (``eq_obj1id`` / ``eq_obj2id``) and switches it on
(``eq_active``): no recompile. A weld between sites holds the sites' frames together (MuJoCo
ignores ``relpose`` for sites), as V-REP's loop closure does. It is as stiff as the grasps' welds
(two timesteps, the joint limits' impedance).

The links in use are ``World.dummy_links`` (equality name -> the two sites' names): an edit of
the scene (a new model) takes them up again (:func:`reapply`); stopping the simulation ends them
(``mj_resetData`` switches every pool weld off).
"""

from __future__ import annotations

import mujoco
import numpy as np

from simx_server.sim.mechanisms import LIMIT_SOLIMP, stiff_solref

__all__ = ["PREFIX", "add_pool", "free", "link", "reapply", "unlink"]

#: Name prefix of the pool's weld equalities.
PREFIX = "simx_link:"
#: Welds added when a pool is made or grown.
POOL = 4
_SITE = int(mujoco.mjtObj.mjOBJ_SITE)
_WELD = int(mujoco.mjtEq.mjEQ_WELD)


def _pool(m: mujoco.MjModel) -> list[int]:
    return [e for e in range(m.neq) if (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e) or "").startswith(PREFIX)]


def free(world) -> int:
    """A pool weld not in use.

    Args:
        world: the World.

    Returns:
        Its equality id, or -1 when the pool is missing or every weld is in use.
    """
    m = world.model
    used = {mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, name) for name in world.dummy_links}
    return next((e for e in _pool(m) if e not in used and not world.data.eq_active[e]), -1)


def add_pool(spec: mujoco.MjSpec, site: str, other: str) -> None:
    """Add :data:`POOL` inactive site welds (between ``site`` and ``other``: placeholders, each
    link writes its own sites) to the scene's spec.

    Args:
        spec: the scene's spec.
        site: a site's name.
        other: another site's name.
    """
    taken = {e.name for e in spec.equalities}
    k = 0
    for _ in range(POOL):
        while f"{PREFIX}{k}" in taken:
            k += 1
        eq = spec.add_equality()
        eq.name = f"{PREFIX}{k}"
        eq.type = mujoco.mjtEq.mjEQ_WELD
        eq.objtype = mujoco.mjtObj.mjOBJ_SITE
        eq.name1, eq.name2 = site, other
        eq.active = False
        eq.data[10] = 1.0  # torquescale: orientation held as firmly as position
        eq.solref, eq.solimp = stiff_solref(spec.option.timestep), list(LIMIT_SOLIMP)
        taken.add(eq.name)


def link(world, e: int, site: int, other: int) -> None:
    """Weld the frames of sites ``site`` and ``other`` with pool weld ``e``.

    Args:
        world: the World.
        e: a pool weld (:func:`free`).
        site: a dummy's site id.
        other: the linked dummy's site id.
    """
    m = world.model
    m.eq_obj1id[e], m.eq_obj2id[e] = site, other
    world.data.eq_active[e] = 1
    name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_EQUALITY, e)
    world.dummy_links[name] = (mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, site),
                               mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_SITE, other))


def unlink(world, equalities: np.ndarray) -> None:
    """Switch welds off and forget the pool's among them.

    Args:
        world: the World.
        equalities: equality ids.
    """
    world.data.eq_active[equalities] = 0
    for e in equalities.tolist():
        world.dummy_links.pop(mujoco.mj_id2name(world.model, mujoco.mjtObj.mjOBJ_EQUALITY, e) or "", None)


def reapply(world, links: dict[str, tuple[str, str]]) -> None:
    """After ``World.replace_model``: the links of ``links`` whose weld and sites are in the new
    model, made again.

    Args:
        world: the World, its new model installed.
        links: equality name -> (site, site) before the edit.
    """
    m = world.model
    world.dummy_links.clear()
    for name, (a, b) in links.items():
        e = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, name)
        sa, sb = (mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, s) for s in (a, b))
        if e >= 0 and sa >= 0 and sb >= 0 and int(m.eq_type[e]) == _WELD and int(m.eq_objtype[e]) == _SITE:
            link(world, e, sa, sb)
