"""PyRep's first program, on simx: a Panda in an empty scene, moved by joint targets, then to a
pose through a planned path; in this process, headless (docs/PYREP.md).

Usage: ``MUJOCO_GL=egl python examples/pyrep_panda.py [Panda.ttm]`` (default: PyRep's model in
``../shared/pyrep/robot_ttms/arms/`` beside the checkout).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from pyrep import PyRep
from pyrep.robots.arms.panda import Panda

MODEL = Path(__file__).resolve().parents[2] / "shared" / "pyrep" / "robot_ttms" / "arms" / "Panda.ttm"


def main() -> None:
    model = sys.argv[1] if len(sys.argv) > 1 else str(MODEL)
    pr = PyRep()
    pr.launch("", headless=True)  # the empty scene: a floor and a light
    pr.import_model(model)
    pr.start()
    arm = Panda()
    start = np.array(arm.get_joint_positions())
    arm.set_joint_target_positions((start + 0.2).tolist())  # the joints' position controllers
    for _ in range(20):
        pr.step()
    print("joints after 1 s:", np.round(arm.get_joint_positions(), 3))
    tip = arm.get_tip()
    goal = tip.get_position() + [0.1, -0.1, -0.1]
    path = arm.get_path(goal, quaternion=tip.get_quaternion())
    while not path.step():
        pr.step()
    for _ in range(20):
        pr.step()
    print("tip:", np.round(tip.get_position(), 3), "goal:", np.round(goal, 3))
    pr.stop()
    pr.shutdown()


if __name__ == "__main__":
    main()
