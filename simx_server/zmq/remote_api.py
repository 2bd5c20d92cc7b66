"""The ZMQ remote API as one front door the command line attaches to the simulation loop
(:meth:`simx_server.loop.core.Loop.attach`; the interface is :class:`simx_server.loop.front_door.FrontDoor`)."""

from __future__ import annotations

import logging
from typing import Any

from pathlib import Path

from simx_server.base.resources import raise_open_files_limit
from simx_server.loop.front_door import FrontDoor, LoopAccess
from simx_server.zmq.frontend import DEFAULT_PORT, Frontend
from simx_server.zmq.gate import Gate
from simx_server.zmq.sockets import max_connections
from simx_server.zmq.codec import Request
from simx_server.zmq.service import ZmqService

log = logging.getLogger("simx.zmq")

__all__ = ["DEFAULT_PORT", "ZmqRemoteApi", "curve_keys", "endpoints"]


def endpoints(hosts: list[str] | tuple[str, ...], port: int) -> list[str]:
    """ZMQ endpoints for ``hosts`` (``--host``) on ``port``: ``tcp://HOST:PORT`` (IPv6 in brackets)."""
    return [f"tcp://[{h}]:{port}" if ":" in h else f"tcp://{h}:{port}" for h in hosts]


def counter_endpoints(main: list[str]) -> list[str]:
    """Where CoppeliaSim 4.3-4.5's clients read the step counter: each of ``main``'s hosts on the
    port after its own (their ``RemoteAPIClient(host, port)`` connects ``cntport = port + 1``)."""
    out = []
    for endpoint in main:
        head, _, port = endpoint.rpartition(":")
        if port.isdigit() and int(port) < 65535:
            out.append(f"{head}:{int(port) + 1}")
    return out


def curve_keys(folder: str | Path) -> tuple[bytes, bytes, frozenset]:
    """The CURVE keys of ``--zmq-curve FOLDER``: ``server.key_secret`` (the server's key pair) and
    the authorised clients' public keys, ``clients/*.key``, in the certificate format of
    ``zmq.auth.create_certificates`` (docs/SECURITY.md).

    Raises:
        ValueError: a file is missing or holds no key, or no client key is authorised.
    """
    import zmq.auth

    folder = Path(folder)
    try:
        public, secret = zmq.auth.load_certificate(folder / "server.key_secret")
    except (OSError, ValueError) as exc:
        raise ValueError(f"{folder / 'server.key_secret'}: {exc}") from None
    if not secret:
        raise ValueError(f"{folder / 'server.key_secret'} holds no secret key")
    clients = folder / "clients"
    try:
        keys = frozenset(zmq.auth.load_certificates(clients))
    except (OSError, ValueError) as exc:
        raise ValueError(f"{clients}: {exc}") from None
    if not keys:
        raise ValueError(f"{clients} holds no client public key (*.key): no client could connect")
    return secret, public, keys


class ZmqRemoteApi(FrontDoor):
    """CoppeliaSim's ZMQ remote API served by the loop ``server`` on ``endpoints``: a front door
    (:class:`~simx_server.loop.front_door.FrontDoor`).

    :meth:`open` binds the socket (zmq.ZMQError when it cannot) and starts its thread; the
    loop calls the rest (``handle``, ``after_step``, ``housekeeping``, ``close``) from its
    simulation thread. Its clients are in the loop's registry under :attr:`service` (their
    ``door``: it keeps and forgets them, :meth:`ZmqService.keeps`, :meth:`ZmqService.forget`).
    """

    kinds: tuple[str, ...] = ("zmq", "zmq-gone")

    def __init__(self, server: LoopAccess, endpoints: list[str], curve: tuple[bytes, bytes, frozenset] | None = None):
        files = raise_open_files_limit()
        gate = Gate(curve, max_connections(files))
        self.frontend = Frontend(endpoints, server.deliver, gate, server.serve_or_deliver, self._quick,
                                 counter_endpoints(endpoints))
        self.service = ZmqService(server, self.frontend)

    @property
    def bound(self) -> list[str]:
        """The endpoints bound (after :meth:`open`)."""
        return self.frontend.bound

    def open(self) -> None:
        self.frontend.open()
        if self.frontend.counter_bound:
            log.info("ZMQ step counter of CoppeliaSim 4.3-4.5's clients on %s", ", ".join(self.frontend.counter_bound))
        if self.frontend.gate.curve is not None:
            log.info("ZMQ remote API with CURVE: %d authorised client keys", len(self.frontend.gate.curve[2]))
        elif any(not (e.startswith("tcp://127.") or e.startswith("tcp://[::1]") or e.startswith("tcp://localhost"))
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

    def close(self) -> None:
        self.frontend.close()

    def _quick(self, request: Request) -> bool:
        """Whether a request may be served on the socket thread: not a call seen loading or
        editing the scene (:attr:`ZmqService.edit_calls`), which would hold that thread."""
        return request.func not in self.service.edit_calls

