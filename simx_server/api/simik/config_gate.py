"""The distance gate of ``simIK.findConfig`` (CoppeliaSim 4.0-4.2): IK is solved only from a
random configuration whose tips lie near enough their targets.

coppeliaKinematicsRoutines 4.1 ``ikGetConfigForTipPose`` (what ``simIK.findConfig`` and
``sim.getConfigForTipPose`` run) draws joint positions within their ranges and, for each
element of the group, measures its tip against its target in the element's base frame:
``sqrt((m0 dx)^2 + (m1 dy)^2 + (m2 dz)^2 + (m3 angle)^2)`` with ``metric`` ``m`` (default
``{1, 1, 1, 0.1}``: m, and 0.1 x rad), summed over the elements; only a configuration within
``thresholdDist`` is handed to IK.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.simik import environments as _environments
from simx_server.base.arguments import as_vector as _vector
from simx_server.sim.rotations import rotation_angle
from simx_wire.protocol import ArgumentError

#: coppeliaKinematicsRoutines' default metric: x, y, z (m) and the angle (rad) weighed 0.1.
DEFAULT_METRIC = (1.0, 1.0, 1.0, 0.1)


def metric_of(value: Any) -> np.ndarray:
    """``findConfig``'s ``metric`` (None: :data:`DEFAULT_METRIC`) as (4,) non-negative floats.

    Raises:
        ArgumentError: not four numbers, or one negative.
    """
    m = np.array(DEFAULT_METRIC if value is None else _vector(value, 4, "metric"), dtype=float)
    if (m < 0).any():
        raise ArgumentError("metric: its four weights must not be negative")
    return m


def tip_distance(ctx: CallContext, env: Any, g: Any, joints: list[int], q: np.ndarray, metric: np.ndarray) -> float:
    """The group's tips' summed distance to their targets with the group's ``joints`` at ``q``
    (the other joints as the environment has them), in ``metric`` (see the module's text).

    Args:
        ctx: the caller's context.
        env: the simIK environment.
        g: its group.
        joints: the joints ``q`` is for (the group's, in its order).
        q: (len(joints),) positions (rad or m).
        metric: (4,) weights of x, y, z and the angle.

    Returns:
        The distance (m, with the angle weighed).
    """
    kept = {j: env.q[j] for j in joints if j in env.q}
    env.q.update(zip(joints, (float(v) for v in q)))  # env_data places them, and their dependent joints
    try:
        d = _environments.env_data(ctx, env)
    finally:
        for j in joints:
            if j in kept:
                env.q[j] = kept[j]
            else:
                env.q.pop(j, None)
    total = 0.0
    for el in g.elements:
        if not el.flags & 1 or el.target < 0:
            continue
        tp, tr, _, _ = _environments.frame(ctx, env, d, el.tip)
        gp, gr, _, _ = _environments.frame(ctx, env, d, el.target)
        base_r = _environments.frame(ctx, env, d, el.base)[1] if el.base >= 0 else np.eye(3)
        dx = base_r.T @ (tp - gp) * metric[:3]
        angle = rotation_angle(gr.T @ tr) * metric[3]
        total += float(np.sqrt(dx @ dx + angle * angle))
    return total


def far(ctx: CallContext, env: Any, g: Any, joints: list[int], q: np.ndarray, gate: tuple[float, np.ndarray]) -> bool:
    """Whether the configuration ``q`` lies beyond ``gate`` ``(thresholdDist, metric)``
    (:func:`tip_distance`): IK is not started from it."""
    return tip_distance(ctx, env, g, joints, q, gate[1]) > gate[0]
