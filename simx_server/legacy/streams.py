"""Streamed commands (``simx_opmode_streaming``): each client's streams are executed again after
every simulation step and published on ``simx/<name>/stream/<client>`` by the sending thread
(images once the render thread has drawn them; in order with the client's replies), each update
within the reply budget
(``limits.MAX_REPLY_BYTES``). A client of the synchronous barrier gets a step's update with the
reply to its next request, right ahead of it (:meth:`StreamPublisher._put_stream`). A mixin of
:class:`simx_server.legacy.server.LegacyDoor`.
"""

from __future__ import annotations

import logging
import time
from concurrent.futures import Future

import zenoh

from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.commands import HANDLERS
from simx_server.sim.mesh_geometry import TreesPending
from simx_server.sim.state import RunState
from simx_server.sim.vision import Deferred
from simx_server.legacy.replies import IMAGES, SMALL, image_pixels, image_size, pack_large, reply_size
from simx_server.legacy.sessions import Session

log = logging.getLogger("simx.server")


class _Stream:
    """One streamed command of one client (simx_opmode_streaming + alpha ms)."""

    __slots__ = ("name", "args", "delay", "last")

    def __init__(self, name: str, args: list, delay_ms: int):
        self.name, self.args, self.delay, self.last = name, args, delay_ms / 1000.0, -1e9

    def renew(self, args: list, delay_ms: int) -> None:
        """A newer streaming request of the same command: its arguments and period run from the
        next step on (a setter streams its newest value, as V-REP's server replaced the command)."""
        self.args, self.delay = args, delay_ms / 1000.0


#: s this thread lets the interpreter go after submitting a pass's first frame, so that the
#: render thread starts it at once instead of once the pass's other streams are executed
#: (interleaved A/B, the Gymnasium env's step at 84x84: 0.06-0.2 ms shorter, issue 44).
_RENDER_HANDOFF = 50e-6
#: Zenoh priority of a synchronous client's stream updates. Zenoh's sending pipeline held a small
#: message that followed a large one in the same priority queue for about its batching time
#: limit (1 ms): the ping's reply behind the step's update with images (bare Zenoh, a 60 KB put
#: then a small reply: 1.35 ms; the put at this priority: 0.31 ms). Replies travel at the
#: queries' priority (data). The update, handed over before the ping's reply and of higher
#: priority, still arrives before it; a reply handed over before an update may now arrive after
#: it (issue 44).
_STEPPED_PRIORITY = zenoh.Priority.INTERACTIVE_HIGH


class StreamPublisher:
    """Publishing of the clients\x27 streams (needs the door\x27s ``session``, ``prefix``, ``sim``, ``sessions``, ``courier``, ``viewers``, ``_streams``, ``_stream_renders``, ``_held_updates`` and ``_resolve``)."""

    def _publish_streams(self) -> None:
        if self.session is None:
            return
        if self.viewers.watched:  # the whole cost of the viewer feed without a viewer
            self.viewers.publish(self.sim.world)
        now = time.monotonic()
        sim = self.sim
        # Streamed frames render on their own thread (VisionSensors.for_streams), so an image
        # request never waits behind them (50 streams of a 4096x4096 sensor made one wait 4.2 s).
        # Image streams wait while that thread still has limits.MAX_STREAM_STEPS_RENDERING steps
        # of frames to make: every client's image streams skip steps meanwhile (they get the
        # newest frame once it is free) instead of queueing seconds of frames and memory.
        self._stream_renders = [fs for fs in self._stream_renders if not all(f.done() for f in fs)]
        rendering = len(self._stream_renders) >= limits.MAX_STREAM_STEPS_RENDERING
        # and streams of large frames skip steps while the stream thread drew more than its share
        # of the time (limits.STREAM_RENDER_SHARE), leaving the CPU to requests
        large = limits.STREAM_THREAD_PIXELS if sim.vision.streams_over_share() else None
        step_renders: list[Future] = []
        sim.vision.for_streams = True  # their frames render on the stream render thread
        try:
            self._publish_each(sim, now, rendering, step_renders, large)
        finally:
            sim.vision.for_streams = False
            sim.editor.files.caller = None  # set per client below
        if step_renders:
            self._stream_renders.append(step_renders)

    def _publish_each(self, sim, now: float, rendering: bool, step_renders: list[Future],
                      large: int | None = None) -> None:
        """Execute and hand over every client's due streams (images only when not ``rendering``,
        and not of ``large`` pixels or more)."""
        encodings: dict = {}  # this step's updates with images, by content: encoded once
        running = sim.state is RunState.RUNNING
        # The first frame submitted to a render thread waits for the interpreter to start, which
        # this thread holds while it executes the other streams: it lets it go once a pass
        # (_RENDER_HANDOFF) so that the frame renders meanwhile (MuJoCo's rendering runs without
        # the interpreter).
        handed_off = False
        # every client's streams within limits.MAX_STREAMS_STEP_SECONDS of this thread's time a
        # step; the clients taken in turn (each step starts with the next), the rest skip the step
        began, clients = time.thread_time(), list(self._streams.items())
        turn = self._stream_turn = (getattr(self, "_stream_turn", -1) + 1) % max(1, len(clients))
        for client, streams in clients[turn:] + clients[:turn]:
            if not streams:
                continue
            session = self.sessions.get(client)
            # A client of the synchronous barrier gets every step's update (see _put_stream):
            # its steps come only with its triggers, which it sends once their replies came.
            stepped = running and sim.is_synchronous(client)
            if not stepped and not self.sessions.can_send(session):
                continue  # its updates and replies wait to be sent: its streams skip this step
            sim.editor.files.caller = f"legacy:{client}"  # its streamed calls act as it (client_files)
            images = stepped or not rendering  # else its image streams skip this step
            big = None if stepped else large
            budget = limits.MAX_REPLY_BYTES
            entries = []
            renders = []
            for ident, s in streams.items():
                if s.delay and now - s.last < s.delay:
                    continue
                if time.thread_time() - began > limits.MAX_STREAMS_STEP_SECONDS:
                    break  # this step's time for streams is spent: the rest skip it
                name = s.name
                if name in IMAGES:
                    if not images or (big and image_pixels(sim, s.args) >= big):
                        continue
                    cost = image_size(sim, name, s.args)
                    if cost > budget:
                        entries.append([name, list(ident[1:]), False, f"not executed: the update would exceed "
                                        f"{limits.MAX_REPLY_BYTES} bytes (limits.MAX_REPLY_BYTES)"])
                        continue
                    budget -= cost
                s.last = now
                handler = HANDLERS[name]
                try:
                    value = handler(sim, s.args)
                    if type(value) is Deferred:
                        renders.append(value)
                        if not handed_off:  # once a pass: the render thread starts now (see above)
                            handed_off = True
                            time.sleep(_RENDER_HANDOFF)
                    elif type(value) not in SMALL:
                        budget -= reply_size(value)
                        if budget < 0:
                            budget += reply_size(value)
                            raise P.RemoteError(f"not sent: the update would exceed {limits.MAX_REPLY_BYTES} "
                                                "bytes (limits.MAX_REPLY_BYTES)")
                    entries.append([name, list(ident[1:]), True, value])
                except TreesPending:  # a mesh's tree is being built off this thread: the next steps have it
                    continue
                except P.RemoteError as exc:
                    entries.append([name, list(ident[1:]), False, str(exc)[:limits.MAX_ERROR_CHARS]])
                except Exception as exc:
                    log.exception("client %s: streamed simx%s raised", client, name)
                    entries.append([name, list(ident[1:]), False, f"internal error: {type(exc).__name__}"])
            if entries:
                bulk = limits.MAX_REPLY_BYTES - budget >= limits.BULK_SEND_BYTES  # the update's bytes, about
                encoded = self._put_stream(client, session, entries, renders, encodings, bulk, stepped)
                if encoded is not None:
                    step_renders.append(encoded)  # after its frames

    def _put_stream(self, client: str, sess: Session | None, entries: list, renders: list[Deferred],
                    encodings: dict, bulk: bool = False, stepped: bool = False) -> Future | None:
        """Hand one client's stream update to the sending thread (its lane): published once
        ``renders`` (its images) are done and encoded, in order with the client's replies.
        ``bulk`` (images of limits.BULK_SEND_BYTES or more): put with blocking congestion control
        (Zenoh's "drop" dropped 50 MB updates every time) and giving way to other clients' sends.
        ``stepped`` (a client of the synchronous barrier, after a step): put with blocking
        congestion control too, and never skipped, as V-REP guaranteed that after
        ``simxSynchronousTrigger`` + ``simxGetPingTime`` the inbox holds that step's streamed
        values (simExtRemoteApi's ``CSimxSocket``: each main-script pass executes the streamed
        commands into ``_dataToSend``, which goes out inside the reply to the client's next
        message). Zenoh's "drop" left an update out whenever its link's queue had no room
        within ``wait_before_drop`` (1 ms), which a loaded machine's Zenoh thread missed about
        once in 300 steps: the client then read the previous step's values. Its updates travel
        at Zenoh's priority ``_STEPPED_PRIORITY``, above its replies, and each is *held* until
        that client's next request is answered, then handed over right ahead of that reply
        (:meth:`_hand_held`): as in V-REP (``CSimxSocket::_executeCommands`` runs a pass's
        received commands, the trigger among them, and its streamed commands together, before
        the pass's main script; their replies leave together), the trigger's reply comes with
        the values and the clock of the state it was executed on, never with those of the step
        it releases, which a program's read right after the trigger raced (its clock advanced
        by 0 or 2 steps about one time in three).

        An update with images is encoded on the render thread, after its frames, into Zenoh's
        bytes (a 4096x4096 image is 50 MB to copy twice: 80 ms; putting the result costs
        microseconds), once per step for clients whose updates are the same (``encodings``):
        the sending thread only pushes, and no reply waits behind the copies. Returns the
        future of that encoding (None without images)."""
        session, key, t = self.session, P.stream_key(self.prefix, client), self.sim.sim_time_ms
        if renders:
            same = (t, tuple((e[0], repr(e[1]), e[2], id(e[3].future) if type(e[3]) is Deferred else repr(e[3]))
                             for e in entries))
            encoded = encodings.get(same)
            if encoded is None:
                def encode() -> zenoh.ZBytes:
                    results = self._resolve([[ok, value] for *_, ok, value in entries], client)
                    return zenoh.ZBytes(P.stream_update(t, [e[:2] + r for e, r in zip(entries, results)],
                                                        pack_large))

                encoded = encodings[same] = self.sim.vision.after_all(renders, encode)
            waits = [encoded]

            def update() -> zenoh.ZBytes:
                return encoded.result()
        else:
            try:
                payload = P.stream_update(t, entries)  # now: the values are this step's
            except Exception:
                log.exception("client %s: encoding its stream update", client)
                return None
            waits = []

            def update() -> bytes:
                return payload

        congestion = zenoh.CongestionControl.BLOCK if bulk or stepped else zenoh.CongestionControl.DROP
        priority = _STEPPED_PRIORITY if stepped else zenoh.Priority.DEFAULT

        def send() -> None:
            try:
                if not bulk or stepped or self.courier.bulk_allowed():
                    session.put(key, update(), congestion_control=congestion, priority=priority)
            except Exception:
                log.exception("client %s: publishing its streams", client)
            finally:
                if sess is not None:
                    self.sessions.sent(sess)

        self._hand_held(client)  # an earlier update of this client leaves first
        if stepped:
            self._held_updates[client] = (sess, send, waits, bulk)
        else:
            self._hand(client, sess, send, waits, bulk)
        return waits[0] if waits else None

    def _hand_held(self, client: str) -> bool:
        """Hand ``client``'s held stream update (a synchronous client's, see :meth:`_put_stream`)
        to the sending thread, if any: before its next reply. True when there was one."""
        held = self._held_updates.pop(client, None)
        if held is None:
            return False
        self._hand(client, *held)
        return True

    def _hand(self, client: str, sess: Session | None, send, waits: list, bulk: bool) -> None:
        if sess is not None:
            self.sessions.handed_over(sess)
        self.courier.send(client, send, waits, bulk)
