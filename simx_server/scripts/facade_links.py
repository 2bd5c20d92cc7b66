"""CoppeliaSim 4.x's dummy links and ``sim.checkVisionSensorEx`` (mixin of
:class:`simx_server.scripts.facade.ScriptSim`).

Linked dummies: ``sim.setLinkDummy`` keeps a pair (both ways, a dummy in one pair at most, as
CoppeliaSim keeps it), a link of CoppeliaSim's IK tip-target kind, which moves nothing by itself;
a weld equality between two sites of the MJCF (MuJoCo's loop closure, CoppeliaSim's
dynamics overlap constraint) is a link too, which ``sim.getLinkDummy`` reports.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import mujoco
import numpy as np

from simx_wire.protocol import UnsupportedError
from simx_server.base.arguments import as_integer as _int
from simx_server.sim.objects import DUMMY
from simx_server.sim.state import SimulationView

HANDLE_ALL = -2


class LinkCalls:
    """Dummy links; vision sensor checks returning the image (facade mixin)."""

    def _dummy(self, handle: Any, what: str) -> int:
        return self._world.get(self._h(handle, what), DUMMY).handle

    def getLinkDummy(self, dummyHandle: Any) -> int:  # noqa: N802, N803
        """The dummy linked to ``dummyHandle`` (see the module's text); -1 for none."""
        h = self._dummy(dummyHandle, "dummyHandle")
        kept = self._store("dummy_links").get(h)
        if kept is not None and kept in self._world.objects:
            return kept
        m = self._world.model
        site = self._world.objects[h].mj_id
        for e in range(m.neq):
            if m.eq_type[e] == mujoco.mjtEq.mjEQ_WELD and m.eq_objtype[e] == mujoco.mjtObj.mjOBJ_SITE:
                a, b = int(m.eq_obj1id[e]), int(m.eq_obj2id[e])
                if site in (a, b):
                    other = b if site == a else a
                    found = [o.handle for o in self._world.objects.values() if o.type == DUMMY and o.mj_id == other]
                    if found:
                        return found[0]
        return -1

    def setLinkDummy(self, dummyHandle: Any, linkDummyHandle: Any) -> None:  # noqa: N802, N803
        """Link two dummies (-1: unlink); a dummy's previous link goes."""
        links = self._store("dummy_links")
        h = self._dummy(dummyHandle, "dummyHandle")
        other = _int(linkDummyHandle, "linkDummyHandle")
        if other != -1:
            other = self._dummy(other, "linkDummyHandle")
        for one in (h, other):
            old = links.pop(one, None)
            if old is not None:
                links.pop(old, None)
        if other != -1 and other != h:
            links[h], links[other] = other, h

    def checkVisionSensorEx(self, sensorHandle: Any, entityHandle: Any, returnImage: Any) -> list[float]:  # noqa: N802, N803
        """The sensor's image now: RGB values 0..1 (``returnImage`` true) or its depth 0..1 (near
        to far), rows bottom-up. simx renders the whole scene: ``entityHandle`` must be
        ``sim.handle_all`` (an object alone: UnsupportedError)."""
        e = _int(entityHandle, "entityHandle")
        if e != HANDLE_ALL:
            self._world.get(e)
            raise UnsupportedError("checkVisionSensorEx of one entity: simx's sensors render the whole scene "
                                   "(pass sim.handle_all)")
        h = self._vision(sensorHandle)
        if returnImage:
            img, _ = self.getVisionSensorImg(h)
            return (np.frombuffer(img, np.uint8) / 255.0).tolist()
        return list(self.getVisionSensorDepthBuffer(h))

    if TYPE_CHECKING:  # provided by the facade
        _world: Any

        def _h(self, handle: Any, what: str = "object handle") -> int: ...

        def _store(self, kind: str) -> dict: ...

        def _vision(self, handle: Any) -> int: ...

        def _simulation(self, what: str) -> SimulationView: ...

        def getVisionSensorImg(self, handle: Any, options: Any = 0, rgbaCutOff: Any = 0, pos: Any = None,
                               size: Any = None) -> tuple[bytes, list[int]]: ...

        def getVisionSensorDepthBuffer(self, sensorHandle: Any, pos: Any = None, size: Any = None) -> list[float]: ...
