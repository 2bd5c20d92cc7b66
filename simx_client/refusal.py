"""Why a Zenoh session could not open: nobody listens, or a server listens and refused it.

Zenoh answers both cases with the same error ("Unable to connect to any of [...]"), at once.
:func:`open_session` then looks at the endpoint itself, with the standard library only: a TCP
connection that is refused means nobody listens (Zenoh's error stands); one that is accepted
means a server is there, and a TLS handshake tells which layer refused: TLS against plain TCP
(or the reverse), the certificate, or Zenoh's authentication after the handshake. The result is
:class:`simx_wire.protocol.RefusedError` naming the cause and the Zenoh config file in play,
so that ``simxStart`` (and ``simx-viewer``) say it at once instead of waiting out the timeout.
"""

from __future__ import annotations

import json
import socket
import ssl

import zenoh

from simx_client.client_config import config_in_play
from simx_client.identity import user_of
from simx_wire import protocol as P

PROBE_TIMEOUT = 1.0  # s for the probe's TCP connection and TLS handshake


def _setting(config: zenoh.Config, key: str):
    try:
        return json.loads(config.get_json(key) or "null")
    except (zenoh.ZError, ValueError):
        return None


def _endpoint(config: zenoh.Config) -> tuple[str, str, int] | None:
    """``(protocol, host, port)`` of the config's first connect endpoint, None if unreadable."""
    endpoints = _setting(config, "connect/endpoints") or []
    if isinstance(endpoints, dict):
        endpoints = endpoints.get("client") or []
    if not endpoints:
        return None
    protocol, _, address = str(endpoints[0]).partition("/")
    address = address.split("#", 1)[0].split("?", 1)[0]
    host, _, port = address.rpartition(":")
    try:
        return protocol, host.strip("[]"), int(port)
    except ValueError:
        return None


def _tls_context(config: zenoh.Config, verify: bool) -> ssl.SSLContext:
    context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    if verify:
        ca = _setting(config, "transport/link/tls/root_ca_certificate")
        if ca:
            context.load_verify_locations(cafile=ca)
        else:
            context.load_default_certs()
        cert = _setting(config, "transport/link/tls/connect_certificate")
        key = _setting(config, "transport/link/tls/connect_private_key")
        if cert and key:
            context.load_cert_chain(cert, key)
    else:
        context.check_hostname = False
        context.verify_mode = ssl.CERT_NONE
    return context


def _handshake(host: str, port: int, context: ssl.SSLContext) -> str | None:
    """None when a TLS handshake with ``context`` succeeds, else why it failed."""
    try:
        with socket.create_connection((host, port), PROBE_TIMEOUT) as raw, \
                context.wrap_socket(raw, server_hostname=host) as tls:
            tls.version()
        return None
    except ssl.SSLCertVerificationError as exc:
        return f"its certificate was not accepted ({exc.verify_message})"
    except (ssl.SSLError, OSError) as exc:
        return f"{type(exc).__name__}: {exc}"


def why_refused(config: zenoh.Config) -> str | None:
    """Why a server at the config's endpoint refused a session, or None when nobody listens there
    (or the endpoint is not TCP or TLS, which this probe does not speak).

    Args:
        config: the client's Zenoh config (its first connect endpoint, TLS and user settings).

    Returns:
        One sentence (a TLS mismatch, a certificate the client does not trust, a refused user),
        or None.
    """
    found = _endpoint(config)
    if found is None or found[0] not in ("tcp", "tls"):
        return None
    protocol, host, port = found
    where = f"{host}:{port}"
    try:
        socket.create_connection((host, port), PROBE_TIMEOUT).close()
    except OSError:
        return None  # nobody listens: Zenoh's own error says it
    speaks_tls = _handshake(host, port, _tls_context(config, verify=False)) is None
    if protocol == "tcp" and speaks_tls:
        return (f"the server at {where} speaks TLS and this client connects over plain TCP: use a Zenoh config "
                "whose endpoint is tls/ and that names the server's certificate authority (docs/SECURITY.md)")
    if protocol == "tls" and not speaks_tls:
        return (f"the server at {where} does not speak TLS (plain TCP) and this client connects over TLS: "
                "use a Zenoh config whose endpoint is tcp/")
    if protocol == "tls":
        failed = _handshake(host, port, _tls_context(config, verify=True))
        if failed:
            return f"the TLS handshake with the server at {where} failed: {failed}"
    user = _setting(config, "transport/auth/usrpwd/user")
    if not user:
        return (f"the server at {where} refused the session: it requires authentication and this client "
                "gives no user and password (transport/auth/usrpwd)")
    return (f"the server at {where} refused the session of user {user!r}: a wrong password, or a user it "
            "does not know (transport/auth/usrpwd)")


def open_session(config: zenoh.Config, config_file: str) -> zenoh.Session:
    """``zenoh.open(config)``; a refusal raises :class:`~simx_wire.protocol.RefusedError` naming
    its cause and ``config_file`` (the Zenoh config in play, as the user knows it).

    Raises:
        simx_wire.protocol.RefusedError: a server listens there and refused the session.
        zenoh.ZError: nobody listens there (or another failure of Zenoh's).

    Args:
        config: the client's Zenoh config.
        config_file: how messages name it.

    Returns:
        The session.
    """
    try:
        return zenoh.open(config)
    except zenoh.ZError:
        reason = why_refused(config)
        if reason is None:
            raise
    raise P.RefusedError(f"{reason}; Zenoh config: {config_file}")


def unanswered_handshake(session: zenoh.Session, prefix: str, client: str, address: str,
                         port: int) -> P.RefusedError | None:
    """After a handshake that timed out: the refusal to raise when the server is there (its
    liveliness token answers a liveliness query) and did not answer this client, which its access
    control does when user ``client``'s ids are not the user's to call under; None when the server
    is not there (the timeout stands).

    Args:
        session: the client's open Zenoh session.
        prefix: the server's key-expression prefix.
        client: the client id that asked.
        address, port: where the server listens (for the message).

    Returns:
        The refusal, or None.
    """
    try:
        seen = any(True for _ in session.liveliness().get(P.server_token_key(prefix), timeout=0.5))
    except zenoh.ZError:
        seen = False
    if not seen:
        return None
    return P.RefusedError(
        f"the server at {address}:{port} is there (its liveliness token is seen) but did not answer this "
        f"client's handshake: its access control does not let user {user_of(client)} call under its ids, or "
        f"it is overloaded (docs/SECURITY.md); Zenoh config: {config_in_play()}")
