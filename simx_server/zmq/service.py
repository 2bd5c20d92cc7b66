"""The simulation thread's side of the ZMQ remote API: clients, stepping, and the calls themselves.

The simulation loop (:class:`simx_server.loop.core.Loop`) takes ``("zmq", Incoming)``
deliveries from its ready ring and gives them to :meth:`ZmqService.handle`, between simulation
steps, as it serves every front door's requests (:mod:`simx_server.loop.front_door`). Each client (its ``uuid``) has:

* a **stepping level** (``sim.setStepping(True)`` adds one, ``False`` takes one off): while it is
  above 0 the client is part of the simulation's synchronous barrier (the one of
  ``simxSynchronous``, :class:`~simx_server.scene.simulation.Simulation`, under the id
  ``zmq:<uuid>``), so the simulation steps only when it, and every other stepped client, asks
  for the next step with ``sim.step()``;
* a **lock count** (``sim.acquireLock`` / ``sim.releaseLock``): while above 0 the barrier also
  waits for ``zmq-lock:<uuid>``, which never triggers: the simulation does not step;
* ``sim.step()``: answered ``{func: "_*wait*_"}`` at once (the client answers ``_*executed*_``);
  the ``_*executed*_`` is answered ``{ret: []}`` once a simulation step has run since the
  ``sim.step()``, or at once while the simulation is not running (CoppeliaSim's server does the
  same, its add-on's ``sim.step``). A stepped client's ``sim.step()`` is its trigger: when it
  completes the barrier the step runs then and there.

``sim.stopSimulation`` resets every ZMQ client's stepping level and locks, as CoppeliaSim's ZMQ
server does. Clients are in the loop's registry (:mod:`simx_server.loop.clients`; a
:class:`~simx_server.zmq.clients.ZmqClient` is its entry with what is the ZMQ door's own). A client is forgotten (it
leaves the barrier) when its connection closes, when it sends ``_*end*_``, or when the loop's
housekeeping finds it past its ``timeout`` (s, its first request's; 600 by default) without a
request (:meth:`ZmqService.keeps`: not while its ``_*executed*_`` waits for a step). Every other ``sim.NAME``,
``simIK.NAME``, ``simOMPL.NAME`` and ``simVision.NAME`` is the API table's (:mod:`simx_server.api`); those that
render (images, depth buffers, vision packets) are answered from the render thread once their
frames are drawn (:mod:`simx_server.zmq.renders`), the simulation going on meanwhile.
"""

from __future__ import annotations

import inspect
import logging
import time
from typing import Any, Callable

import cbor2

from simx_wire.protocol import ArgumentError, RemoteError
from simx_server.base import job_ring, limits
from simx_server.base.arguments import quote
from simx_server.loop.budgets import cut
from simx_server.loop.front_door import LoopAccess
from simx_server.sim.state import RunState
from simx_server.sim.vision import Deferred
from simx_server.zmq import codec
from simx_server.zmq.budgets import RENDERS, Connection, reply_estimate
from simx_server.zmq.clients import ZmqClient
from simx_server.zmq.frontend import Frontend, Incoming
from simx_server.api import SIM, SIMIK, SIMOMPL, SIMVISION, CallContext, Callers, client_context, names
from simx_server.api.mesh_waits import answered
from simx_server.api.sim.stepped import CallbackCall, Stepped
from simx_server.zmq.renders import RenderedReplies, Rendering, values as _values

log = logging.getLogger("simx.zmq")

#: ``sim.NAME`` answered by the service itself (a client's state, not the scene's).
STEPPING = ("setStepping", "step", "yield", "switchThread", "acquireLock", "releaseLock")
_EMPTY = cbor2.dumps({})
#: Requests that end a long call suspended in its callback (the client gave the callback up, or
#: the callback asks for a step of its own); any other request is the callback's own, served as usual.
_ENDS_CALLBACK = frozenset({"sim.step", "sim.yield", "sim.switchThread", codec.END})
#: A version-1 client's step (CoppeliaSim 4.3-4.5's ``client.step()`` sends ``step``): answered
#: once a step has run, the step counter published first.
_STEPS_1 = frozenset({"step", "sim.step", "sim.yield", "sim.switchThread"})
_NO_COUNTER = ("the step counter (a PUB socket on the port after the server's ZMQ port, which this client's "
               "client.step() reads) could not be bound, see the server's log; free that port, or use "
               "coppeliasim-zmqremoteapi-client 2.x")


class ZmqService(RenderedReplies):
    """ZMQ clients and their calls, on the simulation thread.

    Args:
        server: the loop (:class:`~simx_server.loop.front_door.LoopAccess`: its ``sim``,
            ``clients``, ``step_now`` and ``leave_sync``).
        frontend: the socket thread that replies go through.
    """

    def __init__(self, server: LoopAccess, frontend: Frontend):
        self.server = server
        self.frontend = frontend
        #: This door's clients by uuid: the loop's registry's dict of them.
        self.clients: dict[str, ZmqClient] = server.clients.of(self)
        self.connections: dict[bytes, Connection] = {}  # routing id -> its uuids and share
        self._remote: CallContext | None = None
        self._libraries = {t.library: {n: t[n].function for n in t.names(Callers.CLIENTS)} for t in (SIM, SIMIK, SIMOMPL, SIMVISION)}
        self._functions = self._libraries["sim"]
        self._signatures: dict[str, inspect.Signature] = {}
        self._held = 0  # clients with a held _*executed*_
        self._in_after_step = self._again = False
        self._deferred: list[tuple] = []  # (when, client, envelope, func, args): calls past their connection's share
        self._own: dict[str, Callable[[ZmqClient, list, list], None]] = {
            "setStepping": self._set_stepping, "step": self._step, "yield": self._step,
            "switchThread": self._step, "acquireLock": self._acquire_lock, "releaseLock": self._release_lock,
            "stopSimulation": self._stop_simulation,
        }
        self._implemented = {lib: frozenset(fns) | frozenset(STEPPING if lib == "sim" else ()) for lib, fns in
                             self._libraries.items()}
        self.edit_calls: set[str] = set()  # seen reaching the editor: never served in place (remote_api)

    @property
    def sim(self):
        return self.server.sim

    @property
    def remote(self) -> CallContext:
        """This door's clients' context of the API table (made anew for a new simulation)."""
        if self._remote is None or self._remote.view is not self.server.sim:
            self._remote = client_context(self.server.sim)
        return self._remote

    # ------------------------------------------------------------ the ready ring
    def handle(self, kind: str, item: Any) -> None:
        """A ready-ring item of the ZMQ frontend (simulation thread)."""
        if kind == "zmq-gone":
            for client in [c for c in self.clients.values() if c.fd == item]:
                self.forget(client, "disconnected")
            for identity in [i for i, c in self.connections.items() if c.fd == item and not c.uuids]:
                del self.connections[identity]
            return
        incoming: Incoming = item
        try:
            self._serve(incoming)
        except Exception as exc:  # every request gets a reply, whatever happens
            log.exception("answering a ZMQ request %r", incoming.request)
            self.frontend.send(incoming.envelope, codec.encode_error(
                f"internal error while answering {quote(incoming.request.func, 100)}: {type(exc).__name__}"))

    def _serve(self, incoming: Incoming) -> None:
        req, envelope = incoming.request, incoming.envelope
        now = time.monotonic()
        identity = envelope[0] if envelope else b""
        connection = self.connections.get(identity)
        if connection is None:
            connection = self.connections[identity] = Connection(incoming.fd, now)
        connection.fd = incoming.fd
        client = self.clients.get(req.uuid)
        if client is None or client.connection != identity:
            if req.func == codec.END:
                if client is not None:
                    self.forget(client, "left")
                self.frontend.send(envelope, _EMPTY)
                return
            if len(connection.uuids) >= limits.MAX_ZMQ_CLIENTS_PER_CONNECTION:
                self.frontend.send(envelope, codec.encode_error(
                    f"{quote(req.func, 100)[1:-1]}: this connection holds {len(connection.uuids)} ZMQ clients (uuids) "
                    f"already (limits.MAX_ZMQ_CLIENTS_PER_CONNECTION); use one connection per client"))
                return
        if client is not None and client.connection != identity:  # the same uuid on a new connection
            old = self.connections.get(client.connection)
            if old is not None:
                old.uuids.discard(client.uuid)
            client.connection = identity
            connection.uuids.add(client.uuid)
        if client is None:
            if len(self.clients) >= limits.MAX_CLIENTS and not self._evict_one():
                self.frontend.send(envelope, codec.encode_error(
                    f"server busy: it serves {len(self.clients)} ZMQ clients already (limits.MAX_CLIENTS), all "
                    "stepped, locked or waiting; try again later"))
                return
            client = ZmqClient(req.uuid, incoming.fd, req.timeout, now, identity, self, req.version)
            self.server.clients.add(client)
            connection.uuids.add(req.uuid)
            log.info("ZMQ client %s connected%s", client.label, f" ({quote(req.lang, 40)})" if req.lang else "")
        client.fd, client.last_seen = incoming.fd, now
        self.server.hold_pass(req.uuid, limits.ZMQ_PASS_WINDOW)  # served a while (CoppeliaSim's handleQueue)
        if client.fault is not None and req.func != codec.END:  # told instead of executed
            func = (client.long_func or "sim.step") if req.func == codec.EXECUTED else req.func
            self.frontend.send(envelope, self._told_fault(client, func))
            return
        if req.func == codec.EXECUTED:
            if client.in_callback:  # the callback's return values: the motion goes on
                client.in_callback = False
                self.frontend.send(envelope, self._advance(client, req.args))
            else:
                self._executed(client, envelope)
            return
        client.waiting = False  # any other request ends a sim.step's wait
        if client.long is not None and not (client.in_callback and req.func not in _ENDS_CALLBACK):
            self._end_long(client)  # and abandons a call that lasted several steps
        if req.func == codec.END:
            self.forget(client, "left")
            self.frontend.send(envelope, _EMPTY)
            return
        wait = max(connection.wait(now), client.share.wait(now))  # the uuid's share follows it to a new connection
        if wait > 0:  # past its share: the call waits its turn, other connections go on meanwhile
            log.info("ZMQ client %s: %s waits %.1f s (its connection's scene edits and long calls took more than "
                     "%.0f%% of the simulation thread, limits.EDIT_SHARE)", client.label, quote(req.func, 100), wait,
                     100 * limits.EDIT_SHARE)
            self._deferred.append((now + wait, client, envelope, req.func, req.args))
            return
        self._answer(client, envelope, req.func, req.args)

    def _answer(self, client: ZmqClient, envelope: list, func: str, args: list) -> None:
        """Reply to ``func(*args)``; its time (on this thread) is charged to the client's connection."""
        if client.version == codec.VERSION_1 and func in _STEPS_1:  # no _*wait*_ in version 1
            self._step(client, [])
            self._executed(client, envelope)
            return
        editor = self.sim.editor
        start, edits = time.monotonic(), getattr(editor, "edits", 0)
        with editor.files.acting(client.files_key), job_ring.serving(client.connection, client.files_key):
            payload = self._call(client, func, args)
        done = time.monotonic()
        edited = getattr(editor, "edits", 0) != edits  # it reached the editor: an edit (zmq.budgets.Connection)
        if edited:
            self.edit_calls.add(func)
        connection = self.connections.get(client.connection)
        if connection is not None:
            connection.charge_call(done - start, done, edited)
        if type(payload) is Rendering:
            self._reply_rendered(client, envelope, func, payload)
        else:
            self.frontend.send(envelope, payload)

    def _call(self, client: ZmqClient, func: str, args: list) -> bytes | Rendering:
        """The encoded reply to ``func(*args)``: ``{ret}``, ``{err}`` or ``{func: _*wait*_}``; for
        a call that renders, the reply to send once the render thread is done (:class:`Rendering`)."""
        namespace, _, name = func.partition(".")
        try:
            if func == "setStepping" and client.version == codec.VERSION_1:
                values = self._set_stepping_1(client, args)
            elif namespace == "zmqRemoteApi":
                values = names.api_call(name, args, self._implemented)
            elif namespace == "sim" and name in self._own:
                reply = self._own[name](client, args)
                if isinstance(reply, bytes):
                    return reply
                values = reply
            elif namespace == "sim" and name in self._functions:
                refused = reply_estimate(self.sim, name, args)
                if refused is not None:
                    return self._error(client, func, refused)
                if name in RENDERS:
                    return self._render(client, func, name, args)
                values = self._call_table(name, args)
                if isinstance(values, Stepped):
                    if client.version == codec.VERSION_1:
                        values.generator.close()
                        raise RemoteError("a call that lasts several simulation steps needs protocol version 2 "
                                          "(coppeliasim-zmqremoteapi-client 2.x); CoppeliaSim 4.3-4.5's client runs "
                                          "sim.wait, sim.waitForSignal, sim.moveToConfig and sim.moveToPose itself")
                    if client.long is not None:  # another long call from inside a callback
                        self._end_long(client)
                    return self._start_long(client, func, values)
            elif name in self._libraries.get(namespace, ()):
                values = self._call_table(name, args, namespace)
            elif name in names.coppeliasim_functions(namespace):
                raise RemoteError(f"not implemented by simx (CoppeliaSim 4.x has {namespace}.{name}; "
                                  "docs/ZMQ.md lists what simx has)")
            else:
                raise RemoteError("no such function")
            if type(values) is Deferred:  # a .ttt converted, a long call (api.long_calls) run off this thread
                return Rendering(values, 0, self._signature(name, namespace).return_annotation in ("None", None))
            return self._encoded(client, func, values)
        except Exception as exc:
            return self._call_error(client, func, exc)

    def _call_error(self, client: ZmqClient, func: str, exc: Exception) -> bytes:
        """The ``{err}`` reply of a call that raised ``exc``."""
        if isinstance(exc, RemoteError):
            return self._error(client, func, str(exc))
        if isinstance(exc, (TypeError, ValueError, OverflowError)):  # bad arguments caught in the conversions
            return self._error(client, func, f"bad arguments: {exc}")
        if isinstance(exc, RecursionError):
            return self._error(client, func, "arguments nested too deeply")
        if isinstance(exc, OSError) and exc.errno is not None:  # a path the system refuses (too long, ...)
            return self._error(client, func, f"refused: {exc.strerror} (errno {exc.errno})")
        log.error("ZMQ client %s: %s raised", client.label, quote(func, 100), exc_info=exc)
        return self._error(client, func, f"internal error: {type(exc).__name__}: {exc}", logged=True)

    def _error(self, client: ZmqClient, func: str, message: str, logged: bool = False) -> bytes:
        text = cut(f"{quote(func, 100)[1:-1]}: {message}")  # the loop's rule, as the legacy door's
        if not logged:
            log.warning("ZMQ client %s: %s", client.label, text)
        return codec.encode_error(text)

    def _signature(self, name: str, library: str = "sim") -> inspect.Signature:
        key = name if library == "sim" else f"{library}.{name}"
        signature = self._signatures.get(key)
        if signature is None:
            signature = self._signatures[key] = inspect.signature(self._libraries[library][name])
        return signature

    def _call_table(self, name: str, args: list, library: str = "sim") -> list | Stepped | Deferred:
        fn, signature, remote = self._libraries[library][name], self._signature(name, library), self.remote
        try:
            result = answered(self.sim, lambda: fn(remote, *args))  # a mesh's tree built off this thread meanwhile
        except TypeError as exc:  # the wrong number of arguments, or a bad one met deeper in
            try:
                signature.bind(remote, *args)
            except TypeError as arity:
                raise ArgumentError(f"{arity} ({library}.{name}{names.shown(signature)})") from None
            raise exc
        if isinstance(result, (Stepped, Deferred)):
            return result
        return _values(result, signature.return_annotation in ("None", None))

    def _run_deferred(self) -> None:
        """Serve the scene edits whose wait is over (their clients still there)."""
        now = time.monotonic()
        due = [d for d in self._deferred if d[0] <= now]
        if not due:
            return
        self._deferred = [d for d in self._deferred if d[0] > now]
        for _, client, envelope, func, args in due:
            if self.clients.get(client.uuid) is client:
                self._answer(client, envelope, func, args)

    # ------------------------------------------------------------------ stepping
    def _set_stepping(self, client: ZmqClient, args: list) -> list:
        if len(args) != 1:
            raise ArgumentError("sim.setStepping takes one boolean")
        previous = client.stepping
        if args[0]:
            client.stepping += 1
            if previous == 0:
                self.sim.enable_sync(client.sync_id, True)
                log.info("ZMQ client %s: stepping on", client.label)
        elif client.stepping > 0:
            client.stepping -= 1
            if client.stepping == 0:
                self.server.leave_sync(client.sync_id, "left stepping mode")
        return [previous]

    def _set_stepping_1(self, client: ZmqClient, args: list) -> list:
        """CoppeliaSim 4.3-4.5's ``setStepping(enable, uuid)`` (its add-on's global function; the
        uuid names the client, here its connection): stepped or not, no levels; returns nothing."""
        enable = bool(args and args[0])
        if enable and not self.frontend.counter_bound:
            raise RemoteError(_NO_COUNTER)
        if enable != bool(client.stepping):
            client.stepping = min(client.stepping, 1)
            self._set_stepping(client, [enable])
        return []

    def _step(self, client: ZmqClient, args: list) -> bytes:
        sim = self.sim
        client.step_at = sim.steps
        if sim.state is RunState.RUNNING and client.stepping > 0 and sim.trigger(client.sync_id):
            self.server.step_now()  # its trigger completed the barrier; a failure is told to every client
        client.waiting = True
        return codec.encode_wait()

    def _executed(self, client: ZmqClient, envelope: list) -> None:
        if not client.waiting:
            if client.gave_up:
                func, client.gave_up = client.gave_up, ""
                self.frontend.send(envelope, self._error(client, func, "the motion ended while its callback ran (the "
                                                                       "callback asked for a step, or made another "
                                                                       "call that lasts several steps)"))
                return
            self.frontend.send(envelope, self._error(client, codec.EXECUTED, "nothing waits for it (it answers "
                                                                             "a _*wait*_ of sim.step)"))
            return
        if self.sim.state is not RunState.RUNNING or self.sim.steps > client.step_at:
            client.waiting = False
            self._send_resumed(client, envelope)
            return
        if client.held is None:
            self._held += 1
        client.held = envelope

    def _resume(self, client: ZmqClient) -> bytes:
        """The reply due once a client's step has run: its sim.step's (empty) return, or the next
        increment of its call that lasts several steps (``_*wait*_`` again, or its return); the
        error of a failed step instead, when that step failed."""
        if client.fault is not None:
            return self._told_fault(client, client.long_func if client.long is not None else "sim.step")
        return self._advance(client) if client.long is not None else codec.encode_reply([])

    def _send_resumed(self, client: ZmqClient, envelope: list) -> None:
        """Send :meth:`_resume`'s reply; a version-1 client's goes after the step count is
        published, which its ``client.step()`` waits for once answered."""
        publish = {"publish": self.sim.steps} if client.version == codec.VERSION_1 else {}
        self.frontend.send(envelope, self._resume(client), **publish)

    def _told_fault(self, client: ZmqClient, func: str) -> bytes:
        """The ``{err}`` reply that tells ``client`` the failed step it is marked with
        (``Client.fault``, the loop's rule for every door's clients: once, at its next call);
        its wait for a step and any call that lasts several steps end with it."""
        message, client.fault = client.fault or "", None
        client.waiting = False
        if client.long is not None:
            self._end_long(client)
            client.gave_up = ""  # told now, by this error
        return self._error(client, func, message)

    def after_step(self) -> None:
        """After a step (or a loop pass without one): answer the ``_*executed*_`` whose step has
        run. Answering may trigger the next step (a call that lasts several steps): then this
        looks again, once that step's own pass (nested) has returned."""
        if self._deferred:
            self._run_deferred()
        if not self._held:
            return
        if self._in_after_step:
            self._again = True
            return
        self._in_after_step = True
        try:
            self._again = True
            while self._again:
                self._again = False
                sim = self.sim
                for client in list(self.clients.values()):
                    if client.held is not None and (sim.state is not RunState.RUNNING or sim.steps > client.step_at):
                        envelope, client.held, client.waiting = client.held, None, False
                        self._held -= 1
                        self._send_resumed(client, envelope)
        finally:
            self._in_after_step = False

    # ------------------------------------------------- calls that last several steps
    def _start_long(self, client: ZmqClient, func: str, stepped: Stepped) -> bytes:
        """Begin a call that lasts several steps: the client is stepped meanwhile (CoppeliaSim's
        ``sim.setStepping(true)`` inside ``sim.moveToConfig``), each increment waits for a step."""
        self._set_stepping(client, [True])
        client.long, client.long_func = stepped.generator, func
        return self._advance(client)

    def _advance(self, client: ZmqClient, value: list | None = None) -> bytes:
        """Run the next increment (``value``: the return values of the callback it asked for):
        ``_*wait*_`` while it wants a step, ``{func: NAME, args}`` while it wants the client's
        callback run, else its reply."""
        try:
            wanted = client.long.send(value)
        except StopIteration as done:
            self._end_long(client)
            return codec.encode_reply(done.value or [])
        except Exception as exc:
            func = client.long_func
            self._end_long(client)
            return self._call_error(client, func, exc)
        if isinstance(wanted, CallbackCall):
            client.in_callback = True
            try:
                return codec.encode_callback(wanted.callback, wanted.args)
            except Exception as exc:  # arguments that cannot go over the wire
                func = client.long_func
                self._end_long(client)
                return self._call_error(client, func, exc)
        return self._step(client, [])

    def _end_long(self, client: ZmqClient) -> None:
        generator, client.long = client.long, None
        client.waiting = False
        if client.in_callback:
            client.in_callback, client.gave_up = False, client.long_func
        if generator is not None:
            generator.close()
            if client.stepping:
                self._set_stepping(client, [False])

    def _acquire_lock(self, client: ZmqClient, args: list) -> list:
        if client.locks == 0:
            self.sim.enable_sync(client.lock_id, True)
        client.locks += 1
        return []

    def _release_lock(self, client: ZmqClient, args: list) -> list:
        if client.locks > 0:
            client.locks -= 1
            if client.locks == 0:
                self.server.leave_sync(client.lock_id, "released its lock")
        return []

    def _stop_simulation(self, client: ZmqClient, args: list) -> list:
        self._call_table("stopSimulation", args)
        for other in self.clients.values():  # CoppeliaSim's ZMQ server: a stop ends every client's stepping
            self._unstep(other)
        self.after_step()
        return []

    def _unstep(self, client: ZmqClient) -> None:
        if client.stepping:
            client.stepping = 0
            self.server.leave_sync(client.sync_id, "out of stepping mode")
        if client.locks:
            client.locks = 0
            self.server.leave_sync(client.lock_id, "lock released")

    # ------------------------------------------------------------------- clients
    def keeps(self, client: ZmqClient) -> bool:
        """A client whose ``_*executed*_`` waits for a step does not expire."""
        return client.held is not None

    def forget(self, client: ZmqClient, how: str) -> None:
        """Drop a client: it leaves the barrier (the step the others triggered may run now)."""
        if not self.server.clients.remove(client):
            return
        connection = self.connections.get(client.connection)
        if connection is not None:
            connection.uuids.discard(client.uuid)
        if client.held is not None:
            self._held -= 1
            client.held = None
        if client.long is not None:
            client.long.close()
            client.long, client.in_callback = None, False
        log.info("ZMQ client %s %s", client.label, how)
        self.sim.editor.files.release(client.files_key)  # its folder and budget
        self._unstep(client)

    def _evict_one(self) -> bool:
        """Forget the longest silent client that holds nothing (no stepping, lock or wait), to make
        room for a new one; False when there is none."""
        idle = self.server.clients.oldest(self, lambda c: not (c.stepping or c.locks or c.held or c.long))
        if idle is None:
            return False
        self.forget(idle, "dropped to make room for a new client")
        return True

    def housekeeping(self, now: float) -> None:
        """Serve the scene edits whose wait is over (also when no step comes); the loop has
        expired the silent clients before (:meth:`keeps`, :meth:`forget`)."""
        if self._deferred:
            self._run_deferred()
