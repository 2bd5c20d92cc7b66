"""Transports beside Zenoh served by the same loop: a mixin of :class:`~simx_server.legacy.server.Server`.

Another transport (the ZMQ remote API, :mod:`simx_server.zmq`) has a thread of its own that reads
its requests and puts ``(kind, item)`` tuples into the server's ready ring (:attr:`deliver`); the
simulation thread hands each to the transport's ``handle(kind, item)`` between steps, exactly as
it serves Zenoh requests. The transport also hears of every step (``after_step``: a client that
waits for a step is answered there) and of the loop's housekeeping, and tells how many clients it
has (so that an idle ``--speed 0`` server still steps for them). Its stepped clients join the
simulation's synchronous barrier; :meth:`step_now` and :meth:`leave_sync` are how it acts on it.
"""

from __future__ import annotations

import logging
from typing import Any, Callable

log = logging.getLogger("simx.server")


class OtherTransports:
    """Other transports of a server: ``attach`` them before ``serve``."""

    def _init_transports(self, deliver: Callable[[Any], None]) -> None:
        #: The transports attached (attach()).
        self.transports: list[Any] = []
        self._kinds: dict[str, Any] = {}  # ready-ring item kind -> the transport that handles it
        #: How another transport's thread hands ``(kind, item)`` to the simulation thread.
        self.deliver = deliver

    def attach(self, transport: Any) -> None:
        """Serve ``transport`` from this loop. It has ``kinds`` (the kinds of the ``(kind, item)``
        tuples its thread puts in the ready ring with :attr:`deliver`), ``handle(kind, item)``
        (run on the simulation thread between steps), ``after_step()`` (after each step and each
        loop pass without one), ``housekeeping(now)``, ``client_count()`` and ``close()``."""
        self.transports.append(transport)
        for kind in transport.kinds:
            self._kinds[kind] = transport

    def step_now(self) -> bool:
        """One step now (a stepped client of another transport completed the synchronous
        barrier); False when it failed (every client is told, as for any failed step)."""
        return self._step()

    def leave_sync(self, client: str, how: str) -> None:
        """``client`` (of any transport) leaves the synchronous barrier; the step the others all
        triggered runs now."""
        self._leave_sync(client, how)

    def _after_step(self) -> None:
        for transport in self.transports:
            try:
                transport.after_step()
            except Exception:  # a bug must not end the simulation thread
                log.exception("%s after a step", type(transport).__name__)

    def _transports_housekeeping(self, now: float) -> None:
        for transport in self.transports:
            transport.housekeeping(now)

    def _transport_clients(self) -> int:
        return sum(t.client_count() for t in self.transports)

    def _close_transports(self) -> None:
        for transport in self.transports:
            try:
                transport.close()
            except Exception:  # closing must not mask the reason we stop
                log.exception("closing %s", type(transport).__name__)

    if False:  # provided by Server  # pragma: no cover
        def _step(self) -> bool: ...

        def _leave_sync(self, client: str, how: str) -> None: ...
