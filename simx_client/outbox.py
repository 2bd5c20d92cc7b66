"""The client's outbox: non-blocking commands waiting to be sent, as the legacy client's
``_messageToSend`` buffer held them between two passes of its communication thread (extApi.c).

Rules (docs/PROTOCOL.md "The client's outbox"):

* a command waiting a second time (same identity, :func:`simx_wire.protocol.identity`) replaces
  the older one, which leaves the outbox: only the newest call runs, at the place of the newest
  call (so a set, an append and a newer set of the same signal run as append then set);
  commands in :data:`~simx_wire.protocol.DO_NOT_OVERWRITE` all stay;
* otherwise the order of the calls is kept;
* :meth:`Outbox.take` empties the outbox into batches of at most :data:`MAX_BATCH_COMMANDS`
  commands and about :data:`MAX_BATCH_BYTES` bytes, one request each;
* a batch the server answered "busy" (:func:`simx_wire.protocol.busy`) goes back to the head
  of the outbox (:meth:`Outbox.refused`), minus the commands that were called again since: the
  newer call waits already, or was sent already in a later request.

Not thread-safe: the :class:`~simx_client.connection.Connection` calls it under its lock.
"""

from __future__ import annotations

import itertools
from typing import Any

from simx_wire import protocol as P

#: Most commands in one request (the server's limits.MAX_COMMANDS_PER_REQUEST is the same value).
MAX_BATCH_COMMANDS = P.MAX_COMMANDS_PER_REQUEST
#: A batch is closed once it holds this many bytes of packed commands (a larger command goes
#: alone); far below the server's limits.MAX_REQUEST_BYTES (64 MiB).
MAX_BATCH_BYTES = 4 * 1024 * 1024


class Batch:
    """Commands taken from the outbox for one request.

    Attributes:
        commands: ``[[name, mode, args], ...]`` in the order they run.
        packed: each command's msgpack bytes (``protocol.pack``), for
            :meth:`~simx_wire.protocol.RequestEncoder.encode_packed`.
        keys: each command's outbox key: its identity, or a unique key for a do-not-overwrite one.
        seq: the batch's number, increasing in the order batches are taken.
    """

    __slots__ = ("commands", "packed", "keys", "seq")

    def __init__(self, seq: int):
        self.commands: list[list] = []
        self.packed: list[bytes] = []
        self.keys: list[Any] = []
        self.seq = seq


class _Unique:
    """The outbox key of a do-not-overwrite command: equal to nothing else."""

    __slots__ = ()


class Outbox:
    """Commands waiting to be sent, keyed by identity, in call order."""

    def __init__(self) -> None:
        self._waiting: dict[Any, tuple[list, bytes]] = {}
        self._seq = itertools.count(1)
        self._open = 0  # batches taken and not yet answered
        self._newest_sent: dict[tuple, int] = {}  # identity -> seq of the newest batch carrying it (while batches are open)

    def __len__(self) -> int:
        return len(self._waiting)

    def __contains__(self, ident: tuple) -> bool:
        """Whether a call of the command ``ident`` waits."""
        return ident in self._waiting

    def commands(self) -> list[list]:
        """The waiting commands ``[name, mode, args]``, in the order they will be sent.

        Returns:
            A new list.
        """
        return [command for command, _ in self._waiting.values()]

    def put(self, ident: tuple, command: list, packed: bytes) -> None:
        """Add a call (``packed`` is ``protocol.pack(command)``): it replaces a waiting call of
        the same command and goes to the end.

        Args:
            ident: the command's identity (``protocol.identity``).
            command: ``[name, mode, args]``.
            packed: its encoding.
        """
        key = _Unique() if command[0] in P.DO_NOT_OVERWRITE else ident
        waiting = self._waiting
        if key in waiting:
            del waiting[key]
        waiting[key] = (command, packed)

    def take(self) -> list[Batch]:
        """Empty the outbox into batches (none when it is empty), oldest calls first.

        Returns:
            Batches of at most MAX_BATCH_COMMANDS commands and MAX_BATCH_BYTES bytes each.
        """
        if not self._waiting:
            return []
        batches: list[Batch] = []
        batch, size = None, 0
        newest = self._newest_sent
        for key, (command, packed) in self._waiting.items():
            if batch is None or len(batch.commands) >= MAX_BATCH_COMMANDS or size + len(packed) > MAX_BATCH_BYTES:
                batch, size = Batch(next(self._seq)), 0
                batches.append(batch)
                self._open += 1
            batch.commands.append(command)
            batch.packed.append(packed)
            batch.keys.append(key)
            size += len(packed)
            if type(key) is not _Unique:
                newest[key] = batch.seq
        self._waiting = {}
        return batches

    def refused(self, batch: Batch) -> None:
        """The server did not queue ``batch``: its commands wait again, ahead of those that came
        since, except the ones called again since (waiting, or sent in a later batch).

        Args:
            batch: a batch :meth:`take` gave.
        """
        newest = self._newest_sent
        back: dict[Any, tuple[list, bytes]] = {}
        for key, command, packed in zip(batch.keys, batch.commands, batch.packed):
            if type(key) is _Unique or (key not in self._waiting and newest.get(key, 0) <= batch.seq):
                back[key] = (command, packed)
                if type(key) is not _Unique:
                    newest.pop(key, None)  # not sent: waiting again
        if back:
            back.update(self._waiting)
            self._waiting = back

    def answered(self, batch: Batch) -> None:
        """``batch``'s request is over (answered, refused or timed out).

        Args:
            batch: a batch :meth:`take` gave.
        """
        self._open -= 1
        if self._open <= 0:
            self._open = 0
            self._newest_sent.clear()  # no batch left that a later one could supersede

    def clear(self) -> None:
        """Forget every waiting command (the connection is lost)."""
        self._waiting = {}
