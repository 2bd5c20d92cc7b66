"""A ZMQ remote API client's entry in the loop's registry (:mod:`simx_server.loop.clients`):
its identity and expiry, and what only the ZMQ door keeps of it (its stepping level and locks,
its wait for a step, a call that lasts several steps, its connection); the door's service
(:mod:`simx_server.zmq.service`) reads and writes it on the simulation thread."""

from __future__ import annotations

from typing import Any

from simx_server.loop.clients import Client
from simx_server.zmq import codec


class ZmqClient(Client):
    """One ZMQ remote API client (a ``RemoteAPIClient``, by its uuid): its entry in the loop's
    registry (``id``: the uuid; ``expiry``: its ``timeout``), with its stepping state."""

    __slots__ = ("sync_id", "lock_id", "fd", "stepping", "locks",
                 "step_at", "waiting", "held", "label", "long", "long_func", "connection", "in_callback",
                 "gave_up", "files_key", "version")

    def __init__(self, uuid: str, fd: int, timeout: float | None, now: float, connection: bytes = b"",
                 door: Any = None, version: int = codec.PROTOCOL_VERSION):
        super().__init__(uuid, door, now, timeout if timeout is not None else codec.DEFAULT_TIMEOUT)
        self.version = version  # its requests' protocol version (1: CoppeliaSim 4.3-4.5's client)
        self.label = f"zmq:{uuid[:8]}" if version == codec.PROTOCOL_VERSION else f"zmq43:{uuid[-8:]}"
        self.sync_id, self.lock_id = f"zmq:{uuid}", f"zmq-lock:{uuid}"
        self.fd = fd
        self.stepping = 0  # sim.setStepping level
        self.locks = 0  # sim.acquireLock count
        self.step_at = -1  # Simulation.steps when its sim.step() came
        self.waiting = False  # its sim.step() was answered _*wait*_: _*executed*_ is due
        self.held: list | None = None  # envelope of its _*executed*_, answered after the next step
        self.long = None  # the generator of a call that lasts several steps (sim.moveToConfig ...)
        self.long_func = ""
        self.in_callback = False  # its long call waits for the _*executed*_ of a callback the client runs
        self.gave_up = ""  # the long call abandoned while its callback ran (its _*executed*_ is refused)
        self.connection = connection  # its connection's routing id (ZmqService.connections)
        self.files_key = f"zmq:{uuid}"  # its folder's key (simx_server.scene.client_files)

    @property
    def uuid(self) -> str:
        """The client's uuid: its id in the registry."""
        return self.id
