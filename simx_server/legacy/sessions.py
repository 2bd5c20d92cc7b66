"""Per-client intake: bounded request queues served round robin, render bounds, evictions.

Zenoh's threads call :meth:`Sessions.admit` with a parsed request; the simulation thread takes
requests back with :meth:`Sessions.take`. Between them is one ``queue.SimpleQueue``, the loop's
*ready ring*: it holds each client that has requests waiting exactly once (a
:class:`~simx_server.loop.front_door.ReadyClient` of the legacy door, beside the other doors'
deliveries). The simulation thread takes a client from the ring, executes that client's
oldest request and, if the client has more, puts it back at the end of the ring: clients are
served one request each in turn, so one client's flood delays another's request by at most
one request per flooding client, never by the flood's length.

Every queue is bounded (limits.py): requests and bytes per client, bytes over all clients,
clients with state. A request over a bound is not queued; :meth:`Sessions.admit` returns the
reason and the caller answers it at once. A client with
:data:`~simx_server.base.limits.MAX_UNSENT_PER_CLIENT` replies or stream updates not sent yet
(waiting for their images, or for room on its link) is *parked*: not served until one of them
is sent, so that a flood of image requests, or requests of a client that stopped reading, queue
up in its own bounded queue, not in the render thread's nor the sending thread's.

This is the door's own intake state, on Zenoh's threads and under a lock; what the loop keeps
of every client (last request, expiry, edit share, a failed step's message) is in its registry
(:mod:`simx_server.loop.clients`). No MuJoCo in here: this module is the queueing discipline
alone, testable without a server.
"""

from __future__ import annotations

import collections
import queue
import threading
import time
from typing import Any

from simx_wire import proof as PR
from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.commands import NOT_STREAMABLE

_MODE_MASK, _MODE_BLOCKING = P.MODE_MASK, P.MODE_BLOCKING


class Session:
    """The intake state of one client (its queue and counters); touched under the lock."""

    __slots__ = ("client", "door", "queue", "queued_bytes", "scheduled", "parked", "unsent", "last_seen", "step",
                 "secret", "window")

    def __init__(self, client: str, now: float, door: Any = None):
        self.client = client
        self.door = door  # the door that serves it (front_door.ReadyClient)
        self.queue: collections.deque = collections.deque()  # (request, payload size)
        self.queued_bytes = 0
        self.scheduled = False  # in the ready ring, or parked (it has requests waiting)
        self.parked = False  # waiting for one of its sends before it is served again
        self.unsent = 0  # replies and stream updates of this client handed over and not sent yet
        self.last_seen = now  # time.monotonic() of its last request
        self.step = -1  # Simulation.steps when its last blocking request was answered (legacy pacing)
        self.secret: bytes | None = None  # what its requests prove (simx_wire.proof); None: not handshaken
        self.window = PR.Window()  # the sequence numbers of its proofs used so far


class Sessions:
    """Every client's intake state, the ready ring and their bounds.

    Args:
        ready: the ring the simulation thread waits on; gets :class:`Session` objects.
        door: the door their sessions name (``Session.door``: the loop has it serve them).
        schedule: how :meth:`admit` schedules a client that had nothing waiting (thread-safe;
            default: ``ready.put``; the server serves it in place when it can).
        max_requests, max_bytes: a client's queue bounds (requests, payload bytes).
        max_total_bytes: payload bytes queued over all clients.
        max_clients: clients with state.
        max_per_user: clients with state of one user (client ids ``<user>-<uuid>``).
        max_per_peer: client ids one Zenoh session's tokens protect (:mod:`.peers`).
        max_tokens: liveliness tokens recorded (protected and unverified together).
        max_unsent: a client's replies and updates not sent yet before it is parked.
        prove: whether a client id belongs to the client that handshook under it
            (:mod:`simx_wire.proof`; the door's sessions always do; off for queueing tests).
    """

    def __init__(self, ready: queue.SimpleQueue, max_requests: int = limits.MAX_QUEUED_REQUESTS,
                 max_bytes: int = limits.MAX_QUEUED_BYTES, max_total_bytes: int = limits.MAX_QUEUED_BYTES_TOTAL,
                 max_clients: int = limits.MAX_CLIENTS, max_unsent: int = limits.MAX_UNSENT_PER_CLIENT,
                 max_per_user: int = limits.MAX_CLIENTS_PER_USER, max_per_peer: int = limits.MAX_CLIENTS_PER_PEER,
                 max_tokens: int = limits.MAX_CLIENT_TOKENS, door: Any = None, schedule: Any = None,
                 prove: bool = False):
        self.ready = ready
        self.prove = prove
        self.door = door
        self._schedule = schedule if schedule is not None else ready.put
        self.max_requests, self.max_bytes, self.max_total_bytes = max_requests, max_bytes, max_total_bytes
        self.max_clients, self.max_unsent, self.max_per_user = max_clients, max_unsent, max_per_user
        self._per_user: dict[str, int] = {}  # authenticated user -> its clients with state
        self.max_per_peer, self.max_tokens = max_per_peer, max_tokens
        self.tokens: set[str] = set()  # clients whose liveliness token protects them (peers.PeerCheck)
        self.unverified: set[str] = set()  # tokens seen whose session is not known (or over its bound)
        self._peers: dict[str, set[str]] = {}  # Zenoh session id -> the client ids its tokens protect
        self._peer_of: dict[str, list[str]] = {}  # client -> the sessions whose share holds it
        self._lock = threading.Lock()
        self._sessions: dict[str, Session] = {}
        self._total_bytes = 0
        self.evicted: list[str] = []  # clients dropped to make room; the simulation thread forgets them

    def __len__(self) -> int:
        return len(self._sessions)

    def get(self, client: str) -> Session | None:
        """The client's session, or None."""
        return self._sessions.get(client)

    # ------------------------------------------------------------ Zenoh's threads
    def admit(self, client: str, request: Any, size: int, payload: bytes = b"", proof: bytes | None = None,
              hello: bool = False) -> str | None:
        """Queue ``request`` (``size`` payload bytes) of ``client``; None when queued, else the
        reason it was not (the caller answers the request with it at once).

        With ``prove``: ``payload`` is the request's bytes, ``proof`` its attachment (None: none),
        ``hello`` whether it asks for a ``Hello``. A request that does not prove the id is its
        sender's (:meth:`_unproven`) is refused before anything of it is kept."""
        now = time.monotonic()
        checked = None  # (secret, the proof's number or None): its MAC, of up to 64 MiB, outside the lock
        if self.prove and proof is not None:
            with self._lock:
                s = self._sessions.get(client)
                secret = None if s is None else s.secret
            if secret is not None:
                checked = (secret, PR.check(secret, proof, payload))
        with self._lock:
            s = self._sessions.get(client)
            if self.prove:
                refused = self._unproven(client, s, payload, proof, checked)
                if refused is not None:
                    return refused
            if s is None:
                user = _user(client)
                if user and self._per_user.get(user, 0) >= self.max_per_user and not self._evict_one(user):
                    return (f"{P.BUSY}: user {user} has {self.max_per_user} clients already "
                            "(limits.MAX_CLIENTS_PER_USER); finish some first")
                if len(self._sessions) >= self.max_clients and not self._evict_one():
                    return (f"{P.BUSY}: it serves {self.max_clients} clients already "
                            "(limits.MAX_CLIENTS); try again later")
                s = self._sessions[client] = Session(client, now, self.door)
                if user:
                    self._per_user[user] = self._per_user.get(user, 0) + 1
            if self.prove and hello and s.secret is None:
                s.secret = PR.new_secret()  # its Hello's reply tells it, and it alone
            s.last_seen = now
            refused = self._bound(s, size)
            if refused is not None:
                if not s.scheduled and not s.queue and not s.unsent:
                    self._drop(client)  # a client whose first request is refused keeps no state
                return refused
            s.queue.append((request, size))
            s.queued_bytes += size
            self._total_bytes += size
            if s.scheduled:
                return None
            s.scheduled = True
        # Scheduled after the lock: whoever serves it takes the same lock at once.
        self._schedule(s)
        return None

    @staticmethod
    def _unproven(client: str, s: Session | None, payload: bytes, proof: bytes | None,
                  checked: tuple[bytes, int | None] | None = None) -> str | None:
        """Why a request under ``client`` (whose session is ``s``) is not its sender's to make
        (lock held), or None. An id the server does not know is free: a request without a proof
        takes it (its Hello binds the id to a new secret). An id bound to a secret takes only
        requests whose proof holds, each sequence number once. An id whose first requests were
        no Hello (a client of the protocol that never asked for a secret) is not bound.
        ``checked``: ``(secret, number)``, the proof checked before the lock under that secret
        (the MAC of a 32 MiB request took 150 ms, every other client's service waiting on the lock)."""
        if s is None:
            if proof is None:
                return None
            return (f"{PR.UNKNOWN}: this server does not know client {P.quote(client)} (it left, expired, or "
                    "the server restarted); handshake again (Hello) for a new secret")
        if s.secret is None:
            return None if proof is None else (f"{PR.NOT_YOURS}: client {P.quote(client)} was not handshaken: "
                                               "it has no secret to prove")
        if proof is None:
            return (f"{PR.NOT_YOURS}: client id {P.quote(client)} belongs to the session that handshook under "
                    "it; its requests carry the proof of its secret (docs/PROTOCOL.md, Identity)")
        seq = checked[1] if checked is not None and checked[0] is s.secret else PR.check(s.secret, proof, payload)
        if seq is None:
            return f"{PR.NOT_YOURS}: the request's proof does not hold for client {P.quote(client)}"
        if not s.window.take(seq):
            return (f"{PR.NOT_YOURS}: request number {seq} of client {P.quote(client)} was used before, or is "
                    f"more than {PR.WINDOW} below its highest (a replay)")
        return None

    def _bound(self, s: Session, size: int) -> str | None:
        """Why a request of ``size`` bytes of ``s`` cannot be queued (lock held), or None."""
        if len(s.queue) >= self.max_requests:
            return (f"{P.BUSY}: this client has {len(s.queue)} requests waiting "
                    f"(limits.MAX_QUEUED_REQUESTS); request dropped")
        if s.queued_bytes + size > self.max_bytes:
            return (f"{P.BUSY}: this client has {s.queued_bytes} bytes of requests waiting "
                    f"(limits.MAX_QUEUED_BYTES = {self.max_bytes}); request dropped")
        if self._total_bytes + size > self.max_total_bytes:
            return (f"{P.BUSY}: {self._total_bytes} bytes of requests waiting from all clients "
                    f"(limits.MAX_QUEUED_BYTES_TOTAL = {self.max_total_bytes}); request dropped")
        return None

    def _evict_one(self, user: str | None = None) -> bool:
        """Drop the oldest client (of ``user``, if given) that holds no token and has nothing
        pending (lock held); False when there is none. Sessions are kept in creation order, so
        under a flood of fresh ids the first candidate is found at once."""
        for client, s in self._sessions.items():
            if (not s.scheduled and client not in self.tokens
                    and (user is None or _user(client) == user)):
                self._drop(client)
                self.evicted.append(client)
                return True
        return False

    def _drop(self, client: str) -> None:
        """Forget a client's session (lock held)."""
        if self._sessions.pop(client, None) is not None:
            user = _user(client)
            if user:
                left = self._per_user[user] - 1
                if left:
                    self._per_user[user] = left
                else:
                    del self._per_user[user]

    def token_seen(self, client: str) -> bool:
        """A client's liveliness token appeared: recorded as unverified (it protects nothing
        until :meth:`token_verified`); False when it is not recorded (limits.MAX_CLIENT_TOKENS,
        or known already)."""
        with self._lock:
            if client in self.tokens or client in self.unverified:
                return False
            if len(self.tokens) + len(self.unverified) >= self.max_tokens:
                return False
            self.unverified.add(client)
            return True

    def token_verified(self, client: str, peers: set[str]) -> bool:
        """The Zenoh sessions in ``peers`` answered for ``client``: its token protects it if
        one of them holds fewer than ``max_per_peer`` protected ids. Returns whether it does."""
        with self._lock:
            if client not in self.unverified:
                return client in self.tokens  # gone meanwhile, or protected already
            shares = []
            for peer in peers:
                ids = self._peers.setdefault(peer, set())
                if len(ids) < self.max_per_peer:
                    ids.add(client)
                    shares.append(peer)
            if not shares:
                return False
            self.unverified.discard(client)
            self.tokens.add(client)
            self._peer_of[client] = shares
            return True

    def token_gone(self, client: str) -> None:
        """A client's liveliness token went (its session closed or undeclared it)."""
        with self._lock:
            self.tokens.discard(client)
            self.unverified.discard(client)
            for peer in self._peer_of.pop(client, ()):
                ids = self._peers[peer]
                ids.discard(client)
                if not ids:
                    del self._peers[peer]

    # ------------------------------------------------------------ simulation thread
    def take(self, s: Session) -> Any:
        """The oldest request of a client taken from the ring, or None when the client is
        parked (too many sends outstanding) or has nothing left. The client goes back to
        the end of the ring when more requests wait."""
        with self._lock:
            if s.unsent >= self.max_unsent:
                s.parked = True  # sent() puts it back in the ring
                return None
            if not s.queue:
                s.scheduled = False
                return None
            request, size = s.queue.popleft()
            s.queued_bytes -= size
            self._total_bytes -= size
            if s.queue:
                self.ready.put(s)
            else:
                s.scheduled = False
        return request

    @staticmethod
    def head_is_blocking(s: Session) -> bool:
        """Whether the oldest request of ``s`` is a blocking call (one command, blocking mode):
        the request that legacy pacing holds until the next simulation step."""
        return Sessions.blocking_head(s) is not None

    @staticmethod
    def blocking_head(s: Session) -> str | None:
        """The command name of the oldest request of ``s`` when it is a blocking call (one
        command, blocking mode), else None. A queued request is ``((query, commands), size)``,
        each command ``[name, mode, args]``."""
        queued = s.queue
        if not queued:
            return None
        (_query, commands), _size = queued[0]
        if len(commands) != 1:
            return None
        name, mode, _args = commands[0]
        return name if mode & _MODE_MASK == _MODE_BLOCKING else None

    @staticmethod
    def carried_trigger(s: Session) -> bool:
        """Whether the oldest request of ``s`` is a blocking ``SynchronousTrigger`` that carries
        the commands its client's outbox held (at most ``protocol.MAX_CARRIED_COMMANDS``, none
        blocking, none editing the scene): served as the trigger alone would be
        (``LegacyDoor._schedule``). Legacy pacing does not hold it (:meth:`head_is_blocking`):
        a trigger's steps come with the barrier, not with the clock."""
        queued = s.queue
        if not queued:
            return False
        (_query, commands), _size = queued[0]
        if not 1 < len(commands) <= P.MAX_CARRIED_COMMANDS + 1:
            return False
        name, mode, _args = commands[-1]
        if name != "SynchronousTrigger" or mode & _MODE_MASK != _MODE_BLOCKING:
            return False
        for name, mode, _args in commands[:-1]:
            if mode & _MODE_MASK == _MODE_BLOCKING or name in NOT_STREAMABLE:
                return False
        return True

    def handed_over(self, s: Session) -> None:
        """A reply or stream update of ``s`` was handed to the sending thread."""
        with self._lock:
            s.unsent += 1

    def sent(self, s: Session) -> None:
        """Called on the sending thread once such a reply or update is sent (or dropped)."""
        with self._lock:
            s.unsent -= 1
            if s.parked and s.unsent < self.max_unsent:
                s.parked = False
                self.ready.put(s)

    def can_send(self, s: Session | None) -> bool:
        """Whether a stream update of ``s`` may be handed over now."""
        return s is None or s.unsent < self.max_unsent

    def pinned(self, client: str) -> bool:
        """Whether ``client`` stays whatever its silence: its liveliness token protects it, or
        requests of it wait (the loop's expiry asks, through the door's ``keeps``)."""
        with self._lock:
            s = self._sessions.get(client)
            return client in self.tokens or (s is not None and s.scheduled)

    def take_evicted(self) -> list[str]:
        """The clients dropped to make room since the last call (the simulation thread forgets them)."""
        with self._lock:
            gone, self.evicted = self.evicted, []
        return gone

    def remove(self, client: str) -> None:
        """Forget a client's intake state unless requests of it wait (its replies not sent yet are still sent)."""
        with self._lock:
            s = self._sessions.get(client)
            if s is not None and not s.scheduled:
                self._drop(client)


def _user(client: str) -> str:
    """The user a client id names (``<user>-<uuid>``), "" for an anonymous id."""
    return client.rpartition("-")[0]


#: Per Zenoh thread: whether keep_thread_state() ran on it.
zenoh_thread = threading.local()


def keep_thread_state() -> None:
    """Keep the Python thread state of the Zenoh thread this runs on.

    A callback declared with ``indirect=False`` runs on Zenoh's own thread, which PyO3 enters
    with ``PyGILState_Ensure`` and leaves with ``PyGILState_Release``: each call creates and
    destroys a thread state, and its first Python frame allocates a fresh frame stack.
    Measured on a blocking call, that costs about 0.25x the bare Zenoh round trip. One more
    ``PyGILState_Ensure``, never released, keeps the thread's state (and its frame stack and
    thread-locals) for the next calls; PyO3's own Ensure/Release still take and release the
    GIL around each call. CPython only; elsewhere nothing is kept.
    """
    zenoh_thread.kept = True
    try:
        import ctypes

        ctypes.pythonapi.PyGILState_Ensure()
    except (ImportError, AttributeError, OSError):
        pass
