"""Streamed commands (``simx_opmode_streaming``): each client's streams are executed again after
every simulation step and published on ``simx/<name>/stream/<client>`` (images once the render
thread has drawn them, in order), each update within the reply budget
(``limits.MAX_REPLY_BYTES``). A mixin of :class:`simx_server.transport.server.Server`.
"""

from __future__ import annotations

import logging
import time
from concurrent.futures import Future

from simx_client import protocol as P
from simx_server.base import limits
from simx_server.commands import HANDLERS
from simx_server.sim.vision import Deferred
from simx_server.transport.replies import IMAGES, SMALL, image_size, reply_size
from simx_server.transport.sessions import Session

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


class StreamPublisher:
    """Publishing of the clients\x27 streams (needs the server\x27s ``session``, ``prefix``, ``sim``, ``sessions``, ``viewers``, ``_streams``, ``_stream_renders`` and ``_resolve``)."""

    def _publish_streams(self) -> None:
        if self.session is None:
            return
        if self.viewers.watched:  # the whole cost of the viewer feed without a viewer
            self.viewers.publish(self.sim.world)
        now = time.monotonic()
        sim = self.sim
        # Image streams wait while the render thread still has limits.MAX_STREAM_STEPS_RENDERING
        # steps of streamed frames to make: every client's image streams skip steps meanwhile (they
        # get the newest frame once it is free), so another client's image request never waits
        # behind more than that (50 streams of a 4096x4096 sensor made it wait 4.2 s).
        self._stream_renders = [f for f in self._stream_renders if not f.done()]
        rendering = len(self._stream_renders) >= limits.MAX_STREAM_STEPS_RENDERING
        last = None
        for client, streams in self._streams.items():
            if not streams:
                continue
            session = self.sessions.get(client)
            images = not rendering and self.sessions.can_render(session)  # else its image streams skip this step
            budget = limits.MAX_REPLY_BYTES
            entries = []
            for ident, s in streams.items():
                if s.delay and now - s.last < s.delay:
                    continue
                name = s.name
                if name in IMAGES:
                    if not images:
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
                    if type(value) not in SMALL and type(value) is not Deferred:
                        budget -= reply_size(value)
                        if budget < 0:
                            budget += reply_size(value)
                            raise P.RemoteError(f"not sent: the update would exceed {limits.MAX_REPLY_BYTES} "
                                                "bytes (limits.MAX_REPLY_BYTES)")
                    entries.append([name, list(ident[1:]), True, value])
                except P.RemoteError as exc:
                    entries.append([name, list(ident[1:]), False, str(exc)[:limits.MAX_ERROR_CHARS]])
                except Exception as exc:
                    log.exception("client %s: streamed simx%s raised", client, name)
                    entries.append([name, list(ident[1:]), False, f"internal error: {type(exc).__name__}"])
            if entries:
                last = self._put_stream(client, session, entries) or last
        if last is not None:  # the render thread's jobs run in order: the step's last is its end
            self._stream_renders.append(last)

    def _put_stream(self, client: str, sess: Session | None, entries: list) -> Future | None:
        """Publish one client's stream update: at once, or (images) once the render thread has
        made its frames; then returns the render-thread job that publishes it."""
        session, key, t = self.session, P.stream_key(self.prefix, client), self.sim.sim_time_ms

        def put() -> None:
            try:
                results = self._resolve([[ok, value] for *_, ok, value in entries], client)
                session.put(key, P.stream_update(t, [e[:2] + r for e, r in zip(entries, results)]))
            except Exception:
                log.exception("client %s: publishing its streams", client)

        if any(type(e[3]) is Deferred for e in entries):
            def put_rendered() -> None:  # images of this step: published once rendered, in order
                try:
                    put()
                finally:
                    if sess is not None:
                        self.sessions.render_done(sess)

            if sess is not None:
                self.sessions.render_started(sess)
            return self.sim.vision.after(put_rendered)
        put()
        return None
