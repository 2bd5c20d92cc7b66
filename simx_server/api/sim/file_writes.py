"""Files that ``sim`` calls write (``sim.saveScene``, ``saveModel``, ``exportMesh``, ``saveImage``):
a remote client's are made and written on the files' thread (issue 84)."""

from __future__ import annotations

from concurrent.futures import Future
from pathlib import Path
from typing import Any, Callable

from simx_server.api import long_calls
from simx_server.api.context import CallContext
from simx_server.sim.vision_results import Deferred


def write_files(ctx: CallContext, key: str | None, made: Callable[[], list[tuple[Path, bytes, str]]],
                value: Any = None) -> Any:
    """Write the files ``made()`` gives (``(file, data, name)``, each where
    :func:`~simx_server.api.sim.misc.target_file` said): for a remote client of a door that replies once a Deferred is done (ZMQ), ``made``
    runs and the files are written on the files' thread (:meth:`ClientFiles.write_later
    <simx_server.scene.client_files.ClientFiles.write_later>`: serialising a scene of a
    200,000-triangle mesh held every other client 6.5 s on the simulation thread); for
    everyone else at once.

    Returns:
        ``value``, or a Deferred of it.
    """
    files = ctx.simulation("write").editor.files
    if key is not None and long_calls.off_thread(ctx):
        written, out = files.write_later(key, made), Future()

        def done(_: Future) -> None:
            error = written.exception()
            out.set_exception(error) if error is not None else out.set_result(value)

        written.add_done_callback(done)
        return Deferred(out)
    for path, data, name in made():
        files.write(path, data, key, name)
    return value
