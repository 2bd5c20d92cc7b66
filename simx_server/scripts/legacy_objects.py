"""Object flags and dummy links of V-REP 3.x scenes' scripts: ``sim.getObjectSpecialProperty``
/ ``sim.setObjectSpecialProperty`` (V-REP 3.x's ``simGet/SetObjectSpecialProperty``, deprecated
in CoppeliaSim 4.x) and ``sim.getLinkDummy`` / ``sim.setLinkDummy``, in MuJoCo's terms:

* **collidable** and **measurable** (``sim.objectspecialproperty_collidable`` 1,
  ``_measurable`` 2): the shape's geoms take part in contacts, collision and distance checks
  (``contype``/``conaffinity`` not 0; simx measures distances between the collidable geoms, so the
  two flags go together);
* **detectable** (``_detectable_all`` 496 and its bits): simx's proximity sensors cast MuJoCo rays
  at every geom, so every shape with geoms is detectable by all sensor kinds;
* **renderable** (``_renderable`` 512): a geom of MuJoCo's visible groups 0-2 (vision sensors
  render those); clearing it moves the shape's geoms to group 3, setting it moves them back;
* ``_cuttable`` and ``_pathplanning_ignored``: simx has no mills and no path planning; read as 0,
  accepted and ignored when set.

A dummy link is a MuJoCo equality between the two dummies' sites (a ``.ttt`` scene's dynamic
loop closures are converted to ``weld`` equalities): ``setLinkDummy(a, b)`` activates the
equality that joins them, ``setLinkDummy(a, -1)`` deactivates every equality of ``a``.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_wire import constants as C
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base.arguments import as_integer as _int
from simx_server.sim.collisions import collidable

__all__ = ["LegacyObjectCalls"]

_COLLIDABLE, _MEASURABLE, _DETECTABLE, _RENDERABLE = 1, 2, 496, 512
_IGNORED = 1024 | 2048  # cuttable, path planning ignored
_HIDDEN_GROUP = 3  # a MuJoCo geom group that vision sensors and the viewer do not show


class LegacyObjectCalls:
    """Special properties and dummy links (a mixin of the facade, through LegacyCalls)."""

    def _geoms_of(self, handle: Any, what: str) -> tuple[Any, np.ndarray]:
        obj = self._world.get(self._h(handle, what))
        m = self._world.model
        if obj.type != C.sim_object_shape_type:
            return obj, np.zeros(0, dtype=int)
        return obj, np.flatnonzero(m.geom_bodyid == obj.mj_id)

    def getObjectSpecialProperty(self, objectHandle: Any) -> int:  # noqa: N802, N803
        """The object's special property bits (see the module): collidable | measurable when a
        geom of the shape collides, detectable (all kinds) when it has geoms, renderable when a
        geom is in groups 0-2. Objects other than shapes: 0."""
        _, geoms = self._geoms_of(objectHandle, "objectHandle")
        if geoms.size == 0:
            return 0
        m = self._world.model
        bits = _DETECTABLE
        if np.any(collidable(m)[geoms]):
            bits |= _COLLIDABLE | _MEASURABLE
        if np.any(m.geom_group[geoms] <= 2):
            bits |= _RENDERABLE
        return bits

    def setObjectSpecialProperty(self, objectHandle: Any, property: Any) -> int:  # noqa: A002, N802, N803
        """Set the special property bits of a shape (see the module); returns 1. Raises
        UnsupportedError for what MuJoCo's model cannot express here: measurable without
        collidable (or the reverse), or part of the detectable bits (simx's proximity sensors
        detect every geom)."""
        obj, geoms = self._geoms_of(objectHandle, "objectHandle")
        bits = _int(property, "property")
        if geoms.size == 0:
            if bits & ~_IGNORED:
                raise UnsupportedError(f"sim.setObjectSpecialProperty: {obj.name!r} is not a shape with geoms: "
                                       "only shapes have collidable/measurable/detectable/renderable flags in simx")
            return 1
        if bool(bits & _COLLIDABLE) != bool(bits & _MEASURABLE):
            raise UnsupportedError("sim.setObjectSpecialProperty: collidable and measurable go together in simx "
                                   "(distances are measured between the collidable geoms)")
        if bits & _DETECTABLE != _DETECTABLE:
            raise UnsupportedError("sim.setObjectSpecialProperty: simx's proximity sensors detect every geom: "
                                   "the detectable flags cannot be cleared")
        m = self._world.model
        saved = self._world.__dict__.setdefault("special_property_saved", {})
        for g in geoms.tolist():
            if bits & _COLLIDABLE and m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
                m.geom_contype[g], m.geom_conaffinity[g] = saved.pop(("collide", g), (1, 1))
            elif not bits & _COLLIDABLE and (m.geom_contype[g] or m.geom_conaffinity[g]):
                saved[("collide", g)] = (int(m.geom_contype[g]), int(m.geom_conaffinity[g]))
                m.geom_contype[g] = m.geom_conaffinity[g] = 0
            if bits & _RENDERABLE and m.geom_group[g] > 2:
                m.geom_group[g] = saved.pop(("group", g), 0)
            elif not bits & _RENDERABLE and m.geom_group[g] <= 2:
                saved[("group", g)] = int(m.geom_group[g])
                m.geom_group[g] = _HIDDEN_GROUP
        return 1

    # ---------------------------------------------------------------- dummy links
    def _dummy_site(self, handle: Any, what: str) -> int:
        obj = self._world.get(self._h(handle, what))
        if obj.type != C.sim_object_dummy_type:
            raise ArgumentError(f"{what}: object {obj.name!r} is not a dummy")
        return int(obj.mj_id)

    def _site_links(self, site: int) -> np.ndarray:
        m = self._world.model
        mine = (m.eq_objtype == mujoco.mjtObj.mjOBJ_SITE) & ((m.eq_obj1id == site) | (m.eq_obj2id == site))
        return np.flatnonzero(mine)

    def getLinkDummy(self, dummyHandle: Any) -> int:  # noqa: N802, N803
        """The dummy ``dummyHandle`` is linked to (an active equality between their sites), -1
        when it is linked to none."""
        site = self._dummy_site(dummyHandle, "dummyHandle")
        m, d = self._world.model, self._world.data
        for e in self._site_links(site).tolist():
            if d.eq_active[e]:
                other = int(m.eq_obj2id[e] if m.eq_obj1id[e] == site else m.eq_obj1id[e])
                for o in self._world.objects.values():
                    if o.type == C.sim_object_dummy_type and o.mj_id == other:
                        return o.handle
        return -1

    def setLinkDummy(self, dummyHandle: Any, linkedDummyHandle: Any) -> int:  # noqa: N802, N803
        """Link two dummies (``-1``: unlink ``dummyHandle`` from every dummy); returns 1.
        Unlinking deactivates the equalities of the dummy's site; linking activates the equality
        between the two sites. Raises UnsupportedError when the scene has no equality between
        them: simx does not add constraints to the model at run time."""
        site = self._dummy_site(dummyHandle, "dummyHandle")
        d = self._world.data
        links = self._site_links(site)
        if _int(linkedDummyHandle, "linkedDummyHandle") == -1:
            d.eq_active[links] = 0
            return 1
        other = self._dummy_site(linkedDummyHandle, "linkedDummyHandle")
        m = self._world.model
        pair = [e for e in links.tolist() if {int(m.eq_obj1id[e]), int(m.eq_obj2id[e])} == {site, other}]
        if not pair:
            raise UnsupportedError("sim.setLinkDummy: the scene has no equality between these two dummies' sites: "
                                   "simx links dummies only where the scene file links them (no constraints are "
                                   "added to the MuJoCo model at run time)")
        d.eq_active[links] = 0
        d.eq_active[pair] = 1
        return 1
