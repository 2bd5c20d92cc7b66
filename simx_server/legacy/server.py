"""The legacy remote API's front door: V-REP's ``simx*`` calls over Zenoh, on the simulation loop.

Zenoh callbacks never touch MuJoCo and never block: the query callback reads and checks the
request, answers at once what it refuses (unreadable, over a bound, a full client queue) and
queues the rest in the client's own bounded queue (:mod:`simx_server.legacy.sessions`), whose
session then sits in the loop's ready ring (a :class:`~simx_server.loop.front_door.ReadyClient`);
liveliness callbacks note clients' tokens. The simulation loop (:class:`simx_server.loop.core.Loop`,
to which :class:`LegacyDoor` is attached) takes the ready sessions round robin, between physics
steps, under its pacing, and has the door serve each one's next request
(:meth:`LegacyDoor.serve_ready`): it is executed atomically within the budgets (reply size,
request time, the client's share of scene edits), its reply handed to the sending thread
(:mod:`simx_server.loop.courier`: a client that stops reading never holds the simulation
thread), and after every step each client's streamed commands are published
(:meth:`LegacyDoor.publish`). The door's clients are in the loop's registry
(:class:`LegacyClient`: the loop expires them and tells them of a failed step); what is the
door's own (its Zenoh queries and queues, its stream tables) stays here.

:class:`Server` is the convenient whole: a loop with this door attached (``simx-server`` adds
the ZMQ door and the scripts' hooks to it).
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import zenoh

from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.base.arguments import quote
from simx_server.api.mesh_waits import answered
from simx_server.commands import HANDLERS, NOT_STREAMABLE
from simx_server.scene.simulation import Simulation
from simx_server.sim.vision import Deferred
from simx_server.legacy.client_commands import ClientCommands
from simx_server.legacy.consoles import CONSOLE_COMMANDS, Consoles
from simx_server.loop.budgets import cut as _cut
from simx_server.loop.clients import Client
from simx_server.loop.core import PACINGS, Loop
from simx_server.loop.front_door import FrontDoor, LoopAccess
from simx_server.legacy.handshakes import HandshakeGuard
from simx_server.legacy.intake import Intake
from simx_server.legacy.peers import PeerCheck
from simx_server.legacy.replies import (IMAGES, SMALL, answer, encode_response, image_size, reply_size,
                                           resolve, send_refusal, tell_secret)
from simx_server.legacy.sessions import Session, Sessions
from simx_server.legacy.streams import StreamPublisher, _Stream
from simx_server.legacy.viewer_feed import ViewerFeed
from simx_server.legacy.zenoh_config import DEFAULT_HOSTS, DEFAULT_PORTS

log = logging.getLogger("simx.server")

_STREAMING = (P.MODE_STREAMING, P.MODE_STREAMING_SPLIT)
__all__ = ["DEFAULT_HOSTS", "DEFAULT_PORTS", "PACINGS", "LegacyClient", "LegacyDoor", "Server"]


class LegacyClient(Client):
    """A legacy remote API client in the loop's registry, with the errors kept for its
    ``simxGetLastErrors`` (at most limits.MAX_ERRORS_KEPT)."""

    __slots__ = ("errors",)

    def __init__(self, client_id: str, door: Any, now: float, expiry: float):
        super().__init__(client_id, door, now, expiry)
        self.errors: list[str] = []

    def expired_how(self) -> str:
        return f"expired (no liveliness token, no request for {self.expiry:g} s)"


class Server:
    """Serves one :class:`Simulation` on Zenoh: a simulation loop (:attr:`loop`) with the legacy
    remote API's door (:attr:`door`) attached; other doors are attached with :meth:`attach`.

    Args:
        sim: the simulation (owned by the thread that calls serve()).
        config: Zenoh config (see :func:`zenoh_config`).
        speed: real-time factor in asynchronous mode; 0 runs as fast as possible.
        prefix: key-expression prefix (``simx``).
        client_expiry: s a client without a liveliness token may stay silent before its
            state is dropped (limits.CLIENT_EXPIRY).
        pacing: ``"legacy"`` (default): while the simulation runs asynchronously, a client's
            blocking call is executed only once the simulation has stepped since that client's
            previous blocking call was answered, so two consecutive blocking calls never see
            the same step (V-REP executed remote commands once per simulation pass; programs
            poll a joint with blocking calls until it stops moving). Stopped, paused or waiting
            for a synchronous trigger, requests are served at once, as in V-REP's instance
            passes. ``"immediate"``: every request is served as soon as it arrives (one round
            trip per blocking call, whatever the step).

    Raises:
        ValueError: a negative speed, a client expiry <= 0 or an unknown pacing.
    """

    def __init__(self, sim: Simulation, config: zenoh.Config, speed: float = 1.0,
                 prefix: str = P.DEFAULT_PREFIX, client_expiry: float = limits.CLIENT_EXPIRY,
                 pacing: str = "legacy"):
        self.loop = Loop(sim, speed=speed, client_expiry=client_expiry, pacing=pacing)
        self.door = LegacyDoor(self.loop, config, prefix)
        self.loop.attach(self.door)
        self.sim = sim

    def open(self) -> None:
        """Open the legacy door's Zenoh session (raises zenoh.ZError)."""
        self.door.open()

    def attach(self, door: FrontDoor) -> None:
        """Serve another front door from the loop (before :meth:`serve`)."""
        self.loop.attach(door)

    def serve(self) -> None:
        """Run the simulation loop until :meth:`request_stop`."""
        self.loop.serve()

    def request_stop(self) -> None:
        """Ask :meth:`serve` to return (safe from signal handlers and other threads)."""
        self.loop.request_stop()

    def close(self) -> None:
        """Close the simulation, the sending thread and every door; idempotent."""
        self.loop.close()


class LegacyDoor(ClientCommands, StreamPublisher, FrontDoor):
    """The legacy remote API's front door on ``loop`` (``loop.attach(door)`` is the caller's).

    Args:
        loop: the loop (:class:`~simx_server.loop.front_door.LoopAccess`).
        config: Zenoh config (see :func:`zenoh_config`).
        prefix: key-expression prefix (``simx``).
    """

    #: ``("gone", client)``: a client's liveliness token went; ``("viewer-model", query)``.
    kinds: tuple[str, ...] = ("gone", "viewer-model")

    def __init__(self, loop: LoopAccess, config: zenoh.Config, prefix: str = P.DEFAULT_PREFIX):
        self.loop = loop
        self.sim = loop.sim
        self.courier = loop.courier
        self.prefix = prefix
        self._config = config
        self._registry: dict[str, LegacyClient] = loop.clients.of(self)  # this door's clients, by id
        # Their sessions are the ready ring's ready clients; one with nothing waiting is served
        # on Zenoh's thread when the simulation thread waits for work (Loop.serve_or_deliver).
        self.sessions = Sessions(loop.ring, door=self, schedule=self._schedule, prove=True)
        self.peers = PeerCheck(self.sessions, prefix)  # which Zenoh session holds each token
        self._streams: dict[str, dict[tuple, _Stream]] = {}
        self._stream_renders: list = []  # futures of the last step's image-stream updates (StreamPublisher)
        self._held_updates: dict[str, tuple] = {}  # synchronous clients' step updates, sent before their next reply
        self.consoles = Consoles()  # simxAddStatusbarMessage, simxAuxiliaryConsole*
        self._trigger_reply: threading.Event | None = None  # a trigger's step waits for its reply
        self.session: zenoh.Session | None = None
        self.handshakes: HandshakeGuard | None = None
        self.viewers = ViewerFeed(prefix, loop.deliver, self.courier.send)  # simx-viewer's model and state
        self.intake = Intake(self)  # reads requests: on Zenoh's threads, large ones on a thread of their own

    # ------------------------------------------------------------ zenoh side
    def open(self) -> None:
        """Open the Zenoh session and declare the queryable and liveliness; raises zenoh.ZError."""
        self.session = zenoh.open(self._config)
        self._call_prefix = len(P.call_key(self.prefix, ""))  # a query's key minus this is its client
        # Direct callbacks: Zenoh's thread reads the request and queues it (or refuses it).
        self._queryable = self.session.declare_queryable(
            P.call_keys(self.prefix), zenoh.handlers.Callback(self.intake.on_query, indirect=False))
        self._legacy_queryable = self.session.declare_queryable(
            P.legacy_call_key(self.prefix), zenoh.handlers.Callback(self._refuse_old, indirect=False))
        self.peers.open(self.session)
        self._token = self.session.liveliness().declare_token(P.server_token_key(self.prefix))
        self._watch = self.session.liveliness().declare_subscriber(
            P.client_token_prefix(self.prefix), zenoh.handlers.Callback(self._on_client_token, indirect=False),
            history=True)
        self.viewers.open(self.session)
        self.handshakes = HandshakeGuard.of(self.session, self._config)  # slots kept free for new clients
        if self.handshakes is not None:
            self.handshakes.start()

    def _refuse_old(self, query: zenoh.Query) -> None:
        """A client of protocol version 1 or 2 (one call key for all): refuse with the reason."""
        key = str(query.key_expr)
        reply = P.error_response(
            f"protocol version mismatch: this server speaks {P.PROTOCOL_VERSION}, which sends "
            "requests to <prefix>/call/<client>; install the same simx version on client and server")
        self.courier.send(key, lambda: send_refusal(query, key, reply))

    def _on_client_token(self, sample: zenoh.Sample) -> None:
        client = str(sample.key_expr).rsplit("/", 1)[-1]
        gone = sample.kind == zenoh.SampleKind.DELETE
        self.peers.token(client, not gone)  # a token protects its client once its session is known
        if gone:
            self.loop.deliver(("gone", client))

    def close(self) -> None:
        """Close the Zenoh session (the loop has finished pending renders and their replies);
        idempotent."""
        self.intake.close()
        if self.handshakes is not None:
            self.handshakes.close()
        if self.session is not None:
            session, self.session = self.session, None
            # Zenoh's close waits for every link: one to a client that stopped reading held it
            # 11.6 s, and SIGTERM must end the server within 2 s. It runs on a thread of its own
            # and the server goes on after ZENOH_CLOSE_SECONDS (the process exits with it).
            closer = threading.Thread(target=self._close_session, args=(session,), name="simx-zenoh-close",
                                      daemon=True)
            closer.start()
            closer.join(limits.ZENOH_CLOSE_SECONDS)
            if closer.is_alive():
                log.warning("Zenoh's session did not close within %g s (a peer that stopped reading?); "
                            "not waiting for it (limits.ZENOH_CLOSE_SECONDS)", limits.ZENOH_CLOSE_SECONDS)

    @staticmethod
    def _close_session(session: zenoh.Session) -> None:
        try:
            session.close()
        except Exception as exc:  # closing must not mask the reason we stop
            log.debug("closing Zenoh session: %s", exc)

    # ------------------------------------------ what the loop calls (FrontDoor, ReadyDoor)
    blocking = staticmethod(Sessions.head_is_blocking)  # its next request is paced (ReadyDoor)

    def serve_ready(self, ready: Session, step: int | None) -> None:
        """Serve a ready session's next request (``step``: the step its blocking call sees)."""
        request = self.sessions.take(ready)
        if request is not None:
            if self.sessions.evicted:  # their folders go before a newcomer's files count (MAX_FILE_HOLDERS)
                self.housekeeping(0.0)
            if step is not None:
                ready.step = step  # legacy pacing: the step its blocking call saw
            self._answer(ready, request[0], request[1])

    def handle(self, kind: str, item: Any) -> None:
        if kind == "gone":
            self._forget(item, "left")
        elif kind == "viewer-model":  # item is the query here
            self.viewers.answer(item, self.sim.world)

    def publish(self) -> None:
        self._publish_streams()

    def keeps(self, client: Any) -> bool:
        """A client whose liveliness token protects it, or whose requests wait, does not expire."""
        return self.sessions.pinned(client.id)

    def forget(self, client: Any, how: str) -> None:
        self._forget(client.id, how)

    def housekeeping(self, now: float) -> None:
        """Forget the clients the intake dropped to make room for another (limits.MAX_CLIENTS,
        limits.MAX_CLIENTS_PER_USER): the oldest without a liveliness token or a request waiting."""
        for client in self.sessions.take_evicted():
            self._forget(client, "evicted to make room for another client (limits.MAX_CLIENTS or "
                                 "MAX_CLIENTS_PER_USER): it held no liveliness token and had no request waiting")

    def watched(self) -> bool:
        return bool(len(self.sessions) or self.viewers.watched)

    def _join(self, client: str) -> LegacyClient:
        """The registry entry of ``client``, made at its first request (logged)."""
        entry = self._registry.get(client)
        if entry is None:
            entry = LegacyClient(client, self, time.monotonic(), self.loop.client_expiry)
            self.loop.clients.add(entry)
            log.info("client %s connected", client)
        return entry

    # ------------------------------------------------------------ requests
    def _answer(self, session: Session, query: zenoh.Query, commands: list) -> None:
        """Execute a request and hand its reply to the sending thread (sent once its images
        are rendered, after the client's earlier replies and stream updates). Every request
        gets a reply, whatever happens (then a short refusal)."""
        client = session.client
        try:
            entry = self._registry.get(client)
            if entry is None:
                entry = self._join(client)
            entry.last_seen = session.last_seen  # when its intake took its last request (Zenoh's thread)
            if entry.fault is None:
                results = self._run(client, commands)
                if session.secret is not None:
                    tell_secret(commands, results, session.secret)
            else:  # a failed step since this client's last request: told instead of executed
                message, entry.fault = entry.fault, None
                self._keep_error(client, message)
                results = [[False, message]] * len(commands)
            t, state, scene = self.sim.stamp()
            server_time = int((time.monotonic() - self.loop.started) * 1000)
            renders = [value.future for _, value in results if type(value) is Deferred]
            bulk = renders and sum(image_size(self.sim, name, args) for (name, _, args), (_, value)
                                   in zip(commands, results) if type(value) is Deferred) >= limits.BULK_SEND_BYTES
            if renders:  # encoded by the sending thread once rendered: one such reply in memory at a time
                in_place = False

                def payload() -> bytes:
                    return self._response(t, state, self._resolve(results, client), server_time, scene, client,
                                          large=True)
            else:  # encoded now: the values are this step's
                encoded = self._response(t, state, results, server_time, scene, client)
                # Served in place, with nothing of its client on its way: sent by the thread
                # that read the request, once the simulation is let go (Loop.serve_or_deliver).
                in_place = (len(encoded) <= limits.IN_PLACE_REPLY_BYTES and not session.unsent
                            and not self._streams.get(client))

                def payload() -> bytes:
                    return encoded
        except Exception as exc:  # the server never dies from a client
            log.exception("client %s: answering a request", client)
            refusal = P.error_response(f"internal error while answering the request: {type(exc).__name__}")
            renders, bulk, in_place = [], False, False

            def payload() -> bytes:
                return refusal
        self._reply(session, query, payload, renders, bulk, in_place)

    def _schedule(self, session: Session) -> None:
        """Zenoh's thread: a client with nothing waiting has a request. A blocking call (its
        client waits for the reply) is served in place when it can be (Loop.serve_or_deliver),
        unless it loads or edits the scene (which would hold Zenoh's thread as long as it
        takes); anything else goes to the ready ring: a oneshot or streaming flood is served
        round robin by the simulation thread, not by Zenoh's threads in parallel, where it
        would take the interpreter from every other client's calls."""
        name = Sessions.blocking_head(session)
        if (name is not None and name not in NOT_STREAMABLE) or Sessions.carried_trigger(session):
            self.loop.serve_or_deliver(session)
        else:
            self.loop.ring.put(session)

    def _reply(self, session: Session, query: zenoh.Query, payload, renders: list, bulk: bool = False,
               in_place: bool = False) -> None:
        """Hand ``query``'s reply (``payload()``, called on the sending thread) to the courier
        on its client's lane: sent once ``renders`` are done, in order with its stream updates
        (``bulk``: images of limits.BULK_SEND_BYTES or more, see loop.courier). ``in_place``,
        while the request is served in place: sent by the serving thread instead."""
        client = session.client
        stepping, self._trigger_reply = self._trigger_reply, None  # a trigger's step waits for it
        if self._hand_held(client):  # its step's stream update leaves right ahead (StreamPublisher)
            in_place = False

        def send() -> None:
            try:
                answer(query, payload())
            finally:
                self.sessions.sent(session)
                if stepping is not None:
                    stepping.set()

        self.sessions.handed_over(session)
        sends = self.loop.in_place
        if in_place and sends is not None:
            sends.append(send)
        else:
            self.courier.send(client, send, renders, bulk)

    _response = staticmethod(encode_response)

    def _run(self, client: str, commands: list) -> list:
        """Each command's ``[ok, value]``; commands past the reply budget (limits.MAX_REPLY_BYTES)
        or the request's time budget (limits.MAX_REQUEST_SECONDS), and scene loads and edits past
        the client's share (limits.EDIT_SHARE), get an error result instead of their value. Any
        other command that reached the scene's editor (``Editor.edits``: a script function that
        edits) is charged to that share as an edit too.

        The commands run in order, as V-REP's server ran a message's (simExtRemoteApi
        ``CSimxSocket::_executeCommands``): a command after a ``simxTransferFile`` of the same
        message (written off this thread) runs once that file is written, so that a
        ``simxLoadScene`` sent with it finds it (the wait is for this client's own writes, at most
        limits.MAX_UNWRITTEN_BYTES)."""
        execute, budget, editor = self._execute, limits.MAX_REPLY_BYTES, self.sim.editor
        results = []
        writing = False  # a transfer of this message is being written
        # The thread's own time (CPU): on a loaded machine a descheduled thread is not busy, and
        # a Ray env runner's batch of five reads was cut after 0.5 s of wall time. Waiting (for
        # renders, in scripts) counts past MAX_REQUEST_WALL_SECONDS.
        cpu, wall = time.thread_time(), time.monotonic()
        for name, mode, args in commands:
            if writing:
                self.sim.editor.files.settle(f"legacy:{client}", wait=True)
                writing = False
            if name in IMAGES and budget < image_size(self.sim, name, args):
                results.append(self._over_budget(client, name))
                continue
            if (time.thread_time() - cpu > limits.MAX_REQUEST_SECONDS
                    or time.monotonic() - wall > limits.MAX_REQUEST_WALL_SECONDS):
                results.append(self._refused(client, name, f"not executed: the request took its {limits.MAX_REQUEST_SECONDS:g} "
                                             "s of the simulation thread (limits.MAX_REQUEST_SECONDS; "
                                             f"{limits.MAX_REQUEST_WALL_SECONDS:g} s of wall time, "
                                             "limits.MAX_REQUEST_WALL_SECONDS); send the rest in another request"))
                continue
            if name in NOT_STREAMABLE:
                result = self._edit(client, name, mode, args)
                if type(result[1]) is Deferred:  # a load or transfer done off this thread
                    self._keep_later(client, name, result[1])
                    writing = name == "TransferFile"
                results.append(result)
                continue
            edits, began = editor.edits, time.monotonic()
            result = execute(client, name, mode, args)
            if editor.edits != edits:  # it reached the editor (a script's function that edits...): an edit
                done = time.monotonic()
                self._join(client).share.add(done - began, done)
            value = result[1]
            t = type(value)
            if t is Deferred:
                budget -= image_size(self.sim, name, args)
            elif t not in SMALL:
                budget -= reply_size(value)
                if budget < 0:
                    budget += reply_size(value)
                    result = self._over_budget(client, name)
            results.append(result)
        return results

    def _over_budget(self, client: str, name: str) -> list:
        return self._refused(client, name, f"not executed, the reply would exceed {limits.MAX_REPLY_BYTES} bytes "
                                           "(limits.MAX_REPLY_BYTES); ask for less in one request")

    def _refused(self, client: str, name: str, why: str) -> list:
        message = f"simx{name}: {why}"
        log.warning("client %s: %s", client, message)
        self._keep_error(client, message)
        return [False, message]

    def _edit(self, client: str, name: str, mode: int, args: list) -> list:
        """A scene load or edit, within the client's share of the simulation thread: each costs
        its duration, the debt falls by limits.EDIT_SHARE s per s (loop.budgets.Share); past the
        share the call is refused (``BUSY``)."""
        now = time.monotonic()
        share = self._join(client).share
        if share.over(now):
            return self._refused(client, name, f"{P.BUSY}: this client's scene loads and edits took more than "
                                               f"{limits.EDIT_SHARE:.0%} of the simulation thread "
                                               "(limits.EDIT_SHARE); try again later")
        result = self._execute(client, name, mode, args)
        done = time.monotonic()
        share.add(done - now, done)
        return result

    _resolve = staticmethod(resolve)  # results with their Deferred images rendered (sending or render thread)

    def _execute(self, client: str, name: str, mode: int, args: list) -> list:
        base = mode & P.MODE_MASK
        try:
            streams = self._streams.get(client)
            if base == P.MODE_DISCONTINUE:
                if streams:
                    streams.pop(P.identity(name, args), None)
                return [True, None]
            handler = HANDLERS.get(name)
            if handler is None:  # a command about the calling client, or none at all
                if name not in self._CLIENT_COMMANDS:
                    raise P.UnsupportedError(f"unknown command {quote(name)}")
                own = self._CLIENT_COMMANDS[name]
                return [True, getattr(self, own)(client, args) if own else self.consoles.execute(name, client, args)]
            if base in _STREAMING:
                if name in NOT_STREAMABLE:
                    raise P.ArgumentError(f"simx{name} cannot be streamed: only reads and settings stream "
                                          "(scene loads, edits and file transfers run once: use simx_opmode_oneshot "
                                          "or simx_opmode_blocking)")
                streams = self._streams.setdefault(client, {})
                ident = P.identity(name, args)
                delay = mode & P.MODE_ARG_MASK if base == P.MODE_STREAMING else 0
                stream = streams.get(ident)
                if stream is not None:  # V-REP: the newest request of a command replaces its stream
                    stream.renew(args, delay)
                else:
                    if len(streams) >= limits.MAX_STREAMS_PER_CLIENT:
                        raise P.ArgumentError(f"too many streams: at most {limits.MAX_STREAMS_PER_CLIENT} "
                                              "per client (limits.MAX_STREAMS_PER_CLIENT); discontinue some")
                    streams[ident] = _Stream(name, args, delay)
            elif streams and name not in P.DO_NOT_OVERWRITE:
                streams.pop(P.identity(name, args), None)  # a new non-streamed call replaces the stream
            with self.sim.editor.files.acting(f"legacy:{client}"):  # its file calls use its own folder
                return [True, answered(self.sim, lambda: handler(self.sim, args))]  # a mesh's tree built meanwhile
        except P.RemoteError as exc:
            label = name if name in P.COMMANDS else quote(name)
            message = _cut(f"simx{label}: {exc}")
            log.warning("client %s: simx%s failed: %s", client, label, message[len(label) + 6:])
        except Exception as exc:
            label = name if name in P.COMMANDS else quote(name)
            message = _cut(f"internal error in simx{label}: {type(exc).__name__}: {exc}")
            log.error("client %s: simx%s raised: %s", client, label, message,
                      exc_info=not isinstance(exc, RecursionError))
        self._keep_error(client, message)
        return [False, message]

    def _keep_later(self, client: str, name: str, deferred: Deferred) -> None:
        """A load's or transfer's error off the simulation thread: kept and logged as any."""
        errors = self._join(client).errors

        def done(future: Any) -> None:
            exc = future.exception()
            if isinstance(exc, P.RemoteError):
                message = _cut(f"simx{name}: {exc}")
                log.warning("client %s: simx%s failed: %s", client, name, message[len(name) + 6:])
                errors.append(message)  # (one list operation at a time: no lock needed)
                del errors[:-limits.MAX_ERRORS_KEPT]

        deferred.future.add_done_callback(done)

    def _keep_error(self, client: str, message: str) -> None:
        errors = self._join(client).errors
        errors.append(message)
        del errors[:-limits.MAX_ERRORS_KEPT]

    # Commands about the calling client rather than the world.
    _CLIENT_COMMANDS = {
        "Bye": "_bye", "Synchronous": "_synchronous", "SynchronousTrigger": "_trigger",
        "GetLastErrors": "_last_errors", **{name: None for name in CONSOLE_COMMANDS},
    }
