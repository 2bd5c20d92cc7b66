"""The one error a V-REP scene (``.ttt``) or model (``.ttm``) file that cannot be read raises,
and the bounds that keep reading a hostile file finite (docs/SECURITY.md, "V-REP scene files")."""

from __future__ import annotations

# Bounds on what one file may make the reader do; each crossing is a SceneFileError.
MAX_FILE_BYTES = 256 * 1024 * 1024        # the .ttt/.ttm file itself
MAX_BODY_BYTES = 512 * 1024 * 1024        # the decoded body (header's size; Huffman output stops here)
MAX_NESTING = 32                          # record lists inside record lists
MAX_RECORDS = 5_000_000                   # records read in one file
MAX_OBJECTS = 100_000                     # scene objects
MAX_TREE_DEPTH = 200                      # objects from a root down to the deepest child
MAX_MESH_VERTICES = 1_000_000             # vertices of one mesh (pool arrays likewise)
MAX_MESH_TRIANGLES = 200_000             # triangles of one mesh (MuJoCo reads at most 200,000 from an STL)
MAX_SCENE_VERTICES = 5_000_000            # vertices decoded in one file (a shared pool array once)
MAX_SCENE_TRIANGLES = 5_000_000           # triangles decoded in one file (a shared pool array once)
MAX_TEXTURE_PIXELS = 16 * 1024 * 1024     # pixels of one texture (4096 x 4096)
MAX_SCENE_TEXTURE_PIXELS = 32 * 1024 * 1024  # pixels of all the file's textures
MAX_STRING_BYTES = 16 * 1024 * 1024       # one string, one script's text
MAX_SCRIPT_BYTES = 32 * 1024 * 1024       # the text of all the file's scripts


class SceneFileError(ValueError):
    """A ``.ttt``/``.ttm`` file that cannot be read: truncated, corrupted, beyond a bound.

    Attributes:
        file: the file's name (as given).
        record: the tag path of the record being read (e.g. ``"SHP/Ge2/Gst"``), ``"header"``,
            or ``"worker"`` (the worker process's bounds, :mod:`simx_server.scene.ttt.worker`).
        message: what is wrong, without the file and the record.
    """

    def __init__(self, file: str, record: str, message: str):
        super().__init__(f"{file}: record {record}: {message}")
        self.file = file
        self.record = record
        self.message = message
