"""Run the suite with each file's tests in another order, to find tests that pass only after
the tests before them (a module-scoped server left stopped, a pose left set ...).

    python scripts/test_order.py            # each file's tests reversed
    python scripts/test_order.py --seed 44  # shuffled with that seed
    python scripts/test_order.py --seed 44 tests/scene   # a part of the suite

Files keep their order and their tests stay in them (pytest-xdist's --dist loadfile, as
scripts/test.sh); the node ids go to pytest in a file (``@ids``). Run it in the test venv
(``.venv/bin/python``) after scripts/test.sh has made it; exits with pytest's status."""

from __future__ import annotations

import argparse
import random
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def reorder(ids: list[str], seed: int | None) -> list[str]:
    """``ids`` (pytest node ids) with each file's tests reversed (``seed`` None) or shuffled."""
    by_file: dict[str, list[str]] = {}
    for node in ids:
        by_file.setdefault(node.split("::", 1)[0], []).append(node)
    rng = random.Random(seed)
    out: list[str] = []
    for tests in by_file.values():
        if seed is None:
            out += tests[::-1]
        else:
            tests = tests[:]
            rng.shuffle(tests)
            out += tests
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, help="shuffle each file's tests with this seed (default: reverse them)")
    parser.add_argument("--workers", type=int, default=4, help="pytest-xdist workers (default 4)")
    parser.add_argument("paths", nargs="*", default=["tests"], help="what to collect (default: tests)")
    args = parser.parse_args()
    marker = ["-m", "not ray"]
    listed = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
                             *marker, *args.paths], cwd=ROOT, capture_output=True, text=True, check=False)
    ids = [line.strip() for line in listed.stdout.splitlines() if "::" in line]
    if not ids:
        print(listed.stdout[-2000:], listed.stderr[-2000:], sep="\n", file=sys.stderr)
        return 2
    with tempfile.NamedTemporaryFile("w", suffix=".txt", delete=False) as f:
        f.write("\n".join(reorder(ids, args.seed)) + "\n")
    how = "reversed" if args.seed is None else f"shuffled (seed {args.seed})"
    print(f"simx: {len(ids)} tests, each file's {how}", flush=True)
    try:
        return subprocess.run([sys.executable, "-m", "pytest", "-q", "-ra", "-p", "no:cacheprovider", *marker,
                               "-n", str(args.workers), "--dist", "loadfile", f"@{f.name}"], cwd=ROOT,
                              check=False).returncode
    finally:
        Path(f.name).unlink()


if __name__ == "__main__":
    sys.exit(main())
