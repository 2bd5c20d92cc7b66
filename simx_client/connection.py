"""One :class:`Connection` per ``simxStart``: a Zenoh session to one server, the legacy inbox
and outbox, streams and pause-communication batching.

Legacy semantics (reference/opmode_semantics.md): every mode except ``buffer`` and ``remove``
sends its command; ``blocking`` waits for the fresh reply and consumes it; the others answer
from the inbox (the newest reply of the same command), or "no value" (flag 1). Replies of
non-blocking commands and every streamed update land in the inbox, where they stay until
read by a blocking call, removed, discontinued or the connection ends.
"""

from __future__ import annotations

import json
import logging
import threading
import time
import uuid
from typing import Any

import zenoh

from simx_client import constants as C
from simx_client import protocol as P

log = logging.getLogger("simx.client")

DEFAULT_BLOCKING_TIMEOUT = 5.0  # s, _REPLY_WAIT_TIMEOUT_IN_MS
_NO_VALUE = (C.simx_return_novalue_flag, None)


def client_config(address: str, port: int) -> zenoh.Config:
    """Zenoh config of a client: client mode, one TCP endpoint, multicast scouting off."""
    config = zenoh.Config()
    config.insert_json5("mode", '"client"')
    config.insert_json5("connect/endpoints", json.dumps([f"tcp/{address}:{port}"]))
    config.insert_json5("scouting/multicast/enabled", "false")
    return config


class Connection:
    """A connected legacy client.

    Args:
        address, port: where the server listens (``simxStart``'s first two arguments).
        blocking_timeout: s a blocking call waits for its reply.
        hello_timeout: s to wait for the server's handshake (default: blocking_timeout).
        prefix: the server's key-expression prefix.

    Raises:
        zenoh.ZError: nothing listens at ``address:port``.
        ConnectionError: the peer does not answer as a simx server within ``blocking_timeout``.
        ProtocolError: the server speaks another protocol version.
    """

    def __init__(self, address: str, port: int, blocking_timeout: float = DEFAULT_BLOCKING_TIMEOUT,
                 prefix: str = P.DEFAULT_PREFIX, hello_timeout: float | None = None):
        self.address, self.port, self.prefix = address, port, prefix
        self.client = uuid.uuid4().hex
        self.blocking_timeout = blocking_timeout
        self.last_cmd_time = 0  # ms, simxGetLastCmdTime
        self.server_state = 0
        self._lock = threading.Lock()
        self._inbox: dict[tuple, tuple[bool, Any, int]] = {}
        self._streams: set[tuple] = set()
        self._outbox: dict[Any, list] = {}
        self._paused = False
        self._key = P.call_key(prefix)
        self.session = zenoh.open(client_config(address, port))
        try:
            self._subscriber = self.session.declare_subscriber(
                P.stream_key(prefix, self.client), self._on_stream)
            self.server_info = self.request([["Hello", P.MODE_BLOCKING, []]], hello_timeout)[0][1]
            self._token = self.session.liveliness().declare_token(P.client_token_key(prefix, self.client))
        except BaseException:
            self.session.close()
            raise

    # --------------------------------------------------------------- transport
    def request(self, commands: list[list], timeout: float | None = None) -> list[list]:
        """Send commands and wait for their results ``[[ok, value], ...]``.

        Raises:
            TimeoutError: no reply within the timeout (the server is gone or too slow).
            ProtocolError: the server refused the request.
        """
        replies = self.session.get(self._key, payload=P.request(self.client, commands),
                                   timeout=self.blocking_timeout if timeout is None else timeout)
        for reply in replies:
            if reply.ok is not None:
                return self._results(reply.ok.payload.to_bytes())
        raise TimeoutError(f"no reply from the simx server at {self.address}:{self.port}")

    def _results(self, payload: bytes) -> list[list]:
        message = P.unpack(payload)
        if "err" in message:
            raise P.ProtocolError(f"server refused the request: {message['err']}")
        self.last_cmd_time = message["t"]
        self.server_state = message["s"]
        return message["r"]

    def _send_async(self, commands: list[list]) -> None:
        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is None:
                return
            try:
                message = P.unpack(reply.ok.payload.to_bytes())
            except P.ProtocolError as exc:
                log.warning("unreadable reply: %s", exc)
                return
            if "err" in message:
                log.warning("server refused a request: %s", message["err"])
                return
            t = message["t"]
            with self._lock:
                self.server_state = message["s"]
                for (name, mode, args), (ok, value) in zip(commands, message["r"]):
                    if mode & P.MODE_MASK != P.MODE_DISCONTINUE:
                        self._inbox[P.identity(name, args)] = (ok, value, t)

        try:
            self.session.get(self._key, on_reply, payload=P.request(self.client, commands),
                             timeout=self.blocking_timeout)
        except zenoh.ZError as exc:
            log.warning("sending %d command(s) failed: %s", len(commands), exc)

    def _on_stream(self, sample: zenoh.Sample) -> None:
        try:
            message = P.unpack(sample.payload.to_bytes())
        except P.ProtocolError as exc:
            log.warning("unreadable stream update: %s", exc)
            return
        t = message["t"]
        with self._lock:
            for name, id_args, ok, value in message["r"]:
                ident = (name, *(P._hashable(a) for a in id_args))
                if ident in self._streams:
                    self._inbox[ident] = (ok, value, t)

    # ------------------------------------------------------------ legacy modes
    def call(self, name: str, args: list, mode: int) -> tuple[int, Any]:
        """Execute one command with a legacy operation mode; returns ``(return code, value)``.

        ``value`` is the command's result when the code is 0, the server's error message when
        it is 8, and None otherwise.
        """
        base = mode & P.MODE_MASK
        ident = P.identity(name, args)
        if base == P.MODE_BUFFER:
            return self._read(ident)
        if base == P.MODE_REMOVE:
            with self._lock:
                self._inbox.pop(ident, None)
            return C.simx_return_ok, None
        if base == P.MODE_BLOCKING:
            with self._lock:
                self._streams.discard(ident)
                self._inbox.pop(ident, None)
            try:
                ok, value = self.request([[name, mode, args]])[0]
            except TimeoutError:
                return C.simx_return_timeout_flag | C.simx_return_novalue_flag, None
            except P.ProtocolError as exc:
                log.warning("simx%s: %s", name, exc)
                return C.simx_return_remote_error_flag, str(exc)
            return (C.simx_return_ok, value) if ok else (C.simx_return_remote_error_flag, value)
        if base not in (P.MODE_ONESHOT, P.MODE_STREAMING, P.MODE_ONESHOT_SPLIT,
                        P.MODE_STREAMING_SPLIT, P.MODE_DISCONTINUE):
            return C.simx_return_illegal_opmode_flag, None
        with self._lock:
            if base in (P.MODE_STREAMING, P.MODE_STREAMING_SPLIT):
                self._streams.add(ident)
            else:
                self._streams.discard(ident)
            if base == P.MODE_DISCONTINUE:
                self._inbox.pop(ident, None)
            if self._paused:
                key = object() if name in P.DO_NOT_OVERWRITE else ident
                self._outbox.pop(key, None)  # an overwritten command moves to the end
                self._outbox[key] = [name, mode, args]
                return self._read_locked(ident)
        self._send_async([[name, mode, args]])
        return self._read(ident)

    def _read(self, ident: tuple) -> tuple[int, Any]:
        with self._lock:
            return self._read_locked(ident)

    def _read_locked(self, ident: tuple) -> tuple[int, Any]:
        entry = self._inbox.get(ident)
        if entry is None:
            return _NO_VALUE
        ok, value, t = entry
        self.last_cmd_time = t
        return (C.simx_return_ok, value) if ok else (C.simx_return_remote_error_flag, value)

    def pause_communication(self, enable: bool) -> None:
        """``simxPauseCommunication``: hold non-blocking commands, then send them as one batch."""
        with self._lock:
            self._paused = bool(enable)
            if self._paused or not self._outbox:
                return
            batch, self._outbox = list(self._outbox.values()), {}
        self._send_async(batch)

    def close(self) -> None:
        """Send what is held, say goodbye and close the session; idempotent, never hangs."""
        session = self.__dict__.pop("session", None)
        if session is None:
            return
        with self._lock:
            batch, self._outbox, self._paused = list(self._outbox.values()), {}, False
        try:
            session.get(self._key, lambda reply: None,
                        payload=P.request(self.client, batch + [["Bye", P.MODE_ONESHOT, []]]),
                        timeout=0.5)
        except zenoh.ZError:
            pass
        closer = threading.Thread(target=session.close, daemon=True)
        closer.start()
        closer.join(timeout=2.0)

    @property
    def connected(self) -> bool:
        return "session" in self.__dict__ and not self.session.is_closed()


def wait_connect(address: str, port: int, wait: bool, timeout: float, blocking_timeout: float,
                 prefix: str = P.DEFAULT_PREFIX) -> Connection | None:
    """Connect to a simx server, retrying until ``timeout`` s when ``wait``; None on failure."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            return Connection(address, port, blocking_timeout, prefix,
                              hello_timeout=max(0.1, min(blocking_timeout, deadline - time.monotonic())))
        except P.ProtocolError as exc:
            log.error("simxStart(%s, %d): %s", address, port, exc)
            return None
        except (zenoh.ZError, TimeoutError, ConnectionError) as exc:
            if not wait or time.monotonic() >= deadline:
                log.info("simxStart(%s, %d): no simx server: %s", address, port, exc)
                return None
        time.sleep(0.05)
