"""The transfer folder, each client's folder in it, and the files clients name: ``simxTransferFile``,
``simxEraseFile``, where ``simxLoadScene``/``simxLoadModel`` find a file (options bit 0: the
client's own, in its folder; else a server-side path in a trusted folder), and where the ``sim``
file calls (``sim.saveScene``, ``sim.saveImage``, ``sim.loadImage``, ``sim.importShape``...) may
write and read. Trust rules: docs/SECURITY.md, "Files and scenes sent by clients"; the folder
itself and the checks: scene_guard.

Who calls: a front door sets :attr:`ClientFiles.caller` (``"zmq:<uuid>"``, ``"legacy:<id>"``)
around each request it serves (:meth:`ClientFiles.acting`) and calls :meth:`ClientFiles.release`
when the client leaves. A client's files live in ``<transfer folder>/.simx-clients/<hash of its
key>`` (0700, made at its first file), within ``MAX_CLIENT_FILES_BYTES`` for it and
``MAX_TRANSFER_FOLDER_BYTES`` for all together; the folder goes when the client leaves, or, when
it holds the loaded scene, when that scene is replaced. In-process use (tests, no door: caller
None) has the transfer folder itself as its folder.

The ``sim`` file calls ask :meth:`ClientFiles.writer` who writes: a script whose file lies in a
client's folder (a scene or model that client sent) always acts as that client, and once that
client has left (its folder gone) it may no longer read or write files; a script of the operator's
scene acts as the client that called it (``simxCallScriptFunction``, ``sim.callScriptFunction``:
:meth:`ClientFiles.on_behalf`) and as the operator otherwise; a door's own calls (the ZMQ ``sim``)
act as the door's caller. The operator (None) writes as V-REP did: relative names in the first
scene's folder, anything in the scene folders, never in a transfer folder.

Runs on the simulation thread, like every handler; nothing here is on a per-call hot path.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import shutil
import threading
import weakref
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import Any, Iterable

from simx_wire.protocol import BUSY, ArgumentError, RemoteError
from simx_server.base import job_ring, limits
from simx_server.base import scene_guard as guard
from simx_server.base.arguments import quote
from simx_server.scene.file_writer import FileWriter
from simx_server.scene.later_writes import LaterWrites
from simx_server.scene.ttt import cache as ttt_cache

log = logging.getLogger("simx.editing")

#: The transfer folder's subfolder that holds one folder per client (a reserved ``.simx`` name).
CLIENTS = ".simx-clients"


def _bounded(name: str) -> PurePosixPath:
    """``name`` as a path, once its length is within the bounds (before any file system call: a
    5,000-character name made the server's own stat raise ENAMETOOLONG, whose message named the
    server's folder to the client). Raises ArgumentError."""
    pure = PurePosixPath(name)
    if len(name.encode("utf-8", "surrogatepass")) > limits.MAX_FILE_NAME_BYTES or any(
            len(part.encode("utf-8", "surrogatepass")) > limits.MAX_FILE_NAME_PART_BYTES for part in pure.parts):
        raise ArgumentError(f"file name {quote(name)} refused: at most {limits.MAX_FILE_NAME_BYTES} bytes "
                            f"(limits.MAX_FILE_NAME_BYTES), {limits.MAX_FILE_NAME_PART_BYTES} between two '/' "
                            "(limits.MAX_FILE_NAME_PART_BYTES)")
    return pure


class ClientFiles(LaterWrites):
    """The transfer folder of one server process, its clients' folders, and the trusted folders.

    Args:
        scene: the scene the server started with (the operator's): its folder is trusted.
        scene_paths: the ``--scene-path`` folders, trusted too.

    The folder (``<tmp>/simx-<pid>-<start>-*``, 0700, marked) is made at once, after stale
    folders of dead servers are swept; :meth:`close` removes it, and so does the
    interpreter's exit.
    """

    def __init__(self, scene: Path, scene_paths: Iterable[str | Path] = ()):
        self.files_dir = guard.make_transfer_folder()
        self.close = weakref.finalize(self, shutil.rmtree, str(self.files_dir), ignore_errors=True)
        self.roots = [Path(os.path.realpath(ttt_cache.origin(scene).parent)),
                      *(Path(os.path.realpath(p)) for p in scene_paths)]
        #: The client the simulation thread serves now (set by the doors), None: no client.
        self.caller: str | None = None
        self._script_caller: str | None = None  # the client that called into a script now
        self._folders: dict[str, Path] = {}  # client key -> its folder
        self._usage: dict[str, tuple[int, int]] = {}  # client key ("" the in-process one) -> (entries, bytes)
        self._scene_key: str | None = None  # the client whose folder holds the loaded scene
        self._gone: set[str] = set()  # clients gone whose folder holds the loaded scene
        # simxTransferFile's writes, off the simulation thread (one at a time, each client's in order,
        # the clients in turn):
        self._lock = threading.Lock()  # _usage and _pending: the writing thread updates them too
        self._pending: dict[str, list[Any]] = {}  # key -> [entries, bytes, writes] not written yet
        self._writer = FileWriter()
        self._unwritten: dict[str, int] = {}  # key -> bytes handed to the files' thread, not written yet

    # ------------------------------------------------------------- who calls
    @contextlib.contextmanager
    def acting(self, key: str | None) -> Iterator[None]:
        """Serve client ``key`` (a door's request) inside the block."""
        previous, self.caller = self.caller, key
        if key:
            self._gone.discard(key)
        try:
            yield
        finally:
            self.caller = previous

    @contextlib.contextmanager
    def on_behalf(self) -> Iterator[None]:
        """A client's call into a scene script (simxCallScriptFunction): the operator's scripts
        write and read as that client inside the block."""
        previous, self._script_caller = self._script_caller, self.caller
        try:
            yield
        finally:
            self._script_caller = previous

    def writer(self, script_path: Path | None) -> str | None:
        """Who a ``sim`` file call acts as (see the module's text): a client's key (``""``: the
        in-process caller's folder) or None for the operator.

        Args:
            script_path: the calling script's file, None for a door's own calls (a ZMQ client's ``sim``).

        Raises:
            RemoteError: the script was sent by a client that has left (its folder went): it
                acts as nobody, never as the operator.
        """
        if script_path is None:
            return self.caller
        key = self.key_of(Path(script_path))
        if key is None and guard.inside(Path(os.path.realpath(script_path)), self.files_dir):
            raise RemoteError("this script was sent by a client that has left: its files went with it")
        return key if key is not None else self._script_caller

    # ------------------------------------------------------------- folders
    def folder(self, key: str | None) -> Path:
        """The folder of client ``key`` (made now if need be); the transfer folder itself for
        the in-process caller (None or ``""``)."""
        if not key:
            return self.files_dir
        folder = self._folders.get(key)
        if folder is None:
            folder = self.files_dir / CLIENTS / hashlib.sha256(key.encode("utf-8", "surrogatepass")).hexdigest()[:32]
            folder.mkdir(parents=True, exist_ok=True, mode=0o700)
            self._folders[key] = folder
        return folder

    def key_of(self, path: Path) -> str | None:
        """The client whose folder holds ``path`` (``""``: the transfer folder's own files), or
        None when it lies in no folder of this server's."""
        path = Path(os.path.realpath(path))
        for key, folder in self._folders.items():
            if guard.inside(path, folder):
                return key
        if guard.inside(path, self.files_dir) and not guard.inside(path, self.files_dir / CLIENTS):
            return ""
        return None

    def release(self, key: str) -> None:
        """Client ``key`` left: its jobs not started go (long calls, conversions that would write
        here: ``job_ring.cancel_all``), then its folder, and its budget with it (kept while the
        loaded scene lies in it: then it goes when that scene is replaced)."""
        job_ring.cancel_all(key)
        self.settle(key, wait=True)
        if key == self._scene_key:
            self._gone.add(key)
            return
        self._remove(key)

    def settle(self, key: str | None, wait: bool = False) -> None:
        """What client ``key`` does next with its files sees its writes (``simxTransferFile``,
        off the simulation thread) done: raises RemoteError (``server busy``) while some are
        not, so that the simulation thread never waits behind the files' thread (a client's
        blocking transfer is answered once written); ``wait``: wait for them instead (the
        client left: its folder goes after them).

        Raises:
            RemoteError: without ``wait``, writes of the client not done yet."""
        with self._lock:
            writes = list(self._pending.get(key or "", (0, 0, []))[2])
        if writes and not wait:
            raise RemoteError(f"{BUSY}: {len(writes)} file(s) this client sent are being written; "
                              "send it again once they are (a blocking simxTransferFile returns then)")
        for write in writes:
            try:
                write.result()
            except Exception:  # its own reply says why
                pass

    def scene_installed(self, file: Path) -> None:
        """``file`` is now the loaded scene: the folder of a client that left and held the
        scene before goes."""
        previous, key = self._scene_key, self.key_of(file)
        self._scene_key = key or None
        if previous and previous != self._scene_key and previous in self._gone:
            self._gone.discard(previous)
            self._remove(previous)

    def _remove(self, key: str) -> None:
        folder = self._folders.pop(key, None)
        with self._lock:
            self._usage.pop(key, None)
            self._pending.pop(key, None)
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
            log.info("files of client %s removed", quote(key, 60))

    def _measure(self, key: str) -> tuple[int, int]:
        usage = guard.folder_usage(self.folder(key))
        with self._lock:
            self._usage[key] = usage
        return usage

    # ------------------------------------------------------------- names
    def transfer_path(self, name: Any, key: str | None = None) -> Path:
        """Where the file called ``name`` of the calling client (or of ``key``) lives; refuses
        names outside its folder and the server's own names (``.simx*``)."""
        if not isinstance(name, str) or not name or "\x00" in name:
            raise ArgumentError("file name must be a non-empty string")
        pure = _bounded(name)
        folder = self.folder(self.caller if key is None else key)
        path = (folder / pure).resolve()
        if pure.is_absolute() or ".." in pure.parts or folder not in path.parents:
            raise ArgumentError(f"file name {quote(name)} refused: outside the transfer folder (a relative "
                                "name in the client's own folder)")
        if any(part.startswith(".simx") for part in pure.parts):
            raise ArgumentError(f"file name {quote(name)} refused: names starting with .simx are reserved")
        return path

    def public(self, path: Path) -> str:
        """``path`` as a client may see it: files in a client's folder by their name in it; a
        V-REP file's conversion as that file."""
        path = ttt_cache.origin(path)
        key = self.key_of(path)
        if key is not None:
            return Path(os.path.realpath(path)).relative_to(self.folder(key)).as_posix()
        return str(path)

    def scrub(self, text: str) -> str:
        """An error text without the transfer folder's path (it is never named in replies)."""
        for folder in sorted(self._folders.values(), key=lambda f: -len(str(f))):
            text = text.replace(f"{folder}{os.sep}", "").replace(str(folder), "<your folder>")
        return text.replace(f"{self.files_dir}{os.sep}", "").replace(str(self.files_dir), "<transfer folder>")

    # ------------------------------------------------------------- writing
    def store(self, path: Path, data: bytes, key: str | None, name: str) -> None:
        """Write ``data`` as ``path`` (in the folder of client ``key``), within its budgets.

        Raises:
            RemoteError: past a budget (:meth:`_reserve`); the file cannot be written.
        """
        key = key or ""
        self._write(path, data, key, name, self._reserve(path, len(data), key, name))

    def _reserve(self, path: Path, size: int, key: str, name: str) -> tuple[int, int]:
        """Count ``size`` bytes for ``path`` against client ``key``'s budgets before it is written;
        returns the ``(entries, bytes)`` counted, which :meth:`_write` gives back once written.

        Raises:
            RemoteError: its folder would hold more than ``MAX_TRANSFER_FILES`` entries or
                ``MAX_CLIENT_FILES_BYTES``; above its ``MIN_CLIENT_FILES_BYTES``, more than its
                share of the pool (the pool divided by the clients holding files) or more than
                the pool; all clients' folders more than ``MAX_TRANSFER_FOLDER_BYTES``.
        """
        folder = self.folder(key)
        if key not in self._usage:
            self._measure(key)
        try:
            old = path.stat().st_size if path.is_file() else None
        except OSError:
            old = None
        new_entries = (old is None) + sum(1 for p in path.parents if guard.inside(p, folder)
                                          and p != folder and not p.exists())
        with self._lock:
            entries, used = self._usage[key]
            p_entries, p_bytes, _ = self._pending.get(key, (0, 0, []))
            entries, used = entries + p_entries, used + p_bytes
            if entries + new_entries > limits.MAX_TRANSFER_FILES:
                raise RemoteError(f"file {quote(name)} refused: this client's folder holds {entries:,} files and "
                                  f"folders, MAX_TRANSFER_FILES = {limits.MAX_TRANSFER_FILES:,} (erase some)")
            mine = used - (old or 0) + size
            if mine > limits.MAX_CLIENT_FILES_BYTES:
                raise RemoteError(f"file {quote(name)} refused: this client's files would take {mine:,} bytes, more "
                                  f"than MAX_CLIENT_FILES_BYTES = {limits.MAX_CLIENT_FILES_BYTES:,} (erase some)")
            others = {k: b + self._pending.get(k, (0, 0, []))[1] for k, (_, b) in self._usage.items() if k != key}
            base = limits.MIN_CLIENT_FILES_BYTES
            pool = max(0, limits.MAX_TRANSFER_FOLDER_BYTES - limits.RESERVED_CLIENT_FILES_BYTES)
            holders = 1 + sum(1 for b in others.values() if b > 0)
            share = pool // holders
            if mine - base > share:
                raise RemoteError(f"file {quote(name)} refused: this client's files would take {mine:,} bytes, more "
                                  f"than its share of the transfer folder with {holders} clients holding files: "
                                  f"{base + share:,} (MIN_CLIENT_FILES_BYTES = {base:,} and the rest of "
                                  f"MAX_TRANSFER_FOLDER_BYTES shared; erase some)")
            if max(0, mine - base) + sum(max(0, b - base) for b in others.values()) > pool:
                raise RemoteError(f"file {quote(name)} refused: the clients' files above their "
                                  f"MIN_CLIENT_FILES_BYTES = {base:,} fill their part of MAX_TRANSFER_FOLDER_BYTES = "
                                  f"{limits.MAX_TRANSFER_FOLDER_BYTES:,} (erase some)")
            total = mine + sum(others.values())
            if total > limits.MAX_TRANSFER_FOLDER_BYTES:
                raise RemoteError(f"file {quote(name)} refused: the clients' files would take {total:,} bytes, more "
                                  f"than MAX_TRANSFER_FOLDER_BYTES = {limits.MAX_TRANSFER_FOLDER_BYTES:,} (erase some)")
            reserved = (new_entries, size - (old or 0))
            pending = self._pending.setdefault(key, [0, 0, []])
            pending[0] += reserved[0]
            pending[1] += reserved[1]
            return reserved

    def _write(self, path: Path, data: bytes, key: str, name: str, reserved: tuple[int, int]) -> None:
        """Write a file :meth:`_reserve` counted (``reserved``), then count what the folder holds."""
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(path.name + ".part")
            tmp.write_bytes(data)
            tmp.replace(path)
        except OSError as exc:  # str(exc) would name the folder
            raise RemoteError(f"cannot store {quote(name)}: {exc.strerror}") from None
        finally:
            usage = guard.folder_usage(self.folder(key))
            with self._lock:
                self._usage[key] = usage
                pending = self._pending.get(key)
                if pending is not None:
                    pending[0] -= reserved[0]
                    pending[1] -= reserved[1]

    def erase_file(self, name: str) -> None:
        """``simxEraseFile``: delete a file of the calling client's folder."""
        self.settle(self.caller)
        path = self.transfer_path(name)
        if not path.is_file():
            raise RemoteError(f"no transferred file {quote(name)}")
        try:
            path.unlink()
        except OSError as exc:  # str(exc) would name the transfer folder
            raise RemoteError(f"cannot erase {quote(name)}: {exc.strerror}") from None
        finally:
            self._measure(self.caller or "")

    # --------------------------------------------------- the sim calls' files
    def target(self, name: str, key: str | None, what: str) -> Path:
        """Where a ``sim`` call (``sim.saveScene``, ``sim.saveImage``...) acting as ``key`` (see
        :meth:`writer`) writes the file ``name``: a client, by a relative name in its own folder;
        the operator, in the scene folders (relative: the first scene's), never in a transfer
        folder.

        Raises:
            ArgumentError: a client's name outside its folder or reserved.
            RemoteError: the operator's file outside the scene folders; no such folder.
        """
        if key is not None:
            self.settle(key)
            file = self.transfer_path(name, key)
        else:
            _bounded(name)
            file = Path(name)
            if not file.is_absolute():
                file = self.roots[0] / file
            file = Path(os.path.realpath(file))
            if not any(guard.inside(file, root) for root in self.roots) or guard.is_transferred(file):
                raise RemoteError(f"file {quote(name)} refused: {what} writes only in the server's scene folder and "
                                  "its --scene-path folders")
        if not file.parent.is_dir():
            raise RemoteError(f"no folder for {quote(name)}")
        return file

    def write(self, file: Path, data: bytes, key: str | None, name: str) -> None:
        """Write a file :meth:`target` gave: a client's within its budgets (:meth:`store`)."""
        if key is not None:
            self.store(file, data, key, name)
            return
        file.write_bytes(data)

    def source(self, name: str, key: str | None, what: str, here: Path | None = None) -> Path:
        """The file a ``sim`` call acting as ``key`` reads (``sim.loadImage``,
        ``sim.importShape``...): in the scene folders (not a transfer folder) or the caller's
        own folder (the operator: the in-process caller's). A relative name is the caller's own
        file where it has one, else relative to ``here`` (default: the first scene's folder). The
        refusal reads the same whether the file exists or not.

        Raises:
            RemoteError: anywhere else.
        """
        self.settle(key)
        own = self.folder(key)  # the operator: the in-process caller's (the transfer folder itself)
        _bounded(name)
        file = Path(name)
        if not file.is_absolute():
            mine = Path(os.path.realpath(own / file))
            file = mine if guard.inside(mine, own) and mine.is_file() else (here or self.roots[0]) / file
        file = Path(os.path.realpath(file))
        if not ((guard.inside(file, own) and self.key_of(file) == (key or ""))
                or any(guard.inside(file, root) and not guard.is_transferred(file) for root in self.roots)):
            raise RemoteError(f"{what}: {quote(name)} refused: files are read only from the server's scene folder, "
                              "its --scene-path folders and the client's own files")
        return file

    # ------------------------------------------------------------- scenes
    def resolve(self, path: Any, options: int, scene: Path) -> Path:
        """A model or scene file: options bit 0 -> the calling client's file, else a server path,
        absolute or relative to the folder of ``scene`` (the loaded one; the first scene's folder
        while the loaded scene is a client's), which must lie in the first scene's folder or a ``--scene-path`` folder
        and in no transfer folder (of this server or another). A ``.ttt``/``.ttm`` file gives
        its MJCF conversion (:mod:`simx_server.scene.ttt.cache`).

        Raises:
            ArgumentError: not a non-empty string, or a transferred name outside the folder.
            RemoteError: refused (the same text whether or not such a file exists), or missing.
        """
        file = self.locate(path, options, ttt_cache.origin(scene))
        if not ttt_cache.is_vrep_file(file):
            return file
        # a V-REP scene or model: its MJCF conversion (a client's: into its own folder)
        try:
            return ttt_cache.mjcf_for(file, self.folder(self.caller) / ".simx" / "ttt" if options & 1 else None)
        except (ValueError, OSError) as exc:
            raise RemoteError(self.scrub(f"cannot load {quote(path)}: {exc}")) from None

    def root_of(self, file: Path) -> Path:
        """The client's folder that holds ``file`` (the transfer folder for in-process files)."""
        return self.folder(self.key_of(file) or "")

    def locate(self, path: Any, options: int, scene: Path) -> Path:
        """The file :meth:`resolve` loads, under the same rules, before any conversion (a
        ``.ttt`` as itself). Raises as :meth:`resolve`."""
        if not isinstance(path, str) or not path or "\x00" in path:
            raise ArgumentError("file path must be a non-empty string")
        if options & 1:
            self.settle(self.caller)
            file = self.transfer_path(path)
            if not file.is_file():
                raise RemoteError(f"no transferred file {quote(path)}")
            return file
        _bounded(path)
        file = Path(path)
        if not file.is_absolute():
            here = Path(scene).parent
            file = (here if not guard.is_transferred(here) else self.roots[0]) / file
        file = Path(os.path.realpath(file))
        if not any(guard.inside(file, root) for root in self.roots) or guard.is_transferred(file):
            raise RemoteError(f"server-side file {quote(path)} refused: server-side scenes and models are "
                              "loaded only from the server's scene folder and its --scene-path folders "
                              "(a client's own file: options bit 0)")
        try:
            found = file.is_file()
        except OSError:  # a folder it may not read: its text would name the path
            found = False
        if not found:
            raise RemoteError(f"no server-side file {quote(path)}")
        return file
