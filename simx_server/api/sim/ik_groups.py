"""The scene's IK groups (``simx:ik:NAME``, :mod:`simx_server.sim.ik`) as V-REP 3.x's ``sim``
calls: ``sim.handleIkGroup`` and ``sim.getIkGroupHandle``."""

from __future__ import annotations

from typing import Any

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.sim import ik


@sim_function("handleIkGroup")
def handleIkGroup(ctx: CallContext, group: Any) -> int:  # noqa: N802 (V-REP's name)
    """``sim.handleIkGroup(ikGroupHandle)``: solve one group now (its joints' target positions
    move; physics follows at the next step), or every non-explicit group for
    ``sim.handle_all`` (-2) and ``sim.handle_all_except_explicit`` (-3). Returns
    ``sim.ikresult_success`` (1) or ``sim.ikresult_fail`` (2); for several groups the number of
    groups solved. Raises UnknownObjectError for an unknown group.

    Args:
        group: an IK group's handle or name, or -2 / -3.

    Returns:
        1, 2, or the count of groups solved.

    Raises:
        UnknownObjectError: no such group.
    """
    gs = ik.groups(ctx.world)
    group = ik.group_arg(group)
    if group in (-2, -3):  # sim_handle_all, sim_handle_all_except_explicit
        chosen = [g for g in gs.groups.values() if group == -2 or not g.explicit]
        return sum(gs.solve(g) == ik.IK_SUCCESS for g in chosen)
    return gs.solve(gs.group(group))


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
