"""Which Zenoh session holds a client id: the bound on client ids per peer.

A liveliness token keeps a client's state from expiring and from being evicted when the server
is full. Zenoh does not tell the server who sent a query or declared a token (a query's source
info is opt-in and the sender's to write), so one session declaring 1,100 tokens and sending one
request under each id filled ``MAX_CLIENTS``. But a *reply* carries the replying session's id
(``Reply.replier_id``, written by the replier's Zenoh): each client declares a queryable on
``protocol.peer_key`` beside its token, and when a token appears the server queries it once.
A token protects its client only if the session that answers for the id holds fewer than
``limits.MAX_CLIENTS_PER_PEER`` protected ids; ids beyond, and ids nobody answers for in
``limits.PEER_CHECK_SECONDS``, are treated as token-less: they expire when silent and are the
first evicted for a new client. Several sessions answering for one id (a wildcard queryable)
cannot take it from its owner: the id is protected if any of them has room.

The checks run as Zenoh queries with callbacks (none blocks a thread), at most
``limits.MAX_PEER_CHECKS`` at once; tokens beyond ``limits.MAX_CLIENT_TOKENS`` are not recorded.
"""

from __future__ import annotations

import logging
import threading

import zenoh

from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.legacy.sessions import Sessions

log = logging.getLogger("simx.server")


class PeerCheck:
    """Asks which session holds each client id whose token appears, and tells ``sessions``."""

    def __init__(self, sessions: Sessions, prefix: str, timeout: float = limits.PEER_CHECK_SECONDS,
                 max_checks: int = limits.MAX_PEER_CHECKS):
        self.sessions, self.prefix, self.timeout, self.max_checks = sessions, prefix, timeout, max_checks
        self.session: zenoh.Session | None = None
        self._lock = threading.Lock()
        self._checks = 0  # queries in flight

    def open(self, session: zenoh.Session) -> None:
        self.session = session

    def token(self, client: str, alive: bool) -> None:
        """A client's token appeared (``alive``) or went; on Zenoh's thread."""
        if not alive:
            self.sessions.token_gone(client)
            return
        if not self.sessions.token_seen(client) or self.session is None:
            return
        with self._lock:
            if self._checks >= self.max_checks:
                return  # left unverified: the token does not protect its client
            self._checks += 1
        answered: set[str] = set()

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None and reply.replier_id is not None:
                answered.add(str(reply.replier_id.zid))

        def on_done() -> None:
            with self._lock:
                self._checks -= 1
            if not self.sessions.token_verified(client, answered):
                log.info("client %s: its liveliness token does not protect it (%s)", client,
                         "no session answered for it" if not answered else
                         f"its session holds {self.sessions.max_per_peer} protected ids already "
                         "(limits.MAX_CLIENTS_PER_PEER)")

        try:
            self.session.get(P.peer_key(self.prefix, client),
                             zenoh.handlers.Callback(on_reply, on_done, indirect=False), timeout=self.timeout)
        except Exception as exc:  # a closing session: the token stays unverified
            with self._lock:
                self._checks -= 1
            log.debug("peer check of %s: %s", client, exc)
