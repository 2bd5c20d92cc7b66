"""``simIK``'s configuration search: ``findConfig`` (CoppeliaSim 4.0-4.2, ``sim.getConfigForTipPose``)
and ``findConfigs`` (4.3+): IK solved from the current configuration, then from random ones, the
random starts solved many at once where the group allows it (:mod:`simx_server.sim.ik_batch`)."""

from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from simx_server.api import long_calls
from simx_server.api.context import CallContext
from simx_server.api.registry import simik_function
from simx_server.api.simik import chains as _chains, config_gate as _gate, environments as _environments
from simx_server.api.simik.calls import _options
from simx_server.base import limits as L
from simx_server.base.arguments import as_number as _num, as_vector as _vector
from simx_server.sim import ik_batch, ik_solver as S
from simx_wire.protocol import UnsupportedError

#: The longest search on the simulation thread (s): a script's ``maxTime`` of 1e9 held it 10 s.
MAX_SEARCH_SECONDS = 10.0


@simik_function("findConfigs")
def findConfigs(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, jointHandles: Any, params: Any = None,  # noqa: N802, N803
                configs: Any = None) -> list[list[float]]:
    """Configurations of ``jointHandles`` that put the group's tips on their targets: random
    restarts within the joints' ranges (unlimited hinges: ±pi), each solved by damped least
    squares. ``params``: ``maxTime`` (s, default 0.5, at most 10; a ZMQ client's at most
    ``limits.MAX_REQUEST_SECONDS``: it holds the simulation thread), ``findMultiple`` (default
    false: the first found), ``maxDist`` (keep configs closer than this to the current one,
    ``pMetric`` weighting it); simx's own: ``fromCurrent`` (default true: solve from the current
    configuration first), ``thresholdDist`` and ``metric`` (start IK only from random
    configurations whose tips lie that near their targets, as :func:`findConfig`). Sorted by
    distance to the current configuration; empty when none."""
    p = _options(params)
    gate = None
    if p.get("thresholdDist") is not None:
        gate = (_num(p["thresholdDist"], "thresholdDist"), _gate.metric_of(p.get("metric")))
    return _find(ctx, environmentHandle, ikGroupHandle, jointHandles, params, gate)


def _find(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, jointHandles: Any, params: Any,  # noqa: N803
          gate: tuple[float, np.ndarray] | None = None) -> list[list[float]]:
    """:func:`findConfigs`; ``gate`` ``(thresholdDist, metric)``: restarts gated (``config_gate``)."""
    env = _environments.env_of(ctx, environmentHandle)
    g = _environments.group_of(ctx, env, ikGroupHandle)
    with _chains.only_joints(ctx, env, g, jointHandles) as joints:
        p = _options(params)
        bound = L.MAX_REQUEST_SECONDS if long_calls.off_thread(ctx) else MAX_SEARCH_SECONDS  # maxTime 1e9 held all 10 s
        max_time = min(_num(p.get("maxTime", 0.5), "maxTime"), bound)
        multiple = bool(p.get("findMultiple", False))
        max_dist = p.get("maxDist")
        metric = np.ones(len(joints)) if p.get("pMetric") is None else np.array(_vector(p["pMetric"], len(joints), "pMetric"))
        order = _environments.joints_of(ctx, env, g)
        m = ctx.world.model
        jid = [ctx.world.get(j).mj_id for j in order]
        low = np.array([m.jnt_range[j][0] if m.jnt_limited[j] else -np.pi for j in jid])
        high = np.array([m.jnt_range[j][1] if m.jnt_limited[j] else np.pi for j in jid])
        current = np.array([_environments.q_of(ctx, env, j) for j in order])
        rng = np.random.default_rng(int(p.get("seed", 0)) if "seed" in p else None)
        method, damping = g.method, g.damping
        g.method, g.damping = S.METHOD_DLS, max(g.damping, 0.05)
        found: list[np.ndarray] = []
        deadline = time.monotonic() + max_time

        def take(q: np.ndarray) -> bool:
            """Keeps a solution (not one found already, within maxDist); True when the search ends."""
            if any(np.allclose(q, f, atol=1e-3) for f in found):
                return False
            d = float(np.sqrt(np.sum((metric * (q - current)) ** 2)))
            if max_dist is None or d <= _num(max_dist, "maxDist"):
                found.append(q)
                return not multiple
            return False

        try:
            iterations = max(g.iterations, 100)
            if p.get("fromCurrent", True):
                ok, _, q = _environments.solve(ctx, env, g, q0=current.copy(), iterations=iterations)
                if ok and take(q):
                    return _answer(found, order, joints, metric, current)
            chain = _batch_chain(ctx, env, g, order)
            if chain is not None:
                _find_batched(ctx, env, g, order, chain, (low, high), rng, gate, deadline, take)
                return _answer(found, order, joints, metric, current)
            while time.monotonic() < deadline:
                start = rng.uniform(low, high)
                while gate and _gate.far(ctx, env, g, order, start, gate) and time.monotonic() < deadline:
                    start = rng.uniform(low, high)
                ok, _, q = _environments.solve(ctx, env, g, q0=start, iterations=iterations)
                if ok and take(q):
                    break
        finally:
            g.method, g.damping = method, damping
        return _answer(found, order, joints, metric, current)


def _answer(found: list[np.ndarray], order: list[int], joints: list[int], metric: np.ndarray,
            current: np.ndarray) -> list[list[float]]:
    """The configurations found, nearest ``current`` first, in ``joints``' order."""
    found.sort(key=lambda q: float(np.sqrt(np.sum((metric * (q - current)) ** 2))))
    index = [order.index(j) for j in joints]
    return [[float(q[i]) for i in index] for q in found]


#: Random starts solved together by the batched search (:mod:`simx_server.sim.ik_batch`).
BATCH_STARTS = 128


def _batch_chain(ctx: CallContext, env: Any, g: Any, order: list[int]) -> ik_batch.Chain | None:
    """The group as an :class:`~simx_server.sim.ik_batch.Chain` at the environment's
    configuration, or None where the batched search does not apply: not exactly one enabled
    element, a tip or target that is one of the environment's own dummies or an explicit pose,
    dependent joints or joints with max step sizes, a chain the class refuses."""
    elements = [el for el in g.elements if el.flags & 1]
    if len(elements) != 1 or not g.flags & _environments.GROUP_IGNOREMAXSTEPS:
        return None
    el = elements[0]
    if el.target < 0 or el.tip in env.dummies or el.target in env.dummies or el.base in env.dummies:
        return None
    if _environments.slaves_of(ctx, env, order) or any(env.dependency.get(j, (-1,))[0] != -1 for j in order):
        return None
    m = ctx.world.model
    d = _environments.env_data(ctx, env)
    tp, tr, tkind, tid = _environments.frame(ctx, env, d, el.tip)
    gp, gr, gkind, gid = _environments.frame(ctx, env, d, el.target)
    base_r = _environments.frame(ctx, env, d, el.base)[1] if el.base >= 0 else np.eye(3)
    tip_body = int(m.site_bodyid[tid]) if tkind == "site" else tid
    target_body = int(m.site_bodyid[gid]) if gkind == "site" else gid
    jids = [ctx.world.get(j).mj_id for j in order]
    return ik_batch.Chain.build(m, d, jids, (tp, tr), tip_body, (gp, gr), target_body, base_r, el.constraints,
                                el.weights, el.precision)


def _find_batched(ctx: CallContext, env: Any, g: Any, order: list[int], chain: ik_batch.Chain,
                  box: tuple[np.ndarray, np.ndarray], rng: np.random.Generator, gate: tuple[float, np.ndarray] | None,
                  deadline: float, take: Callable[[np.ndarray], bool]) -> None:
    """:func:`_find`'s random restarts on the batched solver: :data:`BATCH_STARTS` random
    configurations at a time within ``box`` (low, high), those within the gate (where there is
    one) solved together, until ``deadline``. Each configuration the batch finds is solved again
    by the exact solver (from a start already within precision: one evaluation) before ``take``
    keeps it (True: the search ends)."""
    m = ctx.world.model
    jid = [ctx.world.get(j).mj_id for j in order]
    lo, hi, top = S.bounds(m, jid, np.array([env.margin.get(j, 0.0) for j in order]))
    weights = np.array([env.weight.get(j, 1.0) for j in order])
    iterations = max(g.iterations, 100)
    while time.monotonic() < deadline:
        starts = rng.uniform(box[0], box[1], (BATCH_STARTS, len(order)))
        if gate:
            starts = starts[chain.gate(starts, gate[1]) <= gate[0]]
        if not len(starts):
            continue
        qs, ok, _ = chain.solve(starts, lo, hi, top, g.damping, iterations, weights, until=deadline)
        for q in qs[ok]:
            exact, _, q = _environments.solve(ctx, env, g, q0=q.copy(), iterations=iterations)
            if exact and take(q):
                return


@simik_function("findConfig", "getConfigForTipPose")
def findConfig(ctx: CallContext, environmentHandle: Any, ikGroupHandle: Any, jointHandles: Any, thresholdDist: Any = 0.1,  # noqa: N802, N803
               maxTime: Any = 0.5, metric: Any = None, callback: Any = None, auxData: Any = None) -> list[float] | None:  # noqa: N803
    """CoppeliaSim 4.0-4.2: the first configuration :func:`findConfigs` finds, nil when none
    (``maxTime`` in s; a ``callback`` is refused: simx cannot call back a client). After the first
    solve, from the current configuration, IK starts only from random configurations whose tips
    lie within ``thresholdDist`` of their targets in ``metric`` ({x, y, z, angle} weights, default
    {1, 1, 1, 0.1}), as coppeliaKinematicsRoutines 4.1's ``ikGetConfigForTipPose``."""
    if callback is not None:
        raise UnsupportedError("simIK.findConfig with a callback: simx cannot call a client's function")
    gate = (_num(thresholdDist, "thresholdDist"), _gate.metric_of(metric))
    found = _find(ctx, environmentHandle, ikGroupHandle, jointHandles, {"maxTime": maxTime}, gate)
    return found[0] if found else None
