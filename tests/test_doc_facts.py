"""Facts the docs repeat stay the code's (issue 44): the V-REP / CoppeliaSim releases whose files
load, the scene formats, and the README's length as a front page.

``simx_server/scene/formats.py`` says them once; the reader's header check is tested against it,
and every doc that names a release range or the loadable formats is read for them.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import pytest

from simx_server.scene import formats
from simx_server.scene.ttt.errors import SceneFileError
from simx_server.scene.ttt.records import HEADER_BYTES, read_header

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: "V-REP 3.1 to CoppeliaSim 4.6", "V-REP 3.1.3 to CoppeliaSim 4.5": a release range in prose.
RANGE = re.compile(r"V-REP \d+(?:\.\d+)+ to CoppeliaSim \d+(?:\.\d+)+")


def _header(serialization: int, minimum: int) -> bytes:
    head = bytearray(HEADER_BYTES)
    head[:4] = b"VREP"
    struct.pack_into("<iiBi", head, 4, serialization, minimum, 0, 8)
    return bytes(head) + b"EOF\x00\x00\x00\x00\x00"


def test_the_reader_takes_the_documented_serializations():
    for ser in (formats.OLDEST_SERIALIZATION, formats.NEWEST_SERIALIZATION):
        assert read_header(_header(ser, ser), "x.ttt").serialization == ser
    with pytest.raises(SceneFileError):
        read_header(_header(formats.OLDEST_SERIALIZATION - 1, formats.OLDEST_SERIALIZATION - 1), "x.ttt")
    with pytest.raises(SceneFileError):
        read_header(_header(formats.NEWEST_SERIALIZATION + 1, formats.NEWEST_SERIALIZATION + 1), "x.ttt")


def test_every_release_range_the_docs_give_is_the_readers():
    found = {f"{doc.relative_to(ROOT)}: {m}" for doc in DOCS for m in RANGE.findall(doc.read_text())}
    assert found, "no doc names the release range (README.md should)"
    wrong = sorted(f for f in found if not f.endswith(formats.VREP_RANGE))
    assert not wrong, f"release ranges other than {formats.VREP_RANGE!r}:\n" + "\n".join(wrong)


def test_no_doc_says_a_loadable_format_cannot_be_loaded():
    said = [f"{doc.relative_to(ROOT)}: {line.strip()[:120]}" for doc in DOCS for line in doc.read_text().splitlines()
            if any(f"`{suffix}` cannot be loaded" in line or f"{suffix} cannot be loaded" in line
                   for suffix in formats.SCENE_FORMATS)]
    assert not said, "docs that say a loadable format cannot be loaded:\n" + "\n".join(said)


def test_the_readme_names_every_format_and_stays_a_front_page():
    readme = (ROOT / "README.md").read_text()
    assert all(suffix in readme for suffix in formats.SCENE_FORMATS)
    assert formats.VREP_RANGE in readme
    assert len(readme.splitlines()) <= 300, "README.md is the front page: reference belongs in docs/"


# ------------------------------------------------------- reference, not run history (issue 83)
#: A commit id: 7 to 40 lowercase hex digits, at least one letter and one digit, standing alone
#: (not part of a longer word, a path, a URL fragment or a ``0x`` constant).
COMMIT = re.compile(r"(?<![0-9A-Za-z_./#-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}(?![0-9A-Za-z_-])")
#: A run date as the project writes them: 2026-11-28.
DATE = re.compile(r"(?<![0-9])(?:19|20)\d\d-[01]\d-[0-3]\d(?![0-9])")
#: A results table's header: a Markdown table with a column whose name says date or commit.
RESULTS_HEADER = re.compile(r"^\|(?:[^|]*\|)*[^|]*\b(?:date|commit)\b[^|]*\|", re.IGNORECASE)
PAGES = [*DOCS, ROOT / "benchmarks" / "README.md"]


def history_lines(text: str) -> list[tuple[int, str]]:
    """``(line number, line)`` of each line of a Markdown page that holds a commit id or a run
    date outside a results table (a table whose header row has a ``date`` or ``commit`` column:
    the rows below it, up to the first line that is no table row, may hold both)."""
    found, in_results = [], False
    for number, line in enumerate(text.splitlines(), 1):
        row = line.lstrip().startswith("|")
        if not row:
            in_results = False
        elif RESULTS_HEADER.match(line.strip()):
            in_results = True
        if not in_results and (COMMIT.search(line) or DATE.search(line)):
            found.append((number, line))
    return found


def test_the_history_detector_finds_ids_and_dates_and_spares_results_tables():
    assert history_lines("measured on simx 6e35fc9 today") == [(1, "measured on simx 6e35fc9 today")]
    assert history_lines("x\nOn 2026-11-25 the suite took 8 min") == [(2, "On 2026-11-25 the suite took 8 min")]
    assert history_lines("| case | ratio |\n|---|---|\n| step (e9bb2ea) | 1.3x |")[0][0] == 3
    assert history_lines("| case | commits counted |\n|---|---|\n| x | 1 |") == []  # no id, nothing to find
    results = "| demos | measured (commit, date) |\n|---|---|\n| 67/90 | 6e35fc9, 2026-11-28 |\n\nafter 6e35fc9"
    assert history_lines(results) == [(5, "after 6e35fc9")]  # the table's rows are spared, prose after it not
    for innocent in ("0x7fffffff", "a handle 12345678", "`deadbeef`s", "sha256 in ORIGIN.md", "file_1234abc.png",
                     "colour #ff00aa", "version 1.2.0", "port 23000", "12:30"):
        assert history_lines(innocent) == [], innocent


def test_no_page_carries_commit_ids_or_run_dates_outside_results_tables():
    found = [f"{page.relative_to(ROOT)}:{n}: {line.strip()[:100]}" for page in PAGES
             for n, line in history_lines(page.read_text())]
    assert not found, ("commit ids or run dates in prose (history goes in commit bodies, dated figures in a "
                       "results table or benchmarks/results/):\n" + "\n".join(found))


def test_pyrep_page_states_the_rlbench_results_csv():
    """docs/PYREP.md's RLBench table is what scripts/rlbench_table.py makes of
    benchmarks/results/rlbench.csv (rerun the script after replacing the CSV)."""
    import subprocess
    import sys

    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "rlbench_table.py"), "--check"], cwd=ROOT)
    assert done.returncode == 0, "docs/PYREP.md differs from benchmarks/results/rlbench.csv: run scripts/rlbench_table.py"
