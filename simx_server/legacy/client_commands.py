"""Commands about the calling client rather than the world: goodbye, synchronous mode and its
trigger, the errors kept for ``simxGetLastErrors``, and forgetting a client. A mixin of
:class:`simx_server.legacy.server.LegacyDoor` (which provides ``sim``, ``loop`` (the loop's
:class:`~simx_server.loop.front_door.LoopAccess`: ``step_after_reply``, ``leave_sync``, ``clients``),
``sessions``, ``_streams``, ``_held_updates`` and ``_registry``, the door's clients in the loop's registry).
"""

from __future__ import annotations

import logging

from simx_wire import protocol as P
from simx_server.sim.state import RunState

log = logging.getLogger("simx.server")


class ClientCommands:
    """The commands a client sends about itself (see the module docstring)."""

    def _last_errors(self, client: str, args: list) -> list[str]:
        entry = self._registry.get(client)
        if entry is None:
            return []
        errors, entry.errors = entry.errors, []
        return errors

    def _bye(self, client: str, args: list) -> None:
        self._forget(client, "disconnected")

    def _synchronous(self, client: str, args: list) -> None:
        if len(args) != 1 or not isinstance(args[0], bool):
            raise P.ArgumentError("simxSynchronous takes one boolean")
        if args[0]:
            self.sim.enable_sync(client, True)
            log.info("client %s: synchronous mode on", client)
        elif self.sim.is_synchronous(client):
            self.loop.leave_sync(client, "left synchronous mode")

    def _trigger(self, client: str, args: list) -> None:
        """``simxSynchronousTrigger``: the step the barrier releases runs once this reply has
        been handed over (``LoopAccess.step_after_reply``), as V-REP answered the trigger
        before the step ran; the client's next call sees the step (``simxGetPingTime``
        returns once it is done). A step that fails is told at the client's next request."""
        sim = self.sim
        if not sim.is_synchronous(client):
            raise P.RemoteError(
                "simxSynchronousTrigger: this client has not enabled synchronous mode (call "
                "simxSynchronous(clientID, True)); the simulation steps once every client that did has triggered")
        if sim.state is RunState.RUNNING and sim.trigger(client):
            self._trigger_reply = self.loop.step_after_reply()  # set by _reply once sent

    def _forget(self, client: str, how: str) -> None:
        """Drop ``client``'s state: its streams, its intake (unless requests of it wait), its
        registry entry (errors, edit share); it leaves the synchronous barrier."""
        self._streams.pop(client, None)
        self._held_updates.pop(client, None)
        self.sessions.remove(client)
        self.sim.editor.files.release(f"legacy:{client}")  # its folder and budget
        entry = self._registry.get(client)
        if entry is not None:
            self.loop.clients.remove(entry)
            log.info("client %s %s", client, how)
        if self.sim.is_synchronous(client):
            self.loop.leave_sync(client, f"{how}: out of synchronous mode")
