"""Joint-space planning for ``Arm``: pose interpolation, path densification, RRT-Connect.

RRT-Connect (Kuffner and LaValle, 2000): two trees, from the start and from the goal, each
grown towards random samples and then towards the other tree's newest node, until they meet.
Collisions are checked by the caller's ``collides(q)`` (MuJoCo through the API table), every
``step`` rad along each edge. Deterministic (seeded).
"""

from __future__ import annotations

from typing import Callable

import numpy as np


def interpolate_poses(start: np.ndarray, goal: np.ndarray, steps: int) -> list[np.ndarray]:
    """``steps`` poses (4, 4) from just after ``start`` to ``goal``: positions on the line,
    rotations on the geodesic."""
    r = goal[:3, :3] @ start[:3, :3].T
    angle = np.arccos(np.clip((np.trace(r) - 1) / 2, -1.0, 1.0))
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    axis = axis / np.linalg.norm(axis) if np.linalg.norm(axis) > 1e-9 else np.array([0.0, 0.0, 1.0])
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    poses = []
    for i in range(1, steps + 1):
        f = i / steps
        rot = np.eye(3) + np.sin(f * angle) * k + (1 - np.cos(f * angle)) * k @ k
        m = np.eye(4)
        m[:3, :3] = rot @ start[:3, :3]
        m[:3, 3] = start[:3, 3] + f * (goal[:3, 3] - start[:3, 3])
        poses.append(m)
    return poses


def densify(configs: np.ndarray, max_step: float) -> np.ndarray:
    """The configurations (n, j) with points inserted so that no joint moves more than
    ``max_step`` between two; flat."""
    out = [configs[0]]
    for a, b in zip(configs[:-1], configs[1:]):
        n = max(int(np.ceil(np.max(np.abs(b - a)) / max_step)), 1)
        out.extend(a + (b - a) * (i / n) for i in range(1, n + 1))
    return np.array(out).reshape(-1)


def _edge_free(a: np.ndarray, b: np.ndarray, collides: Callable[[np.ndarray], bool], step: float) -> bool:
    n = max(int(np.ceil(np.max(np.abs(b - a)) / step)), 1)
    return not any(collides(a + (b - a) * (i / n)) for i in range(1, n + 1))


def rrt_connect(start: np.ndarray, goal: np.ndarray, collides: Callable[[np.ndarray], bool], lo: np.ndarray,
                hi: np.ndarray, step: float = 0.1, max_nodes: int = 2000, seed: int = 0) -> np.ndarray | None:
    """A collision-free path (n, j) from ``start`` to ``goal`` within ``[lo, hi]``, or None
    after ``max_nodes`` nodes. The straight line is tried first."""
    if _edge_free(start, goal, collides, step):
        return np.array([start, goal])
    rng = np.random.default_rng(seed)
    trees: list[tuple[list[np.ndarray], list[int]]] = [([start], [-1]), ([goal], [-1])]
    extend = 0.5

    def grow(tree: tuple[list[np.ndarray], list[int]], towards: np.ndarray) -> int | None:
        nodes, parents = tree
        i = int(np.argmin([np.linalg.norm(n - towards) for n in nodes]))
        d = towards - nodes[i]
        dist = np.linalg.norm(d)
        new = towards if dist <= extend else nodes[i] + d * (extend / dist)
        if not _edge_free(nodes[i], new, collides, step):
            return None
        nodes.append(new)
        parents.append(i)
        return len(nodes) - 1

    def branch(tree: tuple[list[np.ndarray], list[int]], i: int) -> list[np.ndarray]:
        nodes, parents = tree
        out = []
        while i != -1:
            out.append(nodes[i])
            i = parents[i]
        return out

    while sum(len(t[0]) for t in trees) < max_nodes:
        a, b = trees
        new = grow(a, rng.uniform(lo, hi))
        if new is not None:
            target = a[0][new]
            while True:  # connect: b grows towards the new node until it reaches it or is blocked
                j = grow(b, target)
                if j is None:
                    break
                if np.allclose(b[0][j], target):
                    first, second = branch(a, new)[::-1], branch(b, j)
                    path = first + second[1:]
                    if a[0][0] is not start:  # a grew from the goal
                        path = path[::-1]
                    return np.array(path)
        trees.reverse()
    return None
