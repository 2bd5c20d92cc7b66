"""The type every command handler has: ``(simulation, args) -> result``.

``args`` is the command's argument list as the request decoded it; the result is what the reply
carries (or a :class:`~simx_server.sim.vision.Deferred` rendered later). A handler raises a
:class:`~simx_wire.protocol.RemoteError` subclass for a bad call.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from simx_server.scene.simulation import Simulation

Handler = Callable[[Simulation, list[Any]], Any]
