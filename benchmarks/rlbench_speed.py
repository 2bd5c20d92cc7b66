"""RLBench's ``task.step()`` on simx's ``pyrep``, next to MuJoCo's floor, in one run.

RLBench (unchanged: its ``Environment``, ``MoveArmThenGripper(JointVelocity(), Discrete())``,
``reach_target``) on an RLBench main scene (``--scene``: the stand-in that
``../shared/rlbench/build_task_design.py`` writes, or RLBench's own ``task_design.ttt``), one random
joint-velocity action per step. Four figures, each the median of rounds in which simx's steps and
the floor's alternate step by step (:func:`benchmarks.pyrep_step.replayed`: the floor steps the
state each of simx's steps started from, and a drift of a shared machine's speed moves both
alike), timed by the process's CPU time (every thread's: the render thread's and the GL driver's
included) unless ``--clock wall``:

* **low-dim**: observations without cameras (``ObservationConfig.set_all_low_dim``); the floor is
  ``mj_step`` x the step's substeps on a copy of the same compiled model.
* **cameras**: every observation (``set_all``: RLBench's five cameras, RGB, depth and mask, 128x128);
  the floor adds a ``mujoco.Renderer`` RGB, depth and segmentation image of each camera
  (:func:`benchmarks.pyrep_step.sensor_floor_renderer`, no shadows or reflections, as simx's
  sensors draw).
* **N envs, one process**: ``--envs`` environments in one process, stepped in turn (each made
  current first: PyRep's objects act on the instance called last, docs/PYREP.md); ms per step of
  one env against the floor.
* **N processes**: ``--envs`` processes, each one low-dim environment (``--worker``), started
  together: each one's CPU ms per step, and the steps per second of wall time of them all
  against one process's.
* **on implicit**: the low-dim step as simx runs it (``implicitfast`` while no body spins)
  against the same step held on MuJoCo's ``implicit`` integrator, rounds alternated in one
  process (:func:`benchmarks.pyrep_step.on_implicit`).

Without RLBench, or without ``--scene``, it prints ``SKIPPED (not available here): ...`` and exits
0. Not a suite of ``benchmarks.run`` (nor of its ``--smoke``, which CI runs): RLBench is not on the
package index, and its main scene is not in this repository.

Run: ``MUJOCO_GL=egl python -m benchmarks.rlbench_speed --scene FILE [--envs N] [--steps N]
[--rounds R] [--clock cpu|wall] [--json OUT]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from benchmarks.pyrep_step import CLOCKS, on_implicit, replayed, sensor_floor_renderer

CAMERAS = ("cam_front", "cam_overhead", "cam_over_shoulder_left", "cam_over_shoulder_right", "cam_wrist")
TASK = "reach_target"


def missing(scene: Path | None) -> str | None:
    """Why this machine cannot run the benchmark (RLBench or a main scene absent), or None."""
    try:
        import rlbench  # noqa: F401
    except ImportError as exc:
        return f"RLBench is not installed ({exc}); see ../shared/rlbench/README.md"
    if scene is None or not scene.is_file():
        return f"no RLBench main scene (--scene: {scene}); ../shared/rlbench/build_task_design.py writes a stand-in"
    return None


class Env:
    """One RLBench environment and its random actions (seeded)."""

    def __init__(self, scene: Path, cameras: bool, seed: int = 0):
        import rlbench.environment
        from rlbench.action_modes.action_mode import MoveArmThenGripper
        from rlbench.action_modes.arm_action_modes import JointVelocity
        from rlbench.action_modes.gripper_action_modes import Discrete
        from rlbench.observation_config import ObservationConfig
        from rlbench.utils import name_to_task_class

        rlbench.environment.TTT_FILE = str(scene.resolve())  # join(DIR_PATH, an absolute path) is the path
        config = ObservationConfig()
        if cameras:
            config.set_all(True)
        else:
            config.set_all_low_dim(True)
            config.set_all_high_dim(False)
        self.env = rlbench.environment.Environment(action_mode=MoveArmThenGripper(JointVelocity(), Discrete()),
                                                   obs_config=config, headless=True)
        self.env.launch()
        self.task = self.env.get_task(name_to_task_class(TASK))
        self.task.reset()
        self.rng = np.random.default_rng(seed)
        self.n = self.env.action_shape[0]

    @property
    def pyrep(self):
        return self.env._pyrep  # RLBench's own PyRep instance

    def step(self) -> None:
        """One ``task.step`` of a random joint velocity, the gripper kept open."""
        self.task.step(np.concatenate([self.rng.uniform(-0.2, 0.2, self.n - 1), [1.0]]))

    def close(self) -> None:
        self.env.shutdown()


class Floor:
    """MuJoCo alone on the same compiled model: a step's substeps of ``mj_step`` on the data it is
    given (a copy of the state simx's step started from: :func:`benchmarks.pyrep_step.replayed`),
    and with ``cameras`` an RGB, depth and segmentation image per RLBench camera."""

    def __init__(self, env: Env, cameras: bool):
        world = env.pyrep.simulation.world
        self.m = world.model
        self.source = lambda: world.data
        self.substeps = world.substeps
        self.renderer = sensor_floor_renderer(self.m, 128, 128) if cameras else None
        self.ids = [mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_CAMERA, n) for n in CAMERAS] if cameras else []

    def step(self, d: mujoco.MjData) -> None:
        m = self.m
        for _ in range(self.substeps):
            mujoco.mj_step(m, d)
        r = self.renderer
        for cam in self.ids:
            r.update_scene(d, camera=cam)
            flags = r.scene.flags  # as simx's sensors render: no shadows, no reflections
            flags[mujoco.mjtRndFlag.mjRND_SHADOW] = flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
            r.render()
            r.enable_depth_rendering()
            r.render()
            r.disable_depth_rendering()
            r.enable_segmentation_rendering()
            r.render()
            r.disable_segmentation_rendering()

    def close(self) -> None:
        if self.renderer is not None:
            self.renderer.close()


def single(scene: Path, cameras: bool, steps: int, rounds: int, clock: str) -> dict:
    """``{"ms", "floor_ms", "ratio", "substeps"}`` of one environment against its floor."""
    env = Env(scene, cameras)
    try:
        for _ in range(10):
            env.step()
        floor = Floor(env, cameras)
        try:
            ms, floor_ms, ratio = replayed(rounds, steps, env.step, floor.step, floor.m, floor.source, CLOCKS[clock])
            return {"ms": ms, "floor_ms": floor_ms, "ratio": ratio, "substeps": floor.substeps}
        finally:
            floor.close()
    finally:
        env.close()


def in_one_process(scene: Path, n: int, steps: int, rounds: int, clock: str) -> dict:
    """``n`` low-dim environments in this process stepped in turn: ms per step of one env."""
    envs = [Env(scene, False, seed=i) for i in range(n)]
    try:
        def all_of_them() -> None:
            for e in envs:
                e.pyrep.make_current()  # RLBench's objects act on the PyRep called last
                e.step()

        for _ in range(5):
            all_of_them()
        floor = Floor(envs[0], False)
        # the floor steps the first environment's state n times (the envs are copies of one scene)
        ms, floor_ms, ratio = replayed(rounds, steps, all_of_them, lambda d: [floor.step(d) for _ in range(n)],
                                       floor.m, floor.source, CLOCKS[clock])
        return {"envs": n, "ms": ms / n, "floor_ms": floor_ms / n, "ratio": ratio}
    finally:
        for e in envs:
            e.close()


def worker(scene: Path, steps: int) -> dict:
    """One process's low-dim environment: ``steps`` steps after a warm-up, CPU ms per step, and
    the wall time of the steps (the parent starts the workers together)."""
    env = Env(scene, False)
    try:
        for _ in range(10):
            env.step()
        cpu, wall = time.process_time(), time.perf_counter()
        for _ in range(steps):
            env.step()
        return {"cpu_ms": (time.process_time() - cpu) / steps * 1e3, "wall_s": time.perf_counter() - wall,
                "steps": steps}
    finally:
        env.close()


def processes(scene: Path, n: int, steps: int) -> dict:
    """``n`` worker processes started together, and one alone: CPU ms per step of each, steps per
    second of wall time of them all (each worker's own steps over its own wall time, summed)."""
    def run(k: int) -> list[dict]:
        cmd = [sys.executable, "-m", "benchmarks.rlbench_speed", "--worker", "--scene", str(scene), "--steps", str(steps)]
        procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, cwd=Path(__file__).resolve().parents[1])
                 for _ in range(k)]
        out = []
        for p in procs:
            stdout, _ = p.communicate(timeout=1800)
            out.append(json.loads(stdout.strip().splitlines()[-1]))
        return out

    one = run(1)[0]
    many = run(n)
    return {"processes": n, "cpu_ms": statistics.median(w["cpu_ms"] for w in many), "one_cpu_ms": one["cpu_ms"],
            "steps_per_s": sum(w["steps"] / w["wall_s"] for w in many), "one_steps_per_s": one["steps"] / one["wall_s"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", type=Path, default=None, help="an RLBench main scene (MJCF stand-in or .ttt)")
    parser.add_argument("--envs", type=int, default=2, help="environments for the two N cases (2 on 2 cores)")
    parser.add_argument("--steps", type=int, default=40, help="steps per round (cameras: a fifth)")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="cpu")
    parser.add_argument("--json", type=Path, default=None, help="write the figures here too")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    why = missing(args.scene)
    if args.worker:
        print(json.dumps(worker(args.scene, args.steps)))
        return
    if why is not None:
        print(f"rlbench_speed: SKIPPED (not available here): {why}")
        return
    low = single(args.scene, False, args.steps, args.rounds, args.clock)
    cams = single(args.scene, True, max(2, args.steps // 5), args.rounds, args.clock)
    many = in_one_process(args.scene, args.envs, max(2, args.steps // 2), args.rounds, args.clock)
    procs = processes(args.scene, args.envs, args.steps * args.rounds)
    env = Env(args.scene, False)
    try:
        switched = on_implicit(env.step, args.steps, args.rounds, args.clock)
    finally:
        env.close()
    load = os.getloadavg()
    print(f"RLBench {TASK}, JointVelocity, {low['substeps']} substeps a step, clock {args.clock}, "
          f"load {load[0]:.1f}")
    print("case                                  simx (ms)   floor (ms)   ratio")
    print(f"{'low-dim step':<36} {low['ms']:>9.3f}   {low['floor_ms']:>10.3f}   {low['ratio']:>5.2f}x")
    print(f"{'step + 5 cameras (RGB, depth, mask)':<36} {cams['ms']:>9.3f}   {cams['floor_ms']:>10.3f}   "
          f"{cams['ratio']:>5.2f}x")
    label = f"{many['envs']} envs in one process, per env"
    print(f"{label:<36} {many['ms']:>9.3f}   {many['floor_ms']:>10.3f}   {many['ratio']:>5.2f}x")
    print(f"low-dim step as simx runs it {switched[0]:.3f} ms, held on implicit {switched[1]:.3f} ms: "
          f"{switched[2]:.2f}x")
    print(f"{procs['processes']} processes: {procs['cpu_ms']:.3f} ms of CPU per step each (alone {procs['one_cpu_ms']:.3f}); "
          f"{procs['steps_per_s']:.0f} steps/s together, {procs['one_steps_per_s']:.0f} alone "
          f"({procs['steps_per_s'] / procs['one_steps_per_s']:.2f}x)")
    if args.json is not None:
        args.json.write_text(json.dumps({"low_dim": low, "cameras": cams, "one_process": many, "processes": procs,
                                         "on_implicit": switched,
                                         "clock": args.clock, "load": list(load)}, indent=1))


if __name__ == "__main__":
    main()
