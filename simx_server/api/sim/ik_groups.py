"""The scene's IK groups (``simx:ik:NAME``, :mod:`simx_server.sim.ik`) as V-REP 3.x's ``sim``
calls: ``sim.handleIkGroup``, ``sim.getIkGroupHandle``, ``sim.checkIkGroup`` (PyRep's
``solve_ik_via_jacobian``), ``sim.generateIkPath`` (PyRep's linear paths),
``sim.setIkGroupProperties`` and ``sim.setIkElementProperties``."""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.base import limits as L
from simx_server.base.arguments import as_integer, as_number, as_vector
from simx_server.sim import ik, motion_planning, ompl_spaces
from simx_server.sim.world import JOINT
from simx_wire.protocol import ArgumentError


@sim_function("handleIkGroup")
def handleIkGroup(ctx: CallContext, group: Any) -> int:  # noqa: N802 (V-REP's name)
    """``sim.handleIkGroup(ikGroupHandle)`` as coppeliaSimLib ``simHandleIkGroup_internal``: one
    group, which must be tagged for explicit handling, or for ``sim.handle_all`` (-2) every
    group and for ``sim.handle_all_except_explicit`` (-3) every group that is not explicit
    (``CIkGroupContainer::computeAllIkGroups``). A solved group's joints' target positions move;
    physics follows at the next step. A group saved inactive is not solved
    (``CIkGroup_old::computeGroupIk``: ``sim.ikresult_not_performed``).

    Args:
        group: an IK group's handle or name, or -2 / -3.

    Returns:
        For one group ``sim.ikresult_not_performed`` (0), ``success`` (1) or ``fail`` (2); for
        -2 / -3 the number of groups solved (performed).

    Raises:
        UnknownObjectError: no such group.
        ArgumentError: a group not tagged for explicit handling (the main script solves it).
    """
    gs = ik.groups(ctx.world)
    group = ik.group_arg(group)
    if group in (-2, -3):  # sim_handle_all, sim_handle_all_except_explicit
        chosen = [g for g in gs.groups.values() if g.enabled and (group == -2 or not g.explicit)]
        return sum(gs.solve(g) != ik.IK_NOT_PERFORMED for g in chosen)
    g = gs.group(group)
    if not g.explicit:
        raise ArgumentError(f"IK group {g.name!r} is not tagged for explicit handling: the simulation solves it "
                            "at every step (its 'explicit' setting)")
    return gs.solve(g) if g.enabled else ik.IK_NOT_PERFORMED


@sim_function("getIkGroupHandle")
def getIkGroupHandle(ctx: CallContext, name: Any) -> int:  # noqa: N802
    """``sim.getIkGroupHandle(name)``: handle of the group declared as ``simx:ik:NAME``.

    Args:
        name: the group's name (str or bytes).

    Returns:
        The group's handle.

    Raises:
        UnknownObjectError: no such group.
    """
    return ik.groups(ctx.world).group(str(ik.group_arg(name))).handle


@sim_function("checkIkGroup")
def checkIkGroup(ctx: CallContext, group: Any, jointHandles: Any, jointOptions: Any = None) -> tuple[int, list[float]]:  # noqa: N802, N803
    """``sim.checkIkGroup(ikGroupHandle, jointHandles, jointOptions=nil)`` as coppeliaSimLib
    ``CIkGroup_old::checkIkGroup``: solve an explicit group from the joints' current positions
    with the group's own method, damping, iterations and precision, moving only the joints named
    (the chain's others held), and leave the scene as it was.

    Args:
        group: an IK group's handle or name (tagged for explicit handling).
        jointHandles: the joints to solve for (some of the chain's).
        jointOptions: per joint, bit 0 set: held (as left out); nil: none held.

    Returns:
        ``(result, jointValues)``: ``sim.ikresult_success`` (1), ``fail`` (2) or ``not_performed``
        (0, a group saved inactive), and the joints' positions reached (rad or m).

    Raises:
        UnknownObjectError: no such group or joint.
        ArgumentError: a group not tagged for explicit handling, a joint outside its chain.
    """
    gs = ik.groups(ctx.world)
    g = gs.group(ik.group_arg(group))
    if not g.explicit:
        raise ArgumentError(f"IK group {g.name!r} is not tagged for explicit handling")
    if not isinstance(jointHandles, (list, tuple)):
        raise ArgumentError("jointHandles must be a table of joint handles")
    joints = [ctx.h(j, "jointHandles[i]") for j in jointHandles]
    for j in joints:
        ctx.world.get(j, JOINT)
    options = list(jointOptions) if isinstance(jointOptions, (list, tuple)) else [0] * len(joints)
    if len(options) != len(joints):
        raise ArgumentError("jointOptions must have one entry per joint")
    free = [j for j, o in zip(joints, options) if not int(o) & 1]
    result, values = gs.check(g, free)
    by_joint = dict(zip(free, values))
    return result, [by_joint.get(j, ctx.world.joint_position(j)) for j in joints]


@sim_function("generateIkPath")
def generateIkPath(ctx: CallContext, ikGroupHandle: Any, jointHandles: Any, ptCnt: Any,  # noqa: N802, N803
                   collisionPairs: Any = None, jointOptions: Any = None) -> list[float] | None:
    """``sim.generateIkPath(ikGroupHandle, jointHandles, ptCnt, collisionPairs=nil, jointOptions=nil)``
    as coppeliaSimLib ``simGenerateIkPath_internal``: ``ptCnt`` configurations that carry the
    group's tips from where they are to their targets in equal steps, each solved from the one
    before with the group's own method, damping, iterations and precision (an inactive group
    too); a step that misses its precision, or whose configuration makes a pair of
    ``collisionPairs`` collide, fails the whole path. The scene is left as it was. PyRep's
    ``Arm.get_linear_path`` and ``get_path_from_cartesian_path`` are made of it.

    Args:
        ikGroupHandle: an IK group's handle or name.
        jointHandles: the joints that move (some of the chain's; its others are held).
        ptCnt: the number of configurations, 2..``limits.MAX_IK_PATH_POINTS``.
        collisionPairs: ``{entity1, entity2, ...}`` as ``sim.checkCollision`` takes them (a pair
            whose first entry is -1 is skipped; ``sim.handle_all`` as the second), or nil.
        jointOptions: per joint, bit 0 set: held; nil: none held.

    Returns:
        The configurations, flat (ptCnt * len(jointHandles), rad or m), or None (nil) when no
        such path exists.

    Raises:
        UnknownObjectError: no such group, joint or entity.
        ArgumentError: a joint outside the group's chain, ``ptCnt`` out of range, a pair list of
            odd length, options not one per joint.
    """
    g = ik.groups(ctx.world).group(ik.group_arg(ikGroupHandle))
    count = as_integer(ptCnt, "ptCnt")
    if not 2 <= count <= L.MAX_IK_PATH_POINTS:
        raise ArgumentError(f"ptCnt must be in [2, {L.MAX_IK_PATH_POINTS}] "
                            f"(simx_server.base.limits.MAX_IK_PATH_POINTS), got {count}")
    if not isinstance(jointHandles, (list, tuple)) or not jointHandles:
        raise ArgumentError("jointHandles must be a table of joint handles")
    joints = [ctx.world.get(ctx.h(j, "jointHandles[i]"), JOINT).handle for j in jointHandles]
    options = list(jointOptions) if isinstance(jointOptions, (list, tuple)) else [0] * len(joints)
    if len(options) != len(joints):
        raise ArgumentError("jointOptions must have one entry per joint")
    free = [j for j, o in zip(joints, options) if not int(o) & 1]
    raw = list(collisionPairs) if isinstance(collisionPairs, (list, tuple)) else []
    if len(raw) % 2:
        raise ArgumentError("collisionPairs must hold pairs of entities")
    entities = [ctx.h(v, "collisionPairs[i]") for v in raw]
    pairs = [(a, b) for a, b in zip(entities[::2], entities[1::2]) if a != -1]
    collides = None
    if pairs:
        placements = [ompl_spaces.Placement(ctx.world, "joint_position", j) for j in free]
        collides = motion_planning.ScratchCollisions(ctx.world, placements, pairs)
    path = ik.groups(ctx.world).path(g, free, count, collides)
    if path is None:
        return None
    by_joint = {j: path[:, i] for i, j in enumerate(free)}
    held = {j: np.full(count, ctx.world.joint_position(j)) for j in joints if j not in by_joint}
    return np.column_stack([by_joint.get(j, held.get(j)) for j in joints]).reshape(-1).tolist()


_METHOD_WORDS = {v: k for k, v in ik.METHODS.items()}


@sim_function("setIkGroupProperties")
def setIkGroupProperties(ctx: CallContext, group: Any, resolutionMethod: Any, maxIterations: Any,  # noqa: N802, N803
                         damping: Any) -> None:
    """``sim.setIkGroupProperties(ikGroupHandle, resolutionMethod, maxIterations, damping)``:
    ``sim.ik_pseudo_inverse_method`` (0), ``damped_least_squares_method`` (1) or
    ``jacobian_transpose_method`` (2), iterations (1..MAX_IK_ITERATIONS), damping λ.

    Raises:
        UnknownObjectError: no such group.
        ArgumentError: an unknown method, iterations out of range, a negative damping.
    """
    g = ik.groups(ctx.world).group(ik.group_arg(group))
    method, iterations, lam = as_integer(resolutionMethod, "resolutionMethod"), \
        as_integer(maxIterations, "maxIterations"), as_number(damping, "damping")
    if method not in _METHOD_WORDS:
        raise ArgumentError(f"resolutionMethod must be 0, 1, 2 or 3, got {method}")
    ik.set_properties(ctx.world, g, method=_METHOD_WORDS[method], iterations=str(iterations), damping=repr(lam))


@sim_function("setIkElementProperties")
def setIkElementProperties(ctx: CallContext, group: Any, tipDummyHandle: Any, constraints: Any,  # noqa: N802, N803
                           precision: Any = None, weight: Any = None) -> None:
    """``sim.setIkElementProperties(ikGroupHandle, tipDummyHandle, constraints, precision=nil,
    weight=nil)``: the element of that tip's constraint bits (x 1, y 2, z 4, alpha-beta 8,
    gamma 16), precision ``{linear m, angular rad}`` and weights ``{position, orientation}``.

    Raises:
        UnknownObjectError: no such group.
        ArgumentError: no element with that tip, bad constraints, precision or weights.
    """
    g = ik.groups(ctx.world).group(ik.group_arg(group))
    tip = ctx.h(tipDummyHandle, "tipDummyHandle")
    index = next((i for i, el in enumerate(g.parts) if el.tip == tip), None)
    if index is None:
        raise ArgumentError(f"IK group {g.name!r} has no element with tip {tip}")
    n = "" if index == 0 else str(index + 1)
    c = as_integer(constraints, "constraints")
    if not 1 <= c <= 31:
        raise ArgumentError(f"constraints must be V-REP's bits 1-31, got {c}")
    changes = {f"constraints{n}": str(c)}
    for key, value in ((f"precision{n}", precision), (f"weights{n}", weight)):
        if value is not None:
            a, b = as_vector(value, 2, key)
            changes[key] = f"{a!r},{b!r}"
    ik.set_properties(ctx.world, g, **changes)
