"""docs/COVERAGE.md is what the code implements (issue 32): regenerated text equal to the file,
every function of CoppeliaSim 4.x's tables with a status, reasons where not implemented, the
ZMQ service answering every listed name, and the docs linking it."""

from __future__ import annotations

from conftest import ROOT
from simx_server.api import names
from simx_server.zmq import coverage


def test_coverage_doc_is_current():
    text = (ROOT / "docs" / "COVERAGE.md").read_text(encoding="utf-8")
    assert text == coverage.markdown() + "\n", "docs/COVERAGE.md is stale: run python scripts/gen_coverage.py"


def test_every_function_has_a_status_and_each_gap_a_reason():
    t = coverage.table()
    assert len(t["sim"]) == 442 and len(t["simIK"]) == 76
    for rows in t.values():
        for name, status, why in rows:
            assert status in ("implemented", "headless", "n/a", "refused", "missing"), name
            assert status in ("implemented", "headless") or (why and "no entry" not in why), name
    # no reason is kept for a function that is now implemented
    implemented = {n for n, s, _ in t["sim"] if s in ("implemented", "headless")}
    stale = implemented & set(coverage.NOT_IMPLEMENTED)
    assert not stale, f"implemented, still listed in coverage.NOT_IMPLEMENTED: {sorted(stale)}"
    # simVision: the plug-in's list names every function of the table, and no implemented one is a gap
    from simx_server.api import SIMVISION

    assert set(SIMVISION) <= names.current_functions("simVision")
    assert not set(SIMVISION) & set(coverage.VISION_NOT_IMPLEMENTED)


def test_deprecated_names_are_listed_for_the_client():
    for name in ("getScriptHandle", "getVisionSensorResolution"):
        assert name in names.coppeliasim_functions("sim")
        assert name not in names.current_functions("sim")  # the table of 442 stays CoppeliaSim's


def test_docs_link_the_table():
    for doc in ("ZMQ.md", "SCRIPTS.md"):
        assert "COVERAGE.md" in (ROOT / "docs" / doc).read_text(encoding="utf-8"), doc


def test_scripts_doc_lists_the_table_by_module():
    """docs/SCRIPTS.md's list of every function by module is the API table's (generated), and it
    names every entry of both libraries."""
    from simx_server.api import SIM, SIMIK, listing

    text = (ROOT / "docs" / "SCRIPTS.md").read_text(encoding="utf-8")
    begin, end = text.index(listing.BEGIN), text.index(listing.END) + len(listing.END)
    assert text[begin:end] == listing.markdown(), "docs/SCRIPTS.md's api-table is stale: run python scripts/gen_coverage.py"
    block = text[begin:end]
    assert all(f"`{n}`" in block for n in [*SIM, *SIMIK])
