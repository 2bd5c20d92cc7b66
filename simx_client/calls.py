"""The connection registry and :func:`_command`, the path of every ``simx*`` command.

:func:`_command` coerces the arguments, sends the command through the client's
:class:`~simx_client.connection.Connection` and converts the reply; the ``simx*`` functions
(:mod:`simx_client.api` and the ``api_*`` modules) call it directly.
"""

from __future__ import annotations

import logging
import threading
from typing import Any, Callable

from simx_wire import constants as C
from simx_wire import protocol as P
from simx_client.coercion import _int
from simx_client.connection import Connection

log = logging.getLogger("simx.client")

_MAX_CONNECTIONS = 255  # MAX_EXT_API_CONNECTIONS: client ids 0..254
_connections: dict[int, Connection] = {}
_registry_lock = threading.Lock()


# ------------------------------------------------------------------- plumbing
def _connection(client_id: Any) -> Connection | None:
    if type(client_id) is int:
        return _connections.get(client_id)
    try:
        return _connections.get(_int(client_id))
    except Exception:
        return None


def _command(clientID: Any, name: str, make_args: Callable[[], list], operationMode: Any,
             convert: Callable[[Any], Any] = lambda v: v, default: Any = None,
             memo: Callable[[Any], Any] | None = None) -> tuple[int, Any]:
    """Run one command; returns ``(return code, converted value or default)``.

    With ``memo`` (a function copying a converted value), a value read again from the inbox
    (a ``buffer`` loop on an unchanged image) is converted once and handed out as copies.
    """
    conn = _connection(clientID)
    if conn is None:
        return C.simx_return_initialize_error_flag, default
    try:
        args = make_args()
        mode = _int(operationMode)
    except Exception as exc:  # any argument that cannot be converted: a local error, never a raise
        log.warning("simx%s: bad argument: %s: %s", name, type(exc).__name__, exc)
        return C.simx_return_local_error_flag, default
    rc, value = conn.call(name, args, mode)
    if rc or mode & P.MODE_MASK == P.MODE_REMOVE:  # remove returns no value
        if rc & C.simx_return_remote_error_flag:
            log.debug("simx%s: remote error: %s", name, value)
        elif rc & C.simx_return_local_error_flag:
            log.warning("simx%s: %s", name, value)
        return rc, default
    try:
        if memo is None or mode & P.MODE_MASK == P.MODE_BLOCKING:  # a blocking reply is always fresh
            return rc, convert(value)
        key = P.identity(name, args)
        hit = conn.converted.get(key)
        if hit is None or hit[0] is not value:
            hit = conn.converted[key] = (value, convert(value))
        return rc, memo(hit[1])
    except Exception as exc:  # a reply of the wrong shape: the server's fault, not the caller's
        log.warning("simx%s: unreadable reply %s: %s", name, P.quote(value), exc)
        return C.simx_return_remote_error_flag, default
