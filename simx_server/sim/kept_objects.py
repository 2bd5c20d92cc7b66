"""The state of the objects that keep their V-REP types on a MuJoCo site: old paths
(:class:`~simx_server.sim.old_paths.OldPath`, from the ``path_data=FILE`` setting a converted
``.ttt`` gives them, or made by ``sim.createPath``) and V-REP's view cameras (their optics, from
``camera=ANGLE,ORTHO,NEAR,FAR,PERSPECTIVE``), by handle.

One store per :class:`~simx_server.sim.world.World` (:func:`store`), made when first asked for and
kept across the world's edits (handles do not change); a new scene has a new world, a new store.
A simulation's stop gives each path its position and each camera its view angle and ortho size
back, as CoppeliaSim does (:func:`simulation_started`, :func:`simulation_ended`).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from dataclasses import dataclass

from simx_wire.protocol import ObjectTypeError
from simx_server.sim.objects import _TYPE_NAMES, CAMERA, PATH
from simx_server.sim.old_paths import OldPath

log = logging.getLogger("simx.scene")

MAX_PATH_FILE_BYTES = 16 << 20


@dataclass
class CameraState:
    """A camera's optics (``CViewableBase``): view angle (rad), ortho view size (m), clipping
    planes (m), perspective or orthographic; defaults those of ``CCamera::commonInit``."""

    view_angle: float = math.radians(60.0)
    ortho_size: float = 2.0
    near: float = 0.05
    far: float = 30.0
    perspective: bool = True


class KeptObjects:
    """Old paths and cameras of one world, by handle."""

    def __init__(self, world):
        self.world = world
        self.paths: dict[int, OldPath] = {}
        self.cameras: dict[int, CameraState] = {}
        self.initial: dict[int, object] = {}  # what a simulation stop restores (simulation_started)

    def path(self, handle: int) -> OldPath:
        """The old path ``handle``.

        Args:
            handle: the path's handle.

        Returns:
            Its container (loaded from its data file when first asked for).

        Raises:
            UnknownObjectError: no such object. ObjectTypeError: not an old path.
        """
        obj = self.world.get(handle)
        if obj.type != PATH:
            raise ObjectTypeError(f"object {obj.name!r} (handle {handle}) is a {_TYPE_NAMES.get(obj.type, 'object')}, "
                                  "not a path")
        if handle not in self.paths:
            self.paths[handle] = _load_path(self.world, obj)
        return self.paths[handle]

    def camera(self, handle: int) -> CameraState:
        """The camera ``handle``'s optics.

        Args:
            handle: the camera's handle.

        Returns:
            Its optics (the scene's when first asked for).

        Raises:
            UnknownObjectError: no such object. ObjectTypeError: not a camera.
        """
        obj = self.world.get(handle)
        if obj.type != CAMERA:
            raise ObjectTypeError(f"object {obj.name!r} (handle {handle}) is a {_TYPE_NAMES.get(obj.type, 'object')}, "
                                  "not a camera")
        if handle not in self.cameras:
            self.cameras[handle] = _camera(obj)
        return self.cameras[handle]


def copied(world, pairs: list[tuple[int, int]]) -> None:
    """Give each copy (``(original, copy)`` handles) of an old path or camera the original's
    current state, as CoppeliaSim copies the object (``CPath_old::copyYourself``,
    ``CCamera::copyYourself``).

    Args:
        world: the world.
        pairs: ``(original, copy)`` handles.
    """
    kept = getattr(world, "_kept_objects", None)
    if kept is None:
        return
    for src, dst in pairs:
        if src in kept.paths and dst in world.objects and world.objects[dst].type == PATH:
            p = kept.paths[src]
            kept.paths[dst] = OldPath({"points": p.points.tolist(), "attributes": p.attributes,
                                       "length_method": p.length_method, "angle_coeff": p.angle_coeff,
                                       "on_spot_coeff": p.on_spot_coeff, "position": p.position})
        elif src in kept.cameras and dst in world.objects and world.objects[dst].type == CAMERA:
            kept.cameras[dst] = dataclasses.replace(kept.cameras[src])


def simulation_started(world) -> None:
    """Remember each path's position and each camera's view angle and ortho size, to be restored
    when the simulation stops (``CPathCont_old::initializeInitialValues``,
    ``CCamera::initializeInitialValues``).

    Args:
        world: the world.
    """
    kept = store(world)
    kept.initial = {}
    for obj in list(world.objects.values()):
        if obj.type == PATH:
            kept.initial[obj.handle] = kept.path(obj.handle).position
        elif obj.type == CAMERA:
            c = kept.camera(obj.handle)
            kept.initial[obj.handle] = (c.view_angle, c.ortho_size)


def simulation_ended(world) -> None:
    """Restore what :func:`simulation_started` remembered (``CPathCont_old::simulationEnded``,
    ``CCamera::simulationEnded``), for the objects still there.

    Args:
        world: the world.
    """
    kept = getattr(world, "_kept_objects", None)
    for handle, value in (getattr(kept, "initial", None) or {}).items():
        if handle in kept.paths and world.objects.get(handle) is not None:
            kept.paths[handle].set_position(value)
        elif handle in kept.cameras and world.objects.get(handle) is not None:
            kept.cameras[handle].view_angle, kept.cameras[handle].ortho_size = value
    if kept is not None:
        kept.initial = {}


def store(world) -> KeptObjects:
    """The store of ``world`` (made on first use).

    Args:
        world: the world.

    Returns:
        Its store.
    """
    kept = getattr(world, "_kept_objects", None)
    if kept is None:
        kept = world._kept_objects = KeptObjects(world)
    return kept


def _camera(obj) -> CameraState:
    text = obj.settings.get("camera", "")
    try:
        v = [float(x) for x in text.split(",")] if text else []
    except ValueError:
        v = []
    if len(v) != 5 or not all(math.isfinite(x) for x in v):
        return CameraState()
    return CameraState(v[0], v[1], v[2], v[3], v[4] != 0)


def _load_path(world, obj) -> OldPath:
    """The path data file named by ``obj``'s ``path_data`` setting (none: an empty path); a file
    that cannot be read gives an empty path and one log line."""
    file = obj.settings.get("path_data")
    if not file:
        return OldPath()
    try:
        return OldPath(read_path_file(world.scene_path.parent, file))
    except (OSError, ValueError, TypeError) as exc:
        log.warning("scene %s: path %r: its data %r cannot be read (%s); the path is empty",
                    world.scene_name, obj.name, file, exc)
        return OldPath()


def read_path_file(folder, file: str) -> dict:
    """An old path's data file (:mod:`simx_server.scene.ttt.kinds` writes it): a scene's, or a
    loaded model's in its own folder (:mod:`simx_server.scene.model_files`).

    Args:
        folder: the folder (``pathlib.Path``) the file must lie in.
        file: the ``path_data=`` setting's value.

    Returns:
        The JSON object (:class:`OldPath`'s ``data``).

    Raises:
        ValueError: a file outside ``folder``, larger than ``MAX_PATH_FILE_BYTES``, or not a
            JSON object. OSError: it cannot be read.
    """
    folder = folder.resolve()
    path = (folder / file).resolve()
    if folder not in path.parents or not path.is_file() or path.stat().st_size > MAX_PATH_FILE_BYTES:
        raise ValueError("not a file of the scene's folder within MAX_PATH_FILE_BYTES")
    data = json.loads(path.read_text(encoding="utf-8"))
    if not isinstance(data, dict):
        raise ValueError("not a JSON object")
    return data


def given(world, handle: int, data: dict) -> None:
    """Give old path ``handle`` its data (a loaded model's, read when it was prepared).

    Args:
        world: the world.
        handle: the path's handle.
        data: :func:`read_path_file`'s object.
    """
    store(world).paths[handle] = OldPath(data)
