"""The transfer folder and the files clients name: ``simxTransferFile``, ``simxEraseFile``,
and where ``simxLoadScene``/``simxLoadModel`` find a file (options bit 0: the client's, in the
transfer folder; else a server-side path in a trusted folder). Trust rules: docs/SECURITY.md,
"Files and scenes sent by clients"; the folder itself and the checks: scene_guard.

Runs on the simulation thread, like every handler; nothing here is on a per-call hot path.
"""

from __future__ import annotations

import logging
import os
import shutil
import weakref
from pathlib import Path, PurePosixPath
from typing import Any, Iterable

from simx_wire.protocol import ArgumentError, RemoteError
from simx_server.base import limits
from simx_server.base import scene_guard as guard
from simx_server.base.arguments import quote
from simx_server.scene.ttt import cache as ttt_cache

log = logging.getLogger("simx.editing")


class ClientFiles:
    """The transfer folder of one server process and the folders it trusts.

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

    def transfer_path(self, name: Any) -> Path:
        """Where a transferred file called ``name`` lives; refuses names outside the folder
        and the server's own names (``.simx*``)."""
        if not isinstance(name, str) or not name or "\x00" in name:
            raise ArgumentError("file name must be a non-empty string")
        pure = PurePosixPath(name)
        path = (self.files_dir / pure).resolve()
        if pure.is_absolute() or ".." in pure.parts or self.files_dir not in path.parents:
            raise ArgumentError(f"file name {quote(name)} refused: outside the transfer folder")
        if any(part.startswith(".simx") for part in pure.parts):
            raise ArgumentError(f"file name {quote(name)} refused: names starting with .simx are reserved")
        return path

    def public(self, path: Path) -> str:
        """``path`` as a client may see it: files in the transfer folder by their name in it; a
        V-REP file's conversion as that file."""
        path = ttt_cache.origin(path)
        if guard.inside(path, self.files_dir):
            return path.relative_to(self.files_dir).as_posix()
        return str(path)

    def scrub(self, text: str) -> str:
        """An error text without the transfer folder's path (it is never named in replies)."""
        return text.replace(f"{self.files_dir}{os.sep}", "").replace(str(self.files_dir), "<transfer folder>")

    def transfer_file(self, name: str, data: Any) -> None:
        """``simxTransferFile``: store ``data`` as ``name`` in the transfer folder.

        Raises:
            ArgumentError: a name outside the folder or reserved, data not bytes or larger than
                ``MAX_TRANSFER_FILE_BYTES``.
            RemoteError: the folder would hold more than ``MAX_TRANSFER_FILES`` entries or
                ``MAX_TRANSFER_FOLDER_BYTES``; the file cannot be written.
        """
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise ArgumentError(f"file data must be bytes, got {type(data).__name__}")
        path = self.transfer_path(name)
        size = len(data)
        if size > limits.MAX_TRANSFER_FILE_BYTES:
            raise ArgumentError(f"file {quote(name)} refused: {size:,} bytes, more than "
                                f"MAX_TRANSFER_FILE_BYTES = {limits.MAX_TRANSFER_FILE_BYTES:,}")
        entries, used = guard.folder_usage(self.files_dir)
        try:
            old = path.stat().st_size if path.is_file() else None
        except OSError:
            old = None
        new_entries = (old is None) + sum(1 for p in path.parents if guard.inside(p, self.files_dir)
                                          and p != self.files_dir and not p.exists())
        if entries + new_entries > limits.MAX_TRANSFER_FILES:
            raise RemoteError(f"file {quote(name)} refused: the transfer folder holds {entries:,} files and "
                              f"folders, MAX_TRANSFER_FILES = {limits.MAX_TRANSFER_FILES:,} (erase some)")
        if used - (old or 0) + size > limits.MAX_TRANSFER_FOLDER_BYTES:
            raise RemoteError(f"file {quote(name)} refused: the transfer folder would hold {used - (old or 0) + size:,}"
                              f" bytes, more than MAX_TRANSFER_FOLDER_BYTES = {limits.MAX_TRANSFER_FOLDER_BYTES:,}"
                              " (erase some)")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(path.name + ".part")
            tmp.write_bytes(bytes(data))
            tmp.replace(path)
        except OSError as exc:
            raise RemoteError(f"cannot store {quote(name)}: {exc.strerror}") from exc
        log.info("received file %s (%d bytes)", quote(name), size)

    def erase_file(self, name: str) -> None:
        """``simxEraseFile``: delete a transferred file."""
        path = self.transfer_path(name)
        if not path.is_file():
            raise RemoteError(f"no transferred file {quote(name)}")
        try:
            path.unlink()
        except OSError as exc:  # str(exc) would name the transfer folder
            raise RemoteError(f"cannot erase {quote(name)}: {exc.strerror}") from None

    def resolve(self, path: Any, options: int, scene: Path) -> Path:
        """A model or scene file: options bit 0 -> a transferred file, else a server path,
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
        # a V-REP scene or model: its MJCF conversion (a client's: into its transfer folder)
        try:
            return ttt_cache.mjcf_for(file, self.files_dir / ".simx" / "ttt" if options & 1 else None)
        except (ValueError, OSError) as exc:
            raise RemoteError(self.scrub(f"cannot load {quote(path)}: {exc}")) from None

    def locate(self, path: Any, options: int, scene: Path) -> Path:
        """The file :meth:`resolve` loads, under the same rules, before any conversion (a
        ``.ttt`` as itself). Raises as :meth:`resolve`."""
        if not isinstance(path, str) or not path or "\x00" in path:
            raise ArgumentError("file path must be a non-empty string")
        if options & 1:
            file = self.transfer_path(path)
            if not file.is_file():
                raise RemoteError(f"no transferred file {quote(path)}")
            return file
        file = Path(path)
        if not file.is_absolute():
            here = Path(scene).parent
            file = (here if not guard.is_transferred(here) else self.roots[0]) / file
        file = Path(os.path.realpath(file))
        if not any(guard.inside(file, root) for root in self.roots) or guard.is_transferred(file):
            raise RemoteError(f"server-side file {quote(path)} refused: server-side scenes and models are "
                              "loaded only from the server's scene folder and its --scene-path folders "
                              "(a client's own file: options bit 0)")
        if not file.is_file():
            raise RemoteError(f"no server-side file {quote(path)}")
        return file
