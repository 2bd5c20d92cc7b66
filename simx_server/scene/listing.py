"""``simx-server --list-objects SCENE``: the scene as V-REP's scene hierarchy would show it.

The scene is loaded exactly as the server loads it (:class:`~simx_server.sim.world.World`: the same
object mapping, names, handles and motors; the child scripts through
:class:`~simx_server.scripts.scene_scripts.Scripts`, read and compiled but not run), and each V-REP object is
described with what a porting user must match: its handle, its V-REP type (the
``sim_object_*_type`` that ``simxGetObjectGroupData`` reports), its name, and

* joints: revolute / prismatic / spherical, V-REP's joint mode (force/torque mode: motor on or
  off, control loop on = position target, off = velocity target, as :mod:`simx_server.sim.motors`
  implements them), maximum force/torque and upper velocity, position range;
* vision sensors: resolution, image kind (``depth`` also for a filter chain that outputs the
  depth image), near/far clipping planes and perspective angle (the
  larger of the horizontal and vertical view angles, as ``sim_visionfloatparam_perspective_angle``),
  the filter chain (:mod:`simx_server.sim.vision_filters`);
* proximity sensors: the range (the rangefinder's cutoff); lights: directional or spotlight;
* any object with a child script: its file and language.

No Zenoh, no rendering: nothing is started. :func:`describe` returns plain data (also printed
as JSON with ``--json``), :func:`format_tree` the text.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import mujoco

from simx_server.base.limits import MAX_JOINT_FORCE
from simx_server.base.scene_guard import transfer_folders
from simx_server.scene.ttt import cache as ttt_cache
from simx_server.sim import naming
from simx_server.sim import vision_filters as VF
from simx_server.sim import world as W
from simx_server.sim.group_data import _joint_properties
from simx_server.sim.object_params import _perspective
from simx_server.sim.sensor_spec import sensor_spec

TYPE_NAMES = {W.SHAPE: "shape", W.JOINT: "joint", W.DUMMY: "dummy", W.VISION_SENSOR: "vision sensor",
              W.LIGHT: "light", W.PROXIMITY_SENSOR: "proximity sensor", W.FORCE_SENSOR: "force sensor",
              W.CAMERA: "camera", W.PATH: "path"}
_JOINT_KINDS = {10: "revolute", 11: "prismatic", 12: "spherical"}


def _joint(world: W.World, obj: W.SceneObject) -> dict[str, Any]:
    m = world.model
    (kind, _), (low, span) = _joint_properties(world, obj.handle)
    out: dict[str, Any] = {"joint_type": _JOINT_KINDS.get(kind, "free")}
    if m.jnt_limited[obj.mj_id] and kind in (10, 11):
        out["range"] = [low, low + span]
    i = world.motors.index.get(obj.handle)
    if i is None:
        tendon = world.motors.tendon_of_joint.get(obj.mj_id)
        out["motor"] = f"none (moved through tendon {tendon!r})" if tendon else "none"
        return out
    mo = world.motors
    out.update(motor_enabled=bool(mo.enabled[i]), control_loop=bool(mo.loop[i]),
               max_force=float(mo.max_force[i]), max_velocity=float(mo.max_velocity[i]),
               actuator=mo.names.get(obj.handle))
    return out


def _vision_sensor(world: W.World, obj: W.SceneObject) -> dict[str, Any]:
    spec = sensor_spec(world.model, obj)
    steps = [s.name + (f"({','.join(f'{a:g}' for a in s.args)})" if s.args else "") for s in spec.filters]
    depth = spec.depth_image or (VF.uses_depth(spec.filters) and VF.writes_image(spec.filters))
    out = {"resolution": [spec.width, spec.height], "image": "depth" if depth else "rgb",
           "near": spec.near, "far": spec.far, "view_angle": _perspective(world.model, spec)}
    if steps:
        out["filters"] = ";".join(steps)
    return out


def describe(scene: str | Path, dt: float | None = None, name: str | None = None) -> dict[str, Any]:
    """The scene's V-REP objects, in tree order, as plain data.

    ``dt``: the step (None: the scene's saved one); ``name``: the file the user gave when
    ``scene`` is its conversion (a .ttt's MJCF). Returns ``{"scene": file name, "objects": [...]}``; each object is a dict with ``handle``,
    ``name``, ``type`` (``sim_object_*_type``), ``type_name``, ``parent`` (handle, -1 the
    world), ``depth`` (0 for children of the world), ``mjcf_name`` where the V-REP name is
    not the MJCF name (:mod:`simx_server.sim.naming`: ``head#0``) and the settings of its type (see the
    module's docstring; angles in rad, lengths in m, forces in N or N·m).

    Raises:
        ValueError: the scene cannot be loaded (MuJoCo's message, or a bound of
            :mod:`simx_server.base.limits`), or a child script is missing or outside its folder.
    """
    from simx_server.scripts.scene_scripts import Scripts  # the scene's scripts, read and compiled, not run

    world = W.World(scene, dt, name=name)
    scripts = Scripts(world, untrusted=transfer_folders())
    m = world.model
    renamed = {r.name: r for r in naming.vrep_names(m)[1]}
    depth = {W.WORLD: -1}
    objects = []
    for obj in _tree_order(world):
        depth[obj.handle] = depth[obj.parent] + 1
        entry: dict[str, Any] = {"handle": obj.handle, "name": obj.name, "type": obj.type,
                                 "type_name": TYPE_NAMES[obj.type], "parent": obj.parent,
                                 "depth": depth[obj.handle]}
        if obj.name in renamed:
            entry["mjcf_name"] = renamed[obj.name].mj_name  # a name several MJCF kinds share
        if obj.type == W.JOINT:
            entry.update(_joint(world, obj))
        elif obj.type == W.VISION_SENSOR:
            entry.update(_vision_sensor(world, obj))
        elif obj.type == W.SHAPE:
            b = obj.mj_id
            free = m.body_jntnum[b] == 1 and m.jnt_type[m.body_jntadr[b]] == mujoco.mjtJoint.mjJNT_FREE
            if m.body_mocapid[b] >= 0 or free:
                entry["body"] = "mocap" if m.body_mocapid[b] >= 0 else "free"
        elif obj.type == W.PROXIMITY_SENSOR:
            k = next(k for k in range(m.nsensor) if m.sensor_objtype[k] == mujoco.mjtObj.mjOBJ_SITE
                     and m.sensor_objid[k] == obj.mj_id and m.sensor_type[k] == mujoco.mjtSensor.mjSENS_RANGEFINDER)
            entry["range"] = float(m.sensor_cutoff[k]) if m.sensor_cutoff[k] > 0 else None  # None: unlimited
        elif obj.type == W.LIGHT:
            entry["light"] = "directional" if m.light_type[obj.mj_id] == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL \
                else "spotlight"
        script = scripts.scripts.get(obj.handle)
        if script is not None:
            entry["child_script"] = {"file": obj.settings.get("child_script", script.path.name),
                                     "language": script.language}
            if script.load_error:
                entry["child_script"]["error"] = script.load_error
        objects.append(entry)
    return {"scene": world.scene_name, "objects": objects}


def _tree_order(world: W.World) -> list[W.SceneObject]:
    """Objects depth first, children in handle order (as V-REP's hierarchy lists them)."""
    children: dict[int, list[W.SceneObject]] = {}
    for obj in world.objects.values():
        children.setdefault(obj.parent, []).append(obj)
    out, stack = [], list(reversed(children.get(W.WORLD, [])))
    while stack:
        obj = stack.pop()
        out.append(obj)
        stack.extend(reversed(children.get(obj.handle, [])))
    return out


def _settings_text(o: dict[str, Any]) -> str:
    parts = []
    if o["type"] == W.JOINT:
        kind = o["joint_type"]
        parts.append(kind)
        unit, force, speed = ("m", "N", "m/s") if kind == "prismatic" else ("rad", "N·m", "rad/s")
        if isinstance(o.get("motor"), str):
            parts.append(f"motor {o['motor']}")
        else:
            parts.append("force/torque mode, motor " + ("on" if o["motor_enabled"] else "off (free joint)"))
            parts.append("control loop " + ("on (position target)" if o["control_loop"] else "off (velocity target)"))
            unlimited = o["max_force"] >= MAX_JOINT_FORCE  # the scene limits neither actuator nor joint
            parts.append(f"max force {'unlimited' if unlimited else format(o['max_force'], 'g') + ' ' + force}")
            parts.append(f"max velocity {o['max_velocity']:g} {speed}")
        if "range" in o:
            parts.append(f"range {o['range'][0]:g}..{o['range'][1]:g} {unit}")
    elif o["type"] == W.VISION_SENSOR:
        w, h = o["resolution"]
        parts.append(f"{w}x{h} {o['image']}, near {o['near']:g} m, far {o['far']:g} m, "
                     f"view angle {math.degrees(o['view_angle']):.4g} deg")
        if "filters" in o:
            parts.append(f"filters {o['filters']}")
    elif o["type"] == W.SHAPE and "body" in o:
        parts.append(o["body"])
    elif o["type"] == W.PROXIMITY_SENSOR:
        parts.append("range unlimited" if o["range"] is None else f"range {o['range']:g} m")
    elif o["type"] == W.LIGHT:
        parts.append(o["light"])
    if "mjcf_name" in o:
        parts.append(f"MJCF name {o['mjcf_name']!r}, shared with an element of another kind")
    script = o.get("child_script")
    if script:
        text = f"child script {script['file']} ({script['language']})"
        parts.append(text + (f": cannot be loaded: {script['error']}" if "error" in script else ""))
    return ", ".join(parts)


def format_tree(described: dict[str, Any]) -> str:
    """The text :func:`main` prints: a header, then one line per object, indented by parent."""
    objects = described["objects"]
    lines = [f"scene {described['scene']}: {len(objects)} objects (handle, V-REP type, name as in "
             "V-REP's scene hierarchy, settings)"]
    for o in objects:
        settings = _settings_text(o)
        lines.append(f"{o['handle']:>5}  {o['type_name']:<16}  {'  ' * o['depth']}{o['name']}"
                     + (f"  [{settings}]" if settings else ""))
    return "\n".join(lines)


def main(scene: str | Path, as_json: bool = False, dt: float | None = None) -> int:
    """Print the listing of ``scene`` to stdout; 0, or 2 with one line on stderr when the scene
    is missing or cannot be loaded."""
    path = Path(scene)
    if not path.is_file():
        print(f"simx-server: --list-objects: no scene file {str(path)!r}", file=sys.stderr)
        return 2
    try:
        name = None
        if ttt_cache.is_vrep_file(path):  # a V-REP .ttt/.ttm: its (cached) MJCF conversion
            name = path.name  # the listing names the user's file, not the cache's
            path = ttt_cache.mjcf_for(path)
        described = describe(path, dt, name)
    except (ValueError, OSError) as exc:
        text = " ".join(str(exc).split())  # MuJoCo's messages span lines
        print(f"simx-server: --list-objects: {text}", file=sys.stderr)
        return 2
    print(json.dumps(described, indent=1) if as_json else format_tree(described), flush=True)
    return 0
