"""One :class:`Connection` per ``simxStart``: a Zenoh session to one server, the legacy inbox
and outbox, streams and pause-communication batching.

Legacy semantics (reference/opmode_semantics.md): every mode except ``buffer`` and ``remove``
sends its command; ``blocking`` waits for the fresh reply and consumes it; the others answer
from the inbox (the newest reply of the same command, read before the command is sent, so
never the reply to the call itself), or "no value" (flag 1). Replies of
non-blocking commands and every streamed update land in the inbox, where they stay until
read by a blocking call, removed, discontinued or the connection ends.

Non-blocking commands wait in the outbox (:mod:`simx_client.outbox`), as in the legacy client:
a thread of the connection sends what waits as one request once per communication cycle
(``simxStart``'s ``commThreadCycleInMs``), one such request in flight at a time, never while
communication is paused; a blocking call sends what waits right ahead of itself. A request the
server answers "busy" goes back to the outbox and is sent again.

The server's liveliness token tells whether it is there (a killed server's token goes at once,
a frozen one's when its Zenoh lease expires). When it goes the connection is lost, as the
legacy client's socket was (extApi.c ``_communicationThread``): the connection id turns -1 and
the inbox and the outbox are cleared, so ``buffer`` reads answer "no value" (1) rather than the
last value, and every call fails with the legacy codes (blocking: 3, at once; others: 1)
without sending anything. When the server comes back, a client that may reconnect
(``doNotReconnectOnceDisconnected`` false) handshakes again, sends every stream again and gets a
new connection id; one that may not stays disconnected: its Zenoh session is closed.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from typing import Any

import zenoh

from simx_wire import constants as C
from simx_wire import proof as PR
from simx_wire import protocol as P
from simx_client.client_config import CONFIG_ENV, PREFIX_ENV, client_config, config_in_play  # noqa: F401 (re-exported)
from simx_client.outbox import MAX_BATCH_COMMANDS
from simx_client.identity import USER_ENV, answer_peer_check, client_id  # noqa: F401 (re-exported)
from simx_client.refusal import open_session, unanswered_handshake
from simx_client.sender import DEFAULT_CYCLE, OutboxSender, direct

log = logging.getLogger("simx.client")

DEFAULT_BLOCKING_TIMEOUT = 5.0  # s, _REPLY_WAIT_TIMEOUT_IN_MS
STREAM_BACKLOG = 4096  # stream updates kept unread; beyond, the oldest are dropped
_NO_VALUE = (C.simx_return_novalue_flag, None)
_TIMED_OUT = (C.simx_return_timeout_flag | C.simx_return_novalue_flag, None)  # blocking, no reply
_REQUEST_FRAMING = 4096  # a request's bytes besides its commands' (version, client id, arrays)
_RESUME_PAUSE = 0.2  # s between two handshakes of a client that reconnects
_NO_RESPONSE = [P.PROTOCOL_VERSION, 0, 0, 0, 0, []]  # "the last response" before there is one
_connection_ids = itertools.count(1)
_STREAMING = (P.MODE_STREAMING, P.MODE_STREAMING_SPLIT)
_SPLIT = (P.MODE_ONESHOT_SPLIT, P.MODE_STREAMING_SPLIT)


_direct = direct


class Connection(OutboxSender):
    """A connected legacy client.

    Args:
        address, port: where the server listens (``simxStart``'s first two arguments).
        blocking_timeout: s a blocking call waits for its reply.
        prefix: the server's key-expression prefix.
        hello_timeout: s to wait for the server's handshake (default: blocking_timeout).
        reconnect: whether to resume after the server went away (``not doNotReconnectOnceDisconnected``).
        cycle: s between two requests of the outbox (``commThreadCycleInMs`` / 1000); 0 sends
            each as soon as the previous one is answered.

    Raises:
        zenoh.ZError: nothing listens at ``address:port``.
        RefusedError: a server listens there and refused the session (TLS, authentication).
        TimeoutError: the peer does not answer as a simx server in time.
        ProtocolError: the server speaks another protocol version.
        LocalError: the client's Zenoh config file or user name is unusable (:func:`client_config`).
    """

    def __init__(self, address: str, port: int, blocking_timeout: float = DEFAULT_BLOCKING_TIMEOUT,
                 prefix: str = P.DEFAULT_PREFIX, hello_timeout: float | None = None, reconnect: bool = False,
                 cycle: float = DEFAULT_CYCLE):
        self.address, self.port, self.prefix = address, port, prefix
        config = client_config(address, port)  # raises LocalError
        self.client = client_id(config)
        self.blocking_timeout = blocking_timeout
        self.reconnect = reconnect
        self.last_cmd_time = 0  # ms, simxGetLastCmdTime
        self.connection_id = next(_connection_ids)
        self._alive = True  # the server's token is seen and the handshake done
        self._epoch = 0  # times the server went away: a reconnection attempt ends when it changes
        self._resuming = False
        self._lock = threading.Lock()
        self._inbox: dict[tuple, tuple[bool, Any, int]] = {}
        self._streams: dict[tuple, list] = {}  # identity -> the [name, mode, args] that streams it
        self._in_flight: dict[tuple, int] = {}  # split commands sent and not answered yet
        self._init_sender(cycle)  # the outbox, its lock and its thread's state
        self.converted: dict[tuple, tuple[Any, Any]] = {}  # the facade's last conversion per command
        self._key = P.call_key(prefix, self.client)
        self._encoder = P.RequestEncoder(self.client)
        self._messages = itertools.count(1)  # also the sequence numbers of the requests' proofs
        self._secret: bytes | None = None  # the server's for this client id (simx_wire.proof), from Hello
        self._rebinding = threading.Lock()
        self._t0 = time.monotonic()
        self._out = (0, 0.0)  # (message id, client time) of the last request
        self._in: tuple[tuple[int, float], list] = ((0, 0.0), _NO_RESPONSE)  # its header and the last reply
        self.session = open_session(config, config_in_play())  # RefusedError: a server refused it
        try:
            # A declared querier: the key expression is resolved once, not at every call.
            self._querier = self.session.declare_querier(self._key, timeout=blocking_timeout)
            # Stream updates wait in a channel and are filed when the inbox is read: they then
            # always include every update that arrived before the reply a caller just got.
            self._subscriber = self.session.declare_subscriber(
                P.stream_key(prefix, self.client), zenoh.handlers.RingChannel(STREAM_BACKLOG))
            self.server_info = self._hello(hello_timeout)  # before the token: nobody knows the id yet
            # Answers the server's question "which session holds this id?" (one empty reply):
            # Zenoh stamps the reply with this session's id, so the server can bound ids per session.
            self._peer = self.session.declare_queryable(
                P.peer_key(prefix, self.client), _direct(answer_peer_check))
            self._token = self.session.liveliness().declare_token(P.client_token_key(prefix, self.client))
            self._watch = self.session.liveliness().declare_subscriber(
                P.server_token_key(prefix), _direct(self._on_server_token), history=True)
            self._start_sender()
        except TimeoutError:
            refused = unanswered_handshake(self.session, prefix, self.client, address, port)
            self.session.close()
            if refused is not None:
                raise refused from None
            raise
        except BaseException:
            self.session.close()
            raise

    # --------------------------------------------------------------- transport
    def _hello(self, timeout: float | None = None) -> Any:
        """The handshake: the server's ``Hello`` result, whose ``"secret"`` proves this client's
        later requests (simx_wire.proof). Sent without a proof: the server binds the id anew."""
        info = self._request([["Hello", P.MODE_BLOCKING, []]], timeout, False, prove=False)[0][1]
        if type(info) is dict and type(info.get("secret")) is bytes:
            self._secret = info.pop("secret")  # other threads' requests meanwhile used the old one
        return info

    def _handshake(self) -> Any:
        """A handshake again (the server came back): proven when this client has a secret, so
        that a server that still knows it answers; one that forgot it (a restart) makes
        :meth:`request` handshake anew (:meth:`_rebind`). The ``Hello`` result, its secret kept."""
        if self._secret is None:
            return self._hello()
        info = self.request([["Hello", P.MODE_BLOCKING, []]])[0][1]
        if type(info) is dict and type(info.get("secret")) is bytes:
            self._secret = info.pop("secret")
        return info

    def _rebind(self, secret: bytes | None) -> None:
        """The server forgot this client (proof.UNKNOWN): handshake again, once for all the
        requests that were refused with ``secret``."""
        with self._rebinding:
            if self._secret is secret and secret is not None:
                self._hello()

    def _seal(self, payload: bytes, header: tuple[int, float]) -> bytes | None:
        """The attachment that proves request ``header[0]`` is this client's (None before its Hello)."""
        secret = self._secret
        return None if secret is None else PR.seal(secret, header[0], payload)

    def _encode(self, commands: list[list]) -> bytes:
        """The request carrying ``commands``; LocalError for arguments msgpack cannot carry
        (an int beyond 64 bits, a lone surrogate in a str, nesting beyond msgpack's limit)."""
        try:
            return self._encoder.encode(commands)
        except (TypeError, ValueError, OverflowError) as exc:  # UnicodeEncodeError is a ValueError
            raise P.LocalError(f"arguments that cannot be sent: {type(exc).__name__}: {exc}") from exc

    def _payload(self, commands: list[list], payload: bytes | None = None) -> tuple[bytes, tuple[int, float]]:
        if payload is None:  # the blocking path: encoded here, without _encode's extra call
            try:
                payload = self._encoder.encode(commands)
            except (TypeError, ValueError, OverflowError):
                payload = self._encode(commands)  # raises the LocalError
        if len(payload) > P.MAX_REQUEST_BYTES:
            raise P.LocalError(f"a request of {len(payload):,} bytes cannot be sent: the server takes at most "
                               f"{P.MAX_REQUEST_BYTES:,} (protocol.MAX_REQUEST_BYTES)")
        header = self._out = (next(self._messages), time.monotonic())
        return payload, header

    def request(self, commands: list[list], timeout: float | None = None, flush: bool = False,
                rebind: bool = True) -> list[list]:
        """Send commands and wait for their results ``[[ok, value], ...]``; with ``flush``, what
        waits in the outbox leaves first, right ahead of them (unless communication is paused).
        A server that forgot this client (its state expired) is handshaken again and the
        commands sent once more (unless ``rebind`` is false).

        Raises:
            TimeoutError: no reply within the timeout (the server is gone or too slow).
            ProtocolError: the server refused the request.
            LocalError: arguments that cannot be encoded (nothing was sent).

        Args:
            commands: ``[name, mode, args]`` lists.
            timeout: s; None: the connection's blocking timeout.
            flush: send the outbox first.
            rebind: handshake again when the server forgot this client.

        Returns:
            One ``[ok, value]`` per command.
        """
        secret = self._secret
        try:
            return self._request(commands, timeout, flush)
        except P.ProtocolError as exc:
            if not rebind or PR.UNKNOWN not in str(exc):
                raise
        self._rebind(secret)
        return self._request(commands, timeout, flush)

    def _request(self, commands: list[list], timeout: float | None, flush: bool, prove: bool = True) -> list[list]:
        carried, epoch = None, self._epoch
        with self._send_lock:
            if flush and self._outbox and not self._paused:
                carried = self._carry(commands)  # a trigger takes the outbox along (OutboxSender._carry)
                if carried is None:
                    self._send_outbox(background=False)
            try:
                if carried is None:
                    payload, header = self._payload(commands)
                else:  # the outbox's commands first, as their own request would have run them
                    packed = carried.packed + [P.pack(command) for command in commands]
                    payload, header = self._payload(carried.commands + commands, self._encoder.encode_packed(packed))
                attachment = self._seal(payload, header) if prove else None
                if timeout is None:
                    replies = self._querier.get(payload=payload, attachment=attachment)
                else:
                    replies = self.session.get(self._key, payload=payload, timeout=timeout, attachment=attachment)
            except BaseException:
                if carried is not None:  # not sent: the batch is over, as an asynchronous send that failed
                    self._carried(carried, None, epoch)
                raise
        message = None
        try:
            for reply in replies:
                ok = reply.ok
                if ok is not None:
                    message = self._accept(ok.payload.to_bytes(), header)
                    self.last_cmd_time = message[1]
                    break
        finally:
            results = None if carried is None else self._carried(carried, message, epoch)
        if message is None:
            raise TimeoutError(f"no reply from the simx server at {self.address}:{self.port}")
        return message[5] if results is None else results

    def _accept(self, payload: bytes, header: tuple[int, float]) -> list:
        """Decode a response (raises ProtocolError) and keep it for the message-info calls."""
        message = P.unpack_response(payload)
        self._in = (header, message)
        return message

    def _store(self, ident: tuple, ok: bool, value: Any, t: int) -> None:
        """Put a reply in the inbox (lock held): the newest replaces, string streams add up."""
        old = self._inbox.get(ident)
        if ident[0] in P.ACCUMULATE and ok and old is not None and old[0]:
            value = old[1] + value
        self._inbox[ident] = (ok, value, t)

    def _drain_streams(self) -> None:
        """File every stream update received so far (lock held); none while disconnected."""
        if not self._alive:
            return
        while (sample := self._subscriber.try_recv()) is not None:
            try:
                t, entries = P.unpack_stream_update(sample.payload.to_bytes())
            except P.ProtocolError as exc:
                log.warning("unreadable stream update: %s", exc)
                continue
            for name, id_args, ok, value in entries:
                ident = (name, *(P._hashable(a) for a in id_args))
                if ident in self._streams:
                    self._store(ident, ok, value, t)

    def _discard_streams(self) -> None:
        """Empty the stream channel unread (lock held, session open)."""
        try:
            while self._subscriber.try_recv() is not None:
                pass
        except zenoh.ZError:  # the session is being closed
            pass

    def _on_server_token(self, sample: zenoh.Sample) -> None:
        """Zenoh thread: the server's liveliness token came (PUT) or went (DELETE)."""
        if sample.kind == zenoh.SampleKind.DELETE:
            with self._lock:
                if self._alive:
                    log.warning("simx server at %s:%d went away%s", self.address, self.port,
                                "" if self.reconnect else "; this client does not reconnect")
                self._alive = False
                self._epoch += 1
                # What the legacy client did on disconnection: nothing received before is
                # handed out as fresh, nothing queued is sent to a later server.
                self._inbox.clear()
                self._outbox.clear()
                self.converted.clear()
                self._in = ((0, 0.0), _NO_RESPONSE)
                self._discard_streams()
                if self.reconnect:
                    return
                self._streams.clear()
                session = self.__dict__.pop("session", None)
            if session is not None:  # closed off this Zenoh thread, which must not block
                threading.Thread(target=session.close, daemon=True).start()
        elif self.reconnect:
            with self._lock:
                if self._alive or self._resuming or "session" not in self.__dict__:
                    return
                self._resuming = True
                epoch = self._epoch
            threading.Thread(target=self._resume, args=(epoch,), daemon=True).start()

    def _resume(self, epoch: int) -> None:
        """The server is back: handshake again (retried until it answers, goes away again or
        this connection closes) and restart every stream."""
        try:
            while True:
                try:
                    info = self._handshake()
                    break
                except (TimeoutError, zenoh.ZError) as exc:
                    log.info("reconnecting to %s:%d: %s", self.address, self.port, exc)
                except P.ProtocolError as exc:
                    log.error("reconnecting to %s:%d failed: %s", self.address, self.port, exc)
                    return
                time.sleep(_RESUME_PAUSE)
                if epoch != self._epoch or "session" not in self.__dict__:
                    return
            with self._lock:
                if epoch != self._epoch or "session" not in self.__dict__:
                    return  # it went away again meanwhile
                self.server_info = info
                self._discard_streams()  # sent to the lost connection (the server forgot its streams)
                streams = list(self._streams.values())
                self.connection_id = next(_connection_ids)
                self._alive = True
        except AttributeError:  # closed meanwhile (no session, querier or subscriber left)
            return
        finally:
            self._resuming = False
        if streams:
            self._send_async(streams)
        log.info("reconnected to the simx server at %s:%d", self.address, self.port)

    # ------------------------------------------------------------ legacy modes
    def call(self, name: str, args: list, mode: int) -> tuple[int, Any]:
        """Execute one command with a legacy operation mode; returns ``(return code, value)``.

        ``value`` is the command's result when the code is 0, the server's error message when
        it is 8, the reason when it is 32 (arguments that cannot be encoded), and None otherwise.

        Args:
            name: the command (``"GetJointPosition"`` ...).
            args: its arguments, plain Python values.
            mode: ``simx_opmode_*``, with its wait argument in the high 16 bits.

        Returns:
            ``(returnCode, value)``.
        """
        base = mode & P.MODE_MASK
        if base == P.MODE_BLOCKING:
            if not self._alive:  # lost: the legacy client timed out, with an empty inbox
                return _TIMED_OUT
            if self._streams or self._inbox:  # forget this command's stream and stored reply
                ident = P.identity(name, args)
                with self._lock:
                    self._streams.pop(ident, None)
                    self._inbox.pop(ident, None)
            try:
                ok, value = self.request([[name, mode, args]], flush=True)[0]
            except (TimeoutError, zenoh.ZError):
                return _TIMED_OUT
            except P.LocalError as exc:
                return C.simx_return_local_error_flag, str(exc)
            except (P.ProtocolError, ValueError, TypeError, IndexError) as exc:  # refused or misshapen
                log.warning("simx%s: %s", name, exc)
                return C.simx_return_remote_error_flag, str(exc)
            return (C.simx_return_ok, value) if ok else (C.simx_return_remote_error_flag, value)
        ident = P.identity(name, args)
        if base == P.MODE_BUFFER:
            return self._read(ident)
        if base == P.MODE_REMOVE:  # 0 when a reply was removed, else 1 (legacy)
            with self._lock:
                removed = self._inbox.pop(ident, None)
            return (C.simx_return_ok if removed is not None else C.simx_return_novalue_flag), None
        if base not in (P.MODE_ONESHOT, P.MODE_DISCONTINUE, *_STREAMING, *_SPLIT):
            return C.simx_return_illegal_opmode_flag, None
        command = [name, mode, args]
        try:  # packed before it is kept as a stream or in the outbox: what is kept can be sent
            packed = P.pack(command)
        except (TypeError, ValueError, OverflowError) as exc:  # UnicodeEncodeError is a ValueError
            return C.simx_return_local_error_flag, f"arguments that cannot be sent: {type(exc).__name__}: {exc}"
        if len(packed) > P.MAX_REQUEST_BYTES - _REQUEST_FRAMING:
            return C.simx_return_local_error_flag, (f"a command of {len(packed):,} bytes cannot be sent: the server "
                                                    f"takes requests of at most {P.MAX_REQUEST_BYTES:,} bytes")
        with self._lock:
            if base in _SPLIT and (ident in self._in_flight or ident in self._outbox):
                rc, value = self._read_locked(ident)
                return rc | C.simx_return_split_progress_flag, value
            if base in _STREAMING:
                self._streams[ident] = command
            else:
                self._streams.pop(ident, None)
            if base == P.MODE_DISCONTINUE:
                self._inbox.pop(ident, None)
            if not self._alive:  # nothing is sent; a stream is sent again on reconnection
                return _NO_VALUE
            # The answer is the reply already in the inbox, read before sending, as the legacy
            # client read it before its communication thread sent the command: never the reply
            # to this very call, however fast it comes back.
            answer = self._read_locked(ident)
            self._outbox.put(ident, command, packed)  # an overwritten command moves to the end
            if len(self._outbox) == 1:
                self._wake.notify()
        return answer

    def _read(self, ident: tuple) -> tuple[int, Any]:
        with self._lock:
            return self._read_locked(ident)

    def _read_locked(self, ident: tuple) -> tuple[int, Any]:
        self._drain_streams()
        entry = self._inbox.get(ident)
        if entry is None:
            return _NO_VALUE
        ok, value, t = entry
        if ident[0] in P.ACCUMULATE:
            del self._inbox[ident]  # a string stream's data is handed out once
        self.last_cmd_time = t
        return (C.simx_return_ok, value) if ok else (C.simx_return_remote_error_flag, value)

    def pause_communication(self, enable: bool) -> None:
        """``simxPauseCommunication``: hold the outbox (True), then let it leave (False): what
        waits leaves together, at the next cycle or with the next blocking call.

        Args:
            enable: hold (True) or release (False).
        """
        with self._lock:
            self._paused = bool(enable)
            if not self._paused and self._outbox:
                self._wake.notify()

    def in_message_info(self, info_type: int) -> int | None:
        """A field of the last message received (simx_headeroffset_*), None if unknown or
        disconnected (the legacy inbox, header included, is cleared on disconnection).

        Implements ``simxGetInMessageInfo``.

        Args:
            info_type: a ``simx_headeroffset_*`` value.

        Returns:
            The field, or None.
        """
        if not self._alive:
            return None
        header, message = self._in
        _, _, state, server_time, scene, _ = message
        fields = {C.simx_headeroffset_server_time: server_time,
                  C.simx_headeroffset_scene_id: scene,
                  C.simx_headeroffset_server_state: state}
        return self._header(header, info_type, fields)

    def out_message_info(self, info_type: int) -> int | None:
        """A field of the last message sent (simx_headeroffset_*), None if unknown.

        Implements ``simxGetOutMessageInfo``.

        Args:
            info_type: a ``simx_headeroffset_*`` value.

        Returns:
            The field, or None.
        """
        return self._header(self._out, info_type, {})

    def _header(self, header: tuple[int, float], info_type: int, fields: dict) -> int | None:
        message_id, sent = header
        fields[C.simx_headeroffset_message_id] = message_id
        fields[C.simx_headeroffset_client_time] = int((sent - self._t0) * 1000) if message_id else 0
        fields[C.simx_headeroffset_version] = C.SIMX_VERSION
        fields[C.simx_headeroffset_crc] = 0  # no CRC: Zenoh's transport checks integrity
        return fields.get(info_type)

    def close(self) -> None:
        """Send what is held, say goodbye and close the session; idempotent, never hangs."""
        session = self.__dict__.pop("session", None)
        if session is None:
            return
        with self._send_lock, self._lock:  # after whatever the sender thread is sending
            self._closed, self._paused = True, False
            self._wake.notify_all()
            parts = [batch.packed for batch in self._outbox.take()] or [[]]
        if len(parts[-1]) >= MAX_BATCH_COMMANDS:
            parts.append([])
        parts[-1] = parts[-1] + [P.pack(["Bye", P.MODE_ONESHOT, []])]
        try:
            for packed in parts:
                payload = self._encoder.encode_packed(packed)
                session.get(self._key, _direct(lambda reply: None), payload=payload, timeout=0.5,
                            attachment=self._seal(payload, (next(self._messages), 0.0)))
        except zenoh.ZError:
            pass
        closer = threading.Thread(target=session.close, daemon=True)
        closer.start()
        closer.join(timeout=2.0)

    @property
    def connected(self) -> bool:
        """Whether the session is open and the server's liveliness token is seen."""
        return "session" in self.__dict__ and self._alive and not self.session.is_closed()
