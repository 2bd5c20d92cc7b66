"""A minimal client of CoppeliaSim 4.3/4.4's ZMQ remote API (protocol version 1), written from the
protocol's description for the tests (docs/PROTOCOL.md, part 2, "Protocol version 1"): it behaves as
the ``zmqRemoteApi`` package those releases shipped, in what matters to a server.

* One ``REQ`` socket on the server's port: a request is the CBOR map ``{func, args}`` (no uuid, no
  version); the reply ``{success, ret}`` or ``{success: false, error}``, and a failed call raises
  ``Exception(reply.get('error'))`` (so a reply without ``error`` shows as ``Exception: None``).
* ``client.getObject('sim')`` asks ``zmqRemoteApi.info`` for the namespace and makes an object
  whose functions send ``sim.NAME`` and whose constants are attributes.
* One ``SUB`` socket (conflated) on the port after it: ``client.step()`` drains it, sends
  ``step`` with the client's uuid, then waits for a message on it (the server's step counter).
  ``client.setStepping(enable)`` sends ``setStepping`` with ``[enable, uuid]``.

Unlike that client, every receive here has a timeout (``TIMEOUT_MS``), so that a server that never
answers fails a test instead of hanging it.
"""

from __future__ import annotations

import uuid
from typing import Any

import cbor2
import zmq

TIMEOUT_MS = 20000


class Client43:
    """A CoppeliaSim 4.3/4.4-style client of the server on ``127.0.0.1:port`` (its step counter on
    ``port + 1``); :meth:`close` closes its sockets."""

    def __init__(self, port: int, host: str = "127.0.0.1"):
        self.context = zmq.Context()
        self.socket = self.context.socket(zmq.REQ)
        self.cntsocket = self.context.socket(zmq.SUB)
        for sock in (self.socket, self.cntsocket):
            sock.setsockopt(zmq.LINGER, 0)
            sock.setsockopt(zmq.RCVTIMEO, TIMEOUT_MS)
        self.socket.connect(f"tcp://{host}:{port}")
        self.cntsocket.setsockopt(zmq.SUBSCRIBE, b"")
        self.cntsocket.setsockopt(zmq.CONFLATE, 1)
        self.cntsocket.connect(f"tcp://{host}:{port + 1}")
        self.uuid = str(uuid.uuid4())
        self.stepping = False
        self.counts: list[bytes] = []  # the step counter's messages client.step() read

    def close(self) -> None:
        self.socket.close(0)
        self.cntsocket.close(0)
        self.context.term()

    def raw(self, message: Any) -> dict:
        """Send ``message`` (a CBOR value, or bytes as they are) and return the decoded reply."""
        self.socket.send(message if isinstance(message, bytes) else cbor2.dumps(message))
        return cbor2.loads(self.socket.recv())

    def call(self, func: str, args: Any) -> Any:
        """``func(*args)``: its only return value, a tuple of several, or None for none."""
        reply = self.raw({"func": func, "args": list(args)})
        if not reply.get("success", False):
            raise Exception(reply.get("error"))
        ret = reply["ret"]
        if len(ret) == 1:
            return ret[0]
        return tuple(ret) if ret else None

    def getObject(self, name: str) -> Any:  # noqa: N802 (the client's name)
        """The namespace ``name`` (``sim``) as an object, from ``zmqRemoteApi.info``."""
        namespace = type(name, (), {})
        for key, value in self.call("zmqRemoteApi.info", [name]).items():
            if "func" in value:
                setattr(namespace, key, staticmethod(lambda *a, func=f"{name}.{key}": self.call(func, a)))
            else:
                setattr(namespace, key, value["const"])
        return namespace

    def setStepping(self, enable: bool = True) -> Any:  # noqa: N802
        if enable != self.stepping:
            self.stepping = enable
            return self.call("setStepping", [enable, self.uuid])
        return None

    def step(self) -> None:
        """One simulation step: returns once the server answered ``step`` and published the counter."""
        if not self.stepping:
            return
        try:
            self.cntsocket.recv(zmq.NOBLOCK)  # a count published earlier
        except zmq.Again:
            pass
        self.call("step", [self.uuid])
        self.counts.append(self.cntsocket.recv())
