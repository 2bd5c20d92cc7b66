"""The data files that a loaded model's objects name in their ``simx:`` settings: a converted
``.ttm``'s old paths (``path_data=FILE``, :mod:`simx_server.sim.kept_objects`) and custom data
blocks (``custom_data=FILE``, :mod:`simx_server.scene.custom_data`). A scene reads them from its
own folder; a model's lie in the model's folder (its conversion's), which the scene does not
look in. They are read when the model is prepared (:func:`take`, any thread), those settings
leave its spec, and its objects get the data once attached (:func:`attach`), as CoppeliaSim's
``CFileOperations::loadModel`` reads a model's paths and custom data with its objects.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import NamedTuple

import mujoco

from simx_wire.protocol import RemoteError
from simx_server.scene import custom_data
from simx_server.sim import kept_objects
from simx_server.sim.objects import parse_settings

log = logging.getLogger("simx.editing")

_KEYS = ("path_data", "custom_data")


class ObjectFiles(NamedTuple):
    """What one object of a model brings from its files."""

    name: str  #: the object's name in the model (before any suffix)
    path: dict | None  #: its old path's data (``kept_objects.read_path_file``), or None
    blocks: dict[str, bytes] | None  #: its custom data blocks, or None


def take(spec: mujoco.MjSpec, folder: Path, label: str, scrub=str) -> list[ObjectFiles]:
    """Read the files a model's settings name, from the model's ``folder``, and take those
    settings out of its spec. Any thread.

    A path file that cannot be read leaves an empty path and one log line, as a scene's does.

    Args:
        spec: the model's spec, not yet attached.
        folder: the model file's folder.
        label: the model's path as the client gave it, quoted, for messages.
        scrub: hides the transfer folder in a message (``ClientFiles.scrub``).

    Returns:
        The objects' data.

    Raises:
        RemoteError: ``cannot load model <label>: ...`` (a custom data file missing, outside
            the folder, malformed or too large).
    """
    out, total = [], [0]
    for text in list(spec.texts):
        if not text.name.startswith("simx:") or not any(f"{k}=" in text.data for k in _KEYS):
            continue
        try:
            items = parse_settings(text.data)
        except ValueError:  # the scene's compile with it says what is wrong
            continue
        name, path, blocks = text.name[5:], None, None
        if items.get("path_data"):
            try:
                path = kept_objects.read_path_file(folder, items["path_data"])
            except (OSError, ValueError) as exc:
                log.warning("model %s: path %r: its data %r cannot be read (%s); the path is empty",
                            label, name, items["path_data"], scrub(str(exc)))
        if items.get("custom_data"):
            try:
                blocks = custom_data.read(folder, items["custom_data"], name, total)
            except ValueError as exc:
                raise RemoteError(scrub(f"cannot load model {label}: {exc}")) from None
        out.append(ObjectFiles(name, path, blocks))
        rest = " ".join(i for i in text.data.split() if i.partition("=")[0] not in _KEYS)
        if rest:
            text.data = rest
        else:
            spec.delete(text)
    return out


def attach(sim, files: tuple[ObjectFiles, ...], suffix: str) -> None:
    """Give a just-attached model's objects (their names given ``suffix``) their data: old
    paths their points, objects their custom data blocks (``Simulation.custom_data``).

    Args:
        sim: the simulation.
        files: :func:`take`'s list.
        suffix: the suffix the model's names got.
    """
    world = sim.world
    for f in files:
        obj = world.by_name.get(f.name + suffix)
        if obj is None:
            continue
        if f.path is not None:
            kept_objects.given(world, obj.handle, f.path)
        if f.blocks:
            sim.custom_data[obj.handle] = dict(f.blocks)
