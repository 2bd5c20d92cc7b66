"""Sending a connection's outbox (:mod:`simx_client.outbox`): the sender thread, requests
without waiting for their reply, and "server busy" answers.

:class:`OutboxSender` is a part of :class:`simx_client.connection.Connection` (its base class),
kept apart to keep each module short; it uses the connection's lock, inbox, encoder and
querier. The legacy client's communication thread (extApi.c ``_communicationThread``) sent its
outbox once per ``commThreadCycleInMs`` and waited for the reply before sending again; the
sender thread does the same, except that a command called after a pause of a cycle or more
leaves at once, and that a blocking call sends the outbox right ahead of itself
(:meth:`Connection.request` with ``flush``) instead of waiting for the thread.
"""

from __future__ import annotations

import logging
import threading
import time
from typing import Any

import zenoh

from simx_wire import proof as PR
from simx_wire import protocol as P
from simx_client.outbox import Batch, Outbox

log = logging.getLogger("simx.client")

DEFAULT_CYCLE = 0.005  # s between two requests of the outbox (commThreadCycleInMs 5, the usual)
_RETRY_FIRST, _RETRY_MOST = 0.005, 0.2  # s before a refused batch is sent again (doubling while busy)
_SPLIT = (P.MODE_ONESHOT_SPLIT, P.MODE_STREAMING_SPLIT)
#: Most outbox commands a ``simxSynchronousTrigger`` takes along in its request (OutboxSender._carry);
#: the server's limits.MAX_CARRIED_COMMANDS is the same value.
CARRY_MOST = P.MAX_CARRIED_COMMANDS


def direct(callback: Any, drop: Any = None) -> zenoh.handlers.Callback:
    """A Zenoh callback run on Zenoh's own thread. The default ("indirect") starts a non-daemon
    Python thread per handler, which keeps the interpreter from exiting while a session is open.
    Every callback here is short and never blocks.

    Args:
        callback: called with each sample or reply.
        drop: called once when the handler is dropped, or None.

    Returns:
        The handler, for Zenoh's ``declare_*`` and ``get``.
    """
    return zenoh.handlers.Callback(callback, drop, indirect=False)


class OutboxSender:
    """The outbox of a :class:`~simx_client.connection.Connection` and what sends it."""

    def _init_sender(self, cycle: float) -> None:
        """State of the outbox and its thread (``self._lock`` must exist); the thread starts
        with :meth:`_start_sender` once the connection is up."""
        self._outbox = Outbox()  # non-blocking commands waiting to be sent
        self._paused = False  # simxPauseCommunication
        self.cycle = max(0.0, cycle)  # s between two requests of the outbox
        self._send_lock = threading.Lock()  # taking from the outbox and sending: one thread at a time, in order
        self._wake = threading.Condition(self._lock)  # wakes the sender thread
        self._batches_out = 0  # the sender thread's requests not answered yet
        self._next_send = 0.0  # time.monotonic() before which the outbox is not sent
        self._retry = _RETRY_FIRST
        self._closed = False

    def _start_sender(self) -> None:
        threading.Thread(target=self._send_loop, name=f"simx-outbox-{self.connection_id}", daemon=True).start()

    def _send_loop(self) -> None:
        """The sender thread: sends the outbox once per cycle while it holds commands, one
        request in flight at a time, never while communication is paused."""
        while True:
            with self._lock:
                while True:
                    if self._closed:
                        return
                    if self._outbox and not self._paused and self._alive and not self._batches_out:
                        delay = self._next_send - time.monotonic()
                        if delay <= 0:
                            break
                        self._wake.wait(delay)
                    else:
                        self._wake.wait()
            with self._send_lock:
                try:
                    self._send_outbox(background=True)
                except Exception:  # the sender must outlive any one request
                    log.exception("sending the outbox")

    def _send_outbox(self, background: bool) -> None:
        """Send everything the outbox holds, one request per batch (``_send_lock`` held)."""
        with self._lock:
            if not self._alive or self._closed:
                return
            batches = self._outbox.take()
            if not batches:
                return
            self._next_send = time.monotonic() + self.cycle
            if background:
                self._batches_out += len(batches)
        for batch in batches:
            self._send_async(batch.commands, self._encoder.encode_packed(batch.packed), batch, background)

    def _carry(self, commands: list[list]) -> Batch | None:
        """The outbox, taken as one batch to travel in the request of ``commands`` (``_send_lock``
        held, outbox not empty, communication not paused), or None when it leaves in requests of
        its own (:meth:`_send_outbox`).

        Only a ``simxSynchronousTrigger`` takes it along, as V-REP's client sent what waited in
        its outbox in the message of the blocking call: a step's targets reach the server in the
        trigger's request, one request a step instead of two, and the server serves it in place
        (``simx_server.legacy.sessions.Sessions.carried_trigger``). Other blocking calls do not:
        legacy pacing holds, and serves in place, requests of one blocking command only, which a
        blocking read relies on; a trigger is paced by the barrier instead. Not with split
        commands (the asynchronous path counts them in flight), nor beyond
        :data:`CARRY_MOST` commands (the server serves larger batches round robin)."""
        if len(commands) != 1 or commands[0][0] != "SynchronousTrigger":
            return None
        with self._lock:
            if not self._alive or self._closed or len(self._outbox) > CARRY_MOST:
                return None
            if any(mode & P.MODE_MASK in _SPLIT for _name, mode, _args in self._outbox.commands()):
                return None
            batches = self._outbox.take()
            if len(batches) != 1:  # cannot happen within CARRY_MOST commands; sent apart if it did
                for batch in batches:
                    self._outbox.refused(batch)
                    self._outbox.answered(batch)
                return None
            self._next_send = time.monotonic() + self.cycle
            return batches[0]

    def _carried(self, batch: Batch, message: list | None, epoch: int) -> list:
        """File the results of a carried ``batch`` (the first of ``message``'s results; None:
        no reply) as its own reply would have been filed; returns the other results. A
        "server busy" answer puts the batch back in the outbox."""
        results = [] if message is None else message[5]
        n = len(batch.commands)
        with self._lock:
            try:
                if message is None or epoch != self._epoch or not self._alive:
                    return results[n:]
                if P.busy(results):
                    self._refused(batch)
                    return results[n:]
                self._retry = _RETRY_FIRST
                t = message[1]
                for (name, mode, args), (ok, value) in zip(batch.commands, results):
                    if mode & P.MODE_MASK != P.MODE_DISCONTINUE:
                        self._store(P.identity(name, args), ok, value, t)
                return results[n:]
            finally:
                self._outbox.answered(batch)
                if self._outbox:
                    self._wake.notify()

    def _refused(self, batch: Batch) -> None:
        """The server answered ``batch`` busy (lock held): it waits again, sent after a pause
        that doubles while the server stays busy."""
        self._outbox.refused(batch)
        self._next_send = max(self._next_send, time.monotonic() + max(self._retry, self.cycle))
        if self._retry == _RETRY_FIRST:
            log.info("simx server at %s:%d busy: %d command(s) wait in the outbox and are sent again",
                     self.address, self.port, len(batch.commands))
        self._retry = min(2 * self._retry, _RETRY_MOST)

    def _send_async(self, commands: list[list], payload: bytes | None = None, batch: Batch | None = None,
                    background: bool = False) -> None:
        """Send ``commands`` (``payload``: their request, when encoded already) without waiting:
        the results land in the inbox. ``batch``: the outbox batch they are, which a busy answer
        puts back; ``background``: sent by the sender thread (counted in ``_batches_out``)."""
        payload, header = self._payload(commands, payload)
        secret = self._secret
        split = [P.identity(n, a) for n, m, a in commands if m & P.MODE_MASK in _SPLIT]
        epoch = self._epoch
        answered = []

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is None:
                return
            answered.append(True)
            try:
                message = self._accept(reply.ok.payload.to_bytes(), header)
            except P.ProtocolError as exc:
                log.warning("%s", exc)
                if PR.UNKNOWN in str(exc):  # the server forgot this client: handshake again, off its thread
                    threading.Thread(target=self._rebind, args=(secret,), daemon=True).start()
                return
            t = message[1]
            with self._lock:
                if epoch != self._epoch or not self._alive:
                    return  # a reply of a lost connection: its inbox was cleared
                if batch is not None:
                    if P.busy(message[5]):
                        self._refused(batch)
                        return
                    self._retry = _RETRY_FIRST
                for (name, mode, args), (ok, value) in zip(commands, message[5]):
                    if mode & P.MODE_MASK != P.MODE_DISCONTINUE:
                        self._store(P.identity(name, args), ok, value, t)

        def on_done() -> None:
            if not answered and epoch == self._epoch:
                log.warning("simx server at %s:%d: no reply to %d command(s) sent without waiting",
                            self.address, self.port, len(commands))
            with self._lock:
                for ident in split:
                    self._in_flight[ident] -= 1
                    if not self._in_flight[ident]:
                        del self._in_flight[ident]
                if batch is not None:
                    self._outbox.answered(batch)
                    if background:
                        self._batches_out -= 1
                    if self._outbox:
                        self._wake.notify()

        with self._lock:
            for ident in split:
                self._in_flight[ident] = self._in_flight.get(ident, 0) + 1
        try:
            self._querier.get(direct(on_reply, on_done), payload=payload, attachment=self._seal(payload, header))
        except Exception as exc:  # zenoh.ZError (a closed session), or anything: the batch is over
            answered.append(False)  # said here
            on_done()
            log.warning("sending %d command(s) failed: %s", len(commands), exc)
