"""The Zenoh config of a client (what ``simxStart`` asks for, over the user's config file) and
the config file in play as messages name it. Used by :mod:`simx_client.connection` and by raw
Zenoh sessions (tests, benchmarks, ``simx-viewer``) that must reach a server the same way.
"""

from __future__ import annotations

import json
import os

import zenoh

from simx_wire import protocol as P

#: Environment variables naming a client Zenoh config file, first found wins (ZENOH_CONFIG is
#: Zenoh's own convention). docs/SECURITY.md shows TLS and user/password files.
CONFIG_ENV = ("SIMX_ZENOH_CONFIG", "ZENOH_CONFIG")
#: Environment variable with the server's key-expression prefix for ``simxStart`` (default ``simx``).
PREFIX_ENV = "SIMX_PREFIX"


def config_in_play() -> str:
    """The client's Zenoh config file as messages name it: ``FILE ($SIMX_ZENOH_CONFIG)``, or none.

    Returns:
        The file and the variable that names it, or ``none (...)``.
    """
    found = next(((os.environ[v], v) for v in CONFIG_ENV if os.environ.get(v)), None)
    return f"{found[0]} (${found[1]})" if found else f"none (neither ${' nor $'.join(CONFIG_ENV)} is set)"


def client_config(address: str, port: int) -> zenoh.Config:
    """Zenoh config of a client: what ``simxStart`` asks for, over the user's config file.

    Without a config file: client mode, one endpoint ``tcp/<address>:<port>``, multicast
    scouting off. With a file named by ``$SIMX_ZENOH_CONFIG`` (or else ``$ZENOH_CONFIG``), that
    file (TLS certificates, user/password...) with the same three settings forced: mode
    ``client``, scouting off, and one connect endpoint ``<protocol>/<address>:<port>`` where
    ``<protocol>`` is the one of the file's first connect endpoint (``tls``, ``quic``...), ``tcp``
    when it has none. So an unchanged legacy program reaches a TLS server through the
    environment alone; the file's own addresses are not used (``simxStart``'s are).

    Raises:
        LocalError: the file cannot be read or is not a valid Zenoh config (``simxStart`` -1).

    Args:
        address: the server's host (``simxStart``'s connectionAddress).
        port: its port (``simxStart``'s connectionPort).

    Returns:
        The config.
    """
    path, var = next(((os.environ[v], v) for v in CONFIG_ENV if os.environ.get(v)), (None, None))
    protocol = "tcp"
    if path is None:
        config = zenoh.Config()
    else:
        try:
            config = zenoh.Config.from_file(path)
            endpoints = json.loads(config.get_json("connect/endpoints") or "[]")
        except (zenoh.ZError, ValueError) as exc:
            raise P.LocalError(f"cannot use the Zenoh config {path} (${var}): {exc}") from None
        if isinstance(endpoints, dict):  # per mode: {"client": [...], "peer": [...]}
            endpoints = endpoints.get("client") or []
        if endpoints:
            protocol = str(endpoints[0]).split("/", 1)[0]
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([f"{protocol}/{address}:{port}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    return config
