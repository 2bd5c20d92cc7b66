"""Every repository path the docs name exists (issue 33 item 10).

README.md and docs/*.md name files and folders of the checkout (``tests/client/test_constants.py``,
``scripts/serve.sh``, ``docs/security/server.json5``...) and link to others (``[ZMQ](docs/ZMQ.md)``).
A path that moved or never existed sends a reader nowhere: this test reads the docs and fails
naming each such path and the doc that names it.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: Top-level folders of the checkout: a word starting with one of them and a slash is a path.
TOP = ("simx_server", "simx_client", "simx_viewer", "scenes", "tests", "docs", "benchmarks", "examples",
       "scripts", ".ci")
PATH = re.compile(r"(?<![\w./-])((?:%s)/[\w./-]*[\w/])" % "|".join(re.escape(t) for t in TOP))
LINK = re.compile(r"\]\(([^)#\s]+)")  # a Markdown link's target, without its #anchor
#: Paths the docs name that a checkout does not hold until a documented command makes them
#: (gitignored): the certificates of `sh docs/security/make-certs.sh`, the benchmarks' results.
MADE = ("docs/security/tls", "benchmarks/results")


def named_paths(doc: Path) -> set[str]:
    """The repository paths ``doc`` names: words under a top-level folder, and relative links
    (made relative to the checkout's root)."""
    text = doc.read_text()
    found = {m.group(1).rstrip(".") for m in PATH.finditer(text)}
    for m in LINK.finditer(text):
        target = m.group(1)
        if "://" in target or target.startswith("mailto:"):
            continue
        resolved = (doc.parent / target).resolve()
        found.add(resolved.relative_to(ROOT).as_posix() if resolved.is_relative_to(ROOT) else target)
    # A pattern rather than a path (tests/*.py, server-<i>.log, {a,b}): not checked.
    return {p for p in found if not any(c in p for c in "*<>{}$")}


def exists(path: str) -> bool:
    """Whether ``path`` is in the checkout: from its root, or, for a module named the way
    docs/ARCHITECTURE.md names the server's (``scripts/lua.py``), inside ``simx_server``."""
    if path.startswith(MADE):
        return True
    return (ROOT / path).exists() or (ROOT / "simx_server" / path).exists()


def test_the_path_finder_sees_paths_and_links(tmp_path):
    doc = tmp_path / "x.md"
    doc.write_text("Run `scripts/serve.sh`, read tests/client/test_constants.py. and [API](docs/API.md), "
                   "not https://example.org/docs/x nor tests/*.py; my_tests/x is no path.")
    assert PATH.findall(doc.read_text()) == ["scripts/serve.sh", "tests/client/test_constants.py",
                                            "docs/API.md"]
    assert named_paths(doc) == {"scripts/serve.sh", "tests/client/test_constants.py", "docs/API.md"}
    assert exists("tests/client/test_constants.py") and exists("scripts/lua.py")
    assert not exists("tests/test_constants.py")  # the path docs/API.md named (issue 33 item 10)


def test_every_path_the_docs_name_exists():
    missing = [f"{doc.relative_to(ROOT)}: {path}" for doc in DOCS for path in sorted(named_paths(doc))
               if not exists(path)]
    assert not missing, "paths the docs name that the checkout does not have:\n" + "\n".join(missing)
