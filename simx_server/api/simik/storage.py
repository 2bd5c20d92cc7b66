"""``simIK.save`` and ``simIK.load``: an environment's content as a buffer, and back.

CoppeliaSim saves an environment's kinematic content (its objects, joints and groups) in its
kinematics routines' binary format (``ikSave`` / ``ikLoad`` of coppeliaKinematicsRoutines'
``ik.cpp``) and loads it into an *empty* environment only ("Environment must be empty"). An
environment of simx has the scene's objects, so what it saves is what it holds of its own: its
own dummies, groups and their elements, and its joints' positions, modes, weights, limit
margins, step sizes, dependencies and spherical joints' rotations, with the name of every scene
object it refers to.
The buffer is simx's (``simxIK1`` and JSON): it loads into an environment of the same scene (the
names are checked), in this server or another; a buffer CoppeliaSim wrote is refused by name, as
is anything that does not check out. The buffer is untrusted input: its size, counts and every
value are bounded before use.
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import simik_function
from simx_server.api.simik import environments as _environments
from simx_server.base.arguments import as_bytes
from simx_server.sim import ik_chain, ik_solver as S
from simx_server.sim.objects import JOINT, WORLD
from simx_wire.protocol import ArgumentError

MAGIC = b"simxIK1\n"
#: Largest buffer ``simIK.load`` reads (bytes), most elements in one group.
MAX_BUFFER, MAX_ELEMENTS = 4 << 20, 256
_SCALAR = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


@simik_function("save")
def save(ctx: CallContext, environmentHandle: Any) -> bytes:  # noqa: N803
    """The environment's content as a buffer (see the module's docstring) for :func:`load`."""
    env = _environments.env_of(ctx, environmentHandle)
    w = ctx.world
    groups = [{"handle": g.handle, "name": g.name, "method": g.method, "damping": g.damping,
               "iterations": g.iterations, "flags": g.flags,
               "elements": [dataclasses.asdict(el) for el in g.elements]} for g in env.groups.values()]
    joints: dict[int, dict[str, Any]] = {}
    for key, table in (("q", env.q), ("mode", env.mode), ("weight", env.weight), ("margin", env.margin),
                       ("max_step", env.max_step), ("dependency", env.dependency)):
        for j, v in table.items():
            joints.setdefault(int(j), {})[key] = (list(v) if isinstance(v, tuple) else int(v) if key == "mode"
                                                  else float(v))
    for j, quat in env.ball.items():
        joints.setdefault(int(j), {})["ball"] = [float(v) for v in quat]
    dummies = [{"handle": d.handle, "name": d.name, "parent": d.parent, "position": d.position.tolist(),
                "rotation": d.rotation.reshape(9).tolist()} for d in env.dummies.values()]
    used = set(joints) | {d.parent for d in env.dummies.values()}
    for g in env.groups.values():
        for el in g.elements:
            used |= {el.tip, el.target, el.base}
    for spec in joints.values():
        if "dependency" in spec:
            used.add(int(spec["dependency"][0]))
    names = {str(h): w.get(h).name for h in sorted(used) if h != WORLD and h not in env.dummies and h in w.objects}
    body = {"objects": names, "dummies": dummies, "next_dummy": env.next_dummy, "groups": groups, "joints": {str(j): s for j, s in joints.items()},
            "next_group": env.next_group, "next_element": env.next_element}
    return MAGIC + json.dumps(body, separators=(",", ":")).encode("utf-8")


@simik_function("load")
def load(ctx: CallContext, environmentHandle: Any, data: Any) -> None:  # noqa: N803
    """Load a buffer of :func:`save` into an environment without groups of its own (its joint
    settings are replaced by the buffer's).

    Raises:
        ArgumentError: the environment has groups, or the buffer is not simx's, is too large, is
            malformed, or names objects this scene does not have under those names.
    """
    env = _environments.env_of(ctx, environmentHandle)
    if env.groups:
        raise ArgumentError("simIK.load needs an empty environment (no groups): load into a new one")
    raw = as_bytes(data, "data")
    if len(raw) > MAX_BUFFER:
        raise ArgumentError(f"data is {len(raw)} bytes: simIK.load reads at most {MAX_BUFFER}")
    if not raw.startswith(MAGIC):
        raise ArgumentError("data is not an IK environment saved by simx's simIK.save (CoppeliaSim's own IK "
                            "file format is not read)")
    try:
        body = json.loads(raw[len(MAGIC):].decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        raise ArgumentError("data is not a readable simIK.save buffer") from None
    new = _Reader(ctx).environment(body)
    for f in dataclasses.fields(new):
        setattr(env, f.name, getattr(new, f.name))


class _Reader:
    """Checks a decoded buffer against the scene and builds the environment it describes."""

    def __init__(self, ctx: CallContext):
        self.w = ctx.world
        self.local: set[int] = set()  # the buffer's own dummies

    def _dict(self, v: Any, what: str) -> dict:
        if not isinstance(v, dict):
            raise ArgumentError(f"simIK.load: {what} must be a map")
        return v

    def _int(self, v: Any, what: str, low: int = -(1 << 31), high: int = (1 << 31) - 1) -> int:
        if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
            raise ArgumentError(f"simIK.load: {what} must be an integer in {low}..{high}")
        return v

    def _num(self, v: Any, what: str, low: float = -1e9, high: float = 1e9) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not low <= v <= high:
            raise ArgumentError(f"simIK.load: {what} must be a number in {low}..{high}")
        return float(v)

    def _nums(self, v: Any, n: int, what: str, low: float = -1e9) -> tuple[float, ...]:
        if not isinstance(v, list) or len(v) != n:
            raise ArgumentError(f"simIK.load: {what} must be {n} numbers")
        return tuple(self._num(x, what, low) for x in v)

    def _object(self, h: Any, what: str, names: dict, world_ok: bool = True) -> int:
        h = self._int(h, what)
        if (h == WORLD and world_ok) or h in self.local:
            return h
        saved = names.get(str(h))
        obj = self.w.objects.get(h)
        if obj is None or saved != obj.name:
            raise ArgumentError(f"simIK.load: {what} {h} ({saved!r}) is not an object of this scene by that name "
                                "(the buffer was saved with another scene)")
        return h

    def _joint(self, h: int, what: str, names: dict) -> Any:
        obj = self.w.get(self._object(h, what, names, world_ok=False))
        if obj.type != JOINT:
            raise ArgumentError(f"simIK.load: {what} {h} is not a joint")
        return obj

    def environment(self, body: Any) -> _environments.Environment:
        body = self._dict(body, "the buffer")
        names = self._dict(body.get("objects", {}), "objects")
        env = _environments.Environment()
        self._dummies(env, body.get("dummies", []), names)
        env.next_dummy = max(self._int(body.get("next_dummy", env.next_dummy), "next_dummy", 0),
                             max(env.dummies, default=env.next_dummy - 1) + 1)
        groups = body.get("groups", [])
        if not isinstance(groups, list) or len(groups) > _environments.MAX_GROUPS:
            raise ArgumentError(f"simIK.load: groups must be a list of at most {_environments.MAX_GROUPS}")
        for i, spec in enumerate(groups):
            g = self._group(self._dict(spec, f"groups[{i + 1}]"), names)
            if g.handle in env.groups:
                raise ArgumentError(f"simIK.load: group handle {g.handle} twice")
            env.groups[g.handle] = g
        joints = self._dict(body.get("joints", {}), "joints")
        if len(joints) > len(self.w.objects):
            raise ArgumentError("simIK.load: more joints than the scene has objects")
        for key, spec in joints.items():
            self._joint_settings(env, key, self._dict(spec, f"joints[{key}]"), names)
        top = max([*env.groups, env.next_group - 1]) + 1
        env.next_group = max(self._int(body.get("next_group", top), "next_group", 0), top)
        els = [el.handle for g in env.groups.values() for el in g.elements]
        env.next_element = max(self._int(body.get("next_element", 1), "next_element", 0), max(els, default=0) + 1)
        return env

    def _dummies(self, env: _environments.Environment, specs: Any, names: dict) -> None:
        if not isinstance(specs, list) or len(specs) > _environments.MAX_DUMMIES:
            raise ArgumentError(f"simIK.load: dummies must be a list of at most {_environments.MAX_DUMMIES}")
        top = _environments.FIRST_DUMMY + 16 * _environments.MAX_DUMMIES
        specs = [self._dict(d, "a dummy") for d in specs]
        self.local = {self._int(d.get("handle"), "a dummy's handle", _environments.FIRST_DUMMY, top) for d in specs}
        if len(self.local) != len(specs):
            raise ArgumentError("simIK.load: a dummy's handle twice")
        for d in specs:
            name = d.get("name")
            if not isinstance(name, str) or not 0 < len(name) <= 200:
                raise ArgumentError("simIK.load: a dummy's name must be a string of 1-200 characters")
            rot = np.array(self._nums(d.get("rotation"), 9, "a dummy's rotation", -2.0)).reshape(3, 3)
            if not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6):
                raise ArgumentError("simIK.load: a dummy's rotation is not a rotation")
            h = int(d["handle"])
            env.dummies[h] = _environments.LocalDummy(h, name, self._object(d.get("parent", -1), "a dummy's parent", names),
                                                      np.array(self._nums(d.get("position"), 3, "a dummy's position")), rot)
        for h in env.dummies:  # no loops of parents
            a, seen = env.dummies[h].parent, {h}
            while a in env.dummies:
                if a in seen:
                    raise ArgumentError("simIK.load: the dummies' parents form a loop")
                seen.add(a)
                a = env.dummies[a].parent

    def _group(self, spec: dict, names: dict) -> _environments.Group:
        name = spec.get("name")
        if not isinstance(name, str) or len(name) > 1000:
            raise ArgumentError("simIK.load: a group's name must be a string (at most 1000 characters)")
        g = _environments.Group(self._int(spec.get("handle"), "a group's handle", 0), name,
                                method=self._int(spec.get("method", 0), "method", 0, 3),
                                damping=self._num(spec.get("damping", 0.1), "damping", 0.0),
                                iterations=self._int(spec.get("iterations", 6), "iterations", 1,
                                                     _environments.MAX_ITERATIONS),
                                flags=self._int(spec.get("flags", 1), "flags", 0))
        elements = spec.get("elements", [])
        if not isinstance(elements, list) or len(elements) > MAX_ELEMENTS:
            raise ArgumentError(f"simIK.load: a group's elements must be a list of at most {MAX_ELEMENTS}")
        for e in elements:
            e = self._dict(e, "an element")
            g.elements.append(S.Element(
                self._int(e.get("handle"), "an element's handle", 0),
                self._object(e.get("tip"), "an element's tip", names, world_ok=False),
                self._object(e.get("target", -1), "an element's target", names),
                self._object(e.get("base", -1), "an element's base", names),
                self._int(e.get("constraints", 31), "constraints", 0, 31),
                self._nums(e.get("weights", [1.0, 1.0]), 2, "weights", 0.0),
                self._nums(e.get("precision", [0.001, 0.5 * math.pi / 180]), 2, "precision", 1e-12),
                self._int(e.get("flags", 1), "an element's flags", 0)))
        return g

    def _joint_settings(self, env: _environments.Environment, key: str, spec: dict, names: dict) -> None:
        try:
            h = int(key)
        except ValueError:
            raise ArgumentError(f"simIK.load: joint key {key[:20]!r} is not a handle") from None
        obj = self._joint(h, "joint", names)
        scalar = int(self.w.model.jnt_type[obj.mj_id]) in _SCALAR
        for field, low in (("q", -1e9), ("weight", 1e-12), ("margin", 0.0), ("max_step", 1e-12)):
            if field in spec:
                if not scalar:
                    raise ArgumentError(f"simIK.load: joint {h} is not revolute or prismatic: no {field}")
                getattr(env, field)[h] = self._num(spec[field], field, low)
        if "mode" in spec:
            env.mode[h] = self._int(spec["mode"], "mode", 0, 2)
            if env.mode[h] not in (0, 2):
                raise ArgumentError("simIK.load: a joint mode is jointmode_passive (0) or jointmode_ik (2)")
        if "dependency" in spec:
            master, offset, mult = self._nums(spec["dependency"], 3, "dependency")
            m = int(master)
            if m != master or not scalar:
                raise ArgumentError(f"simIK.load: joint {h}'s dependency is malformed")
            if m != -1 and int(self.w.model.jnt_type[self._joint(m, "a master joint", names).mj_id]) not in _SCALAR:
                raise ArgumentError(f"simIK.load: joint {h}'s master is not revolute or prismatic")
            ik_chain.link_dependency(env.dependency, h, m)
            if env.dependency[h][0] != -1:
                env.dependency[h] = (m, offset, mult)
        if "ball" in spec:
            if int(self.w.model.jnt_type[obj.mj_id]) != int(mujoco.mjtJoint.mjJNT_BALL):
                raise ArgumentError(f"simIK.load: joint {h} is not spherical")
            quat = np.array(self._nums(spec["ball"], 4, "a spherical joint's rotation"))
            if not np.linalg.norm(quat) > 1e-9:
                raise ArgumentError("simIK.load: a spherical joint's rotation must not be zero")
            env.ball[h] = quat / np.linalg.norm(quat)
