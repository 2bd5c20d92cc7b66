"""An RLBench-style step on simx's ``pyrep``, against the floor of the same physics and
``mujoco.Renderer`` images in the same process.

RLBench's ``task.step()`` with its default observation is the arm's joint-velocity action
(``set_joint_target_velocities``), one ``PyRep.step()``, then for each of its five cameras
(four in the scene, one on the wrist) what ``Scene._get_cam_data`` does: the camera handled
explicitly, its RGB image and depth (m) read, its mask twin handled and read (a colour-coded
image of object handles), 128x128. The point cloud is numpy on the depth image (RLBench's own
code), not measured here.

The floor runs the same compiled ``MjModel`` on its own ``MjData``, copied from simx's before
each of simx's steps (``benchmarks.pyrep_step.replayed``): ``mj_step`` as many times as
simx's step has substeps, and per camera a ``mujoco.Renderer`` RGB image, depth image and
segmentation image of the same camera (no shadows, no reflections, no multisampling, as
simx's sensors). Reports
ms per step (median of rounds, simx's and the floor's steps alternated:
``benchmarks.pyrep_step.replayed``) and the median of the rounds' ratios. Nothing is asserted.

Scenes: the project's own ``scenes/ur5_rg2_kinect.xml`` (UR5 + RG2, the RG2's scripts run) with
five 128x128 cameras and their mask twins (``RenderMode.OPENGL_COLOR_CODED``) created around it
(default), or ``--scene`` an RLBench scene (the stand-in ``task_design`` that
``../shared/rlbench/build_task_design.py`` writes, or RLBench's own converted): its Panda and
its ``cam_front``, ``cam_overhead``, ``cam_over_shoulder_left``/``_right``, ``cam_wrist`` and
their ``_mask`` twins.

``--clock cpu`` times with the process's CPU time (every thread's, the render thread's and the
GL driver's included) instead of the wall clock (see ``benchmarks.pyrep_step``).

Run: ``MUJOCO_GL=egl python -m benchmarks.rlbench_step [--scene FILE] [--steps N] [--rounds R]
[--clock wall|cpu] [--profile]``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import mujoco
import numpy as np

from benchmarks.pyrep_step import CLOCKS, replayed, sensor_floor_renderer

OWN_SCENE = Path(__file__).resolve().parents[1] / "scenes" / "ur5_rg2_kinect.xml"
RLBENCH_CAMERAS = ("cam_front", "cam_overhead", "cam_over_shoulder_left", "cam_over_shoulder_right", "cam_wrist")
SIZE = 128


def _setup(scene: Path | None):
    """``(pr, arm, [(camera, mask camera)])``: the scene launched and started."""
    from pyrep import PyRep
    from pyrep.const import RenderMode
    from pyrep.objects import VisionSensor

    pr = PyRep()
    pr.launch(str(scene or OWN_SCENE), headless=True)
    if scene is not None:
        from pyrep.robots.arms.panda import Panda

        arm = Panda()
        cams = [(VisionSensor(n), VisionSensor(n + "_mask")) for n in RLBENCH_CAMERAS]
    else:
        from pyrep.robots.robot_component import RobotComponent

        arm = RobotComponent(0, "UR5", [f"UR5_joint{i}" for i in range(1, 7)])  # the arm without IK
        cams = []
        for i, (pos, look) in enumerate([((1.3, 0, 1.2), (0, 0, 0.3)), ((0.3, 0, 2.0), (0.3, 0, 0)),
                                         ((-0.6, 0.6, 1.4), (0.3, 0, 0.2)), ((-0.6, -0.6, 1.4), (0.3, 0, 0.2)),
                                         ((0.9, 0.9, 0.9), (0, 0, 0.4))]):
            pair = []
            for mode in (RenderMode.OPENGL3, RenderMode.OPENGL_COLOR_CODED):
                cam = VisionSensor.create([SIZE, SIZE], explicit_handling=True, render_mode=mode,
                                          near_clipping_plane=0.01, far_clipping_plane=4.5)
                cam.set_position(list(pos))
                cam.set_quaternion(list(_look_at(np.array(pos, float), np.array(look, float))))
                cam.set_name(f"bench_cam{i}" + ("_mask" if mode == RenderMode.OPENGL_COLOR_CODED else ""))
                pair.append(cam)
            cams.append((pair[0], pair[1]))
    for cam, mask in cams:
        cam.set_resolution([SIZE, SIZE])
        mask.set_resolution([SIZE, SIZE])
    pr.start()
    return pr, arm, cams


def _look_at(pos: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Quaternion (x, y, z, w) of a V-REP sensor at ``pos`` looking at ``target`` (+z forward,
    +y image up)."""
    z = target - pos
    z /= np.linalg.norm(z)
    y = np.array([0.0, 0.0, 1.0]) - z[2] * z
    if np.linalg.norm(y) < 1e-6:  # looking straight down: image up along +x
        y = np.array([1.0, 0.0, 0.0]) - z[0] * z
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.column_stack([x, y, z]).reshape(9))
    return np.array([q[1], q[2], q[3], q[0]])


def measure(scene: Path | None, steps: int, rounds: int, clock: str = "wall", profile: bool = False) -> dict:
    """Per step, ms by ``clock`` (:func:`benchmarks.pyrep_step.replayed` over ``rounds``):
    ``physics`` (action + ``PyRep.step()``) and ``observed`` (with the five cameras' images) for
    simx, ``floor_physics`` and ``floor_observed`` for MuJoCo alone, and each case's ``*_ratio``."""
    pr, arm, cams = _setup(scene)
    rng = np.random.default_rng(0)
    n = len(arm.joints)
    try:
        world = pr.simulation.world

        def act() -> None:
            arm.set_joint_target_velocities(rng.uniform(-0.2, 0.2, n).tolist())
            pr.step()

        def observe() -> None:
            act()
            for cam, mask in cams:  # rlbench/backend/scene.py _get_cam_data
                cam.handle_explicitly()
                cam.capture_rgb()
                cam.capture_depth(True)
                mask.handle_explicitly()
                mask.capture_rgb()

        for _ in range(10):
            observe()
        if profile:
            import cProfile
            import pstats

            prof = cProfile.Profile()
            prof.runcall(lambda: [observe() for _ in range(steps)])
            pstats.Stats(prof).sort_stats("tottime").print_stats(25)
        m = world.model
        substeps = world.substeps
        renderer = sensor_floor_renderer(m, SIZE, SIZE)
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_CAMERA, cam.get_name()) for cam, _ in cams]

        def floor_physics(d: mujoco.MjData) -> None:
            for _ in range(substeps):
                mujoco.mj_step(m, d)

        def floor_observed(d: mujoco.MjData) -> None:
            floor_physics(d)
            for cam in ids:
                renderer.update_scene(d, camera=cam)
                flags = renderer.scene.flags  # as simx's sensors render: no shadows, no reflections
                flags[mujoco.mjtRndFlag.mjRND_SHADOW] = flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
                renderer.render()
                renderer.enable_depth_rendering()
                renderer.render()
                renderer.disable_depth_rendering()
                renderer.enable_segmentation_rendering()
                renderer.render()
                renderer.disable_segmentation_rendering()

        out = {}
        for case, ours, floor in (("physics", act, floor_physics), ("observed", observe, floor_observed)):
            out[case], out["floor_" + case], out[case + "_ratio"] = replayed(rounds, steps, ours, floor, m,
                                                                             lambda: world.data, CLOCKS[clock])
        renderer.close()
        return out
    finally:
        pr.shutdown()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=None, help="an RLBench task_design scene (MJCF or .ttt)")
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall")
    parser.add_argument("--profile", action="store_true", help="cProfile the observed step")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    r = measure(args.scene, args.steps, args.rounds, args.clock, args.profile)
    label = "RLBench stand-in" if args.scene else "UR5 + RG2 (scenes/)"
    print(f"scene: {label}, 5 cameras x (RGB + depth + mask) {SIZE}x{SIZE}, clock {args.clock}")
    print("case                          simx (ms)   floor (ms)   ratio")
    print(f"{'arm step (physics)':<28} {r['physics']:>9.3f}   {r['floor_physics']:>10.3f}   "
          f"{r['physics_ratio']:>5.2f}x")
    print(f"{'step + 5 cameras':<28} {r['observed']:>9.3f}   {r['floor_observed']:>10.3f}   "
          f"{r['observed_ratio']:>5.2f}x")


if __name__ == "__main__":
    main()
