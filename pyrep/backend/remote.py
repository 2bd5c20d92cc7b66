"""``pyrep`` against a running ``simx-server``: the same calls through CoppeliaSim's official ZMQ
client (``coppeliasim-zmqremoteapi-client``) instead of the in-process table.

:class:`RemoteContext` offers what :mod:`pyrep.backend.sim` needs of a context (``sim``,
``simik``, ``simompl``, ``state``), its namespaces calling the server's ``sim``/``simIK``/``simOMPL``
by name. The
simulation then runs in the server's process; ``PyRep.step()`` is the client's ``sim.step()``
in stepping mode, as a ZMQ program steps. Server-side paths: ``import_model`` and
``export_scene`` name files the server may read or write (its scene folders).
"""

from __future__ import annotations

import types
from typing import Any

from pyrep.errors import CoppeliaSimError, PyRepError


class _RemoteNamespace:
    """``call(name, *args)`` on a library of the official client (``sim`` or ``simIK``)."""

    def __init__(self, library: Any, label: str):
        self._library = library
        self._label = label

    def call(self, name: str, *args: Any) -> Any:
        try:
            return getattr(self._library, name)(*args)
        except Exception as exc:  # the official client raises Exception with the server's message
            raise CoppeliaSimError(f"{self._label}.{name}: {exc}") from exc

    def __getattr__(self, name: str) -> Any:
        return getattr(self._library, name)


class RemoteContext:
    """The context of a PyRep connected to a simx-server over ZMQ.

    Args:
        host: the server's address.
        port: its ZMQ remote API port (``simx-server --zmq-port``, 23000 by default).

    Raises:
        PyRepError: the official client is not installed.
    """

    def __init__(self, host: str = "127.0.0.1", port: int = 23000):
        try:
            from coppeliasim_zmqremoteapi_client import RemoteAPIClient
        except ImportError as exc:
            raise PyRepError("PyRep over ZMQ needs the official client: pip install "
                             "coppeliasim-zmqremoteapi-client") from exc
        self.client = RemoteAPIClient(host, port)
        self.sim = _RemoteNamespace(self.client.require("sim"), "sim")
        self.simik = _RemoteNamespace(self.client.require("simIK"), "simIK")
        self.state = types.SimpleNamespace()
        self._simompl: _RemoteNamespace | None = None

    @property
    def simompl(self) -> _RemoteNamespace:
        """The server's ``simOMPL`` (required at first use)."""
        if self._simompl is None:
            self._simompl = _RemoteNamespace(self.client.require("simOMPL"), "simOMPL")
        return self._simompl

    def simulation(self, what: str) -> Any:
        raise PyRepError(f"{what}: the simulation runs in the server's process (PyRep connected over ZMQ)")

    def close(self) -> None:
        """Closes the client's socket and context (at once, unsent messages dropped)."""
        self.client.socket.close(0)
        self.client.context.term()
