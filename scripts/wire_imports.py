#!/usr/bin/env python3
"""Point imports of the legacy wire schema at ``simx_wire`` instead of ``simx_client``.

The schema modules (``protocol``, ``constants``, ``decoded_size``, ``legacy_constants``) live in
the neutral package :mod:`simx_wire`; ``simx_client`` still makes them importable under their old
names for its users. The server must not import the client package, so every ``simx_server``
, ``simx_wire`` and ``scenes/`` mention of them is rewritten here, mechanically:

* ``from simx_client import protocol as P`` (any of the four modules, ``as`` names and lists of
  them included) becomes ``from simx_wire import ...``;
* ``simx_client.<module>`` anywhere else (``from simx_client.protocol import X``,
  ``import simx_client.constants``, docstring references) becomes ``simx_wire.<module>``.

Run it again after merging branches whose new code still imports ``simx_client``'s schema:

    python scripts/wire_imports.py            # rewrites simx_server/, simx_wire/, scenes/
    python scripts/wire_imports.py --check    # only lists what it would change (exit 1 if any)

Afterwards it lists every import of ``simx_client`` left in those folders (exit status 1), which
must then be moved by hand: the server may not depend on the client package
(``tests/test_layers.py`` checks it).
"""

from __future__ import annotations

import argparse
import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("simx_server", "simx_wire", "scenes")
WIRE = ("protocol", "constants", "decoded_size", "legacy_constants")

_NAME = rf"(?:{'|'.join(WIRE)})(?:\s+as\s+\w+)?"
#: ``from simx_client import <wire modules only>`` on one line (an ``import``'s list or one name).
FROM_PACKAGE = re.compile(
    rf"^(\s*)from\s+simx_client\s+import\s+(\(?\s*{_NAME}(?:\s*,\s*{_NAME})*\s*,?\s*\)?)", re.MULTILINE
)
#: ``simx_client.<wire module>`` as a dotted name (imports, docstrings, comments).
DOTTED = re.compile(rf"\bsimx_client\.({'|'.join(WIRE)})\b")


def rewrite(text: str) -> str:
    """``text`` with every reference to ``simx_client``'s wire modules pointing at ``simx_wire``."""
    text = FROM_PACKAGE.sub(lambda m: f"{m.group(1)}from simx_wire import {m.group(2)}", text)
    return DOTTED.sub(r"simx_wire.\1", text)


def client_imports(path: Path) -> list[str]:
    """``file:line: statement`` for each import of ``simx_client`` (inside functions too)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        else:
            continue
        if any(n == "simx_client" or n.startswith("simx_client.") for n in names):
            found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {ast.unparse(node)}")
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="change nothing; exit 1 if a file would change")
    args = parser.parse_args(argv)
    files = sorted(p for folder in FOLDERS for p in (ROOT / folder).rglob("*.py"))
    changed = []
    for path in files:
        text = path.read_text()
        new = rewrite(text)
        if new != text:
            changed.append(path.relative_to(ROOT))
            if not args.check:
                path.write_text(new)
    for path in changed:
        print(f"{'would rewrite' if args.check else 'rewrote'} {path}")
    left = [line for path in files for line in client_imports(path)]
    for line in left:
        print(f"still imports simx_client (move it by hand): {line}")
    return 1 if left or (args.check and changed) else 0


if __name__ == "__main__":
    sys.exit(main())
