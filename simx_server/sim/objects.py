"""V-REP's object types as simx maps them onto MuJoCo (shape = body, joint, dummy = site, vision
sensor = camera, light, proximity sensor and force sensor on sites, V-REP's view cameras and old
path objects on sites that keep their types; the world is -1), the
registry entry of one object (:class:`SceneObject`) and the ``simx:`` settings text of MJCF
elements (:func:`parse_settings`).
"""

from __future__ import annotations

import math

import dataclasses
from typing import Any

import mujoco

from simx_wire import constants as C

SHAPE = C.sim_object_shape_type
JOINT = C.sim_object_joint_type
DUMMY = C.sim_object_dummy_type
VISION_SENSOR = C.sim_object_visionsensor_type
LIGHT = C.sim_object_light_type
PROXIMITY_SENSOR = C.sim_object_proximitysensor_type
FORCE_SENSOR = C.sim_object_forcesensor_type
CAMERA = C.sim_object_camera_type
PATH = C.sim_object_path_type
WORLD = -1

_TYPE_NAMES = {SHAPE: "shape", JOINT: "joint", DUMMY: "dummy", VISION_SENSOR: "vision sensor", LIGHT: "light",
               PROXIMITY_SENSOR: "proximity sensor", FORCE_SENSOR: "force sensor", CAMERA: "camera",
               PATH: "path"}
#: The object types simx keeps on a MuJoCo site (``mj_id`` is a site id).
SITES = (DUMMY, PROXIMITY_SENSOR, FORCE_SENSOR, CAMERA, PATH)
#: Types a site keeps from its ``object_type=N`` setting (a .ttt's view cameras and old paths).
KEPT_TYPES = {str(CAMERA): CAMERA, str(PATH): PATH}


@dataclasses.dataclass
class SceneObject:
    """One V-REP scene object backed by a MuJoCo element."""

    handle: int
    name: str
    type: int
    mj_id: int  # id in the MuJoCo table of its type (body, joint, site, camera, light)
    body: int  # MuJoCo body the element belongs to (the body itself for shapes)
    parent: int  # handle of the parent object, -1 for the world
    settings: dict[str, str]


#: ``simx:`` settings that belong to an object's scripts (docs/SCRIPTS.md): copies of the object
#: and models loaded into a scene drop them all together.
SCRIPT_SETTINGS = ("child_script", "customization_script", "threaded", "vrep_version", "script_parameters",
                   "script_timeout", "script_disabled")


def without_scripts(text: str) -> str:
    """The data of a ``simx:`` text without its script settings (:data:`SCRIPT_SETTINGS`).

    Args:
        text: the data of a ``simx:NAME`` text (``"key=value ..."``).

    Returns:
        The same items, the script settings left out.
    """
    return " ".join(i for i in text.split() if i.partition("=")[0] not in SCRIPT_SETTINGS)


def parse_settings(text: str) -> dict[str, str]:
    """Parse ``"key=value key=value"`` (the data of a ``simx:NAME`` custom text).

    Args:
        text: the text's data.

    Returns:
        Key -> value (strings); a later key replaces an earlier one.

    Raises:
        ValueError: an item that is not ``key=value``.
    """
    settings = {}
    for item in text.split():
        key, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"setting {item!r} is not key=value")
        settings[key] = value
    return settings


def positive_setting(items: dict[str, str], key: str) -> float | None:
    """The positive finite number ``items[key]`` (:func:`parse_settings`'s answer), or None
    without ``key``.

    Args:
        items: a text's settings.
        key: the setting.

    Returns:
        The number, or None.

    Raises:
        ValueError: a value that is not a positive finite number (the message names ``key``).
    """
    if key not in items:
        return None
    try:
        value = float(items[key])
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{key} must be a positive number, got {items[key][:40]!r}")
    return value


def text_at(model: mujoco.MjModel, i: int) -> str:
    """The data of custom text ``i`` of ``model`` (its ``<text data=...>``).

    Args:
        model: the compiled model.
        i: a text id, 0 <= i < ``model.ntext``.

    Returns:
        The text, without MuJoCo's terminating NUL.
    """
    adr, size = model.text_adr[i], model.text_size[i]
    return bytes(model.text_data[adr:adr + size - 1]).decode()


def text_of(model: mujoco.MjModel, name: str) -> str | None:
    """The data of the custom text named ``name`` (a scene's ``simx:scene:*`` declarations).

    Args:
        model: the compiled model.
        name: the text's name.

    Returns:
        The text, or None when the model has none of that name.
    """
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, name)
    return None if i < 0 else text_at(model, i)


def apply_vrep_parents(objects: dict[int, SceneObject], by_name: dict[str, SceneObject]) -> None:
    """Give each object whose ``simx:`` settings say ``vrep_parent=NAME`` (``-1``: the world)
    that parent, as V-REP's tree has it, where MuJoCo's tree cannot: an object hung from a
    dummy, a joint, a sensor or a light is carried by that object's body in MuJoCo, but
    ``sim.getObjectParent`` answers the object (coppeliaSimLib ``CSceneObject::getParent``).
    A setting that names no object, or that would close a cycle, is left out (the MuJoCo
    parent stays). The settings are applied until none changes, so that their order does not
    matter: a force sensor's child shape carries the sensor's site in MuJoCo, and hangs from
    the sensor only once the sensor hangs from its own parent.

    Args:
        objects: handle -> object, parents as MuJoCo's tree gives them (changed in place).
        by_name: name -> object.
    """
    wanted = {}
    for obj in objects.values():
        name = obj.settings.get("vrep_parent")
        other = None if name in (None, "-1") else by_name.get(name)
        if name == "-1" or (other is not None and other is not obj):
            wanted[obj.handle] = WORLD if other is None else other.handle
    changed = True
    while changed:  # each object takes its one wanted parent at most once
        changed = False
        for handle, new in wanted.items():
            obj = objects[handle]
            h, seen = new, set()
            while h != WORLD and h not in seen and h != handle:
                seen.add(h)
                h = objects[h].parent
            if h == WORLD and obj.parent != new:
                obj.parent = new
                changed = True


def subtree(world: Any, handle: int) -> list[SceneObject]:
    """Object ``handle`` and every object below it in V-REP's tree (their ``parent`` handles,
    ``vrep_parent=`` settings applied, which never close a cycle), parents before children.

    Args:
        world: the :class:`~simx_server.sim.world.World`.
        handle: the top object's handle.

    Returns:
        The objects, ``handle``'s first.

    Raises:
        UnknownObjectError: no such object.
    """
    children: dict[int, list[SceneObject]] = {}
    for o in world.objects.values():
        children.setdefault(o.parent, []).append(o)
    out = [world.get(handle)]
    for o in out:  # grows while walking
        out.extend(children.get(o.handle, ()))
    return out

