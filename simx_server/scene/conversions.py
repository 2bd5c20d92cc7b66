"""Scene and model loads whose ``.ttt``/``.ttm`` file is converted, and whose client MJCF or
URDF file is parsed and compiled, off the simulation thread.

A client's ``simxLoadScene``/``simxLoadModel`` (and ZMQ's ``sim.loadScene``/``sim.loadModel``)
of a V-REP file, or of the client's own MJCF/URDF file (options bit 0: two 199,000-vertex,
470,000-face OBJ meshes compiled on the simulation thread froze every client 9.4 s), returns at
once with a :class:`~simx_server.sim.vision_results.Deferred`; a
background thread has the file read and converted in its bounded worker process
(:func:`simx_server.scene.ttt.cache.mjcf_for`, :mod:`simx_server.scene.ttt.worker`), then
prepares the load there too, touching nothing the simulation thread owns (a scene: MuJoCo's
parse and compile of the converted MJCF and the new ``World``, ``Editor.prepare_scene``; a
model: its ``MjSpec``, compiled once alone so that its meshes wait in MuJoCo's cache,
``prepare_model``), and hands the rest to the simulation thread (``sim.post``, given by
:func:`simx_server.loop.tasks.attach`): a scene's swap, a model's attach and compile. The simulation keeps stepping and every other client
keeps being served meanwhile; the load's reply leaves when the load is done, with its value or
its error. The file is read under a client's bounds, whoever's folder it is in (no more objects than
``limits.MAX_SCENE_ELEMENTS``: loading the MJCF of 100,000 objects held the simulation thread
for a minute). One conversion runs at a time, on one thread, taking the waiting loads round robin
by client; each client has at most :data:`MAX_WAITING_PER_CLIENT` loads converted or waiting
(more: refused ``server busy``), and a client's load waits behind at most one load of every
other client, whatever they send (a server-wide bound of 4 let five clients' 12 MB files refuse
every other client's 1 kB file for 32 s). Without ``sim.post`` (no loop serves the simulation: in-process
use) the conversion runs in the worker and the caller waits, as before.

V-REP's own ``simLoadScene`` blocks its caller until the scene is loaded; so does the reply here.
Commands of the same request after the load run before it completes (against the old scene).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path
from typing import Any

import mujoco

from simx_wire.protocol import BUSY, RemoteError
from simx_server.base import scene_guard as guard
from simx_server.base.arguments import quote
from simx_server.base.job_ring import JobRing
from simx_server.scene.ttt import cache as ttt_cache
from simx_server.sim.vision_results import Deferred

log = logging.getLogger("simx.editing")

#: Loads of one client (its connection where the door names it, else its caller key; None: the
#: operator's, in-process) converted or waiting for it at once. Taken round robin, a client's
#: load waits behind at most one load of each other client, however many each has waiting; a
#: client's loads not converted yet are dropped when it leaves (:mod:`simx_server.base.job_ring`).
MAX_WAITING_PER_CLIENT = 4


class Conversions(JobRing):
    """The conversions waiting for the one worker, served round robin by client on one thread
    (started when a job comes, ended when none waits): each may take the worker's memory bound."""

    def __init__(self) -> None:
        super().__init__(MAX_WAITING_PER_CLIENT, "simx-ttt-convert", log, "scene conversion")

    def busy(self, mine: int) -> str:
        return (f"{BUSY}: {mine} scene file(s) of this client are being converted or wait for it "
                f"(scene.conversions.MAX_WAITING_PER_CLIENT = {MAX_WAITING_PER_CLIENT}); try again once loaded")


waiting = Conversions()


def pending() -> int:
    """Conversions under way or waiting for their turn (any thread)."""
    return waiting.pending()


def later(sim: Any, files: Any, path: Any, options: int, finish: Callable[[Any], Any],
          prepare: Callable[[Path], Any] | None = None) -> Deferred | None:
    """Convert the V-REP file that ``path`` names off the simulation thread, then run
    ``finish(mjcf)`` on the simulation thread; None where there is nothing to defer (not a
    ``.ttt``/``.ttm`` file, or no ``sim.post``): the caller then loads it at once.

    Args:
        sim: the simulation (its ``post`` and ``world.scene_path``).
        files: the editor's :class:`~simx_server.scene.client_files.ClientFiles`.
        path, options: as the load command gives them (options bit 0: a transferred file).
        finish: the load of the converted MJCF (on the simulation thread); its return value
            is the Deferred's. Given ``prepare``, it gets ``prepare``'s outcome instead of
            the MJCF's path: its value, or the exception it raised (``finish`` raises it).
        prepare: the load's work that touches nothing the simulation thread owns (MuJoCo's
            parse and compile of the converted MJCF, a new ``World``), run on the conversion's
            thread after the conversion, in the same turn (one at a time: each may take the
            memory of a scene); None: the conversion's thread only warms MuJoCo's mesh cache.

    Returns:
        The Deferred of ``finish``'s value (its exception: the load's error).

    Raises:
        ArgumentError, RemoteError: the path is refused (as :meth:`ClientFiles.locate`), or
            :data:`MAX_WAITING_PER_CLIENT` loads of this client already wait (``server busy``).
    """
    post = getattr(sim, "post", None)
    if post is None:
        return None
    file = files.locate(path, options, ttt_cache.origin(sim.world.scene_path))
    vrep = ttt_cache.is_vrep_file(file)
    if not vrep and not (options & 1 and prepare is not None):
        return None  # an operator's MJCF: loaded at once (trusted, as V-REP loaded its files)
    caller = files.caller  # the client the door serves now: the install acts as it too
    client_root = files.folder(caller) if options & 1 else None  # its own folder (resolve's rule)
    root = client_root / ".simx" / "ttt" if client_root is not None else None
    future: Future = Future()
    label = quote(path)

    def install(ready: Any) -> None:  # the simulation thread
        try:
            with files.acting(caller):
                future.set_result(finish(ready))
        except Exception as exc:
            if not isinstance(exc, RemoteError):
                log.exception("loading %s", label)
            future.set_exception(exc)

    def convert() -> None:  # the conversion's thread, one job at a time
        try:
            # a client asked: a client's bounds; a client's MJCF/URDF is prepared as it is
            xml = ttt_cache.mjcf_for(file, root, client=True) if vrep else file
            ready: Any = xml
            if prepare is None:
                _warm(xml, client_root)
            else:
                try:
                    ready = prepare(xml)
                except Exception as exc:  # finish, on the simulation thread, says what is wrong
                    ready = exc
        except (ValueError, OSError) as exc:
            message = files.scrub(f"cannot load {label}: {exc}")
            log.warning("%s", message)
            future.set_exception(RemoteError(message))
            return
        except Exception as exc:
            log.exception("converting %s", label)
            future.set_exception(RemoteError(f"cannot load {label}: internal error {type(exc).__name__}"))
            return
        post(lambda: install(ready))

    def cancelled() -> None:  # dropped before it ran: its client left
        future.set_exception(RemoteError(f"cannot load {label}: not converted, its client left"))

    waiting.add(caller, convert, cancelled)  # RemoteError (busy) past the client's share
    return Deferred(future)


def _warm(xml: Path, client_root: Path | None) -> None:
    """Compile the converted MJCF once on this thread and drop the model: MuJoCo releases the
    GIL while it compiles and keeps the meshes it processed (convex hulls, inertia) in its
    process-wide asset cache, so the load on the simulation thread compiles them again in a
    fraction of the time (measured: 100 shapes of one 190,000-triangle mesh 4.3 -> 0.85 s, four
    199,000-triangle meshes 6.0 -> 0.36 s). A client's conversion is measured first, as the
    simulation thread will measure it (``client_root``: the client's folder); a failure here is left for that load to report. (MuJoCo's
    warning handler is process-wide and the simulation thread swaps it: not touched here.)"""
    try:
        if client_root is not None:
            guard.check_client_file(xml, client_root, "scene")
        if any((xml.parent / "meshes").iterdir()):  # only meshes are cached
            mujoco.MjModel.from_xml_path(str(xml))
    except Exception as exc:  # the load on the simulation thread says what is wrong
        log.debug("warming MuJoCo's cache with %s: %s", xml.name, exc)
