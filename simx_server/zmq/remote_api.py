"""The ZMQ remote API as one piece the command line attaches to a server (:meth:`Server.attach`)."""

from __future__ import annotations

import logging
from typing import Any

from simx_server.zmq.frontend import DEFAULT_PORT, Frontend
from simx_server.zmq.service import ZmqService

log = logging.getLogger("simx.zmq")

__all__ = ["DEFAULT_PORT", "ZmqRemoteApi", "endpoints"]


def endpoints(hosts: list[str] | tuple[str, ...], port: int) -> list[str]:
    """ZMQ endpoints for ``hosts`` (``--host``) on ``port``: ``tcp://HOST:PORT`` (IPv6 in brackets)."""
    return [f"tcp://[{h}]:{port}" if ":" in h else f"tcp://{h}:{port}" for h in hosts]


class ZmqRemoteApi:
    """CoppeliaSim's ZMQ remote API served by ``server``'s loop on ``endpoints``.

    :meth:`open` binds the socket (zmq.ZMQError when it cannot) and starts its thread; the
    server calls the rest (``handle``, ``after_step``, ``housekeeping``, ``client_count``,
    ``close``) from its simulation thread.
    """

    kinds = ("zmq", "zmq-gone")

    def __init__(self, server: Any, endpoints: list[str]):
        self.frontend = Frontend(endpoints, server.deliver)
        self.service = ZmqService(server, self.frontend)

    @property
    def bound(self) -> list[str]:
        """The endpoints bound (after :meth:`open`)."""
        return self.frontend.bound

    def open(self) -> None:
        self.frontend.open()
        if any(not (e.startswith("tcp://127.") or e.startswith("tcp://[::1]") or e.startswith("tcp://localhost"))
               for e in self.frontend.bound):
            log.warning("ZMQ remote API on %s: it has no authentication, any host that reaches it can run the "
                        "simulation (docs/SECURITY.md); keep it on loopback or behind a firewall",
                        ", ".join(self.frontend.bound))

    def handle(self, kind: str, item: Any) -> None:
        self.service.handle(kind, item)

    def after_step(self) -> None:
        self.service.after_step()

    def housekeeping(self, now: float) -> None:
        self.service.housekeeping(now)

    def client_count(self) -> int:
        return len(self.service.clients)

    def close(self) -> None:
        self.frontend.close()
