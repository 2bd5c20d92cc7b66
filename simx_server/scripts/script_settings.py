"""A scene object's script settings (``simx:`` settings of the object that holds a script) as
the options :func:`simx_server.scripts.scene_scripts.load_script` takes."""

from __future__ import annotations

import math
from pathlib import Path

from simx_server.api import script_parameters


def script_options(settings: dict[str, str], name: str, timeout: float, folder: Path) -> dict:
    """The script settings of object ``name`` (``script_timeout=S``, ``threaded=1``,
    ``vrep_version=N``, ``script_parameters=FILE.json`` in ``folder``) as ``load_script``
    options; ValueError for a bad value."""
    bound = settings.get("script_timeout", timeout)
    try:
        bound = float(bound)
        if not (bound > 0 and math.isfinite(bound)):
            raise ValueError
    except ValueError:
        raise ValueError(f"script_timeout of {name!r} must be a positive number of seconds, "
                         f"got {settings.get('script_timeout')!r}") from None
    threaded = settings.get("threaded", "0")
    if threaded not in ("0", "1"):
        raise ValueError(f"threaded of {name!r} must be 0 or 1, got {threaded!r}")
    version = settings.get("vrep_version")
    if version is not None:
        if not version.isdigit():
            raise ValueError(f"vrep_version of {name!r} must be V-REP's version number (30600 for 3.6.0), "
                             f"got {version!r}")
        version = int(version)
    return {"timeout": bound, "threaded": threaded == "1", "version": version,
            "parameters": script_parameters.load(folder, name, settings.get("script_parameters"))}
