"""Converted ``.ttt``/``.ttm`` files, cached by content hash: the first load converts (read,
MJCF, meshes, scripts) into ``$XDG_CACHE_HOME/simx/ttt/<hash>/`` (else ``~/.cache/simx/ttt``,
else ``<tmp>/simx-ttt-<uid>``); later loads of the same bytes use that folder at once, as fast
as an MJCF start. Files sent by clients are converted into the transfer folder instead (so
they stay untrusted, docs/SECURITY.md)."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import tempfile
from pathlib import Path

from simx_server.base import file_kinds
from simx_server.scene.ttt import errors as E
from simx_server.scene.ttt.errors import SceneFileError

log = logging.getLogger("simx.ttt")


def _converter_version() -> str:
    """A digest of the converter's source: part of the cache key, so that a changed reader or
    converter converts again. The converter takes constants and helpers from ``simx_server.sim``
    and ``simx_server.base`` too (contacts, motors, limits): their modules count as well."""
    h = hashlib.sha256()
    package = Path(__file__).parents[2]
    for folder in (Path(__file__).parent, package / "sim", package / "base"):
        for f in sorted(folder.glob("*.py")):
            h.update(f"{folder.name}/{f.name}".encode() + f.read_bytes())
    return h.hexdigest()[:16]


CONVERTER_VERSION = _converter_version()
_origins: dict[Path, Path] = {}  # converted MJCF -> the .ttt/.ttm it came from


def is_vrep_file(path: str | Path) -> bool:
    """Whether ``path`` holds a V-REP / CoppeliaSim scene or model, by its content whatever its
    name (:func:`simx_server.base.file_kinds.is_vrep`: MJCF saved as ``x.ttt`` is MJCF)."""
    return file_kinds.is_vrep(path)


def origin(path: str | Path) -> Path:
    """The ``.ttt``/``.ttm`` a converted MJCF came from, or for a conversion's folder the
    folder of that file (``path`` itself for anything else)."""
    path = Path(path)
    return _origins.get(Path(os.path.realpath(path)), path)


def cache_root() -> Path:
    """Where converted files are kept (created 0700 on first use)."""
    for base in (os.environ.get("XDG_CACHE_HOME"), str(Path.home() / ".cache") if Path.home() != Path("/") else None):
        if base:
            root = Path(base) / "simx" / "ttt"
            try:
                root.mkdir(parents=True, exist_ok=True, mode=0o700)
                if os.access(root, os.W_OK):
                    return root
            except OSError:
                pass
    root = Path(tempfile.gettempdir()) / f"simx-ttt-{os.getuid()}"
    root.mkdir(parents=True, exist_ok=True, mode=0o700)
    return root


def mjcf_for(path: str | Path, root: Path | None = None, client: bool | None = None) -> Path:
    """The MJCF scene converted from the ``.ttt``/``.ttm`` file ``path`` (converted now, or
    found in the cache); logs what did not carry over, one line per kind.

    Args:
        path: the V-REP file.
        root: the folder that holds conversions (default :func:`cache_root`).
        client: a client's file, read under a client's bounds (default: ``root`` is given,
            which callers do for a client's transfer folder). The conversion runs in the
            bounded worker process (:mod:`simx_server.scene.ttt.worker`); this waits for it.

    Raises:
        SceneFileError: the file cannot be read (naming the file and the record), or the
            worker went past its memory or CPU bound (record ``worker``).
        ValueError: MuJoCo cannot compile the conversion.
        OSError: the file cannot be read, or the cache written.
    """
    from simx_server.scene.ttt import worker

    path = Path(path)
    if client is None:
        client = root is not None
    size = path.stat().st_size
    if size > E.MAX_FILE_BYTES:
        raise SceneFileError(path.name, "header", f"{size:,} bytes, more than MAX_FILE_BYTES = {E.MAX_FILE_BYTES:,}")
    data = path.read_bytes()
    stem = "scene" if path.suffix.lower() == ".ttt" else "model"
    # the same bytes as a .ttt and a .ttm convert to scene.xml and model.xml: two folders
    key = hashlib.sha256(data + CONVERTER_VERSION.encode() + stem.encode()).hexdigest()[:32]
    root = cache_root() if root is None else root
    folder = root / key
    xml = folder / f"{stem}.xml"
    if not xml.is_file():
        root.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=f".{key}-", dir=root))
        try:
            worker.convert(path.name, data, work, stem, client=client)
            del data
            try:
                work.rename(folder)
            except OSError:  # another process converted the same file meanwhile
                if not xml.is_file():
                    raise
        finally:
            shutil.rmtree(work, ignore_errors=True)
    try:
        counts = json.loads((folder / "report.json").read_text())
    except (OSError, ValueError):
        counts = {}
    try:
        notes = json.loads((folder / "notes.json").read_text())
    except (OSError, ValueError):
        notes = {}
    approximated = set(notes.get("approximated") or ())
    for kind, n in sorted(counts.items()):
        log.info("%s: %s: %d x %s", path.name, "approximated" if kind in approximated else "not carried over", n, kind)
    for key, label in (("taken", "taken from the file"), ("repaired", "repaired"), ("physics", "physics")):
        if notes.get(key):
            log.info("%s: %s: %s", path.name, label, "; ".join(map(str, notes[key])))
    _origins[Path(os.path.realpath(xml))] = Path(os.path.realpath(path))
    _origins[Path(os.path.realpath(folder))] = Path(os.path.realpath(path.parent))
    return xml
