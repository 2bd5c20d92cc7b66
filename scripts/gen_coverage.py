"""Write the API's generated docs from the code: docs/COVERAGE.md (simx_server/zmq/coverage.py:
every function of CoppeliaSim 4.x's sim and simIK tables with simx's status), and in
docs/SCRIPTS.md the table of every function by module (simx_server/api/listing.py) and the list of
V-REP 3.x global names (simx_server/api/legacy_names.py). Run after adding a function."""

from __future__ import annotations

from pathlib import Path

from simx_server.api import legacy_names, listing
from simx_server.scripts.threads import script_functions
from simx_server.zmq.coverage import markdown


def replace_block(text: str, begin: str, end: str, block: str) -> str:
    """``text`` with the part from ``begin`` to ``end`` (markers included) replaced by ``block``."""
    start, stop = text.index(begin), text.index(end) + len(end)
    return text[:start] + block + text[stop:]


if __name__ == "__main__":
    docs = Path(__file__).resolve().parents[1] / "docs"
    (docs / "COVERAGE.md").write_text(markdown() + "\n", encoding="utf-8")
    scripts = docs / "SCRIPTS.md"
    text = scripts.read_text(encoding="utf-8")
    text = replace_block(text, listing.BEGIN, listing.END, listing.markdown())
    text = replace_block(text, legacy_names.DOC_BEGIN, legacy_names.DOC_END,
                         legacy_names.doc_table(script_functions()))
    scripts.write_text(text, encoding="utf-8")
    print(f"wrote {docs / 'COVERAGE.md'} and the generated tables of {scripts}")
