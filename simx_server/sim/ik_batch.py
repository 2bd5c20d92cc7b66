"""Many IK starts solved at once, for ``simIK.findConfig``'s random search.

coppeliaKinematicsRoutines' ``ikFindConfig`` (what ``simIK.findConfig`` and 4.1's
``sim.getConfigForTipPose`` run) draws random configurations, keeps those whose tip lies
within ``thresholdDist`` of the target, and solves the group's IK from each until one
converges: in C++, thousands of starts within PyRep's 10 ms per try. One start solved by
:func:`simx_server.sim.ik_solver.solve` costs about 100 us per iteration in Python, so
:class:`Chain` solves a batch of starts together with numpy: the chain's forward kinematics as a
product of exponentials (each joint a screw about its axis in a reference configuration, read
once from MuJoCo), the Jacobian's columns from the moved screws, and one damped least-squares
step per start, as ``ik_solver.solve`` takes it (clamped to the joints' ranges, hinge steps
wrapped, ``simIK``'s numeric Jacobian clamped at upper limits). The exact solver confirms every
configuration found here before it is answered.

Only a group of one enabled element whose chain has no dependent joints and whose target does
not move with the chain is batched (:func:`Chain.build` answers None otherwise).
"""

from __future__ import annotations

import time

import mujoco
import numpy as np

from simx_server.sim.ik_solver import CONSTRAINT_ALPHA_BETA, CONSTRAINT_GAMMA, FD_STEP


def rotation_vectors(r: np.ndarray) -> np.ndarray:
    """Rotation vectors (axis x angle) of rotation matrices, as ``mju_quat2Vel`` of their quaternions.

    Args:
        r: (N, 3, 3) rotation matrices.

    Returns:
        (N, 3) rotation vectors (rad); a half turn's sign is either.
    """
    n = r.shape[0]
    flat = r.reshape(n, 9)
    cos = np.clip((flat[:, 0] + flat[:, 4] + flat[:, 8] - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    skew = flat[:, [7, 2, 3]] - flat[:, [5, 6, 1]]  # 2 sin(angle) x axis
    s = np.sin(angle)
    out = skew * (angle / np.maximum(2.0 * s, 1e-12))[:, None]
    near = (s <= 1e-6) | (angle > np.pi - 1e-3)
    if near.any():  # no turn: half the skew part; near a half turn the axis from R + I
        out[near] = 0.5 * skew[near]
        flip = near & (angle > np.pi / 2)
        if flip.any():
            sym = (r[flip] + np.eye(3)) / 2.0
            col = np.argmax(np.diagonal(sym, axis1=1, axis2=2), axis=1)
            axis = sym[np.arange(len(col)), :, col]
            axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)
            sign = np.where(np.sum(axis * skew[flip], axis=1) < 0, -1.0, 1.0)
            out[flip] = axis * (angle[flip] * sign)[:, None]
    return out


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` over the last axis (3), without its overhead on small arrays."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


class Chain:
    """A serial chain of hinge and slide joints from a fixed base to a tip, and one target pose.

    Args:
        hinge: (n,) bool, a hinge (else a slide) per joint, base first.
        axes: (n, 3) the joints' unit axes (world) at ``q_ref``.
        anchors: (n, 3) a point (m) of each hinge's axis at ``q_ref``.
        q_ref: (n,) the reference configuration (rad or m).
        tip: ``(position (3,), rotation (3, 3))`` of the tip at ``q_ref``.
        target: ``(position, rotation)`` of the target (fixed).
        base_rotation: (3, 3) the base's rotation (the gate measures in the base's frame).
        constraints: the element's ``simIK.constraint_*`` bits.
        weights: the element's linear and angular weights.
        precision: the element's linear (m) and angular (rad) precision.
    """

    def __init__(self, hinge: np.ndarray, axes: np.ndarray, anchors: np.ndarray, q_ref: np.ndarray,
                 tip: tuple[np.ndarray, np.ndarray], target: tuple[np.ndarray, np.ndarray], base_rotation: np.ndarray,
                 constraints: int, weights: tuple[float, float], precision: tuple[float, float]):
        self.hinge, self.axes, self.anchors, self.q_ref = hinge, axes, anchors, q_ref
        k = np.zeros((len(hinge), 3, 3))  # each hinge's cross-product matrix (a slide's: zero)
        a = np.where(hinge[:, None], axes, 0.0)
        k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -a[:, 2], a[:, 1], -a[:, 0]
        k[:, 1, 0], k[:, 2, 0], k[:, 2, 1] = a[:, 2], -a[:, 1], a[:, 0]
        self._k, self._k2 = k, k @ k
        self._eye = np.eye(3)
        self.all_hinge = bool(hinge.all())
        self.tip_p, self.tip_r = tip
        self.target_p, self.target_r = target
        self.base_r = base_rotation
        self.pick_lin = [i for i, bit in enumerate((1, 2, 4)) if constraints & bit]
        self.pick_ang = ([0, 1] if constraints & CONSTRAINT_ALPHA_BETA else []) + ([2] if constraints & CONSTRAINT_GAMMA else [])
        self.weights, self.precision = weights, precision

    @classmethod
    def build(cls, model: mujoco.MjModel, data: mujoco.MjData, jids: list[int], tip: tuple[np.ndarray, np.ndarray],
              tip_body: int, target: tuple[np.ndarray, np.ndarray], target_body: int, base_rotation: np.ndarray,
              constraints: int, weights: tuple[float, float], precision: tuple[float, float]) -> Chain | None:
        """The chain of MuJoCo joints ``jids`` at the configuration ``data`` holds.

        Args:
            model: the MuJoCo model.
            data: its data, kinematics up to date (the reference configuration).
            jids: MuJoCo joint ids, base first.
            tip: the tip's ``(position (3,), rotation (3, 3))`` in ``data``.
            tip_body: the body that carries the tip.
            target: the target's pose.
            target_body: the body that carries the target (-1: a fixed pose).
            base_rotation, constraints, weights, precision: as the class.

        Returns:
            The chain, or None when it cannot be batched: a joint that is no hinge or slide, a
            joint that does not carry the tip or one that carries the target, or joints out of
            chain order.
        """
        if not jids:
            return None
        bodies = [int(model.jnt_bodyid[j]) for j in jids]

        def ancestors(b: int) -> set[int]:
            out = set()
            while b > 0:
                out.add(b)
                b = int(model.body_parentid[b])
            return out

        above_tip = ancestors(tip_body)
        if any(b not in above_tip for b in bodies):
            return None
        if target_body >= 0 and ancestors(target_body) & set(bodies):
            return None
        for a, b in zip(bodies, bodies[1:]):  # base first: each joint's body at or above the next's
            if a != b and a not in ancestors(b):
                return None
        kinds = [int(model.jnt_type[j]) for j in jids]
        if any(k not in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE) for k in kinds):
            return None
        hinge = np.array([k == mujoco.mjtJoint.mjJNT_HINGE for k in kinds])
        q_ref = np.array([data.qpos[model.jnt_qposadr[j]] for j in jids], dtype=float)
        return cls(hinge, data.xaxis[jids].copy(), data.xanchor[jids].copy(), q_ref, tip, target, base_rotation,
                   constraints, weights, precision)

    def kinematics(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The tip's pose and the joints' axes in each configuration (the product of exponentials).

        Args:
            q: (N, n) configurations (rad or m).

        Returns:
            ``(tip positions (N, 3) m, tip rotations (N, 3, 3), axes (N, n, 3), anchors (N, n, 3) m)``
            in world axes.
        """
        n_rows, n = q.shape
        dq = q - self.q_ref
        s, c = np.sin(dq)[..., None, None], np.cos(dq)[..., None, None]
        rot_j = self._eye + s * self._k + (1.0 - c) * self._k2  # (N, n, 3, 3); a slide's: the identity
        pos_j = self.anchors - (rot_j @ self.anchors[:, :, None])[..., 0]  # a hinge turns about its anchor
        if not self.all_hinge:
            pos_j = np.where(self.hinge[:, None], pos_j, dq[..., None] * self.axes)
        rot_before = np.empty((n_rows, n, 3, 3))
        pos_before = np.empty((n_rows, n, 3))
        rot_before[:, 0], pos_before[:, 0] = self._eye, 0.0
        rot, pos = rot_j[:, 0], pos_j[:, 0]
        for i in range(1, n):
            rot_before[:, i], pos_before[:, i] = rot, pos
            pos = (rot @ pos_j[:, i, :, None])[..., 0] + pos
            rot = rot @ rot_j[:, i]
        axes = (rot_before @ self.axes[:, :, None])[..., 0]
        anchors = (rot_before @ self.anchors[:, :, None])[..., 0] + pos_before
        return rot @ self.tip_p + pos, rot @ self.tip_r, axes, anchors

    def gate(self, q: np.ndarray, metric: np.ndarray) -> np.ndarray:
        """``ikFindConfig``'s distance of the tip to the target in each configuration:
        ``sqrt((m0 dx)^2 + (m1 dy)^2 + (m2 dz)^2 + (m3 angle)^2)``, dx in the base's frame.

        Args:
            q: (N, n) configurations (rad or m).
            metric: (4,) weights of x, y, z (m) and the angle (rad).

        Returns:
            (N,) distances.
        """
        tip_p, tip_r, _, _ = self.kinematics(q)
        dx = (tip_p - self.target_p) @ self.base_r * metric[:3]
        angle = np.linalg.norm(rotation_vectors(self.target_r.T @ tip_r), axis=1) * metric[3]
        return np.sqrt(np.sum(dx * dx, axis=1) + angle * angle)

    def errors(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The error and Jacobian of the rows the element's constraints choose, as
        :func:`simx_server.sim.ik_solver.errors` and ``jacobian`` give them (position rows in
        world axes, angular rows in the target's; the element's weights scale the error only).

        Args:
            q: (N, n) configurations (rad or m).

        Returns:
            ``(weighted error (N, k), Jacobian (N, k, n), within precision (N,) bool)``.
        """
        tip_p, tip_r, axes, anchors = self.kinematics(q)
        lin = self.target_p - tip_p
        ang = rotation_vectors(self.target_r @ np.transpose(tip_r, (0, 2, 1)))  # world axes
        ang_local = ang @ self.target_r
        lin, ang_local = lin[:, self.pick_lin], ang_local[:, self.pick_ang]
        ok = (np.linalg.norm(lin, axis=1) <= self.precision[0]) & (np.linalg.norm(ang_local, axis=1) <= self.precision[1])
        jv = _cross(axes, tip_p[:, None, :] - anchors)
        jw = axes
        if not self.all_hinge:
            jv = np.where(self.hinge[None, :, None], jv, axes)
            jw = np.where(self.hinge[None, :, None], axes, 0.0)
        jac = np.concatenate([np.transpose(jv, (0, 2, 1))[:, self.pick_lin],
                              np.transpose(jw @ self.target_r, (0, 2, 1))[:, self.pick_ang]], axis=1)
        e = np.concatenate([self.weights[0] * lin, self.weights[1] * ang_local], axis=1)
        return e, jac, ok

    def solve(self, q: np.ndarray, low: np.ndarray, high: np.ndarray, top: np.ndarray, damping: float,
              iterations: int, weights: np.ndarray, numeric: bool = True,
              until: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Damped least squares from each row of ``q`` (N, n) for at most ``iterations`` steps;
        a row stops once within precision, once its error has not fallen by 10 % in 8 steps, or
        at ``until`` (``time.monotonic()``).

        Args:
            q: (N, n) start configurations.
            low: (n,) lower bounds (rad or m; -inf: none).
            high: (n,) upper bounds.
            top: (n,) the ranges' upper ends before margins (the numeric Jacobian's clamp).
            damping: lambda of the damped least squares.
            iterations: the most steps.
            weights: (n,) the joints' weights.
            numeric: clamp the Jacobian's columns at upper limits, as ``simIK``'s.
            until: a ``time.monotonic()`` after which every row stops (None: no bound).

        Returns:
            ``(q (N, n), ok (N,), error norm (N,))``.
        """
        q = np.clip(np.array(q, dtype=float), low, high)
        n_rows = q.shape[0]
        ok = np.zeros(n_rows, bool)
        err = np.full(n_rows, np.inf)
        best = np.full(n_rows, np.inf)
        since = np.zeros(n_rows, int)
        live = np.arange(n_rows)
        lam2 = damping * damping
        for it in range(iterations + 1):
            if not live.size:
                break
            e, jac, good = self.errors(q[live])
            norm = np.linalg.norm(e, axis=1)
            err[live] = norm
            ok[live] = good
            improved = norm < 0.9 * best[live]
            best[live] = np.where(improved, norm, best[live])
            since[live] = np.where(improved, 0, since[live] + 1)
            keep = ~good & (since[live] < 8)
            if it == iterations or (until is not None and time.monotonic() > until):
                break
            live, e, jac = live[keep], e[keep], jac[keep]
            if not live.size:
                break
            ql = q[live]
            if numeric:
                jac = jac * np.clip((top - ql) / FD_STEP, 0.0, 1.0)[:, None, :]
            jw = jac * weights
            a = jw @ np.transpose(jac, (0, 2, 1)) + lam2 * np.eye(jac.shape[1])
            dq = weights * (np.transpose(jac, (0, 2, 1)) @ np.linalg.solve(a, e[..., None]))[..., 0]
            dq = np.where(self.hinge, np.arctan2(np.sin(dq), np.cos(dq)), dq)
            q[live] = np.clip(ql + dq, low, high)
        return q, ok, err
