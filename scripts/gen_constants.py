#!/usr/bin/env python3
"""Generate simx_wire/legacy_constants.py: every constant of the legacy remote API files, by name.

The table is made from the original files, never typed by hand:

* ``vrepConst.py`` of V-REP 3.6 and ``simConst.py`` of CoppeliaSim (both Python files of plain
  assignments: ``name = value``, some values expressions of earlier names such as
  ``sim_simulation_advancing | 0x01``): parsed with :mod:`ast` and evaluated with a small
  evaluator that knows integers, names already defined, unary ``- + ~`` and binary
  ``| & ^ + - * << >>``; any other statement or expression stops the script with its line.
* ``v_repConst.h`` of V-REP 3.6.2 (the C header, the source of the Lua API's constants): only the
  families named in :data:`HEADER_FAMILIES` that the Python files lack and simx uses (vision
  sensor render modes, colour components, ``sim_handleflag_greyscale``, ``simx_cmdmask``); its
  ``enum { ... }`` blocks are parsed (implicit values count up from the previous one).

Get the files (their text is not kept in the repository: only the generated name/value table)::

    git -C <remoteApiBindings clone> show a1feb81:python/python/vrepConst.py > /tmp/vrepConst.py
    git -C <remoteApiBindings clone> show bacfa11:python/python/simConst.py > /tmp/simConst.py
    git -C <include clone> show ea75e262:v_repConst.h > /tmp/v_repConst.h
    python scripts/gen_constants.py /tmp/vrepConst.py /tmp/simConst.py /tmp/v_repConst.h \\
        -o simx_wire/legacy_constants.py

Each file's git blob id is checked against :data:`SOURCES` (a different file is refused, so the
provenance written into the table stays true; ``--any-version`` accepts it and writes its blob
id). ``--check`` regenerates in memory and fails when the committed table differs.
"""

from __future__ import annotations

import argparse
import ast
import hashlib
import operator
import re
import sys
import textwrap
from pathlib import Path

#: Where each file comes from: repository, path, commit, and the git blob id of the file there.
SOURCES = {
    "vrepConst.py": {
        "repo": "CoppeliaRobotics/remoteApiBindings", "path": "python/python/vrepConst.py",
        "commit": "a1feb81d61f6d1aec47169b878613d0cc538b2b7",
        "blob": "53c24e6385ab1a6ae5a311188ea43c5f9714e70b",
        "note": "the last commit of V-REP's vrepConst.py (June 2019, V-REP 3.6.2) before the file "
                "became simConst.py; byte-identical (CRLF aside) to the tutorial's copy, "
                "Ianlande/Vrep_yolov3_ddpg_pytorch vrepConst.py @ 8e97e9a101f0905c60ded36f188f5aa8d477e7d5",
    },
    "simConst.py": {
        "repo": "CoppeliaRobotics/remoteApiBindings", "path": "python/python/simConst.py",
        "commit": "bacfa11921d89bcbff568ef660e6d305d4cda019",
        "blob": "208aac60e274d6786cb82bab0b14d0ed9418e048",
        "note": "CoppeliaSim's legacy remote API constants (HEAD, June 2023)",
    },
    "v_repConst.h": {
        "repo": "CoppeliaRobotics/include", "path": "v_repConst.h",
        "commit": "ea75e2624b4d61dd43021980eb32fee6859e4051",
        "blob": "6b89b36cabc43adcdf31486ff8ba9ff36a3c40d8",
        "note": "V-REP 3.6.2 rev0 ('release 3.6.2. rev0')",
    },
}

#: The header's families that the table takes (name prefixes, or whole names).
HEADER_FAMILIES = ("sim_rendermode_", "sim_colorcomponent_", "sim_handleflag_greyscale", "simx_cmdmask")

_BINARY = {ast.BitOr: operator.or_, ast.BitAnd: operator.and_, ast.BitXor: operator.xor,
           ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.LShift: operator.lshift, ast.RShift: operator.rshift}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Invert: operator.invert}


class SourceError(ValueError):
    """A construct the generator does not evaluate (file, line and what)."""


def git_blob_id(data: bytes) -> str:
    """The id git gives ``data`` as a blob (``git hash-object``)."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def evaluate(node: ast.expr, names: dict[str, int], where: str) -> int:
    """The integer value of ``node``: literals, known names, unary and binary integer operators."""
    if isinstance(node, ast.Constant) and type(node.value) is int:
        return node.value
    if isinstance(node, ast.Name):
        if node.id not in names:
            raise SourceError(f"{where}: {node.id!r} is used before it is defined")
        return names[node.id]
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](evaluate(node.operand, names, where))
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _BINARY[type(node.op)](evaluate(node.left, names, where), evaluate(node.right, names, where))
    raise SourceError(f"{where}: not an integer expression: {ast.dump(node)[:80]}")


def python_constants(text: str, label: str) -> dict[str, int]:
    """``{name: value}`` of every top-level ``name = expression`` of a constants file, in order."""
    out: dict[str, int] = {}
    for stmt in ast.parse(text, label).body:
        where = f"{label}:{stmt.lineno}"
        if isinstance(stmt, ast.Expr) and isinstance(stmt.value, ast.Constant) and isinstance(stmt.value.value, str):
            continue  # a docstring
        if not isinstance(stmt, ast.Assign) or not all(isinstance(t, ast.Name) for t in stmt.targets):
            raise SourceError(f"{where}: not a plain assignment")
        value = evaluate(stmt.value, out, where)
        for target in stmt.targets:
            if target.id in out:
                raise SourceError(f"{where}: {target.id} assigned twice")
            out[target.id] = value
    return out


_C_COMMENT = re.compile(r"/\*.*?\*/|//[^\n]*", re.S)
_ENUM = re.compile(r"\benum\b[^{;]*\{(.*?)\}", re.S)
_C_INT = re.compile(r"\b(0[xX][0-9a-fA-F]+|\d+)[uUlL]*\b")


def header_enum_constants(text: str) -> dict[str, int | None]:
    """``{name: value}`` of every item of every ``enum { ... }`` of a C header; ``None`` where
    the value is an expression this parser does not evaluate (and for the implicit items after it)."""
    names: dict[str, int] = {}
    out: dict[str, int | None] = {}
    for block in _ENUM.finditer(_C_COMMENT.sub(" ", text)):
        previous: int | None = -1
        for item in block.group(1).split(","):
            item = item.strip()
            if not item:
                continue
            name, _, expr = (part.strip() for part in item.partition("="))
            if not re.fullmatch(r"[A-Za-z_]\w*", name):
                raise SourceError(f"v_repConst.h: enum item {item[:60]!r}")
            if expr:
                try:
                    value = evaluate(ast.parse(_C_INT.sub(lambda m: str(int(m.group(1), 0)), expr),
                                               mode="eval").body, names, f"v_repConst.h: {name}")
                except (SourceError, SyntaxError):
                    value = None
            else:
                value = None if previous is None else previous + 1
            out[name] = previous = value
            if value is not None:
                names[name] = value
    return out


def header_families(text: str, families: tuple[str, ...] = HEADER_FAMILIES) -> dict[str, int]:
    """The enum constants of the header whose names start with one of ``families``."""
    out = {}
    for name, value in header_enum_constants(text).items():
        if name.startswith(families):
            if value is None:
                raise SourceError(f"v_repConst.h: the value of {name} could not be evaluated")
            out[name] = value
    missing = [f for f in families if not any(n.startswith(f) for n in out)]
    if missing:
        raise SourceError(f"v_repConst.h: no constant of {missing}")
    return out


def _table(name: str, doc: str, values: dict[str, int]) -> list[str]:
    lines = [f"#: {doc}", f"{name}: dict[str, int] = {{"]
    lines += [f"    {key!r}: {value!r}," for key, value in values.items()]
    return lines + ["}", ""]


def render(tables: dict[str, dict[str, int]], blobs: dict[str, str]) -> str:
    """The text of simx_wire/legacy_constants.py."""
    provenance = []
    for file, src in SOURCES.items():
        provenance.append(f"* ``{file}``: {src['repo']} ``{src['path']}``")
        provenance.append(f"  @ {src['commit']} (git blob {blobs[file]}):")
        provenance += textwrap.wrap(src["note"] + ".", 96, initial_indent="  ", subsequent_indent="  ")
    vrep, sim, header = tables["vrepConst.py"], tables["simConst.py"], tables["v_repConst.h"]
    lines = [
        '"""Every constant of the legacy remote API\'s constants files, by name (GENERATED: do not edit).',
        "",
        "Made by ``scripts/gen_constants.py`` from the original files (their values, not their text):",
        "",
        *provenance,
        "",
        f"{len(vrep)} names in vrepConst.py, {len(sim)} in simConst.py, {len(header)} taken from v_repConst.h",
        f"(families {', '.join(HEADER_FAMILIES)}).",
        "Values are evaluated (some are expressions of earlier names in the files).",
        ":mod:`simx_wire.constants` builds the legacy modules from these tables.",
        '"""',
        "",
        "from __future__ import annotations",
        "",
        *_table("VREPCONST", "V-REP 3.6's vrepConst.py, in file order.", vrep),
        *(["#: CoppeliaSim's legacy simConst.py: the same names, values and order as vrepConst.py",
           "#: (compared when this file was generated), kept once.",
           "SIMCONST: dict[str, int] = dict(VREPCONST)", ""]
          if list(sim.items()) == list(vrep.items()) else
          _table("SIMCONST", "CoppeliaSim's legacy simConst.py, in file order.", sim)),
        *_table("V_REPCONST_H", "V-REP 3.6.2's v_repConst.h: the families above.", header),
    ]
    return "\n".join(lines[:-1]) + "\n"


def generate(vrepconst: Path, simconst: Path, header: Path, any_version: bool = False) -> str:
    """The generated table's text from the three files (their blob ids checked against SOURCES)."""
    blobs, tables = {}, {}
    for file, path in (("vrepConst.py", vrepconst), ("simConst.py", simconst), ("v_repConst.h", header)):
        data = path.read_bytes()
        blobs[file] = git_blob_id(data)
        if blobs[file] != SOURCES[file]["blob"] and not any_version:
            raise SourceError(f"{path} is not {SOURCES[file]['repo']} {SOURCES[file]['path']} @ "
                              f"{SOURCES[file]['commit'][:10]} (git blob {blobs[file]}, expected "
                              f"{SOURCES[file]['blob']}); --any-version accepts it")
        text = data.decode("utf-8")
        tables[file] = header_families(text) if file.endswith(".h") else python_constants(text, file)
    return render(tables, blobs)


def main(argv: list[str] | None = None) -> int:
    """Command line: see the module docstring."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("vrepconst", type=Path, help="V-REP 3.6's vrepConst.py")
    parser.add_argument("simconst", type=Path, help="CoppeliaSim's legacy simConst.py")
    parser.add_argument("header", type=Path, help="V-REP 3.6.2's v_repConst.h")
    parser.add_argument("-o", "--output", type=Path, help="write here (default: stdout)")
    parser.add_argument("--check", action="store_true", help="fail when OUTPUT differs from what would be written")
    parser.add_argument("--any-version", action="store_true", help="accept files whose blob id differs from SOURCES")
    args = parser.parse_args(argv)
    try:
        text = generate(args.vrepconst, args.simconst, args.header, args.any_version)
    except (OSError, SourceError) as exc:
        print(f"gen_constants: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if args.output is None or not args.output.exists() or args.output.read_text() != text:
            print(f"gen_constants: {args.output} is not up to date", file=sys.stderr)
            return 1
        return 0
    if args.output is None:
        sys.stdout.write(text)
    else:
        args.output.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
