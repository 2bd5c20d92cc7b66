"""Who a legacy client is to the server: its client id (``<user>-<uuid4 hex>``), and its answer
to the server's peer check, by which the server learns which Zenoh session holds an id
(docs/SECURITY.md)."""

from __future__ import annotations

import json
import os
import re
import uuid

import zenoh

from simx_wire import protocol as P

#: Environment variable with the user name that starts the client id (default: the config's
#: ``transport/auth/usrpwd/user``); needed with mTLS, where the user is the certificate's name.
USER_ENV = "SIMX_USER"
USER_SEPARATOR = "-"  # client id = <user>-<uuid4 hex>: never in a user name
_USER_NAME = re.compile(r"[A-Za-z0-9_.]{1,95}")  # 95 + 1 + 32 = 128, the longest client id


def answer_peer_check(query: zenoh.Query) -> None:
    """The server's peer check (protocol.peer_key): an empty reply, which Zenoh stamps with
    this session's id.

    Args:
        query: the server's query on this client's peer key.
    """
    try:
        query.reply(query.key_expr, b"")
    finally:
        query.drop()


def client_id(config: zenoh.Config) -> str:
    """A new client id: ``<user>-<uuid4 hex>`` when a user is known, else ``<uuid4 hex>``.

    The user is ``$SIMX_USER``, else the config's ``transport/auth/usrpwd/user``. With the
    user in its id, Zenoh access control can let an authenticated user act under its own ids
    only (``simx/call/<user>-$*``...; docs/SECURITY.md).

    Raises:
        LocalError: the user name is not 1 to 95 letters, digits, ``_`` or ``.`` (no ``-``:
            ``alice-$*`` must not match the ids of a user ``alice-x``).

    Args:
        config: the client's Zenoh config (for its user).

    Returns:
        The id.
    """
    user = os.environ.get(USER_ENV) or json.loads(config.get_json("transport/auth/usrpwd/user") or "null")
    ident = uuid.uuid4().hex
    if not user:
        return ident
    if not (isinstance(user, str) and _USER_NAME.fullmatch(user)):
        raise P.LocalError(f"user name {str(user)[:60]!r} cannot start a client id: use 1 to 95 letters, "
                           "digits, '_' or '.'")
    return f"{user}{USER_SEPARATOR}{ident}"


def user_of(client: str) -> str:
    """The user of a client id.

    Args:
        client: a client id (:func:`client_id`).

    Returns:
        The user that starts it, or ``"(none)"``.
    """
    return client.rpartition(USER_SEPARATOR)[0] or "(none)"
