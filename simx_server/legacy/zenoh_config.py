"""The server's Zenoh configuration: the operator's file (TLS, authentication, access control),
the ``--host``/``--port`` endpoints, multicast scouting always off, and a warning when the
server listens beyond loopback without access control.
"""

from __future__ import annotations

import ipaddress
import json
import logging
from pathlib import Path

import zenoh

from simx_server.base import limits
from simx_server.base.resources import raise_open_files_limit

log = logging.getLogger("simx.server")

#: Where ``simx-server`` listens without ``--host``/``--port``: V-REP's remote API ports (19997, the
#: port of remoteApiConnections.txt, and 19999, the one V-REP's tutorials start from a script) on
#: loopback. Here, not in :mod:`simx_server.legacy.server`, so that the command line checks them
#: before it loads MuJoCo and the API table.
DEFAULT_HOSTS = ("127.0.0.1",)
DEFAULT_PORTS = (19997, 19999)

_BLOCK_WAIT = "transport/link/tx/queue/congestion_control/block/wait_before_close"
_MAX_MESSAGE = "transport/link/rx/max_message_size"
_ACCEPT_TIMEOUT = "transport/unicast/accept_timeout"
_ACCEPT_PENDING = "transport/unicast/accept_pending"
_SHM_KEY = "shared_memory"  # the operator's file names Zenoh's transport/shared_memory section
_ADMIN_KEY = "adminspace"  # the operator's file names Zenoh's admin space


def zenoh_config(endpoints: list[str], config_file: str | Path | None = None) -> zenoh.Config:
    """Server Zenoh config: the file's settings (TLS, authentication, access control), listening
    on ``endpoints`` unless the file lists its own, multicast scouting always off, and a reply
    blocked on a client's full link given up after limits.MAX_BLOCKED_REPLY_SECONDS (unless the
    file sets ``transport/link/tx/queue/congestion_control/block/wait_before_close``), and
    Zenoh's shared-memory transport off (unless the file has a ``shared_memory`` section): it
    kept every client process's 16 MiB pool mapped after the client left. Messages larger than
    limits.MAX_ZENOH_MESSAGE_BYTES are not reassembled (unless the file sets
    ``transport/link/rx/max_message_size``). A new connection has limits.ZENOH_ACCEPT_SECONDS to
    finish Zenoh's handshake, and up to limits.ZENOH_ACCEPT_PENDING of them (at most a third of
    the open-files limit) may be under way at once (unless the file sets
    ``transport/unicast/accept_timeout`` or ``accept_pending``). The admin space is on for the
    server's own session and closed to peers (unless the file has an ``adminspace`` section): the
    handshakes' guard reads the session's links there (:mod:`simx_server.legacy.handshakes`).

    A file without ``listen/endpoints`` listens on ``endpoints`` (``--host``/``--port``), not on
    Zenoh's default (every interface). Listening beyond loopback without access control logs a
    warning: any host that reaches the server could act as any client (docs/SECURITY.md).

    Raises:
        zenoh.ZError: the file cannot be read or is not a valid Zenoh config.
    """
    config = zenoh.Config.from_file(str(config_file)) if config_file else zenoh.Config()
    listen = json.loads(config.get_json("listen/endpoints") or "[]")
    if not listen or listen == json.loads(zenoh.Config().get_json("listen/endpoints")):
        config.insert_json5("listen/endpoints", json.dumps(endpoints))
        listen = endpoints
    config.insert_json5("scouting/multicast/enabled", "false")
    # Zenoh's shared-memory transport maps each client process's 16 MiB pool into the server the
    # first time it sends a message over 3 KiB and never unmaps it: 17 MB more per client process,
    # for good (docs/SECURITY.md, "Memory per connection"). Off unless the operator's file sets it.
    if not (config_file and _SHM_KEY in Path(config_file).read_text(errors="replace")):
        config.insert_json5("transport/shared_memory/enabled", "false")
    # A client that stops reading must not hold the simulation thread's replies for Zenoh's
    # default 5 s (limits.MAX_BLOCKED_REPLY_SECONDS), unless the operator's file sets its own.
    if config.get_json(_BLOCK_WAIT) == zenoh.Config().get_json(_BLOCK_WAIT):
        config.insert_json5(_BLOCK_WAIT, str(int(limits.MAX_BLOCKED_REPLY_SECONDS * 1e6)))
    # A message is reassembled whole before the server sees it: a request past MAX_REQUEST_BYTES
    # is refused, but Zenoh's default (1 GiB) let a 900 MiB one take 1.8 GB first.
    if config.get_json(_MAX_MESSAGE) == zenoh.Config().get_json(_MAX_MESSAGE):
        config.insert_json5(_MAX_MESSAGE, str(limits.MAX_ZENOH_MESSAGE_BYTES))
    # Connections that never finish Zenoh's handshake hold a handshake slot each for accept_timeout:
    # with Zenoh's 100 slots and 10 s, 110 idle TCP connections locked every new client out.
    default = zenoh.Config()
    if config.get_json(_ACCEPT_TIMEOUT) == default.get_json(_ACCEPT_TIMEOUT):
        config.insert_json5(_ACCEPT_TIMEOUT, str(int(limits.ZENOH_ACCEPT_SECONDS * 1000)))
    if config.get_json(_ACCEPT_PENDING) == default.get_json(_ACCEPT_PENDING):
        pending = max(100, min(limits.ZENOH_ACCEPT_PENDING, raise_open_files_limit() // 3))
        config.insert_json5(_ACCEPT_PENDING, str(pending))
    # The handshakes' guard (legacy/handshakes.py) reads which connections are sessions from the
    # session's own admin space: on, and closed to every peer, unless the operator's file says.
    if not (config_file and _ADMIN_KEY in Path(config_file).read_text(errors="replace")):
        config.insert_json5("adminspace", '{enabled: true, permissions: {read: false, write: false}}')
    if not json.loads(config.get_json("access_control/enabled") or "false"):
        flat = [e for v in listen.values() for e in v] if isinstance(listen, dict) else listen
        exposed = [e for e in flat if not _loopback(e)]
        if exposed:
            log.warning("listening on %s without access control: any host that reaches it can act as any "
                        "client (docs/SECURITY.md shows TLS, authentication and access control)",
                        ", ".join(exposed))
    return config


def _loopback(endpoint: str) -> bool:
    """Whether a Zenoh endpoint (``tcp/127.0.0.1:7447``, ``tls/[::1]:7447#iface=lo``...) is on loopback."""
    address = endpoint.split("/", 1)[-1].split("#", 1)[0].split("?", 1)[0]
    host = address.rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:  # another host name, a unix socket path...
        return endpoint.startswith(("unixsock-stream/", "unixpipe/"))
