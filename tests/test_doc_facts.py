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
