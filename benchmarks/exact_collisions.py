"""The cost of collision queries and of planned paths (issue 59: exact mesh queries with coal).

Scenes: PyRep's Panda and Baxter (``../shared/pyrep/robot_ttms``) each imported into ``pyrep``'s
empty scene, in this process, headless, with a 0.1 x 0.1 x 0.3 m pillar beside the Panda.
Rows:

* ``check``: one planner validity check (``ScratchCollisions``: the arm's collection against
  everything else, ``simOMPL``'s default check) at random joint configurations, µs per check
  (median of rounds), and the fraction of configurations found colliding;
* ``api``: one ``Arm.check_arm_collision()`` (``sim.checkCollision`` through the API table) at
  the arm's start pose, µs, and what it answers;
* ``path``: one ``Arm.get_nonlinear_path`` (RRTConnect) of the Panda round the pillar (as
  tests/pyrep/test_planning.py), s per path (median over ``--paths``).

Run the same file against two source trees to compare (the figures hold for one machine and
load; run both in one sitting)::

    PYTHONPATH=/path/to/old/tree MUJOCO_GL=egl python benchmarks/exact_collisions.py
    PYTHONPATH=$PWD MUJOCO_GL=egl python benchmarks/exact_collisions.py
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import mujoco
import numpy as np

MODELS = Path(__file__).resolve().parents[1].parent / "shared" / "pyrep" / "robot_ttms"


def _checks(arm, pr, configs: int, rounds: int) -> tuple[float, float]:
    """µs per validity check (median of ``rounds``) and the colliding fraction."""
    from simx_server.sim import collisions
    from simx_server.sim.motion_planning import ScratchCollisions

    world = pr.simulation.world
    m = world.model
    qadr = [int(m.jnt_qposadr[world.get(j.get_handle()).mj_id]) for j in arm.joints]
    lo, hi = (np.array(v) for v in zip(*[(i[0], i[0] + i[1]) for i in arm.get_joint_intervals()[1]]))
    lo, hi = np.maximum(lo, -np.pi), np.minimum(hi, np.pi)
    check = ScratchCollisions(world, [], [(arm._collision_collection, -2)])
    rng = np.random.default_rng(0)
    qs = rng.uniform(lo, hi, (configs, len(qadr)))
    collisions.pairs_collide(world, check.a, check.b, check.data)  # builds the meshes' trees (not timed)
    times, hits = [], 0
    for _ in range(rounds):
        t = 0.0
        for q in qs:
            check.data.qpos[qadr] = q
            start = time.perf_counter()
            mujoco.mj_kinematics(m, check.data)
            hit = collisions.pairs_collide(world, check.a, check.b, check.data)
            t += time.perf_counter() - start
            hits += bool(hit)
        times.append(t / configs * 1e6)
    return statistics.median(times), hits / (configs * rounds)


def _api(arm, repeats: int = 50) -> tuple[float, bool]:
    arm.check_arm_collision()
    start = time.perf_counter()
    for _ in range(repeats):
        answer = arm.check_arm_collision()
    return (time.perf_counter() - start) / repeats * 1e6, bool(answer)


def _launch(model: str):
    from pyrep import PyRep

    pr = PyRep()
    pr.launch("", headless=True)
    pr.import_model(str(MODELS / "arms" / model))
    return pr


def _path_seconds(paths: int) -> list[float | None]:
    from pyrep.const import ConfigurationPathAlgorithms as Algos, PrimitiveShape
    from pyrep.errors import ConfigurationPathError
    from pyrep.objects import Shape
    from pyrep.robots.arms.panda import Panda

    pr = _launch("Panda.ttm")
    try:
        pr.start()
        arm = Panda()
        tip = arm.get_tip()
        start = np.array(arm.get_joint_positions())
        turned = start.copy()
        turned[0] += np.pi / 4
        arm.set_joint_positions(turned.tolist())
        half_way = tip.get_position()
        turned[0] += np.pi / 4
        arm.set_joint_positions(turned.tolist())
        goal, orientation = tip.get_position(), tip.get_quaternion()
        arm.set_joint_positions(start.tolist())
        Shape.create(PrimitiveShape.CUBOID, [0.1, 0.1, 0.3], position=half_way.tolist(), static=True)
        out: list[float | None] = []
        for _ in range(paths):
            t = time.perf_counter()
            try:
                arm.get_nonlinear_path(goal, quaternion=orientation, algorithm=Algos.RRTConnect)
                out.append(time.perf_counter() - t)
            except ConfigurationPathError:
                out.append(None)
            arm.set_joint_positions(start.tolist())
        return out
    finally:
        pr.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--configs", type=int, default=200, help="random configurations per round")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--paths", type=int, default=5)
    args = parser.parse_args()
    from pyrep.robots.arms.baxter import BaxterLeft
    from pyrep.robots.arms.panda import Panda

    for model, cls in (("Panda.ttm", Panda), ("Baxter.ttm", BaxterLeft)):
        pr = _launch(model)
        try:
            pr.start()
            arm = cls()
            us, fraction = _checks(arm, pr, args.configs, args.rounds)
            api_us, answer = _api(arm)
            print(f"{cls.__name__:10s} check {us:9.1f} us/check  colliding {fraction:5.1%}   "
                  f"api {api_us:8.1f} us  start pose colliding: {answer}")
        finally:
            pr.shutdown()
    seconds = _path_seconds(args.paths)
    found = [s for s in seconds if s is not None]
    median = f"{statistics.median(found):.2f} s" if found else "-"
    print(f"Panda      path  {median} per path (median), {len(found)}/{len(seconds)} found: "
          + " ".join("fail" if s is None else f"{s:.2f}" for s in seconds))


if __name__ == "__main__":
    main()
