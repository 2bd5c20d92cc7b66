"""RLBench's dataset generator, unchanged, on simx's ``pyrep``: its episodes are complete and read
back.

Runs ``rlbench/dataset_generator.py`` of the installed RLBench (a process of its own, its own
arguments: ``--processes``, ``--tasks``, ``--episodes_per_task``, ``--variations 1``,
``--image_size``) into a fresh folder, then checks every episode it wrote as RLBench's
``get_stored_demos`` reads it: a ``low_dim_obs.pkl`` and, in each of the 15 image folders (5
cameras x RGB, depth, mask), one PNG per observation; each episode read back with its images
(``image_paths=False``; masks as files, since ``get_stored_demos``'s ``rgb_handles_to_mask``
overflows uint8 on NumPy >= 2 whatever the simulator). Reports the episodes and PNGs written,
the generator's wall time and CPU time (its processes' own, ``RUSAGE_CHILDREN``), and episodes
per CPU-second. ``tests/pyrep/test_rlbench_dataset.py`` checks the values of one saved episode
against those recorded. Exits with status 1 when an episode is missing or incomplete.

Needs RLBench installed and its main scene ``rlbench/task_design.ttt`` (the stand-in of
``../shared/rlbench/build_task_design.py``).

Run: ``MUJOCO_GL=egl python -m benchmarks.rlbench_dataset [--processes 2] [--tasks reach_target
pick_up_cup] [--episodes 2] [--image-size 64] [--keep DIR]``.
"""

from __future__ import annotations

import argparse
import os
import pickle
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FOLDERS = [f"{cam}_{kind}" for cam in ("left_shoulder", "right_shoulder", "overhead", "wrist", "front")
           for kind in ("rgb", "depth", "mask")]


def generate(out: Path, processes: int, tasks: list[str], episodes: int, size: int) -> dict:
    """Run the generator into ``out``; its wall and CPU seconds and exit status."""
    import rlbench

    script = Path(rlbench.__file__).parent / "dataset_generator.py"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.monotonic()
    proc = subprocess.run([sys.executable, str(script), "--save_path", str(out), "--processes", str(processes),
                           "--tasks", *tasks, "--episodes_per_task", str(episodes), "--variations", "1",
                           "--image_size", str(size), str(size)], capture_output=True, text=True)
    wall = time.monotonic() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"status": proc.returncode, "wall": wall, "cpu": cpu, "log": proc.stdout + proc.stderr}


def check(out: Path, tasks: list[str], episodes: int, size: int) -> tuple[int, int, list[str]]:
    """``(episodes complete, PNGs, problems)`` of what the generator wrote, read back."""
    from rlbench import ObservationConfig
    from rlbench.utils import get_stored_demos

    config = ObservationConfig()
    config.set_all(True)
    for name in ("left_shoulder", "right_shoulder", "overhead", "wrist", "front"):
        camera = getattr(config, f"{name}_camera")
        camera.image_size = [size, size]
        camera.mask = False  # read as files below
    complete, pngs, problems = 0, 0, []
    for task in tasks:
        folder = out / task / "variation0" / "episodes"
        for i in range(episodes):
            episode = folder / f"episode{i}"
            if not (episode / "low_dim_obs.pkl").is_file():
                problems.append(f"{task} episode{i}: no low_dim_obs.pkl")
                continue
            with open(episode / "low_dim_obs.pkl", "rb") as f:
                n = len(pickle.load(f))
            counts = {name: len(list((episode / name).glob("*.png"))) for name in FOLDERS}
            wrong = {name: c for name, c in counts.items() if c != n}
            if wrong:
                problems.append(f"{task} episode{i}: {n} observations, PNGs {wrong}")
                continue
            pngs += sum(counts.values())
            complete += 1
        try:
            demos = get_stored_demos(-1, False, str(out), 0, task, config, random_selection=False)
        except Exception as exc:  # noqa: BLE001 (reported, not raised: the table says it)
            problems.append(f"{task}: get_stored_demos: {type(exc).__name__}: {exc}")
            continue
        for d, demo in enumerate(demos):
            if any(getattr(obs, "front_rgb", None) is None or obs.front_rgb.shape != (size, size, 3)
                   or obs.joint_positions is None for obs in demo):
                problems.append(f"{task} episode{d}: read back without its images or joint positions")
    return complete, pngs, problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", type=int, default=2)
    parser.add_argument("--tasks", nargs="+", default=["reach_target", "pick_up_cup"])
    parser.add_argument("--episodes", type=int, default=2, help="episodes per task")
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--keep", type=Path, default=None, help="write here and keep it (default: a temp folder)")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    out = args.keep or Path(tempfile.mkdtemp(prefix="simx-rlbench-dataset-"))
    try:
        run = generate(out, args.processes, args.tasks, args.episodes, args.image_size)
        complete, pngs, problems = check(out, args.tasks, args.episodes, args.image_size)
    finally:
        if args.keep is None:
            shutil.rmtree(out, ignore_errors=True)
    wanted = len(args.tasks) * args.episodes
    print(f"dataset_generator.py --processes {args.processes}, tasks {' '.join(args.tasks)}, "
          f"{args.episodes} episodes each, {args.image_size}x{args.image_size}: exit status {run['status']}")
    print(f"episodes complete and read back: {complete}/{wanted}, PNGs {pngs}")
    print(f"wall {run['wall']:.1f} s, CPU {run['cpu']:.1f} s (the generator's processes), "
          f"{complete / max(run['cpu'], 1e-9):.3f} episodes per CPU-second")
    for problem in problems:
        print("PROBLEM:", problem)
    if run["status"] != 0 or problems or complete != wanted:
        print(run["log"][-3000:], file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
