"""RLBench, unchanged, on simx's ``pyrep``: one task reset, a few random steps with RLBench's
default observation (five cameras' RGB, depth, point cloud and masks, 128x128), and a live demo
that RLBench's own success conditions judge; in this process, headless (docs/PYREP.md).

Usage: ``MUJOCO_GL=egl python examples/rlbench_demo.py [TASK] [--scene task_design.ttt]``
(default task ``reach_target``; default scene RLBench's own ``rlbench/task_design.ttt``, a Git
LFS file: installed without git-lfs it is a pointer, and ``--scene`` names another main scene,
e.g. a stand-in saved with ``PyRep.export_scene``). ``scripts/rlbench.sh`` installs RLBench and
runs this.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("task", nargs="?", default="reach_target", help="an RLBench task (rlbench/tasks/)")
    parser.add_argument("--scene", type=Path, default=None, help="the main scene instead of RLBench's own")
    parser.add_argument("--steps", type=int, default=5, help="random steps before the demo")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")

    import rlbench.environment
    from rlbench.action_modes.action_mode import MoveArmThenGripper
    from rlbench.action_modes.arm_action_modes import JointVelocity
    from rlbench.action_modes.gripper_action_modes import Discrete
    from rlbench.observation_config import ObservationConfig
    from rlbench.utils import name_to_task_class

    scene = args.scene.resolve() if args.scene else Path(rlbench.environment.DIR_PATH) / rlbench.environment.TTT_FILE
    if not scene.is_file() or scene.read_bytes()[:7] == b"version":
        raise SystemExit(f"{scene} is {'a Git LFS pointer' if scene.is_file() else 'missing'}, not RLBench's "
                         "main scene: install RLBench from a clone made with git-lfs, or pass --scene")
    rlbench.environment.TTT_FILE = str(scene)  # an absolute path: os.path.join keeps it
    obs = ObservationConfig()
    obs.set_all(True)
    env = rlbench.environment.Environment(MoveArmThenGripper(JointVelocity(), Discrete()), obs_config=obs,
                                          headless=True)
    start = time.perf_counter()
    env.launch()
    try:
        task = env.get_task(name_to_task_class(args.task))
        descriptions, observation = task.reset()
        print(f"{args.task}: reset in {time.perf_counter() - start:.1f} s: {descriptions[0]!r}; "
              f"front camera {observation.front_rgb.shape}")
        n = env.action_shape[0]
        times = []
        for _ in range(args.steps):
            action = np.concatenate([np.random.uniform(-0.2, 0.2, n - 1), [1.0]])
            t = time.perf_counter()
            task.step(action)
            times.append(time.perf_counter() - t)
        if times:
            print(f"task.step(): median {np.median(times) * 1e3:.0f} ms with every camera observed")
        t = time.perf_counter()
        demo = task.get_demos(1, live_demos=True)[0]
        print(f"live demo: {len(demo)} steps in {time.perf_counter() - t:.1f} s, "
              f"success {task._task.success()[0]}")
    finally:
        env.shutdown()


if __name__ == "__main__":
    main()
