"""Make the README's two pictures of the Kinect's view: at the start pose and at the tutorial pose.

The bundled scene's UR5 starts pointing straight up, as V-REP's UR5 does, and the Kinect is
eye-in-hand (on the RG2, looking along the approach axis), so the first image a program such as
the tutorial's ``robotControl.py`` shows is the sky gradient above the arm. At the tutorial's DDPG
pose ``[90, -45, 90, 0, -100, 0]`` degrees the Kinect looks down at the table and the red ball.

Usage (from the repository root; MuJoCo renders offscreen, ``MUJOCO_GL=egl`` on a headless
machine)::

    MUJOCO_GL=egl .venv/bin/python scripts/readme_pictures.py [--out docs/images] [--width 320]

writes ``kinect_start.png`` and ``kinect_tutorial_pose.png``: ``kinect_rgb``'s 640x480 image as a
program receives it, rows flipped to top-down (what robotControl.py's ``cv2.flip`` does), and
scaled to ``--width`` pixels wide (OpenCV, ``INTER_AREA``).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import cv2
import numpy as np

from simx_server.scene.simulation import Simulation

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "ur5_rg2_kinect.xml"
TUTORIAL_POSE_DEG = [90, -45, 90, 0, -100, 0]
JOINTS = [f"UR5_joint{i}" for i in range(1, 7)]
SENSOR = "kinect_rgb"
SETTLE_STEPS = 10  # 0.5 s of simulation at dt 0.05: the ball and the gripper come to rest


def kinect_views(scene: Path = SCENE, pose_deg: list[float] = TUTORIAL_POSE_DEG) -> dict[str, np.ndarray]:
    """``kinect_rgb``'s images at the scene's start pose and at ``pose_deg``.

    Returns ``{"kinect_start": img, "kinect_tutorial_pose": img}``, each (480, 640, 3) uint8 RGB,
    rows top-down. The simulation runs in-process (no server, no network): started, stepped
    ``SETTLE_STEPS`` times; then the arm's joints are put at ``pose_deg`` (degrees; position and
    target, as ``simxSetJointPosition`` does on a motorised joint) and it is stepped again.
    """
    sim = Simulation(scene, realtime=False)
    try:
        world = sim.world
        camera = world.resolve(SENSOR).handle
        sim.start()
        for _ in range(SETTLE_STEPS):
            sim.step()
        views = {"kinect_start": sim.vision.image(camera, False)[::-1].copy()}
        for name, degrees in zip(JOINTS, pose_deg):
            world.set_joint_position(world.resolve(name).handle, math.radians(degrees))
        for _ in range(SETTLE_STEPS):
            sim.step()
        views["kinect_tutorial_pose"] = sim.vision.image(camera, False)[::-1].copy()
        return views
    finally:
        sim.close()


def write_pictures(out: Path, width: int = 320) -> list[Path]:
    """Write the two views as PNGs ``width`` pixels wide into ``out``; returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, rgb in kinect_views().items():
        height = round(rgb.shape[0] * width / rgb.shape[1])
        small = cv2.resize(rgb, (width, height), interpolation=cv2.INTER_AREA)
        path = out / f"{name}.png"
        if not cv2.imwrite(str(path), cv2.cvtColor(small, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, 9]):
            raise OSError(f"cannot write {path}")
        paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "images",
                        help="folder for the PNGs (default docs/images)")
    parser.add_argument("--width", type=int, default=320, help="width of each picture in pixels (default 320)")
    args = parser.parse_args(argv)
    for path in write_pictures(args.out, args.width):
        print(f"{path} ({path.stat().st_size // 1024} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
