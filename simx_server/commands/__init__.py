"""The legacy remote API's commands: one handler per command, ``(simulation, args) -> result``.

One module per area (objects and poses, joints, parameters, signals, sensors and images,
collisions, group data, scripts, scene editing, the simulation's run state), each exporting its
handler table; :data:`HANDLERS` merges them. Handlers check every argument (clients are
untrusted) and raise the exceptions of :mod:`simx_wire.protocol`; the transport turns them into
error results and one log line.

Layer: below :mod:`simx_server.legacy`; imports :mod:`simx_server.scene`,
:mod:`simx_server.scripts`, :mod:`simx_server.sim` and :mod:`simx_server.base` only.
"""

from __future__ import annotations

from simx_server.commands.collisions import COLLISION_HANDLERS
from simx_server.commands.editing import EDITING_HANDLERS
from simx_server.commands.group_data import GROUP_DATA_HANDLERS
from simx_server.commands.joints import JOINT_HANDLERS, KINEMATICS_HANDLERS
from simx_server.commands.objects import OBJECT_HANDLERS
from simx_server.commands.parameters import PARAM_HANDLERS, SIMULATION_PARAM_HANDLERS
from simx_server.commands.scripts import SCRIPT_HANDLERS
from simx_server.commands.sensors import IMAGE_HANDLERS, SENSOR_HANDLERS
from simx_server.commands.signals import SIGNAL_HANDLERS
from simx_server.commands.handler import Handler
from simx_server.commands.run_control import SIMULATION_HANDLERS

#: Command name -> handler. Synchronous, SynchronousTrigger and Bye are handled by the
#: transport itself, since they concern the client connection and the stepping loop.
HANDLERS: dict[str, Handler] = {
    **SIMULATION_HANDLERS,
    **OBJECT_HANDLERS,
    **JOINT_HANDLERS,
    **KINEMATICS_HANDLERS,
    **SIMULATION_PARAM_HANDLERS,
    **PARAM_HANDLERS,
    **SIGNAL_HANDLERS,
    **IMAGE_HANDLERS,
    **SENSOR_HANDLERS,
    **COLLISION_HANDLERS,
    **GROUP_DATA_HANDLERS,
    **SCRIPT_HANDLERS,
    **EDITING_HANDLERS,
}

#: Commands that may not stream (``simx_opmode_streaming``): scene loads, edits and file
#: transfers, which V-REP executed once; re-run after every step they would hold every client
#: for as long as the stream lasts. Only reads and settings stream (docs/API.md).
NOT_STREAMABLE = frozenset(EDITING_HANDLERS)

__all__ = ["HANDLERS", "NOT_STREAMABLE", "Handler"]
