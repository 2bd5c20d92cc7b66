"""Runs PyRep's own example programs, unchanged, on simx's ``pyrep`` (issue 59), each with a bound.

PyRep's ``examples/`` (stepjam/PyRep, with the ``.ttt`` scenes beside them) is not part of this
repository: point ``--examples`` at a copy, e.g.::

    git --git-dir=PYREP.git archive HEAD examples | tar -x -C /tmp/pyrep-examples
    MUJOCO_GL=egl PYTHONPATH=$PWD python benchmarks/pyrep_examples.py --examples /tmp/pyrep-examples/examples

Each ``example_*.py`` runs in its own process (the Python running this, the ``PYTHONPATH`` given
to it, ``MUJOCO_GL=egl``), a few empty lines on its standard input (some end on ``input()``), killed after ``--timeout`` s. Some loop many episodes: the bound is what makes a run
comparable, and the lines it printed say how far it got. Prints per example: the exit status
(``timeout`` when killed), the seconds, and its last output lines; ``--only NAME`` runs the
examples whose file name contains NAME.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path


def run(example: Path, timeout: float, lines: int) -> tuple[str, float, list[str]]:
    """``(status, seconds, last output lines)`` of one example run."""
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), PYTHONUNBUFFERED="1")
    start = time.monotonic()
    try:
        done = subprocess.run([sys.executable, example.name], cwd=example.parent, env=env, input="\n" * 10,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=timeout, text=True)
        status, output = f"rc {done.returncode}", done.stdout
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout or ""
        status, output = "timeout", out.decode(errors="replace") if isinstance(out, bytes) else out
    kept = [line for line in output.splitlines() if line.strip() and "WARNING" not in line]
    return status, time.monotonic() - start, kept[-lines:]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--examples", type=Path, required=True, help="PyRep's examples/ folder")
    parser.add_argument("--timeout", type=float, default=300.0, help="s per example")
    parser.add_argument("--lines", type=int, default=6, help="output lines shown per example")
    parser.add_argument("--only", default="", help="run the examples whose name contains this")
    args = parser.parse_args()
    for example in sorted(args.examples.glob("example_*.py")):
        if args.only not in example.name:
            continue
        status, seconds, tail = run(example, args.timeout, args.lines)
        print(f"== {example.stem}: {status} after {seconds:.0f} s", flush=True)
        for line in tail:
            print(f"   {line[:200]}", flush=True)


if __name__ == "__main__":
    main()
