"""The viewer feed: what ``simx-viewer`` needs to show the running scene.

Two Zenoh declarations on the server's session (keys and messages in ``simx_wire.protocol``,
docs/PROTOCOL.md "The viewer feed"):

* ``<prefix>/viewer/model``, a queryable: the compiled model as MuJoCo's binary ``mjb``
  (``mj_saveModel``; exact, assets included), the *generation* that identifies it, and the
  current state. Zenoh's thread only queues the query (bounded by
  ``limits.MAX_VIEWER_QUERIES`` waiting and ``limits.MAX_VIEWER_MODELS_PER_SECOND`` answered);
  the simulation thread, which owns the model, encodes the answer and a sending thread
  (:mod:`simx_server.loop.courier`) sends it, so a viewer that stops reading holds no
  simulation step.
* ``<prefix>/viewer/state``, a publisher: after every simulation step, and at idle ticks when
  the state changed (a stop's reset, a joint set while stopped, a scene load), ``[generation,
  time, qpos, qvel, mocap_pos, mocap_quat]`` as float64 bytes, **only while a subscriber
  exists**. Zenoh's matching listener keeps :attr:`ViewerFeed.watched` up to date, so with no
  viewer a step costs one attribute test.

The generation changes whenever the model the viewer should show changes: another scene
(``simxLoadScene``, ``simxCloseScene``), an edit that recompiles the model (``simxLoadModel``,
``simxRemoveObject``, ``sim.importShape``...: ``World.replace_model``) or a colour set in place
(``sim.setShapeColor`` writes ``geom_rgba``). A viewer reads the state only: nothing here
writes to MuJoCo's model or data.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any, Callable

import mujoco
import numpy as np
import zenoh

from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.base.arguments import quote
from simx_server.legacy.replies import answer

log = logging.getLogger("simx.viewer")


class ViewerFeed:
    """The server's side of simx-viewer: one per :class:`simx_server.legacy.server.LegacyDoor`.

    Args:
        prefix: the server's key-expression prefix.
        enqueue: puts an item in the simulation thread's ready ring (``("viewer-model", query)``
            items come back to :meth:`answer` on that thread).
        send: hands a send to the sending thread (``Courier.send(lane, job)``).

    Attributes:
        watched: True while at least one subscriber matches the state publisher (set by
            Zenoh's thread; read once per step by the simulation thread).
        published: number of states put since the server started.
    """

    def __init__(self, prefix: str, enqueue: Callable[[Any], None], send: Callable[..., None]):
        self.prefix = prefix
        self._send = send
        self.watched = False
        self.published = 0
        self._enqueue = enqueue
        self._waiting = 0  # model queries queued for the simulation thread
        self._count = threading.Lock()  # Zenoh's threads add to _waiting, the simulation thread takes
        # a change of watchers (Zenoh's thread) waits for a put under way (the simulation thread),
        # so that no state is put once "no viewer is watching" was seen
        self._watchers = threading.RLock()
        self._tokens = float(limits.MAX_VIEWER_QUERIES)  # answers allowed now (token bucket)
        self._refilled = time.monotonic()
        self._publisher: zenoh.Publisher | None = None
        self._world: Any = None  # the world and model the generation was given for
        self._model: mujoco.MjModel | None = None
        self._rgba: np.ndarray | None = None
        self._generation = 0
        self._mjb: bytes | None = None
        self._last: bytes | None = None

    def open(self, session: zenoh.Session) -> None:
        """Declare the queryable, the publisher and its matching listener on ``session``."""
        self._queryable = session.declare_queryable(
            P.viewer_model_key(self.prefix), zenoh.handlers.Callback(self._on_query, indirect=False))
        # Drop (Zenoh's default for puts): a slow viewer loses states, it never holds up a step.
        self._publisher = session.declare_publisher(
            P.viewer_state_key(self.prefix), congestion_control=zenoh.CongestionControl.DROP)
        self._listener = self._publisher.declare_matching_listener(
            zenoh.handlers.Callback(self._on_matching, indirect=False))

    # ------------------------------------------------------------- Zenoh's threads
    def _on_matching(self, status: zenoh.MatchingStatus) -> None:
        watched = bool(status.matching)
        with self._watchers:
            if watched != self.watched:
                self._last = None  # the first state after a change of watchers is always put
                self.watched = watched
                log.info("viewer feed: %s (%d states published so far)",
                         "a viewer is watching" if watched else "no viewer is watching", self.published)

    def _on_query(self, query: zenoh.Query) -> None:
        with self._count:
            now = time.monotonic()
            self._tokens = min(float(limits.MAX_VIEWER_QUERIES),
                               self._tokens + (now - self._refilled) * limits.MAX_VIEWER_MODELS_PER_SECOND)
            self._refilled = now
            if self._waiting >= limits.MAX_VIEWER_QUERIES:
                busy = f"{limits.MAX_VIEWER_QUERIES} viewer model queries already wait (limits.MAX_VIEWER_QUERIES)"
            elif self._tokens < 1:
                busy = (f"more than {limits.MAX_VIEWER_MODELS_PER_SECOND:g} viewer model queries a second "
                        "(limits.MAX_VIEWER_MODELS_PER_SECOND)")
            else:
                busy = None
                self._waiting += 1
                self._tokens -= 1
        if busy:
            log.warning("viewer model query on %s not queued: %s", quote(str(query.key_expr)), busy)
            self._reply(query, P.error_response(f"server busy: {busy}; ask again later"))
            return
        self._enqueue(("viewer-model", query))

    # ------------------------------------------------------ the simulation thread
    def answer(self, query: zenoh.Query, world: Any) -> None:
        """Encode the reply to a queued model query (the current model, generation and state)
        and hand it to the sending thread."""
        with self._count:
            self._waiting -= 1
        try:
            generation = self._current(world)
            if self._mjb is None:
                model = world.model
                buffer = np.empty(mujoco.mj_sizeModel(model), np.uint8)
                mujoco.mj_saveModel(model, None, buffer)
                self._mjb = buffer.tobytes()
            reply = P.viewer_model(generation, mujoco.mj_versionString(), self._mjb, self._state(world, generation))
        except Exception as exc:  # the server never dies from a viewer
            log.exception("answering a viewer model query")
            reply = P.error_response(f"internal error: {type(exc).__name__}")
        self._reply(query, reply)

    def _reply(self, query: zenoh.Query, reply: bytes) -> None:
        """Send ``reply`` and Zenoh's final reply on the sending thread (a lane of its own)."""
        self._send(("viewer", id(query)), lambda: answer(query, reply))

    def publish(self, world: Any) -> None:
        """Put the current state when it differs from the last one put, while a viewer watches
        (checked by the caller to spare the state's cost, and again here, with the watchers)."""
        try:
            payload = self._state(world, self._current(world))
            with self._watchers:
                if self.watched and payload != self._last:
                    self._publisher.put(payload)
                    self._last = payload
                    self.published += 1
        except Exception:  # a viewer must never stop the simulation
            log.exception("publishing the viewer state")

    def _current(self, world: Any) -> int:
        """The generation of ``world``'s model: a new one when the world, its model or the
        geoms' colours changed since the last call."""
        model = world.model
        if world is not self._world or model is not self._model \
                or not np.array_equal(model.geom_rgba, self._rgba):
            self._world, self._model, self._rgba = world, model, model.geom_rgba.copy()
            self._generation += 1
            self._mjb = None
        return self._generation

    @staticmethod
    def _state(world: Any, generation: int) -> bytes:
        d = world.data
        return P.viewer_state(generation, float(d.time), d.qpos.astype("<f8").tobytes(),
                              d.qvel.astype("<f8").tobytes(), d.mocap_pos.astype("<f8").tobytes(),
                              d.mocap_quat.astype("<f8").tobytes())
