"""PyRep on simx: the cost of ``PyRep.step()`` against MuJoCo's own ``mj_step`` (the floor).

The scene: PyRep's Panda arm and Panda gripper (``../shared/pyrep/robot_ttms``) imported into
``pyrep``'s empty scene, in this process, headless. Two cases: physics only (``step()``), and
``step()`` plus one 128x128 RGB image of a vision sensor (``capture_rgb()``, what an RLBench
observation reads per camera). The floor runs the same compiled ``MjModel`` on its own
``MjData``, copied from simx's before each of simx's steps (:func:`replayed`: both step the same
state): ``mj_step`` as many times as simx's step has substeps, plus, in the camera case, one
``mujoco.Renderer`` image of the same camera. Reports ms per step (median of rounds) and the
ratio to the floor; PyRep on CoppeliaSim 4.1 publishes about 120 ms per RLBench step
(RLBench #247), for comparison.

``--clock cpu`` times with the process's CPU time (``time.process_time``: every thread's, the
render thread's and the GL driver's included) instead of the wall clock: on a machine shared
with other jobs the wall clock counts the time this process waited for a core, the CPU time
does not.

``--integrators`` instead compares, in one process, rounds of ``step()`` as simx runs it
(``implicitfast`` while no body spins: :mod:`simx_server.sim.integrator`) with rounds of
``step()`` held on MuJoCo's ``implicit`` integrator, alternated, and prints each one's ms per step
and their ratio.

Run: ``MUJOCO_GL=egl python -m benchmarks.pyrep_step [--steps N] [--rounds R] [--clock wall|cpu]
[--integrators]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import mujoco
import numpy as np

MODELS = Path(__file__).resolve().parents[1].parent / "shared" / "pyrep" / "robot_ttms"


def sensor_floor_renderer(m: mujoco.MjModel, width: int, height: int) -> mujoco.Renderer:
    """A ``mujoco.Renderer`` whose offscreen buffer is not multisampled, as simx's sensors
    draw (V-REP's framebuffer objects have no samples): the floor draws what simx draws."""
    saved = m.vis.quality.offsamples
    m.vis.quality.offsamples = 0
    try:
        return mujoco.Renderer(m, width, height)
    finally:
        m.vis.quality.offsamples = saved


def _setup(camera: bool):
    from pyrep import PyRep
    from pyrep.objects import VisionSensor
    from pyrep.robots.arms.panda import Panda

    pr = PyRep()
    pr.launch("", headless=True)
    pr.import_model(str(MODELS / "arms" / "Panda.ttm"))
    pr.import_model(str(MODELS / "end_effectors" / "PandaGripper.ttm"))
    sensor = None
    if camera:
        sensor = VisionSensor.create([128, 128], position=[1.5, 0.0, 1.5], orientation=[np.pi, -0.8, -np.pi / 2])
    pr.start()
    arm = Panda()
    arm.set_joint_target_velocities([0.1] * 7)
    return pr, sensor


CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def replayed(rounds: int, steps: int, ours: Callable[[], object], floor: Callable[[mujoco.MjData], object],
             m: mujoco.MjModel, source: Callable[[], mujoco.MjData],
             clock: Callable[[], float]) -> tuple[float, float, float]:
    """``(ours, floor, ratio)``: ms per call of each (medians over ``rounds``) and the median of the
    rounds' ratios. Before each of simx's calls its data (``source()``) is copied, and right
    after it the floor runs from that copy: each floor call steps the very state simx's call
    started from, with the same contacts, joint limits and motors' gains (the model is
    shared), and the two alternate call by call, so that a drift of a shared machine's speed
    moves both alike. The copies are not timed. (A floor left to run on its own drifts to
    other contacts and limits than simx's, and its cost with it: 0.97-1.18 ms a step were seen
    for the same scene.)

    Args:
        rounds: rounds of ``steps`` calls each.
        ours: simx's call.
        floor: the floor's call, on the data it is given.
        m: the model both step.
        source: simx's data now.
        clock: the timer.
    """
    snapshot, data = mujoco.MjData(m), mujoco.MjData(m)
    for _ in range(3):  # the floor's first calls (a renderer's first frame) are not timed
        mujoco.mj_copyData(data, m, source())
        floor(data)
    per_ours: list[float] = []
    per_floor: list[float] = []
    for _ in range(rounds):
        ours_s = floor_s = 0.0
        for _ in range(steps):
            mujoco.mj_copyData(snapshot, m, source())
            began = clock()
            ours()
            ours_s += clock() - began
            mujoco.mj_copyData(data, m, snapshot)
            began = clock()
            floor(data)
            floor_s += clock() - began
        per_ours.append(ours_s / steps * 1e3)
        per_floor.append(floor_s / steps * 1e3)
    ratio = statistics.median(a / b for a, b in zip(per_ours, per_floor))
    return statistics.median(per_ours), statistics.median(per_floor), ratio


def measure(camera: bool, steps: int, rounds: int, clock: str = "wall") -> tuple[float, float, float]:
    """``(pyrep ms per step, floor ms per step, ratio)`` by ``clock`` (a key of :data:`CLOCKS`):
    :func:`replayed` over ``rounds`` rounds of ``steps`` steps."""
    pr, sensor = _setup(camera)
    try:
        world = pr.simulation.world
        if sensor is not None:
            def pyrep_step() -> None:
                pr.step()
                sensor.capture_rgb()
        else:
            pyrep_step = pr.step
        for _ in range(20):
            pyrep_step()
        m = world.model
        substeps = world.substeps
        renderer = sensor_floor_renderer(m, 128, 128) if sensor is not None else None
        cam = int(np.argmax([m.camera(i).name.startswith("Vision_sensor") for i in range(m.ncam)])) if renderer else -1

        def floor(d: mujoco.MjData) -> None:
            for _ in range(substeps):
                mujoco.mj_step(m, d)
            if renderer is not None:
                renderer.update_scene(d, camera=cam)
                flags = renderer.scene.flags  # as simx's sensors render: no shadows, no reflections
                flags[mujoco.mjtRndFlag.mjRND_SHADOW] = flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
                renderer.render()

        out = replayed(rounds, steps, pyrep_step, floor, m, lambda: world.data, CLOCKS[clock])
        if renderer is not None:
            renderer.close()
        return out
    finally:
        pr.shutdown()


def on_implicit(step: Callable[[], object], steps: int, rounds: int, clock: str = "cpu") -> tuple[float, float, float]:
    """``(ms per step as simx runs it, ms per step held on implicit, their ratio)``: rounds of
    ``steps`` calls of ``step`` with simx's integrator switch, alternated with rounds held on
    MuJoCo's ``implicit`` (:mod:`simx_server.sim.integrator`), in this process; medians (the
    ratio's: of the rounds')."""
    from simx_server.sim import integrator

    choose = integrator.choose

    def implicit(m: mujoco.MjModel, d: mujoco.MjData) -> None:
        m.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICIT

    timer, times = CLOCKS[clock], {choose: [], implicit: []}
    try:
        for _ in range(rounds):
            for way, kept in times.items():
                integrator.choose = way
                began = timer()
                for _ in range(steps):
                    step()
                kept.append((timer() - began) / steps * 1e3)
    finally:
        integrator.choose = choose
    ours, held = times[choose], times[implicit]
    return statistics.median(ours), statistics.median(held), statistics.median(a / b for a, b in zip(ours, held))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall")
    parser.add_argument("--integrators", action="store_true")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    if args.integrators:
        pr, _ = _setup(False)
        try:
            for _ in range(20):
                pr.step()
            ours, held, ratio = on_implicit(pr.step, args.steps, args.rounds, args.clock)
        finally:
            pr.shutdown()
        print(f"PyRep.step(): {ours:.3f} ms as simx runs it, {held:.3f} ms on implicit: {ratio:.2f}x")
        return
    print("case                       pyrep step (ms)   mj_step floor (ms)   ratio")
    for camera in (False, True):
        ours, base, ratio = measure(camera, args.steps, args.rounds, args.clock)
        label = "Panda + gripper, 128x128 RGB" if camera else "Panda + gripper"
        print(f"{label:<28} {ours:>12.3f}   {base:>16.3f}   {ratio:>8.2f}x")


if __name__ == "__main__":
    main()
