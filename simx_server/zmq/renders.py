"""ZMQ calls that wait for a render: their replies leave from the render thread.

A ZMQ image call (``sim.getVisionSensorImg`` and the others of :data:`~simx_server.zmq.budgets.RENDERS`)
is executed on the simulation thread as far as the frames it needs: its arguments are checked,
its frames are submitted to the request render thread, and the job that makes its value from
them (a window cut, bytes or floats) is queued behind them there
(:attr:`~simx_server.api.context.CallContext.defer_renders`: the ``sim`` function answers a
:class:`~simx_server.sim.vision.Deferred`). The simulation thread goes on; once the job is done,
the render thread encodes the reply and hands it to the socket thread (``Frontend.send``), as the
legacy door's image replies leave when their renders are done. A 4096x4096 render (0.5-1.5 s on a
software renderer) thus holds neither the simulation nor another client. Scripts, which run on
the simulation thread and need the value, still wait for it.

The connection cannot send another request meanwhile (its request stays pending in the
frontend: one at a time), and the reply's bytes count toward the unread-reply bounds from
the call on (``Frontend.reserve``): past ``limits.MAX_ZMQ_UNSENT_BYTES`` for the connection or
``MAX_ZMQ_UNSENT_BYTES_TOTAL`` for all, the call answers "server busy" before anything is
rendered. A connection closed while its image renders is sent nothing; its bytes are given back.
"""

from __future__ import annotations

import time
from concurrent.futures import Future
from typing import Any

from simx_server.base import limits
from simx_server.sim.vision import Deferred
from simx_server.zmq import codec
from simx_server.zmq.budgets import held_estimate


class Rendering:
    """A call's reply that the render thread makes: its value's Deferred, the bytes held for it
    (``Frontend.reserve``), and whether its function returns nothing."""

    __slots__ = ("deferred", "held", "returns_none")

    def __init__(self, deferred: Deferred, held: int, returns_none: bool):
        self.deferred, self.held, self.returns_none = deferred, held, returns_none


def values(result: Any, returns_none: bool) -> list:
    """An API function's return as the reply's values: a tuple's items, one value otherwise;
    nothing from a function that returns nothing, nil from one that returns a value."""
    if result is None:
        return [] if returns_none else [None]
    return list(result) if isinstance(result, tuple) else [result]


class RenderedReplies:
    """The ZMQ service's calls that render (mixin of :class:`~simx_server.zmq.service.ZmqService`;
    needs its ``frontend``, ``sim``, ``connections``, ``_call_table``, ``_signature``, ``_error``
    and ``_call_error``), and those whose work another thread does (a .ttt conversion, a long call)."""

    def _render(self, client: Any, func: str, name: str, args: list) -> bytes | Rendering:
        """Start a call that waits for a render (budgets.RENDERS): its frames and the job making
        its value are handed to the render thread, the bytes of its reply held for its connection
        (``Frontend.reserve``: refused "server busy" past the unread-reply bounds, before
        anything is rendered)."""
        held = held_estimate(self.sim, name, args)
        refused = self.frontend.reserve(client.connection, held)
        if refused is not None:
            return self._error(client, func, refused)
        try:
            value = self._call_table(name, args)
        except Exception as exc:
            self.frontend.release(client.connection, held)
            return self._call_error(client, func, exc)
        if type(value) is not Deferred:  # answered without a render (an error's value)
            self.frontend.release(client.connection, held)
            return self._encoded(client, func, value)
        return Rendering(value, held, self._signature(name).return_annotation in ("None", None))

    def _reply_rendered(self, client: Any, envelope: list, func: str, rendering: Rendering) -> None:
        """Send the reply of a call whose value the render thread makes, from that thread once it
        is done; the simulation thread goes on meanwhile. A connection closed meanwhile is sent
        nothing and its bytes are given back."""
        identity, held, returns_none = envelope[0], rendering.held, rendering.returns_none
        if rendering.deferred.thread is None:  # a long call's work (api.long_calls): charged once done
            self._charge_when_done(client, rendering.deferred)

        # ``done`` holds nothing that holds the future: the future keeps its callbacks, and a
        # cycle through them would keep each reply (48 MiB at 4096x4096) until the cyclic
        # collector ran.
        def done(future: Future) -> None:
            if not self.frontend.expects(identity):
                self.frontend.release(identity, held)
                return
            try:
                payload = self._encoded(client, func, values(future.result(), returns_none))
            except Exception as exc:
                payload = self._call_error(client, func, exc)
            self.frontend.send(envelope, payload, held)

        rendering.deferred.future.add_done_callback(done)

    def _charge_when_done(self, client: Any, deferred: Deferred) -> None:
        """Charge the work of a call done off the simulation thread (``deferred.seconds``,
        :mod:`simx_server.api.long_calls`) once done, as a call on that thread is charged: its
        time past limits.MAX_REQUEST_SECONDS, to its connection's share and to its client's
        (``Client.share``: the uuid keeps it on a new connection), before its reply leaves, so
        that its next calls wait their turn (``ZmqService._serve``)."""
        identity = client.connection

        def charge(_future: Future) -> None:  # the long call's thread
            seconds, now = deferred.seconds, time.monotonic()
            connection = self.connections.get(identity)
            if connection is not None:
                connection.charge_call(seconds, now, edit=False)
            client.share.charge(max(0.0, seconds - limits.MAX_REQUEST_SECONDS), now)

        deferred.future.add_done_callback(charge)

    def _encoded(self, client: Any, func: str, items: list) -> bytes:
        """``{ret: items}``, or the error of a reply past limits.MAX_REPLY_BYTES (any thread)."""
        payload = codec.encode_reply(items)
        if len(payload) > limits.MAX_REPLY_BYTES:
            return self._error(
                client,
                func,
                f"the reply would be {len(payload)} bytes, more than {limits.MAX_REPLY_BYTES} (limits.MAX_REPLY_BYTES)",
            )
        return payload
