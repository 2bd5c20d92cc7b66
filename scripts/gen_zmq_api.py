#!/usr/bin/env python3
"""Generate simx_server/zmq/coppeliasim_api.json (package data): the names of CoppeliaSim 4.x's
``sim`` and ``simIK`` functions and the values of their constants, as the ZMQ remote API lists them.

The table is made from the C++ client of CoppeliaRobotics/zmqRemoteApi, whose headers are
generated from CoppeliaSim's own API description: ``RemoteAPIObjects.h`` declares one class per
namespace (``class sim``, ``class simIK``) with a method per function and a
``const int NAME = VALUE;`` per constant, and ``sim-deprecated.h`` / ``sim-special.h`` (included
into ``class sim``) declare the deprecated and special functions. Only names and numbers are
kept; nothing of the headers' text.

Get the files (their text is not kept in the repository)::

    git -C <zmqRemoteApi clone> show 66684dd:clients/cpp/RemoteAPIObjects.h > /tmp/RemoteAPIObjects.h
    git -C <zmqRemoteApi clone> show 66684dd:clients/cpp/sim-deprecated.h > /tmp/sim-deprecated.h
    git -C <zmqRemoteApi clone> show 66684dd:clients/cpp/sim-special.h > /tmp/sim-special.h
    python scripts/gen_zmq_api.py /tmp/RemoteAPIObjects.h /tmp/sim-deprecated.h /tmp/sim-special.h \\
        -o simx_server/zmq/coppeliasim_api.json

Each file's git blob id is checked against :data:`SOURCES` (``--any-version`` accepts another
and writes its id); ``--check`` regenerates in memory and fails when the committed table differs.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys
from pathlib import Path

REPOSITORY = "CoppeliaRobotics/zmqRemoteApi"
COMMIT = "66684ddcf0e5328dbde9c95fd801f38ae592b5c0"
#: File name -> git blob id at COMMIT.
SOURCES = {
    "RemoteAPIObjects.h": "dabf3d78c0cf4d888235434617496d343aa9b46d",
    "sim-deprecated.h": "6744740e40725e329d52d7170317a00e80e908a1",
    "sim-special.h": "bca50292b2c2315a074863b12a61775fb2967815",
}

_CLASS = re.compile(r"^\s*class (\w+)\s*$")
_CONST = re.compile(r"^\s*const int (\w+) = (-?\d+);")
#: A method declaration: return type, then ``name(`` (the constructor has no return type).
_METHOD = re.compile(r"^\s*(?:[\w:<>,\s\[\]]+?)\s+(\w+)\((?!RemoteAPIClient)")


def blob_id(data: bytes) -> str:
    """Git's blob id of ``data``."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def methods(text: str) -> set[str]:
    """Function names declared in a header's lines (several per line allowed: ``f();g();``)."""
    found = set()
    for line in text.splitlines():
        for part in line.split(";"):
            m = _METHOD.match(part)
            if m:
                found.add(m.group(1))
    return found


def parse(objects: str, extra: list[str]) -> tuple[dict[str, list[str]], dict[str, dict[str, int]]]:
    """(namespace -> sorted function names, namespace -> {constant: value})."""
    functions: dict[str, set[str]] = {}
    constants: dict[str, dict[str, int]] = {}
    namespace = None
    for line in objects.splitlines():
        m = _CLASS.match(line)
        if m:
            namespace = m.group(1)
            if namespace == "RemoteAPIObjects":
                namespace = None
            else:
                functions.setdefault(namespace, set())
                constants.setdefault(namespace, {})
            continue
        if namespace is None:
            continue
        c = _CONST.match(line)
        if c:
            constants[namespace][c.group(1)] = int(c.group(2))
            continue
        if "#include" in line:
            continue
        functions[namespace] |= methods(line)
    for text in extra:  # included into class sim
        functions["sim"] |= methods(text)
    return {ns: sorted(names) for ns, names in functions.items()}, constants


def render(functions: dict[str, list[str]], constants: dict[str, dict[str, int]], blobs: dict[str, str]) -> str:
    """The JSON table: its provenance, then one line per namespace's functions and constants."""
    head = {
        "generated_by": "scripts/gen_zmq_api.py (do not edit: regenerate)",
        "source": f"{REPOSITORY} at commit {COMMIT}, clients/cpp/ "
                  + ", ".join(f"{name} (blob {blob})" for name, blob in blobs.items()),
    }
    lines = ["{"] + [f"  {json.dumps(k)}: {json.dumps(v)}," for k, v in head.items()]
    lines.append('  "functions": {')
    lines.append(",\n".join(f"    {json.dumps(ns)}: {json.dumps(names)}" for ns, names in functions.items()))
    lines.append("  },")
    lines.append('  "constants": {')
    lines.append(",\n".join(f"    {json.dumps(ns)}: {json.dumps(dict(sorted(values.items())))}"
                            for ns, values in constants.items()))
    lines += ["  }", "}", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("objects", type=Path, help="RemoteAPIObjects.h")
    p.add_argument("extra", type=Path, nargs="*", help="sim-deprecated.h, sim-special.h")
    p.add_argument("-o", "--output", type=Path, default=Path("simx_server/zmq/coppeliasim_api.json"))
    p.add_argument("--any-version", action="store_true", help="accept files of another version")
    p.add_argument("--check", action="store_true", help="fail when the committed table differs")
    args = p.parse_args(argv)
    blobs = {}
    for path in [args.objects, *args.extra]:
        data = path.read_bytes()
        blob = blob_id(data)
        expected = SOURCES.get(path.name)
        if blob != expected and not args.any_version:
            print(f"{path}: blob {blob} is not {path.name} of {REPOSITORY}@{COMMIT[:12]} ({expected}); "
                  "--any-version takes it anyway", file=sys.stderr)
            return 2
        blobs[path.name] = blob
    functions, constants = parse(args.objects.read_text(), [p.read_text() for p in args.extra])
    text = render(functions, constants, blobs)
    if args.check:
        if args.output.read_text() != text:
            print(f"{args.output} differs from what the headers give: regenerate it", file=sys.stderr)
            return 1
        return 0
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(text)
    print(f"{args.output}: " + ", ".join(f"{ns} {len(functions[ns])} functions, {len(constants[ns])} constants"
                                         for ns in functions))
    return 0


if __name__ == "__main__":
    sys.exit(main())
