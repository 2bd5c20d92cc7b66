"""What the server's loop does for the scene's scripts, as a front door attached to the
loop (:class:`~simx_server.legacy.server.Server`): customization scripts' ``sysCall_nonSimulation``
at every idle pass while the simulation is stopped (``sysCall_suspended`` while paused), and the
legacy remote API ports that scripts open with ``simExtRemoteApiStart(port)`` /
``simRemoteApi.start(port)``, how V-REP scenes open the server on 19999 for their programs.

The script facade records the request (:class:`~simx_server.api.sim.legacy.RemoteApiPorts`,
``Simulation.remote_api``); :class:`ScriptHooks` acts on it from the server's loop. A port the
server listens on already (19997 and 19999 by default) is a no-op. Another port gets a Zenoh
session of its own, made from the server's configuration (the same file's TLS, authentication
and access control, multicast scouting off) listening on the same hosts at that port and
connected to the server's own endpoints: Zenoh routes the clients of that port to the server's
queryables and liveliness, so they are served exactly as the others.
"""

from __future__ import annotations

import json
import logging
import re
from typing import Any

import zenoh

from simx_server.loop.front_door import FrontDoor
from simx_server.sim.state import RunState

log = logging.getLogger("simx.server")

_ENDPOINT = re.compile(r"^(?P<proto>[a-z]+)/(?P<host>\[[^\]]+\]|[^:/]+):(?P<port>\d+)(?P<rest>.*)$")


class ScriptHooks(FrontDoor):
    """A front door attached to the loop (``server.attach``), with no clients of its own: idle
    passes of customization scripts in :meth:`after_step`; the ports scripts ask for, polled from
    ``sim.remote_api`` in :meth:`housekeeping` (a few times a second), their sessions closed at
    the end."""

    kinds: tuple[str, ...] = ()  # it puts nothing in the ready ring

    def __init__(self, sim: Any, config: zenoh.Config):
        self.sim = sim
        self._base = str(config)  # the server's config as JSON (a zenoh.Config cannot be copied)
        listen = json.loads(config.get_json("listen/endpoints") or "[]")
        self.endpoints = [e for v in listen.values() for e in v] if isinstance(listen, dict) else list(listen)
        self.sessions: dict[int, zenoh.Session] = {}

    def listening(self) -> set[int]:
        """Ports the server listens on (its own endpoints and those opened for scripts)."""
        ports = {int(m["port"]) for e in self.endpoints if (m := _ENDPOINT.match(e))}
        return ports | set(self.sessions)

    def handle(self, kind: str, item: Any) -> None:  # pragma: no cover - no kinds
        pass

    def after_step(self) -> None:
        """After each step and each loop pass without one: idle calls of customization scripts."""
        state = self.sim.state
        if state is not RunState.RUNNING:
            self.sim.scripts.idle(paused=state is RunState.PAUSED)

    def housekeeping(self, now: float) -> None:
        self.poll(getattr(self.sim, "remote_api", None))

    def poll(self, requests: Any) -> None:
        """Open the ports ``requests`` (a RemoteApiPorts) has waiting; a failure is logged."""
        if requests is None or not requests.pending:
            return
        for port in requests.take():
            if port in self.listening():
                requests.served.add(port)
                log.info("simExtRemoteApiStart(%d): served already", port)
                continue
            try:
                self.sessions[port] = zenoh.open(self._config_for(port))
                requests.served.add(port)
                log.info("simExtRemoteApiStart(%d): the legacy remote API is served on %s too", port,
                         ", ".join(self._moved(port)))
            except (zenoh.ZError, ValueError) as exc:
                log.warning("simExtRemoteApiStart(%d): cannot listen there: %s", port, exc)

    def _moved(self, port: int) -> list[str]:
        out = []
        for e in self.endpoints:
            m = _ENDPOINT.match(e)
            if m:
                out.append(f"{m['proto']}/{m['host']}:{port}{m['rest']}")
        if not out:
            raise ValueError("the server's endpoints have no port to copy")
        return sorted(set(out), key=out.index)

    def _config_for(self, port: int) -> zenoh.Config:
        config = zenoh.Config.from_json5(self._base)
        config.insert_json5("mode", '"peer"')
        config.insert_json5("listen/endpoints", json.dumps(self._moved(port)))
        config.insert_json5("connect/endpoints", json.dumps(self.endpoints))
        config.insert_json5("scouting/multicast/enabled", "false")
        return config

    def close(self) -> None:
        for session in self.sessions.values():
            try:
                session.close()
            except Exception:  # closing at exit: nothing left to do
                log.debug("closing a script's port", exc_info=True)
        self.sessions.clear()
