"""The whole suite's total from the JUnit XML reports of scripts/test.sh's pytest runs.

    python scripts/suite_total.py RUN1.xml RUN2.xml

scripts/test.sh runs the suite as two pytest invocations (the Ray cluster test alone after the
others), so neither run's own last line is the suite's total. This prints it, last, in pytest's
words: ``N passed, N failed, N skipped`` (``failed`` counts failures and errors; ``, N xfailed``
follows when some tests are expected failures). A test in both reports (a module skipped at
import is reported by both runs: its skip comes before the marker selection) counts once,
with the outcome of the run that ran it. A report that is missing (its pytest died before
writing it) is named in a line before the total. Exits 0.
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

#: Outcomes, the most informative first: a test in both reports keeps the first of these.
_RANK = ("failed", "passed", "xfailed", "skipped")


def outcome(case: ET.Element) -> str:
    """A ``<testcase>``'s outcome: failed (a failure or an error), xfailed, skipped or passed."""
    if case.find("failure") is not None or case.find("error") is not None:
        return "failed"
    skipped = case.find("skipped")
    if skipped is not None:
        return "xfailed" if skipped.get("type") == "pytest.xfail" else "skipped"
    return "passed"


def outcomes(reports: list[Path]) -> tuple[dict[tuple[str, str], str], list[Path]]:
    """Every test's outcome, keyed by (classname, name), across ``reports``; and the reports missing."""
    seen: dict[tuple[str, str], str] = {}
    missing = []
    for path in reports:
        try:
            root = ET.parse(path).getroot()
        except (OSError, ET.ParseError):
            missing.append(path)
            continue
        for case in root.iter("testcase"):
            key = (case.get("classname", ""), case.get("name", ""))
            new = outcome(case)
            old = seen.get(key)
            seen[key] = new if old is None or _RANK.index(new) < _RANK.index(old) else old
    return seen, missing


def total_line(seen: dict[tuple[str, str], str]) -> str:
    """``N passed, N failed, N skipped`` (and ``, N xfailed`` when there are some)."""
    count = {name: 0 for name in _RANK}
    for value in seen.values():
        count[value] += 1
    line = f"{count['passed']} passed, {count['failed']} failed, {count['skipped']} skipped"
    return line + (f", {count['xfailed']} xfailed" if count["xfailed"] else "")


def main(argv: list[str]) -> int:
    seen, missing = outcomes([Path(a) for a in argv])
    for path in missing:
        print(f"simx: no test report {path} (its pytest run ended before writing it): the total lacks its tests")
    print("simx: the whole suite's total (all runs):")
    print(total_line(seen))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
