"""The scene files simx loads and the V-REP / CoppeliaSim releases whose files it reads: said once
here, read by the command line's messages, and checked against README.md and docs/ by
``tests/test_doc_facts.py`` (so the range the docs give is the range the reader takes).
"""

from __future__ import annotations

#: File suffix -> what it is, in the order the docs list them. (The suffix names a kind; a file
#: is loaded as what its content is, whatever its name: simx_server.base.file_kinds.)
SCENE_FORMATS: dict[str, str] = {
    ".xml": "MJCF (MuJoCo's scene format)",
    ".urdf": "URDF",
    ".ttt": "V-REP / CoppeliaSim scene",
    ".ttm": "V-REP / CoppeliaSim model",
}

#: The serialization versions of ``.ttt``/``.ttm`` files the reader takes (records.py checks a
#: file's header against them) and the releases that wrote them.
OLDEST_SERIALIZATION, NEWEST_SERIALIZATION = 18, 25
VREP_RANGE = "V-REP 3.1.3 to CoppeliaSim 4.6"

#: How the command line names what it loads.
SCENE_FILES_TEXT = "an MJCF (.xml), URDF (.urdf) or V-REP / CoppeliaSim (.ttt, .ttm) file"
