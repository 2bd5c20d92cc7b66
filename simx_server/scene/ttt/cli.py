"""``simx-convert scene.ttt -o DIR``: a V-REP scene or model as an MJCF simx loads, with its
meshes and scripts, for a user who wants to edit the result; prints what did not carry over
(one line per kind, with counts)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from simx_server.scene.ttt import convert, reader
from simx_server.scene.ttt.errors import SceneFileError


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``simx-convert`` console script; returns the exit code (2: the file
    cannot be read or converted, with one line naming the file and the record)."""
    p = argparse.ArgumentParser(prog="simx-convert", description=__doc__.split("\n\n")[0])
    p.add_argument("file", help="a V-REP/CoppeliaSim scene (.ttt) or model (.ttm)")
    p.add_argument("-o", "--output", required=True, help="folder to write the MJCF, meshes and scripts into")
    args = p.parse_args(argv)
    src, out = Path(args.file), Path(args.output)
    try:
        scene = reader.read(src)
        xml, report = convert.convert(scene, out, src.stem)
    except (SceneFileError, ValueError, OSError) as exc:
        print(f"simx-convert: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {xml} ({len(scene.objects)} objects, {len(scene.scripts)} scripts)")
    if report.taken:
        print(f"taken from the file: {'; '.join(report.taken)}")
    if report.repaired:
        print(f"repaired: {'; '.join(report.repaired)}")
    for line in report.approximations():
        print(f"approximated: {line}")
    for line in report.lines():
        print(f"not carried over: {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
