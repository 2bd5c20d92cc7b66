"""An IK environment's own dummies: ``simIK.createDummy``, ``setObjectParent``, ``eraseObject``.

An environment of simx has the scene's objects (:mod:`simx_server.api.simik.environments`); a
dummy created here is the environment's alone and never touches the scene: a handle of its own
(from :data:`~simx_server.api.simik.environments.FIRST_DUMMY`, below
``simIK.handleflag_tipdummy``), a name unique among the environment's objects, a parent (-1 the
world, a scene object, or another of its dummies) and a pose relative to it. It moves with its
parent in the environment's configuration, so it serves as an element's tip (carried by the
parent's body: the solver differentiates that point) or target (``simIK.setObjectPose`` places
it), as CoppeliaSim's own ``simIK.addElementFromScene`` and programs that build environments by
hand use it. CoppeliaSim's kinematics routines are the reference (``ik.cpp``: ``ikCreateDummy``,
``ikSetObjectParent``, ``ikEraseObject``; ``CSceneObject::announceSceneObjectWillBeErasedMain``).

``createJoint`` stays out: a joint of an environment would need kinematics beside MuJoCo's.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import simik_function
from simx_server.api.sim import core as _core
from simx_server.api.simik import environments as _environments
from simx_server.base.arguments import as_text as _text
from simx_server.sim import ik_chain
from simx_server.sim.objects import WORLD
from simx_wire.protocol import ArgumentError

MAX_NAME = 200


def place_dummy(ctx: CallContext, env: _environments.Environment, handle: int, relative_to: int, position: Any,
                rotation: Any) -> None:
    """Put one of the environment's dummies at a pose relative to ``relative_to`` (-1 the world,
    ``simIK.handle_parent``, or an object), in the environment's configuration; the rotation is
    made orthonormal."""
    dummy = env.dummies[handle]
    p, r = np.asarray(position, float), ik_chain.rotation_matrix(ik_chain.unit_quaternion(rotation))
    if relative_to != _environments.HANDLE_PARENT:
        d = _environments.env_data(ctx, env)
        if relative_to != WORLD:
            pr, rr, _, _ = _environments.frame(ctx, env, d, relative_to)
            p, r = pr + rr @ p, rr @ r
        if dummy.parent != WORLD:
            pp, rp, _, _ = _environments.frame(ctx, env, d, dummy.parent)
            p, r = rp.T @ (p - pp), rp.T @ r
    dummy.position, dummy.rotation = p, r


def place(ctx: CallContext, environmentHandle: Any, objectHandle: Any, relativeToObjectHandle: Any,  # noqa: N803
          position: list[float], rotation: np.ndarray) -> None:
    """``simIK.setObjectPose`` & co.: one of the environment's dummies in the environment, a scene
    object (a target) in the scene, which the environment shares.

    Raises:
        ArgumentError: a scene object relative to one of the environment's dummies.
    """
    env = _environments.env_of(ctx, environmentHandle)
    h = _environments.object_of(ctx, env, objectHandle)
    parent = _environments.HANDLE_PARENT
    rel = parent if relativeToObjectHandle == parent else _environments.object_of(
        ctx, env, relativeToObjectHandle, "relativeToObjectHandle")
    if h in env.dummies:
        place_dummy(ctx, env, h, rel, position, rotation)
    elif rel in env.dummies:
        raise ArgumentError("a scene object cannot be placed relative to a dummy of an IK environment")
    else:
        _core.set_pose(ctx, h, rel, position=position, rotation=rotation)


def _exists(ctx: CallContext, names: set[str], name: str) -> bool:
    """Whether ``name`` is one of the environment's dummies' (``names``) or a scene object's."""
    return name in names or ctx.sim.getObject(name, {"noError": True}) != -1


@simik_function("createDummy")
def createDummy(ctx: CallContext, environmentHandle: Any, dummyName: Any = "") -> int:  # noqa: N802, N803
    """A dummy of the environment only, at the world's origin; its handle. Without a name it is
    ``dummy0``, ``dummy1`` ... (the first free), as ``ikCreateDummy``.

    Raises:
        ArgumentError: the name is an object's of the environment (its own or the scene's), or
            the environment has MAX_DUMMIES dummies already.
    """
    env = _environments.env_of(ctx, environmentHandle)
    if len(env.dummies) >= _environments.MAX_DUMMIES:
        raise ArgumentError(f"at most {_environments.MAX_DUMMIES} dummies per IK environment: erase one first")
    name = _text(dummyName, "dummyName") if dummyName is not None else ""
    if len(name) > MAX_NAME:
        raise ArgumentError(f"dummyName is longer than {MAX_NAME} characters")
    names = {d.name for d in env.dummies.values()}
    if not name:
        n = 0
        while _exists(ctx, names, f"dummy{n}"):
            n += 1
        name = f"dummy{n}"
    elif _exists(ctx, names, name):
        raise ArgumentError(f"an object named {name!r} exists already in the environment")
    h, env.next_dummy = env.next_dummy, env.next_dummy + 1
    env.dummies[h] = _environments.LocalDummy(h, name)
    return h


def _own(ctx: CallContext, env: _environments.Environment, handle: Any, what: str) -> int:
    h = _environments.object_of(ctx, env, handle, what)
    if h not in env.dummies:
        raise ArgumentError(f"{what} {h} is the scene's: an IK environment changes only its own dummies "
                            "(simIK.createDummy); the scene's objects are edited through sim")
    return h


def _world_pose(ctx: CallContext, env: _environments.Environment, h: int) -> tuple[np.ndarray, np.ndarray]:
    p, r, _, _ = _environments.frame(ctx, env, _environments.env_data(ctx, env), h)
    return p, r


@simik_function("setObjectParent")
def setObjectParent(ctx: CallContext, environmentHandle: Any, objectHandle: Any, parentObjectHandle: Any,  # noqa: N802, N803
                    keepInPlace: Any = True) -> None:  # noqa: N803
    """Attach one of the environment's dummies to a parent (-1 none: the world; a scene object;
    another of its dummies). ``keepInPlace``: it stays where it is, else it keeps its pose
    relative to its parent (``ikSetObjectParent``).

    Raises:
        ArgumentError: the object is the scene's, or the parent is the dummy or one of its children.
    """
    env = _environments.env_of(ctx, environmentHandle)
    h = _own(ctx, env, objectHandle, "objectHandle")
    parent = _environments.object_of(ctx, env, parentObjectHandle, "parentObjectHandle")
    a = parent
    while a in env.dummies:
        if a == h:
            raise ArgumentError("a dummy cannot be the child of itself or of one of its children")
        a = env.dummies[a].parent
    dummy = env.dummies[h]
    if keepInPlace:
        p, r = _world_pose(ctx, env, h)
        dummy.parent = parent
        place_dummy(ctx, env, h, WORLD, p, r)
    else:
        dummy.parent = parent


@simik_function("eraseObject")
def eraseObject(ctx: CallContext, environmentHandle: Any, objectHandle: Any) -> None:  # noqa: N802, N803
    """Erase one of the environment's dummies: its children go to its parent, staying in place;
    the elements whose tip or base it was go, those it was the target of have none
    (``ikEraseObject``).

    Raises:
        ArgumentError: the object is the scene's.
    """
    env = _environments.env_of(ctx, environmentHandle)
    h = _own(ctx, env, objectHandle, "objectHandle")
    parent = env.dummies[h].parent
    for child in [d.handle for d in env.dummies.values() if d.parent == h]:
        p, r = _world_pose(ctx, env, child)
        env.dummies[child].parent = parent
        place_dummy(ctx, env, child, WORLD, p, r)
    del env.dummies[h]
    for g in env.groups.values():
        g.elements = [el for el in g.elements if h not in (el.tip, el.base)]
        for el in g.elements:
            if el.target == h:
                el.target = -1
