"""The writes :class:`~simx_server.scene.client_files.ClientFiles` hands to the files' thread
(:class:`~simx_server.scene.file_writer.FileWriter`): ``simxTransferFile`` and the files of a
client's ``sim`` file calls (``sim.saveScene``, ``exportMesh``...), each listed among the
client's writes until done, so that its next file call finds them (``ClientFiles.settle``).
"""

from __future__ import annotations

import logging
from concurrent.futures import Future
from pathlib import Path
from typing import Any, Callable

from simx_wire.protocol import BUSY, ArgumentError, RemoteError
from simx_server.base import limits
from simx_server.base.arguments import quote

log = logging.getLogger("simx.editing")


class LaterWrites:
    """The files' thread's writes of :class:`~simx_server.scene.client_files.ClientFiles` (a
    mixin: it needs ``caller``, ``_lock``, ``_pending``, ``_writer``, ``_unwritten``,
    ``transfer_path``, ``_reserve``, ``_write`` and ``store``)."""

    def transfer_file(self, name: str, data: Any, later: bool = False) -> Future | None:
        """``simxTransferFile``: store ``data`` as ``name`` in the calling client's folder.

        ``later``: the file is counted against the budgets now and written by a thread of its own
        (:class:`~simx_server.scene.file_writer.FileWriter`: one write at a time, the clients in
        turn), off the simulation thread (sixteen 32 MiB writes on it
        pushed other clients' p99 from 5 ms to 1.7 s); returns the write's Future (its result
        None, or the RemoteError). The client's file calls meanwhile are busy (:meth:`settle`).

        Raises:
            ArgumentError: a name outside the folder or reserved, data not bytes or larger than
                ``MAX_TRANSFER_FILE_BYTES``.
            RemoteError: past a budget of :meth:`_reserve`; the file cannot be written.
        """
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise ArgumentError(f"file data must be bytes, got {type(data).__name__}")
        path = self.transfer_path(name)
        size = len(data)
        if size > limits.MAX_TRANSFER_FILE_BYTES:
            raise ArgumentError(f"file {quote(name)} refused: {size:,} bytes, more than "
                                f"MAX_TRANSFER_FILE_BYTES = {limits.MAX_TRANSFER_FILE_BYTES:,}")
        key = self.caller or ""
        if later:
            self._unwritten_room(key, size, name)
        reserved = self._reserve(path, size, key, name)
        data = data if type(data) is bytes else bytes(data)

        def write() -> None:
            try:
                self._write(path, data, key, name, reserved)
            finally:
                if later:
                    with self._lock:
                        self._unwritten[key] -= size
            log.info("received file %s (%d bytes)", quote(name), size)

        if not later:
            write()
            return None
        with self._lock:
            self._unwritten[key] = self._unwritten.get(key, 0) + size
        return self._hand_over(key, write)

    def _hand_over(self, key: str, job: Callable[[], None]) -> Future:
        """``job`` of client ``key`` to the files' thread, listed among its writes (:meth:`settle`)
        until done; its Future."""
        with self._lock:  # the job cannot end (its writes take this lock) before it is listed
            writes = self._pending.setdefault(key, [0, 0, []])[2]
            future = self._writer.submit(key, job)
            writes.append(future)

        def done(_: Future) -> None:
            with self._lock:
                writes.remove(future)

        future.add_done_callback(done)
        return future

    def _unwritten_room(self, key: str, size: int, name: str) -> None:
        """Raises RemoteError (``server busy``) when ``size`` more bytes for the files' thread
        would pass ``MAX_UNWRITTEN_BYTES`` of this client or ``MAX_UNWRITTEN_BYTES_TOTAL``; a
        file of at most ``MIN_CLIENT_FILES_BYTES`` of a client with none being written passes."""
        with self._lock:
            mine, total = self._unwritten.get(key, 0), sum(self._unwritten.values())
        if not mine and size <= limits.MIN_CLIENT_FILES_BYTES:
            return  # a small file of a client with none being written: never kept out by the others'
        if mine + size > limits.MAX_UNWRITTEN_BYTES:
            raise RemoteError(f"{BUSY}: file {quote(name)}: {mine:,} bytes of this client's files are being written "
                              f"(limits.MAX_UNWRITTEN_BYTES = {limits.MAX_UNWRITTEN_BYTES:,}); send it again")
        if total + size > limits.MAX_UNWRITTEN_BYTES_TOTAL:
            raise RemoteError(f"{BUSY}: file {quote(name)}: {total:,} bytes of files are being written "
                              f"(limits.MAX_UNWRITTEN_BYTES_TOTAL = {limits.MAX_UNWRITTEN_BYTES_TOTAL:,}); send it again")

    def write_later(self, key: str, files: Callable[[], list[tuple[Path, bytes, str]]]) -> Future:
        """Make and write files of client ``key`` on the files' thread (``sim.saveScene``,
        ``sim.exportMesh``... of a door that replies once a Future is done): ``files()`` is run
        there, its ``(file, data, name)`` written as :meth:`write` would (files :meth:`target`
        gave, within the client's budgets), so that serialising a large scene or mesh never holds
        the simulation thread. Until it is done the client's file calls are busy (:meth:`settle`).

        Returns:
            The Future of the writes (None, or what ``files`` or a write raised).
        """
        def job() -> None:
            for file, data, name in files():
                self.store(file, data, key, name)

        return self._hand_over(key, job)
