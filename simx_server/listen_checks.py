"""``simx-server``'s checks of where it listens, and the one line it prints when it cannot (status
2): a port already in use is found with a probe socket before the scene, MuJoCo and the API table
load, so that it is said at once; what Zenoh refuses later is said in the same form."""

from __future__ import annotations

import argparse
import errno
import os
import re

from simx_wire.protocol import zenoh_reason

#: Where a Zenoh error names an endpoint it could not listen on.
_ENDPOINT_IN_ERROR = re.compile(r"bound to (\S+):\s")


def listen_failure(endpoints: list[str], exc: BaseException) -> str:
    """The one line ``simx-server`` prints when Zenoh cannot listen (status 2): for a port already
    in use or an address not of this machine it names the endpoint and the way out (``--port``,
    ``--host``), otherwise Zenoh's reason without the library's source paths. Always starts
    ``simx-server: cannot listen on `` (ServerPool retries another port on that)."""
    text = str(exc)
    found = _ENDPOINT_IN_ERROR.search(text)
    where = found.group(1) if found else ", ".join(endpoints)
    if "Address already in use" in text or "os error 98" in text:
        return _in_use(where)
    if "Cannot assign requested address" in text or "os error 99" in text:
        return (f"simx-server: cannot listen on {where}: that address is not one of this machine's; give "
                "--host one of its own addresses (default 127.0.0.1)")
    return f"simx-server: cannot listen on {where}: {zenoh_reason(text)}"


def _in_use(where: str) -> str:
    return (f"simx-server: cannot listen on {where}: the port is already in use (another simx-server, "
            "or another program, listens there); stop it, or choose a free port with --port N "
            "(the client's simxStart must use the same port)")


def port_in_use(endpoints: list[str]) -> str | None:
    """The refusal line of :func:`listen_failure` for the first TCP-based endpoint (``tcp``,
    ``tls``, ``ws``) whose port something already listens on, or None. Checked before the scene
    loads (2-10 s), so that a taken port is said at once: a probe socket binds the address with
    ``SO_REUSEADDR`` (a port a stopped server left in TIME_WAIT counts as free, as it does for
    Zenoh's listener, which sets the option too) and closes at once."""
    import socket

    for endpoint in endpoints:
        protocol, _, address = endpoint.partition("/")
        if protocol not in ("tcp", "tls", "ws"):
            continue
        host, _, port = address.split("#", 1)[0].split("?", 1)[0].rpartition(":")
        try:
            infos = socket.getaddrinfo(host.strip("[]"), int(port), type=socket.SOCK_STREAM)
        except (OSError, ValueError):
            continue  # Zenoh names what it cannot parse or resolve when it tries
        for family, kind, proto, _, sockaddr in infos:
            with socket.socket(family, kind, proto) as probe:
                probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                try:
                    probe.bind(sockaddr)
                except OSError as exc:
                    if exc.errno == errno.EADDRINUSE:
                        return _in_use(endpoint)
    return None


def zmq_port_in_use(args: argparse.Namespace) -> str | None:
    """The refusal line for an explicit ``--zmq-port N`` that something already listens on (the
    ZMQ remote API served on it: neither ``--no-zmq`` nor ``--zenoh-config`` without
    ``--zmq-curve``/``--zmq-insecure``), as ``simx-server``'s ``_attach_zmq`` says it when the bind fails; None
    otherwise. The default port taken is no refusal (the server goes on without the ZMQ remote
    API), nor is N+1 (the step counter of CoppeliaSim 4.3-4.5's clients,
    logged). Checked with :func:`port_in_use`'s probe, before the scene loads.

    Args:
        args: ``simx-server``'s parsed arguments.

    Returns:
        The line, or None.
    """
    if args.zmq_port is None or args.no_zmq or (args.zenoh_config and not (args.zmq_curve or args.zmq_insecure)):
        return None
    from simx_server.legacy.zenoh_config import DEFAULT_HOSTS

    hosts = args.host or list(DEFAULT_HOSTS)
    if port_in_use([f"tcp/[{h}]:{args.zmq_port}" if ":" in h else f"tcp/{h}:{args.zmq_port}" for h in hosts]) is None:
        return None
    where = ", ".join(f"tcp://[{h}]:{args.zmq_port}" if ":" in h else f"tcp://{h}:{args.zmq_port}" for h in hosts)
    return (f"simx-server: cannot listen on {where} (ZMQ remote API): {os.strerror(errno.EADDRINUSE)}; choose a free "
            "port with --zmq-port N, or --no-zmq")
