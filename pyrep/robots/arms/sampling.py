"""``Arm.solve_ik_via_sampling``'s search, bounded in time as PyRep's.

PyRep calls CoppeliaSim 4.1's ``sim.getConfigForTipPose`` ``trials`` times, each searching random
configurations for at most ``max_time_ms`` (coppeliaSimLib ``CIkGroup::getConfigForTipPose``, the
IK plug-in's ``ikGetConfigForTipPose``), and stops once it has ``max_configs``: a failing search
gives up after ``trials * max_time_ms`` (3 s with PyRep's defaults). Here too: a try draws
random configurations (set in a simIK environment of the table: the server's copy of the
kinematics) until the tip comes within ``distance_threshold`` of the target, and only then
solves IK (``simIK.findConfig``, the server's damped least squares); a configuration found is
kept when it does not collide (``ignore_collisions`` off), as ``sim.getConfigForTipPose``
checks its collision pairs.
"""

from __future__ import annotations

from time import monotonic
from typing import Any

import numpy as np

from pyrep.backend import sim
from pyrep.robots.arms import planning

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


def _tip_distance(env: Any, tip: int, target: np.ndarray) -> float:
    """sim.getConfigForTipPose's distance of the tip (the environment's configuration) to the
    target (4, 4), with its default metric {1, 1, 1, 0.1}: position (m) and 0.1 x angle (rad)."""
    m = np.array(sim.ik_call("getObjectMatrix", env, tip, -1), dtype=float).reshape(3, 4)
    r = target[:3, :3] @ m[:, :3].T
    angle = planning.rotation_angle(r)
    return float(np.sqrt(np.sum((target[:3, 3] - m[:, 3]) ** 2) + (0.1 * angle) ** 2))


def sample_configs(arm: Any, lo: np.ndarray, hi: np.ndarray, trials: int, max_configs: int,
                   distance_threshold: float, max_time_ms: int, ignore_collisions: bool) -> list[np.ndarray]:
    """Configurations (n,) each that put the tip on the target (its pose as the scene has it
    now), found in at most ``trials`` tries of ``max_time_ms`` ms.

    The first try solves IK from the arm's current configuration (``simIK.findConfig``: the
    solution nearest to it, which CoppeliaSim's random search may or may not find). Every other
    try draws random configurations within ``lo`` .. ``hi`` until one puts the tip within
    ``distance_threshold`` of the target (the metric of sim.getConfigForTipPose: m, and 0.1 x
    rad), then solves IK from it; a try with no configuration that near ends at ``max_time_ms``
    without solving, as CoppeliaSim's.

    Args:
        arm: the ``Arm``.
        lo: (n,) lower joint limits (rad or m) the random configurations are drawn within.
        hi: (n,) upper limits.
        trials: tries at most.
        max_configs: stop once this many are found.
        distance_threshold: m (with the metric above).
        max_time_ms: ms per try (a try that solves IK may take one solve longer); the whole
            search stops after ``trials * max_time_ms`` ms.
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
    tip, target = arm._ik_tip.get_handle(), arm._ik_target.get_matrix()
    start = np.array(arm.get_joint_positions(), dtype=float)
    rng = np.random.default_rng()
    found: list[np.ndarray] = []
    per_try = max(int(max_time_ms), 1) / 1000.0
    deadline = monotonic() + max(int(trials), 1) * per_try  # PyRep's whole search at most
    seed: np.ndarray | None = start
    try:
        for trial in range(max(int(trials), 1)):
            now = monotonic()
            if trial and now >= deadline:
                break
            end, config = now + per_try, None
            while True:
                q = rng.uniform(lo, hi) if seed is None else seed
                for j, v in zip(joints, q):
                    sim.ik_call("setJointPosition", env, j, float(v))
                if seed is not None or _tip_distance(env, tip, target) <= distance_threshold:
                    seed = None
                    config = sim.ik_call("findConfig", env, group, joints, float(distance_threshold), per_try)
                    break
                if monotonic() >= end:
                    break
            if not config:
                continue
            q = np.array(config, dtype=float)
            if not ignore_collisions and arm._collides(q):
                continue
            found.append(q)
            if len(found) >= max_configs:
                break
    finally:
        arm.set_joint_positions(start.tolist())
    return found
