"""The one error a V-REP scene (``.ttt``) or model (``.ttm``) file that cannot be read raises,
and the bounds that keep reading a hostile file finite (docs/SECURITY.md, "V-REP scene files")."""

from __future__ import annotations

# Bounds on what one file may make the reader do; each crossing is a SceneFileError.
MAX_FILE_BYTES = 256 * 1024 * 1024        # the .ttt/.ttm file itself
MAX_BODY_BYTES = 512 * 1024 * 1024        # the decoded body (header's size; Huffman output stops here)
MAX_NESTING = 32                          # record lists inside record lists
MAX_RECORDS = 5_000_000                   # records read in one file
MAX_OBJECTS = 100_000                     # scene objects
MAX_MESH_VERTICES = 5_000_000             # vertices of one mesh (pool arrays likewise)
MAX_MESH_TRIANGLES = 10_000_000           # triangles of one mesh
MAX_TEXTURE_PIXELS = 64 * 1024 * 1024     # pixels of one texture
MAX_STRING_BYTES = 16 * 1024 * 1024       # one string (a script's text)


class SceneFileError(ValueError):
    """A ``.ttt``/``.ttm`` file that cannot be read: truncated, corrupted, beyond a bound.

    Attributes:
        file: the file's name (as given).
        record: the tag path of the record being read (e.g. ``"SHP/Ge2/Gst"``), or ``"header"``.
    """

    def __init__(self, file: str, record: str, message: str):
        super().__init__(f"{file}: record {record}: {message}")
        self.file = file
        self.record = record
