"""The scene's IK groups (``simx:ik:NAME``, :mod:`simx_server.sim.ik`) as V-REP 3.x's ``sim``
calls: ``sim.handleIkGroup`` and ``sim.getIkGroupHandle``."""

from __future__ import annotations

from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.sim import ik
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
