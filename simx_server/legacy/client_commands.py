"""Commands about the calling client rather than the world: goodbye, synchronous mode and its
trigger, the errors kept for ``simxGetLastErrors``, and forgetting a client. A mixin of
:class:`simx_server.legacy.server.Server` (which provides ``sim``, ``sessions``, ``_streams``,
``_errors``, ``_edit_shares`` and ``_clients``; the loop, :class:`simx_server.loop.core.Loop`,
``_step`` and ``_leave_sync``).
"""

from __future__ import annotations

import logging

from simx_wire import protocol as P
from simx_server.sim.state import RunState

log = logging.getLogger("simx.server")


class ClientCommands:
    """The commands a client sends about itself (see the module docstring)."""

    def _last_errors(self, client: str, args: list) -> list[str]:
        return self._errors.pop(client, [])

    def _bye(self, client: str, args: list) -> None:
        self._forget(client, "disconnected")

    def _synchronous(self, client: str, args: list) -> None:
        if len(args) != 1 or not isinstance(args[0], bool):
            raise P.ArgumentError("simxSynchronous takes one boolean")
        if args[0]:
            self.sim.enable_sync(client, True)
            log.info("client %s: synchronous mode on", client)
        elif self.sim.is_synchronous(client):
            self._leave_sync(client, "left synchronous mode")

    def _trigger(self, client: str, args: list) -> None:
        sim = self.sim
        if not sim.is_synchronous(client):
            raise P.RemoteError(
                "simxSynchronousTrigger: this client has not enabled synchronous mode (call "
                "simxSynchronous(clientID, True)); the simulation steps once every client that did has triggered")
        if sim.state is RunState.RUNNING and sim.trigger(client) and not self._step():
            session = self.sessions.get(client)
            message = session.fault if session is not None else "the simulation step failed"
            if session is not None:
                session.fault = None  # told now, by this call's error
            raise P.RemoteError(message)

    def _forget(self, client: str, how: str) -> None:
        self._streams.pop(client, None)
        self._errors.pop(client, None)
        self._edit_shares.pop(client, None)
        self.sessions.remove(client)
        if client in self._clients:
            self._clients.discard(client)
            log.info("client %s %s", client, how)
        if self.sim.is_synchronous(client):
            self._leave_sync(client, f"{how}: out of synchronous mode")
