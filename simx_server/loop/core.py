"""The simulation loop: one thread owns the simulation and serves every front door's requests.

The thread that calls :meth:`Loop.serve` owns the simulation. It takes items from the *ready
ring* (one ``queue.SimpleQueue``), serves each between two physics steps, and steps the
simulation every ``dt`` (paced to wall time when ``speed`` > 0; in synchronous mode once every
synchronous client has triggered, the barrier of
:class:`~simx_server.scene.simulation.Simulation`). A ring item is

* a front door's ``(kind, item)`` delivery (:mod:`simx_server.loop.front_door`): handed to the
  door that declared ``kind`` (:meth:`Loop.attach`);
* a *ready client* (:class:`~simx_server.loop.front_door.ReadyClient`) of a door whose clients
  sit in the ring themselves (the legacy remote API's sessions): its door serves its next
  request (``ready.door.serve_ready``), under the loop's pacing;
* the loop's own ``("stop", None)``, which only wakes it.

**Pacing** (``pacing="legacy"``, the default): while the simulation runs asynchronously, a
ready client whose next request is blocking and whose previous blocking request saw the
current step is *held* until the simulation has stepped, so two consecutive blocking calls
never see the same step (V-REP executed remote commands once per simulation pass).
``"immediate"`` serves every request as soon as it is taken. Whatever the pacing, a door may
hold a running pass open (:meth:`Loop.hold_pass`): the asynchronous step then waits, serving
requests, until its window since the previous step is over (the ZMQ door: 2 ms per client
served, CoppeliaSim's ZMQ server).

**Synchronous stepping**: a step the barrier releases on a legacy trigger
(:meth:`Loop.step_after_reply`) runs once the trigger's reply has been handed over, on the
simulation thread, while that reply and the client's next call travel, as V-REP's trigger was
answered before its step ran; whoever holds the simulation next runs that step before serving
anything, so the next call (``simxGetPingTime``, a blocking read) sees the step's result. A
door's thread whose request arrives during that step waits for it (at most ``_DUE_WAIT``) and
serves the request in place right after it.

After every step, and every idle pass while the simulation is not running, each door's
``publish`` sends its streamed updates; after every step, and every pass without one, each
door's ``after_step`` runs (what waited for the step is answered). A few times a second the
loop does its housekeeping: it asks its client registry (:attr:`Loop.clients`,
:mod:`simx_server.loop.clients`) which clients of any door expired and has their door
``forget`` them, runs each door's ``housekeeping``, and writes the rate-limited log summaries
that are due. Nothing a client sends ends the loop: an exception of a step stops the
simulation and is reported to every client of every door at its next request
(``Clients.fault_all``, then each door's ``fault``).

Replies leave on the sending thread (:attr:`Loop.courier`, :mod:`simx_server.loop.courier`), so
a client that stops reading never holds the simulation thread.

**Serving in place** (:meth:`Loop.serve_or_deliver`): one lock, the *owner*, is held by whoever
serves the simulation. The simulation thread holds it always except while it waits for work
(for the next item or the next step's time). A door's reading thread that has a quick request
whose client waits for the reply (a blocking legacy call, a ZMQ call) takes the owner if it is
free, nothing waits in the ring and the simulation thread does not want it back, serves the
request exactly as the simulation thread would (the same ``_handle``, pacing included) and
sends its small reply itself once it has let the owner go: the two thread hand-overs of a call
(ring, then sending thread), which cost more than the call's execution, are skipped. Otherwise
the item goes to the ring as before. The simulation is still touched by one thread at a time,
always between two steps; the owner is held from the loop's construction, so nothing is served
before :meth:`serve` runs or after it returns.

The loop reaches its doors only through :class:`~simx_server.loop.front_door.FrontDoor` (and
a ready client's :class:`~simx_server.loop.front_door.ReadyDoor`); no door subclasses it. The
doors: the legacy remote API over Zenoh (:class:`simx_server.legacy.server.LegacyDoor`), the
ZMQ remote API (:class:`simx_server.zmq.remote_api.ZmqRemoteApi`), the tests' in-process door
(:class:`simx_server.loop.in_process.InProcessDoor`).
"""

from __future__ import annotations

import gc
import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

from simx_server.base import limits
from simx_server.loop import logs
from simx_server.loop.clients import Clients
from simx_server.loop.courier import Courier
from simx_server.loop.front_door import FrontDoor
from simx_server.sim.physics import PhysicsError
from simx_server.sim.state import RunState
from simx_wire.protocol import quote

log = logging.getLogger("simx.server")

_DRAIN_LIMIT = 64  # requests executed between two checks of the step clock
_HOUSEKEEPING = 0.25  # s between two passes of client expiry and log summaries
#: s a door's thread waits for a trigger's step to serve its item in place after it (_after_due).
_DUE_WAIT = 0.02
#: s the simulation thread waits for a trigger's reply to leave before its step (step_after_reply).
_DUE_REPLY_WAIT = 0.005
_DUE = ("due", None)  # wakes the simulation thread for a step a trigger released (no door's kind)
#: ``--pacing``: legacy (a client's blocking calls see distinct simulation steps) or immediate.
PACINGS = ("legacy", "immediate")


class Loop:
    """One simulation served to the front doors attached to it.

    Args:
        sim: the :class:`~simx_server.scene.simulation.Simulation` (owned by the thread that
            calls :meth:`serve`).
        speed: real-time factor in asynchronous mode; 0 runs as fast as possible.
        client_expiry: s a client may stay silent before its state is dropped
            (limits.CLIENT_EXPIRY; the default expiry of the registry's clients).
        pacing: ``"legacy"`` or ``"immediate"`` (see the module docstring).

    Raises:
        ValueError: a negative speed, a client expiry <= 0 or an unknown pacing.
    """

    def __init__(
        self, sim: Any, speed: float = 1.0, client_expiry: float = limits.CLIENT_EXPIRY, pacing: str = "legacy"
    ) -> None:
        if speed < 0:
            raise ValueError(f"speed must be >= 0, got {speed}")
        if pacing not in PACINGS:
            raise ValueError(f"pacing must be one of {', '.join(PACINGS)}, got {pacing!r}")
        if not client_expiry > 0:
            raise ValueError(f"client expiry must be > 0 s, got {client_expiry}")
        self.sim = sim
        self.speed = speed
        self.client_expiry = client_expiry
        self.pacing = pacing
        self._paced = pacing == "legacy"
        #: The ready ring (thread-safe): deliveries, ready clients and ``("stop", None)``.
        self.ring: queue.SimpleQueue[Any] = queue.SimpleQueue()
        #: Thread-safe: how a front door's thread hands ``(kind, item)`` to the simulation thread.
        self.deliver: Callable[[Any], None] = self.ring.put
        self._stopping = threading.Event()
        self._held: list[Any] = []  # ready clients whose next blocking call waits for the next step
        #: ``time.monotonic()`` when the loop was made.
        self.started = time.monotonic()
        #: Every door's clients: identity, last request, expiry, edit share, fault (simulation thread).
        self.clients = Clients()
        self._housekeeping_at = 0.0
        #: Sends replies and updates off the simulation thread.
        self.courier = Courier()
        #: The front doors attached (:meth:`attach`).
        self.doors: list[FrontDoor] = []
        self._kinds: dict[str, FrontDoor] = {}  # delivery kind -> the door that handles it
        #: Whoever serves the simulation holds it: the simulation thread (from construction, so
        #: that nothing is served before :meth:`serve` nor after it), except while it waits for
        #: work; a front door's thread while it serves an item in place (:meth:`serve_or_deliver`).
        self._owner = threading.Lock()
        self._owner.acquire()
        self._wanted = False  # the simulation thread waits for the simulation: no door takes it
        #: While an item is served in place: sends the door runs on its own thread once the
        #: simulation is let go (:meth:`serve_or_deliver`); None otherwise.
        self.in_place: list[Callable[[], None]] | None = None
        #: A step the synchronous barrier released, to run once the trigger's reply has left
        #: (:meth:`step_after_reply`); whoever holds the owner next runs it before anything else.
        self._due = False
        self._due_running = False  # that step runs now: a door's thread may wait for it (_after_due)
        self._due_reply = threading.Event()  # set once the trigger's reply is handed to Zenoh
        #: The current pass's service window (:meth:`hold_pass`): when the pass began (its last
        #: step), the clients served in it and the time each of them adds.
        self._pass_began = time.monotonic()
        self._pass_clients: set[str] = set()
        self._pass_window = 0.0

    # ------------------------------------------------------------- front doors
    def attach(self, door: FrontDoor) -> None:
        """Serve ``door`` from this loop (before :meth:`serve`): its ``(kind, item)``
        deliveries go to its ``handle``; it hears of every step and housekeeping pass.

        Raises:
            ValueError: another door attached declares one of its kinds.
        """
        taken = [kind for kind in door.kinds if kind in self._kinds]
        if taken:
            raise ValueError(f"{type(door).__name__}: kind(s) {', '.join(taken)} taken by another door")
        self.doors.append(door)
        for kind in door.kinds:
            self._kinds[kind] = door

    def step_now(self) -> bool:
        """One step now (a stepped client completed the synchronous barrier); False when it
        failed (every client is told, as for any failed step)."""
        return self._step()

    def step_after_reply(self) -> threading.Event:
        """A stepped client completed the synchronous barrier: the step runs once the trigger's
        reply has been handed over, while that reply and the client's next call travel, and
        before anything else is served (whoever holds the simulation next runs it first), so
        the client's next call sees the step's result. V-REP's remote API did the same: the
        trigger is answered in the pass that releases the step, before the step has run
        (simExtRemoteApi's ``simxSynchronousTrigger`` is answered at the
        ``mainscriptabouttobecalled`` event, and ``simxGetPingTime`` waits for the next one).
        A failed step is told to every client at its next request, as any failed step.

        Returns:
            The event the door sets once the trigger's reply is handed to Zenoh: the simulation
            thread waits for it (at most ``_DUE_REPLY_WAIT`` s) before stepping, since a step
            holds the interpreter and the sending thread could not send the reply meanwhile
            (measured in the Gymnasium env: the trigger's reply waited 3 ms)."""
        self._due = True
        self._due_reply = threading.Event()
        return self._due_reply

    def leave_sync(self, client: str, how: str) -> None:
        """``client`` (of any door) leaves the synchronous barrier; the step the others all
        triggered runs now."""
        self._leave_sync(client, how)

    def hold_pass(self, client: str, seconds: float) -> None:
        """A door served ``client``; while the simulation runs, the loop keeps serving requests
        before its next asynchronous step until ``seconds`` (s) per client served since the
        last step have passed since that step, as CoppeliaSim's ZMQ remote API server does
        (``zmqRemoteApi.handleQueue`` in its add-on, called from ``sysCall_actuation``: once a
        request came in a pass it polls for more until ``msgQueueTimeout_running`` x the
        number of clients served, 2 ms each, have passed). A client that does not step thus
        gets a few calls per simulation pass however fast the passes run, and a pass without
        requests is not slowed. Nothing while the simulation does not run."""
        if self.sim.state is not RunState.RUNNING:
            return
        self._pass_clients.add(client)
        self._pass_window = max(self._pass_window, seconds)

    def _window_left(self) -> float:
        """s left of the current pass's service window (<= 0: none or over)."""
        if not self._pass_clients:
            return 0.0
        return self._pass_began + self._pass_window * len(self._pass_clients) - time.monotonic()

    def _take(self, timeout: float) -> Any:
        """Wait at most ``timeout`` s for a ring item with the simulation let go (a door's
        thread may serve an item in place meanwhile); the item, or None."""
        owner = self._owner
        owner.release()
        try:
            return self.ring.get(timeout=timeout)
        except queue.Empty:
            return None
        finally:
            self._wanted = True  # no door's thread takes the simulation from here
            owner.acquire()
            self._wanted = False

    def _serve_window(self) -> None:
        """Serve what comes until the pass's service window (:meth:`hold_pass`) is over."""
        while not self._stopping.is_set():
            left = self._window_left()
            if left <= 0:
                return
            item = self._take(left)
            if item is not None:
                self._handle(item)
            if self._due:
                self._run_due()

    def request_stop(self) -> None:
        """Ask :meth:`serve` to return (safe from signal handlers and other threads)."""
        self._stopping.set()
        self.ring.put(("stop", None))

    def close(self) -> None:
        """Close the simulation (its pending renders), the sending thread (the sends handed over
        leave first), then the doors."""
        # What :meth:`serve` froze is collectable again: frozen objects are never collected, even
        # by the collections at interpreter exit, so the scene's cycles would outlive the server and
        # extensions that count what is left at exit (nanobind's: OMPL's bindings, once a planning
        # call imported them) would print a wall of "leaked" lines at every exit.
        gc.unfreeze()
        try:
            self.sim.close()
            self.courier.close()
        finally:
            for door in self.doors:
                try:
                    door.close()
                except Exception:  # closing must not mask the reason we stop
                    log.exception("closing %s", type(door).__name__)

    # ------------------------------------------------------------ the loop
    def serve(self) -> None:
        """Run the simulation loop until :meth:`request_stop`."""
        sim = self.sim
        # The loaded scene, handlers and libraries live as long as the server: keep them out of
        # the cyclic collector's passes, which otherwise walk them all (measured: a blocking
        # call's server part falls by about 0.03x the Zenoh floor).
        gc.collect()
        gc.freeze()
        next_tick = time.monotonic()
        while not self._stopping.is_set():
            now = time.monotonic()
            try:
                if now < next_tick:
                    item = self._take(next_tick - now)  # waiting for work: a door may serve meanwhile
                    if item is None:
                        continue
                    self._handle(item)
                    if self._due:  # served here: its reply is with the sending thread
                        self._run_due()
                    continue
                if self._due:
                    self._run_due()
                self._drain()  # requests are always served between steps, even at full speed
                if self._stopping.is_set():
                    break
                interval = sim.world.dt
                if self._stepping() and not self._idle():
                    self._serve_window()
                    if not self._stepping():  # a request served in the window stopped or paused it
                        continue
                    self._step()
                    interval = sim.world.dt / (self.speed or 1.0) if sim.realtime else sim.frame_interval
                elif sim.state is not RunState.RUNNING:
                    self._publish()  # idle pass: streams keep being served
                    self._after_step()
                if self._held:  # stepped, or no longer stepping: their blocking calls are due
                    self._release_held()
                if now >= self._housekeeping_at:
                    self._housekeeping(now)
            except Exception:  # a bug must not end the simulation thread either: log, go on
                log.exception("simulation loop")
                interval = sim.world.dt
            next_tick = max(next_tick + interval, now)

    def serve_or_deliver(self, item: Any) -> None:
        """A front door's thread: serve ``item`` (a ready-ring item: a delivery or a ready
        client) on this thread now if the simulation thread is waiting for work, else put it in
        the ready ring. Served in place, the item sees exactly what the simulation thread would
        have shown it (the loop's pacing applies; the simulation is between two steps), and
        the reply skips two thread hand-overs (about 0.1 ms of a 0.4 ms blocking call): the
        door may append its sends to :attr:`in_place`, which run here once the simulation is
        let go. Thread-safe; waits for the simulation thread only while a trigger's step runs
        (at most ``_DUE_WAIT`` s), to serve the item right after that step."""
        owner = self._owner
        # Only while nothing waits: items in the ring, and the simulation thread, go first (a
        # client's flood served in place would otherwise starve the ring's round robin).
        # While a trigger's step runs, its client's next call waits for the step (_after_due).
        taken = not (self._wanted or not self.ring.empty()) and owner.acquire(blocking=False)
        if not taken and not (self._due_running and self._after_due(owner)):
            self.ring.put(item)
            return
        sends: list[Callable[[], None]] = []
        self.in_place = sends
        try:
            self._handle(item)
        except Exception:  # as on the simulation thread: a bug is logged, the door goes on
            log.exception("serving a request in place")
        finally:
            self.in_place = None
            owner.release()
        for send in sends:
            try:
                send()
            except Exception:
                log.exception("sending a reply in place")
        if self._due:
            # The step a trigger released runs on the simulation thread, woken now that the
            # reply is handed to Zenoh; not on this thread: it is one of Zenoh's, and a step
            # run here held the trigger's reply until the step ended (measured). Whoever
            # holds the simulation next runs the step before anything else.
            self.ring.put(_DUE)

    def _after_due(self, owner: threading.Lock) -> bool:
        """While a trigger's step runs (a door's thread): wait for the simulation (at most
        ``_DUE_WAIT`` s) to serve the item in place right after the step; True when taken.
        The request of a stepped client that arrives during its step (its ``simxGetPingTime``)
        then skips the ring and the sending thread (measured: about 0.15 ms of a 0.9 ms step)."""
        if not owner.acquire(timeout=_DUE_WAIT):
            return False
        if self._wanted or not self.ring.empty():  # others first, as above
            owner.release()
            return False
        return True

    def _drain(self) -> None:
        for _ in range(_DRAIN_LIMIT):
            try:
                self._handle(self.ring.get_nowait())
            except queue.Empty:
                return
            if self._stopping.is_set():
                return

    def _run_due(self) -> None:
        """Run the step the barrier released (:meth:`step_after_reply`; owner held)."""
        self._due = False
        self._due_running = True
        try:
            if not self._due_reply.is_set():  # served on this thread: its reply is with the courier
                self._due_reply.wait(_DUE_REPLY_WAIT)
            if self.sim.state is RunState.RUNNING:
                self._step()  # a failure is told to every client at its next request
        finally:
            self._due_running = False

    def _handle(self, item: Any) -> None:
        if self._due:  # the step a trigger released comes before anything served after it
            self._run_due()
        if type(item) is not tuple:  # a ready client (front_door.ReadyClient)
            door = item.door
            if self._paced and self._stepping() and door.blocking(item):
                steps = self.sim.steps
                if item.step == steps:  # its previous blocking call saw this step: wait for the next
                    self._held.append(item)  # stays scheduled; its queue and bounds are unchanged
                    return
                door.serve_ready(item, steps)
                return
            door.serve_ready(item, None)
            return
        kind, value = item
        handler = self._kinds.get(kind)
        if handler is not None:
            handler.handle(kind, value)
        # else ("stop", None) or _DUE: it only woke the loop

    def _release_held(self) -> None:
        held, self._held = self._held, []
        put = self.ring.put
        for ready in held:  # back in the ring, in the order they were held
            put(ready)

    def _housekeeping(self, now: float) -> None:
        """Expire silent clients, run the doors' housekeeping and write due log summaries (a
        few times a second)."""
        self._housekeeping_at = now + _HOUSEKEEPING
        try:
            for client in self.clients.expired(now):
                client.door.forget(client, client.expired_how())
            for door in self.doors:
                door.housekeeping(now)
            logs.flush()
        except Exception:  # housekeeping must never end the loop
            log.exception("housekeeping")

    def _stepping(self) -> bool:
        return bool(self.sim.state is RunState.RUNNING and not self.sim.synchronous)

    def _idle(self) -> bool:
        """Not real time (``--speed 0``, a scene saved not real time) with no client and no
        viewer: nobody would see the steps, so none are taken (the loop sleeps until a request comes) and an idle server of a
        pool leaves the cores to the servers in use. Paced servers keep V-REP's clock."""
        return not self.sim.realtime and not self.clients.count() and not any(door.watched() for door in self.doors)

    def _step(self) -> bool:
        """One step and its updates; False when the step failed (the simulation is then
        stopped and every client is told at its next request). A new pass begins: its service
        window is empty (:meth:`hold_pass`)."""
        self._pass_clients.clear()
        try:
            self.sim.step()
        except Exception as exc:  # nothing a client sends may end the simulation thread
            self._step_failed(exc)
            self._after_step()
            return False
        finally:
            self._pass_began = time.monotonic()
        self._publish()
        self._after_step()
        return True

    def _step_failed(self, exc: Exception) -> None:
        if isinstance(exc, PhysicsError):  # a blow-up: the simulation has stopped itself
            reason = self.sim.stop_reason or str(exc)
            log.warning("%s", reason)
        else:
            reason = (
                f"the simulation step failed and the simulation was stopped: "
                f"{type(exc).__name__}: {quote(str(exc), 200)}"
            )
            log.error("%s", reason, exc_info=exc)
        if self.sim.state is not RunState.STOPPED:
            try:
                self.sim.stop()
            except Exception:
                log.exception("stopping the simulation after a failed step")
                self.sim.state = RunState.STOPPED  # whatever the cleanup did, no further steps
        self._fault_all(reason)

    def _after_step(self) -> None:
        for door in self.doors:
            try:
                door.after_step()
            except Exception:  # a bug must not end the simulation thread
                log.exception("%s after a step", type(door).__name__)

    def _leave_sync(self, client: str, how: str) -> None:
        released = self.sim.leave_sync(client)
        waiting = len(self.sim.waiting_for())
        log.info(
            "client %s %s (%s)",
            client,
            how,
            "the step its other clients triggered runs now"
            if released
            else f"the next step waits for {waiting} other client(s)"
            if waiting
            else "no synchronous client left: the simulation runs asynchronously",
        )
        if released and self.sim.state is RunState.RUNNING:
            self._step()  # a failure is told to every client at its next request

    def _publish(self) -> None:
        for door in self.doors:
            try:
                door.publish()
            except Exception:  # a bug must not end the simulation thread
                log.exception("%s publishing", type(door).__name__)

    def _fault_all(self, reason: str) -> None:
        """A step failed: every client of every door is told ``reason`` at its next request."""
        self.clients.fault_all(reason)
        for door in self.doors:
            try:
                door.fault(reason)
            except Exception:  # a bug must not end the simulation thread
                log.exception("%s told of a failed step", type(door).__name__)
