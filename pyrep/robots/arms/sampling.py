"""``Arm.solve_ik_via_sampling``'s search, bounded in time as PyRep's.

PyRep calls CoppeliaSim 4.1's ``sim.getConfigForTipPose`` ``trials`` times, each searching random
configurations for at most ``max_time_ms`` (coppeliaSimLib ``CIkGroup::getConfigForTipPose``, the
IK plug-in's ``ikGetConfigForTipPose``), and stops once it has ``max_configs``: a failing search
gives up after ``trials * max_time_ms`` (3 s with PyRep's defaults). Here too, in a simIK
environment of the table (the server's copy of the kinematics): a try solves IK only from
random configurations whose tip comes within ``distance_threshold`` of the target (the server's
damped least squares, many starts at once: :mod:`simx_server.sim.ik_batch`); a configuration
found is kept when it does not collide (``ignore_collisions`` off), as
``sim.getConfigForTipPose`` checks its collision pairs.
"""

from __future__ import annotations

from time import monotonic
from typing import Any

import numpy as np

from pyrep.backend import sim

#: simIK's constraint bits in the order of ``Arm._constraints`` (x, y, z, alpha-beta, alpha-beta, gamma)
_CONSTRAINT_BITS = (1, 2, 4, 8, 8, 16)


def ik_environment(arm: Any) -> tuple[Any, Any, list[int]]:
    """A simIK environment with one group pulling the arm's tip onto its target, from the arm's
    base (made once per arm and kept): ``(environment, group, joint handles)``.

    Raises:
        CoppeliaSimError: the table refused (a tip or target that is not in the scene).
    """
    made = getattr(arm, "_sampling_ik", None)
    if made is None:
        env = sim.ik_call("createEnvironment")
        group = sim.ik_call("createGroup", env)
        constraints = 0
        for bit, on in zip(_CONSTRAINT_BITS, arm._constraints):
            constraints |= bit if on else 0
        sim.ik_call("addElementFromScene", env, group, arm.get_handle(), arm._ik_tip.get_handle(),
                    arm._ik_target.get_handle(), constraints)
        made = arm._sampling_ik = (env, group, [j.get_handle() for j in arm.joints], constraints)
    return made[0], made[1], made[2]


def sample_configs(arm: Any, trials: int, max_configs: int, distance_threshold: float, max_time_ms: int,
                   ignore_collisions: bool) -> list[np.ndarray]:
    """Configurations (n,) each that put the tip on the target (its pose as the scene has it
    now), found in at most ``trials`` tries of ``max_time_ms`` ms.

    The first try solves IK from the arm's current configuration (``simIK.findConfig``: the
    solution nearest to it, which CoppeliaSim's random search may or may not find), then from
    random configurations for the rest of its time. Every other try solves only from random
    configurations within the joints' ranges whose tips lie within ``distance_threshold`` of the
    target (the metric of sim.getConfigForTipPose: m, and 0.1 x rad), as CoppeliaSim's
    ``ikGetConfigForTipPose`` (``simIK.findConfigs`` with ``fromCurrent`` off and that
    ``thresholdDist``, batched: :mod:`simx_server.sim.ik_batch`), and keeps every configuration
    it finds within ``max_time_ms``.

    Args:
        arm: the ``Arm``.
        trials: tries at most.
        max_configs: stop once this many are found.
        distance_threshold: m (with the metric above).
        max_time_ms: ms per try (the first may take one solve longer); the whole search stops
            after ``trials * max_time_ms`` ms.
        ignore_collisions: keep colliding configurations too.

    Returns:
        The configurations found, in the order found (the arm is left where it was).
    """
    env, group, joints = ik_environment(arm)
    wanted = 0
    for bit, on in zip(_CONSTRAINT_BITS, arm._constraints):
        wanted |= bit if on else 0
    if wanted != arm._sampling_ik[3]:  # the element's constraints changed (set_ik_element_properties)
        arm._sampling_ik = None
        env, group, joints = ik_environment(arm)
    start = np.array(arm.get_joint_positions(), dtype=float)
    found: list[np.ndarray] = []
    per_try = max(int(max_time_ms), 1) / 1000.0
    deadline = monotonic() + max(int(trials), 1) * per_try  # PyRep's whole search at most
    for j, v in zip(joints, start):
        sim.ik_call("setJointPosition", env, j, float(v))
    try:
        for trial in range(max(int(trials), 1)):
            if trial and monotonic() >= deadline:
                break
            if trial == 0:  # from the arm's configuration first, then random restarts
                config = sim.ik_call("findConfig", env, group, joints, float(distance_threshold), per_try)
                configs = [config] if config else []
            else:  # random restarts only, every one found within the try
                configs = sim.ik_call("findConfigs", env, group, joints,
                                      {"maxTime": per_try, "findMultiple": True, "fromCurrent": False,
                                       "thresholdDist": float(distance_threshold)})
            for config in configs:
                q = np.array(config, dtype=float)
                if any(np.allclose(q, f, atol=1e-3) for f in found):
                    continue
                if not ignore_collisions and arm._collides(q):
                    continue
                found.append(q)
                if len(found) >= max_configs:
                    return found
    finally:
        arm.set_joint_positions(start.tolist())
    return found
