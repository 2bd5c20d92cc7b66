"""``simxStart``'s connection: :func:`wait_connect` makes a :class:`~simx_client.connection.Connection`,
retrying as ``waitUntilConnected`` and ``timeOutInMs`` say, and logs why it could not.
"""

from __future__ import annotations

import logging
import time

import zenoh

from simx_wire import protocol as P
from simx_client.connection import Connection
from simx_client.sender import DEFAULT_CYCLE

log = logging.getLogger("simx.client")


def wait_connect(address: str, port: int, wait: bool, timeout: float, blocking_timeout: float,
                 reconnect: bool = False, prefix: str = P.DEFAULT_PREFIX, cycle: float = DEFAULT_CYCLE
                 ) -> Connection | None:
    """Connect to a simx server, retrying until ``timeout`` s when ``wait``; None on failure.
    ``cycle``: s between two requests of the outbox (:class:`Connection`).

    Implements ``simxStart``'s connection: ``waitUntilConnected``, ``timeOutInMs``,
    ``reconnectOnDisconnect`` and ``commThreadCycleInMs`` as arguments.

    Args:
        address: the server's host.
        port: its port.
        wait: retry until ``timeout`` (``waitUntilConnected``).
        timeout: s.
        blocking_timeout: s a blocking call waits for its reply.
        reconnect: connect again after a disconnection.
        prefix: the Zenoh key prefix of the server.
        cycle: s.

    Returns:
        The connection, or None (the reason is logged).
    """
    deadline = time.monotonic() + timeout
    while True:
        try:
            return Connection(address, port, blocking_timeout, prefix, reconnect=reconnect, cycle=cycle,
                              hello_timeout=max(0.1, min(blocking_timeout, deadline - time.monotonic())))
        except (P.ProtocolError, P.LocalError) as exc:
            log.error("simxStart(%s, %d): %s", address, port, exc)
            return None
        except P.RefusedError as exc:  # waiting would not change the server's answer
            log.warning("simxStart(%s, %d): %s", address, port, exc)
            return None
        except (zenoh.ZError, TimeoutError) as exc:
            if not wait or time.monotonic() >= deadline:
                _log_nobody(address, port, exc)
                return None
        time.sleep(0.05)


_told_nobody: set[tuple[str, int]] = set()  # (address, port) whose "no simx server" was a WARNING


def _log_nobody(address: str, port: int, exc: BaseException) -> None:
    """``simxStart`` found no simx server: a WARNING the first time for this address and port in
    this process (visible at Python's default log level, where a legacy program that retries
    forever would otherwise show nothing), INFO at every later try."""
    first = (address, port) not in _told_nobody
    _told_nobody.add((address, port))
    log.log(logging.WARNING if first else logging.INFO,
            "simxStart(%s, %d): no simx server at %s:%d (start one there: scripts/serve.sh, or simx-server; "
            "it listens on 19997 and 19999 by default, a --zenoh-config file on its listen endpoints): %s",
            address, port, address, port, P.zenoh_reason(str(exc)))
