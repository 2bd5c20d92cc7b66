"""Writes docs/PYREP.md's RLBench results from the RLBench runner's CSV.

The runner (``../shared/rlbench/run_all.sh``, one task per process) writes ``results.csv``: one
row per task with ``task``, ``reset_ok``, ``demo_ok``, ``success``, ``demo_s``, ``error`` ... (and,
where added from its per-task JSON, ``attempt_error``: the last demo attempt's error).
Kept as data in ``benchmarks/results/rlbench.csv``, it is turned into the summary line and the
per-task table between the ``<!-- rlbench-results:begin -->`` and ``<!-- rlbench-results:end -->``
markers of docs/PYREP.md, so that the page states what the CSV holds and nothing else.

Usage: python scripts/rlbench_table.py [CSV] [PAGE] [--check]
(defaults: benchmarks/results/rlbench.csv, docs/PYREP.md; ``--check`` exits 1 when the page
differs from what the CSV gives instead of writing it).
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- rlbench-results:begin -->", "<!-- rlbench-results:end -->"
COLUMNS = 3  # tasks per table row


def _short(row: dict[str, str]) -> str:
    """The cause of a failed task in a few words: its last demo attempt's error (the
    ``attempt_error`` column, where the CSV has it), else the runner's ``error``."""
    e = (row.get("attempt_error") or row.get("error") or "").replace("|", "/")
    for key, said in (("Demo was completed, but was not successful", "demo ran, not successful"),
                      ("Could not get a path for waypoint", "no path for a waypoint"),
                      ("Could not place the task", "task not placed"),
                      ("TIMEOUT", "over the time limit")):
        if key in e:
            return said
    return e.split("\n")[0][:60] or "failed"


def render(rows: list[dict[str, str]]) -> str:
    """The summary line and the table (Markdown) for the runner's rows.

    Args:
        rows: the CSV's rows as dicts.

    Returns:
        The text that goes between the markers.
    """
    n = len(rows)
    reset = sum(r["reset_ok"] == "True" for r in rows)
    demos = sum(r["success"] == "True" for r in rows)
    lines = [f"**{demos} of {n} tasks give a live demo that RLBench's own success conditions accept at "
             f"the first attempt**; {reset} of {n} reset. Per task (`ok`, or the cause of the failure):", "",
             "| " + " | ".join(["task", "demo"] * COLUMNS) + " |",
             "|" + "---|" * (2 * COLUMNS)]
    cells = [(r["task"], "ok" if r["success"] == "True" else _short(r)) for r in rows]
    for i in range(0, n, COLUMNS):
        part = cells[i:i + COLUMNS] + [("", "")] * (COLUMNS - len(cells[i:i + COLUMNS]))
        lines.append("| " + " | ".join(f"{t} | {d}" if t else " | " for t, d in part) + " |")
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    check = "--check" in argv
    args = [a for a in argv if a != "--check"]
    table = Path(args[0]) if args else ROOT / "benchmarks" / "results" / "rlbench.csv"
    page = Path(args[1]) if len(args) > 1 else ROOT / "docs" / "PYREP.md"
    with open(table, newline="") as f:
        rows = sorted(csv.DictReader(f), key=lambda r: r["task"])
    text = page.read_text()
    head, _, rest = text.partition(BEGIN)
    _, _, tail = rest.partition(END)
    if not rest or END not in rest:
        print(f"{page}: no {BEGIN} ... {END} markers", file=sys.stderr)
        return 1
    new = f"{head}{BEGIN}\n{render(rows)}\n{END}{tail}"
    if check:
        return 0 if new == text else 1
    page.write_text(new)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
