"""The simx server: Zenoh on the outside, one simulation thread on the inside.

Zenoh callbacks never touch MuJoCo and never block: they put the query (or a client's
departure) on a queue. The thread that calls :meth:`Server.serve` owns the simulation; it
executes each request atomically between physics steps, replies, steps the simulation every
``dt`` (paced to wall time when ``speed`` > 0, on triggers in synchronous mode), and after
every step publishes each client's streamed commands.
"""

from __future__ import annotations

import gc
import ipaddress
import json
import logging
import queue
import threading
import time
from pathlib import Path
from typing import Any

import zenoh

from simx_client import protocol as P
from simx_server.arguments import quote
from simx_server.commands import HANDLERS
from simx_server.simulation import RunState, Simulation
from simx_server.vision import Deferred

log = logging.getLogger("simx.server")

DEFAULT_HOSTS = ("127.0.0.1",)
DEFAULT_PORTS = (19997, 19999)
_DRAIN_LIMIT = 64  # requests executed between two checks of the step clock
_MAX_ERRORS = 50  # errors kept per client for simxGetLastErrors
_STREAMING = (P.MODE_STREAMING, P.MODE_STREAMING_SPLIT)


def zenoh_config(endpoints: list[str], config_file: str | Path | None = None) -> zenoh.Config:
    """Server Zenoh config: the file's settings (TLS, authentication, access control), listening
    on ``endpoints`` unless the file lists its own, multicast scouting always off.

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


class _Stream:
    """One streamed command of one client (simx_opmode_streaming + alpha ms)."""

    __slots__ = ("name", "args", "delay", "last")

    def __init__(self, name: str, args: list, delay_ms: int):
        self.name, self.args, self.delay, self.last = name, args, delay_ms / 1000.0, -1e9


class Server:
    """Serves one :class:`Simulation` on Zenoh.

    Args:
        sim: the simulation (owned by the thread that calls serve()).
        config: Zenoh config (see :func:`zenoh_config`).
        speed: real-time factor in asynchronous mode; 0 runs as fast as possible.
        prefix: key-expression prefix (``simx``).
    """

    def __init__(self, sim: Simulation, config: zenoh.Config, speed: float = 1.0,
                 prefix: str = P.DEFAULT_PREFIX):
        if speed < 0:
            raise ValueError(f"speed must be >= 0, got {speed}")
        self.sim = sim
        self.speed = speed
        self.prefix = prefix
        self._config = config
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._stopping = threading.Event()
        self._streams: dict[str, dict[tuple, _Stream]] = {}
        self._clients: set[str] = set()
        self._sync_owner: str | None = None
        self._errors: dict[str, list[str]] = {}  # per client, for simxGetLastErrors
        self._consoles: dict[int, str] = {}  # auxiliary console handle -> title
        self._t0 = time.monotonic()
        self.session: zenoh.Session | None = None

    # ------------------------------------------------------------ zenoh side
    def open(self) -> None:
        """Open the Zenoh session and declare the queryable and liveliness; raises zenoh.ZError."""
        self.session = zenoh.open(self._config)
        self._call_prefix = len(P.call_key(self.prefix, ""))  # a query's key minus this is its client
        # Direct callbacks: Zenoh's thread only enqueues (no Python thread of zenoh's in between).
        self._queryable = self.session.declare_queryable(
            P.call_keys(self.prefix), zenoh.handlers.Callback(self._queue.put, indirect=False))
        self._legacy_queryable = self.session.declare_queryable(
            P.legacy_call_key(self.prefix), zenoh.handlers.Callback(self._refuse_old, indirect=False))
        self._token = self.session.liveliness().declare_token(P.server_token_key(self.prefix))
        self._watch = self.session.liveliness().declare_subscriber(
            P.client_token_prefix(self.prefix), zenoh.handlers.Callback(self._on_client_token, indirect=False))

    @staticmethod
    def _refuse_old(query: zenoh.Query) -> None:
        """A client of protocol version 1 or 2 (one call key for all): refuse with the reason."""
        query.reply(query.key_expr, P.error_response(
            f"protocol version mismatch: this server speaks {P.PROTOCOL_VERSION}, which sends "
            "requests to <prefix>/call/<client>; install the same simx version on client and server"))

    def _on_client_token(self, sample: zenoh.Sample) -> None:
        client = str(sample.key_expr).rsplit("/", 1)[-1]
        if sample.kind == zenoh.SampleKind.DELETE:
            self._queue.put(("gone", client))

    def request_stop(self) -> None:
        """Ask serve() to return (safe from signal handlers and other threads)."""
        self._stopping.set()
        self._queue.put(("stop", None))

    def close(self) -> None:
        """Finish pending renders and their replies, then close the session; idempotent."""
        self.sim.close()
        if self.session is not None:
            session, self.session = self.session, None
            try:
                session.close()
            except Exception as exc:  # closing must not mask the reason we stop
                log.debug("closing Zenoh session: %s", exc)

    # ------------------------------------------------------- simulation side
    def serve(self) -> None:
        """Run the simulation loop until request_stop()."""
        sim = self.sim
        # The loaded scene, handlers and libraries live as long as the server: keep them out of
        # the cyclic collector's passes, which otherwise walk them all (measured: a blocking
        # call's server part falls by about 0.03x the Zenoh floor).
        gc.collect()
        gc.freeze()
        next_tick = time.monotonic()
        while not self._stopping.is_set():
            now = time.monotonic()
            if now < next_tick:
                try:
                    self._handle(self._queue.get(timeout=next_tick - now))
                except queue.Empty:
                    pass
                continue
            self._drain()  # requests are always served between steps, even at full speed
            if self._stepping():
                self._step()
                interval = sim.world.dt / (self.speed or 1.0) if sim.realtime else 0.0
            else:
                if sim.state is not RunState.RUNNING:
                    self._publish_streams()  # idle tick: streams keep being served
                interval = sim.world.dt
            next_tick = max(next_tick + interval, now)

    def _drain(self) -> None:
        for _ in range(_DRAIN_LIMIT):
            try:
                self._handle(self._queue.get_nowait())
            except queue.Empty:
                return

    def _stepping(self) -> bool:
        return self.sim.state is RunState.RUNNING and not self.sim.synchronous

    def _step(self) -> None:
        self.sim.step()
        self._publish_streams()

    def _handle(self, item: Any) -> None:
        if isinstance(item, tuple):
            kind, client = item
            if kind == "gone":
                self._forget(client, "left")
            return
        deferred = False
        try:
            deferred = self._answer(item)
        except Exception:  # the server never dies from a client
            log.exception("answering a query on %s", item.key_expr)
        finally:
            if not deferred:
                item.drop()  # sends Zenoh's final reply at once

    def _answer(self, query: zenoh.Query) -> bool:
        """Execute a request and reply; True when the reply waits for the render thread."""
        payload = query.payload
        try:
            client, commands = P.parse_request(payload.to_bytes() if payload is not None else b"")
            if client != str(query.key_expr)[self._call_prefix:]:
                raise P.ProtocolError("the request's client id is not the one of its key (<prefix>/call/<client>)")
            if client not in self._clients and not P.valid_client_id(client):  # e.g. '*': streams to all
                raise P.ProtocolError(f"client id {quote(client)} is not one key chunk of at most 128 "
                                      "characters without / * $ ? #")
        except P.ProtocolError as exc:
            log.warning("malformed request refused: %s", exc)
            query.reply(query.key_expr, P.error_response(str(exc)))
            return False
        if client not in self._clients:
            self._clients.add(client)
            log.info("client %s connected", client)
        execute = self._execute
        results = [execute(client, name, mode, args) for name, mode, args in commands]
        t, state, scene = self.sim.stamp()
        server_time = int((time.monotonic() - self._t0) * 1000)
        for _, value in results:
            if type(value) is Deferred:
                break
        else:
            query.reply(query.key_expr, P.response(t, state, results, server_time, scene))
            return False

        def reply_and_drop() -> None:
            try:
                query.reply(query.key_expr,
                            P.response(t, state, self._resolve(results, client), server_time, scene))
            except Exception:
                log.exception("replying to client %s", client)
            finally:
                query.drop()

        self.sim.vision.after(reply_and_drop)  # once the images of this request are rendered
        return True

    @staticmethod
    def _resolve(results: list, client: str) -> list:
        """Results with every Deferred replaced by its value (called on the render thread)."""
        out = []
        for ok, value in results:
            if isinstance(value, Deferred):
                try:
                    value = value.future.result()
                except Exception as exc:
                    log.exception("client %s: rendering failed", client)
                    ok, value = False, f"internal error while rendering: {type(exc).__name__}: {exc}"
            out.append([ok, value])
        return out

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
                own = self._CLIENT_COMMANDS.get(name)
                if own is None:
                    raise P.UnsupportedError(f"unknown command {name!r}")
                return [True, getattr(self, own)(client, args)]
            if base in _STREAMING:
                streams = self._streams.setdefault(client, {})
                ident = P.identity(name, args)
                if ident not in streams:
                    streams[ident] = _Stream(name, args, mode & P.MODE_ARG_MASK if base == P.MODE_STREAMING else 0)
            elif streams and name not in P.DO_NOT_OVERWRITE:
                streams.pop(P.identity(name, args), None)  # a new non-streamed call replaces the stream
            return [True, handler(self.sim, args)]
        except P.RemoteError as exc:
            log.warning("client %s: simx%s failed: %s", client, name, exc)
            message = f"simx{name}: {exc}"
        except Exception as exc:
            log.exception("client %s: simx%s raised", client, name)
            message = f"internal error in simx{name}: {type(exc).__name__}: {exc}"
        errors = self._errors.setdefault(client, [])
        errors.append(message)
        del errors[:-_MAX_ERRORS]
        return [False, message]

    # Commands about the calling client rather than the world.
    _CLIENT_COMMANDS = {
        "Bye": "_bye", "Synchronous": "_synchronous", "SynchronousTrigger": "_trigger",
        "AddStatusbarMessage": "_statusbar_message", "AuxiliaryConsoleOpen": "_console_open",
        "AuxiliaryConsoleClose": "_console_close", "AuxiliaryConsolePrint": "_console_print",
        "AuxiliaryConsoleShow": "_console_show", "GetLastErrors": "_last_errors",
    }

    def _statusbar_message(self, client: str, args: list) -> None:
        if len(args) != 1 or not isinstance(args[0], str):
            raise P.ArgumentError("simxAddStatusbarMessage takes one string")
        log.info("[client %s] %s", client[:8], args[0])

    def _console(self, args: list) -> int:
        if not args or not isinstance(args[0], int) or args[0] not in self._consoles:
            raise P.UnknownObjectError(f"no auxiliary console with handle {quote(args[0]) if args else None}")
        return args[0]

    def _console_open(self, client: str, args: list) -> int:
        if len(args) != 3 or not isinstance(args[0], str):
            raise P.ArgumentError("simxAuxiliaryConsoleOpen takes a title, maxLines and mode")
        handle = max(self._consoles, default=0) + 1
        self._consoles[handle] = args[0]
        log.info("[client %s] console %d %r opened", client[:8], handle, args[0])
        return handle

    def _console_close(self, client: str, args: list) -> None:
        log.info("[client %s] console %r closed", client[:8], self._consoles.pop(self._console(args)))

    def _console_print(self, client: str, args: list) -> None:
        title = self._consoles[self._console(args)]
        text = args[1] if len(args) == 2 else None
        if text is not None and not isinstance(text, str):
            raise P.ArgumentError("console text must be a string or None")
        for line in (text or "").splitlines() or [""]:
            log.info("[client %s] [%s] %s", client[:8], title, line if text is not None else "(cleared)")

    def _console_show(self, client: str, args: list) -> None:
        self._console(args)

    def _last_errors(self, client: str, args: list) -> list[str]:
        return self._errors.pop(client, [])

    def _bye(self, client: str, args: list) -> None:
        self._forget(client, "disconnected")

    def _synchronous(self, client: str, args: list) -> None:
        if len(args) != 1 or not isinstance(args[0], bool):
            raise P.ArgumentError("simxSynchronous takes one boolean")
        self.sim.synchronous = args[0]
        self._sync_owner = client if args[0] else None

    def _trigger(self, client: str, args: list) -> None:
        if not self.sim.synchronous:
            raise P.RemoteError("simxSynchronousTrigger: synchronous mode is not enabled (call simxSynchronous(clientID, True))")
        if self.sim.state is RunState.RUNNING:
            self._step()

    def _forget(self, client: str, how: str) -> None:
        self._streams.pop(client, None)
        self._errors.pop(client, None)
        if client in self._clients:
            self._clients.discard(client)
            log.info("client %s %s", client, how)
        if self._sync_owner == client:
            self.sim.synchronous = False
            self._sync_owner = None
            log.info("synchronous mode off: its client %s is gone", client)

    def _publish_streams(self) -> None:
        if self.session is None:
            return
        now = time.monotonic()
        for client, streams in self._streams.items():
            if not streams:
                continue
            entries = []
            for ident, s in streams.items():
                if s.delay and now - s.last < s.delay:
                    continue
                s.last = now
                handler = HANDLERS[s.name]
                try:
                    entries.append([s.name, list(ident[1:]), True, handler(self.sim, s.args)])
                except P.RemoteError as exc:
                    entries.append([s.name, list(ident[1:]), False, str(exc)])
                except Exception as exc:
                    log.exception("client %s: streamed simx%s raised", client, s.name)
                    entries.append([s.name, list(ident[1:]), False, f"internal error: {exc}"])
            if entries:
                self._put_stream(client, entries)

    def _put_stream(self, client: str, entries: list) -> None:
        session, key, t = self.session, P.stream_key(self.prefix, client), self.sim.sim_time_ms

        def put() -> None:
            results = self._resolve([[ok, value] for *_, ok, value in entries], client)
            session.put(key, P.stream_update(t, [e[:2] + r for e, r in zip(entries, results)]))

        if any(isinstance(e[3], Deferred) for e in entries):
            self.sim.vision.after(put)  # images of this step: published once rendered, in order
        else:
            put()
