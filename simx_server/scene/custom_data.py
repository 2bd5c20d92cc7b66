"""The custom data blocks a scene brings (a converted ``.ttt``'s ``sim.writeCustomDataBlock``
data): each object's ``custom_data=FILE.json`` setting names a JSON object next to the scene,
tag -> the block's bytes in base64 (:mod:`simx_server.scene.ttt.scripts`).

They go into the one custom data store of the simulation, ``Simulation.custom_data``
(``{handle: {tag: bytes}}``), which ``sim.readCustomDataBlock``/``simReadCustomDataBlock`` (the
3.x calls, through the scripts' shared state) and ``sim.readCustomDataBlockEx``/``customData.*``
properties all read and write.
"""

from __future__ import annotations

import base64
import binascii
import json
import logging
from pathlib import Path

from simx_server.sim.world import World

log = logging.getLogger("simx.scene")

MAX_SCENE_CUSTOM_BYTES = 16 << 20  # the whole custom data store's bound (api.sim.data)


def load(world: World) -> dict[int, dict[str, bytes]]:
    """The custom data of ``world``'s objects, by handle.

    Raises:
        ValueError: a file outside the scene's folder, missing, not such a JSON object, or more
            than ``MAX_SCENE_CUSTOM_BYTES`` in all (naming the object and the file).
    """
    store: dict[int, dict[str, bytes]] = {}
    folder = world.scene_path.parent
    total = [0]
    for obj in world.objects.values():
        file = obj.settings.get("custom_data")
        if file:
            store[obj.handle] = read(folder, file, obj.name, total)
    return store


def read(folder: Path, file: str, name: str, total: list[int] | None = None) -> dict[str, bytes]:
    """The blocks of one object's ``custom_data=FILE`` (a scene's, or a loaded model's in its
    own folder, :mod:`simx_server.scene.model_files`).

    Args:
        folder: the folder the file must lie in.
        file: the setting's value.
        name: the object's name, for messages.
        total: the bytes read so far (added to; more than twice ``MAX_SCENE_CUSTOM_BYTES`` of
            JSON, base64 and all, is refused).

    Returns:
        Tag -> data.

    Raises:
        ValueError: a file outside ``folder``, missing, not such a JSON object, or too large.
    """
    total = total if total is not None else [0]
    path = (folder / file).resolve()
    if folder.resolve() not in path.parents or not path.is_file():
        raise ValueError(f"custom_data {file!r} of {name!r} not found in {folder}")
    total[0] += path.stat().st_size
    if total[0] > MAX_SCENE_CUSTOM_BYTES * 2:  # base64: 4 characters per 3 bytes, plus JSON
        raise ValueError(f"custom_data of the scene: more than {MAX_SCENE_CUSTOM_BYTES} bytes in all")
    try:
        items = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(items, dict) or not all(isinstance(v, str) for v in items.values()):
            raise ValueError("must be a JSON object of tag -> base64 text")
        return {str(tag): base64.b64decode(v, validate=True) for tag, v in items.items()}
    except (ValueError, UnicodeDecodeError, binascii.Error) as exc:
        raise ValueError(f"custom_data {file!r} of {name!r}: {exc}") from None


def install(sim, store: dict[int, dict[str, bytes]]) -> None:
    """Make ``store`` (:func:`load` of the newly loaded scene) the custom data of ``sim``, shared
    with its scripts' 3.x custom data calls (the scripts' shared state)."""
    sim.custom_data = store
    sim.scripts.shared["custom_data"] = store
