"""The scripts that objects bring when they arrive in a loaded scene: a loaded model's
(``sim.loadModel``, ``simxLoadModel``, PyRep's ``import_model``) and copies'
(``sim.copyPasteObjects``, ``simxCopyPasteObjects``), run as the scene's own, as in CoppeliaSim
(``CFileOperations::loadModel`` adds a model's scripts with its objects; a copy's scripts are
copied with it).

A model's scripts are read from its ``simx:`` settings when the model is prepared
(:func:`take`, any thread: its files in the model file's own folder, a ``.ttm``'s conversion's),
and those settings leave the scene's spec: the scene's spec names only the scene's own scripts,
read once at the scene's load; what arrives later lives in :class:`~simx_server.scripts.
scene_scripts.Scripts` alone, by handle. Trust follows docs/SECURITY.md: a model of a trusted
folder (the scene's, ``--scene-path``, the in-process operator's) runs its Lua scripts, its Python
scripts only with ``--allow-python-scripts``; a model a client sent (its transfer folder) runs
them only with ``--allow-remote-code``, and loads without them otherwise (:func:`attach`).
"""

from __future__ import annotations

import logging
from pathlib import Path

import mujoco

from simx_wire.protocol import RemoteError
from simx_server.base import scene_guard as guard
from simx_server.scripts.child import REMOTE_CODE_FLAG
from simx_server.scripts.scene_scripts import ScriptSource, model_scripts
from simx_server.sim.objects import SCRIPT_SETTINGS, parse_settings, without_scripts
from simx_server.sim.state import RunState

log = logging.getLogger("simx.editing")


def take(spec: mujoco.MjSpec, folder: Path, label: str, scrub=str) -> list[ScriptSource]:
    """The scripts a model's ``simx:`` settings name, taken out of its spec (``spec``'s texts
    keep their other settings). Any thread.

    Args:
        spec: the model's spec, not yet attached.
        folder: the model file's folder, where its scripts lie.
        label: the model's path as the client gave it, quoted, for messages.
        scrub: hides the transfer folder in a message (``ClientFiles.scrub``).

    Returns:
        The scripts, by the names the model gives their objects.

    Raises:
        RemoteError: ``cannot load model <label>: ...`` (a script file missing or outside the
            model's folder, a bad script setting).
    """
    settings: dict[str, dict[str, str]] = {}
    for text in list(spec.texts):
        if not text.name.startswith("simx:"):
            continue
        try:
            items = parse_settings(text.data)
        except ValueError:  # the scene's compile with it says what is wrong
            continue
        if not any(key in items for key in SCRIPT_SETTINGS):
            continue
        settings[text.name[5:]] = items
        rest = without_scripts(text.data)
        if rest:
            text.data = rest
        else:
            spec.delete(text)
    try:
        return model_scripts(settings, folder)
    except ValueError as exc:
        raise RemoteError(scrub(f"cannot load model {label}: {exc}")) from None


def attach(sim, sources: tuple[ScriptSource, ...], suffix: str, client: bool, label: str) -> None:
    """Attach a just-attached model's scripts (:func:`take`) to its objects (their names
    given ``suffix``), on the simulation thread. A client's model (``client``) brings them only
    with ``--allow-remote-code``: otherwise it stays loaded without them, and one log line says so.
    """
    if not sources:
        return
    scripts = sim.scripts
    if client and not scripts.allow_remote_code:
        log.warning("model %s: its %d script(s) do not run: simx runs code sent by clients only when the "
                    "server is started with %s", label, len(sources), REMOTE_CODE_FLAG)
        return
    pairs = []
    for source in sources:
        obj = sim.world.by_name.get(source.name + suffix)
        if obj is None:
            log.warning("model %s: the %s script of %r has no object of that name: not run", label, source.kind,
                        source.name)
            continue
        pairs.append((obj.handle, source))
    _attach(sim, pairs, f"model {label}")


def copy(sim, pairs: list[tuple[int, int]]) -> None:
    """Give copies the scripts of their originals (``(original, copy)`` handles), as
    CoppeliaSim copies an object's scripts with it (``CSceneObjectContainer`` copy buffer)."""
    scripts = sim.scripts
    _attach(sim, [(new, source) for old, new in pairs for source in scripts.source_of(old)], "copies")


def _attach(sim, pairs: list[tuple[int, ScriptSource]], what: str) -> None:
    if not pairs:
        return
    untrusted = guard.transfer_folders(sim.editor.files_dir)
    try:
        added = sim.scripts.attach(pairs, running=sim.state is not RunState.STOPPED, untrusted=untrusted)
    except ValueError as exc:  # checked when read: a file gone since, or refused
        log.error("%s: scripts not run: %s", what, sim.editor.files.scrub(str(exc)))
        return
    log.info("%s: %d script(s) attached", what, len(added))
