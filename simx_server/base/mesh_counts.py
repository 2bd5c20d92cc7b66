"""What a client's mesh and texture files hold, counted on their bytes before MuJoCo reads them
(scene_guard measures client files with these): vertices and faces as MuJoCo's readers take
them, a PNG's pixels from its header."""

from __future__ import annotations

import posixpath
import re
import struct


def png_pixels(head: bytes) -> int | None:
    """Pixels of a PNG by its header (width x height), None when ``head`` is no PNG's."""
    if head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) >= 24 and head[12:16] == b"IHDR":
        w, h = struct.unpack(">II", head[16:24])
        return w * h
    return None


#: An OBJ vertex line as MuJoCo's reader (tinyobjloader) takes one: after \n, \r or \r\n (or at
#: the start), optional blanks (space, tab), ``v``, a blank.
_OBJ_VERTEX = re.compile(rb"(?:^|[\r\n])[ \t]*v[ \t]")


def mesh_vertices(data: bytes, name: str) -> int:
    """Vertices a mesh file holds (an upper bound), counted as MuJoCo's readers take them.

    By the extension MuJoCo picks its reader by: ``.stl`` is read as binary STL whatever its
    first bytes (an 80-byte header that starts with ``solid`` included), three vertices per
    triangle of its count; ``.obj`` by its vertex lines (CR, LF or CRLF, leading blanks);
    ``.msh`` by its header's count; any other name (a ``content_type``) by the most of these
    and three floats per vertex."""
    ext = posixpath.splitext(name.lower())[1]
    if ext == ".stl":
        return 3 * struct.unpack("<I", data[80:84])[0] if len(data) >= 84 else 0
    text = len(_OBJ_VERTEX.findall(data))
    if ext == ".obj":
        return text
    if ext == ".msh":
        return max(text, struct.unpack("<i", data[:4])[0] if len(data) >= 4 else 0)
    return max(text, len(data) // 12)


#: An OBJ face line (``f`` and its vertex references), as :data:`_OBJ_VERTEX`.
_OBJ_FACE = re.compile(rb"(?:^|[\r\n])[ \t]*f[ \t]([^\r\n]*)")


def mesh_faces(data: bytes, name: str) -> int:
    """Triangles a mesh file makes (an upper bound), as MuJoCo's readers take them: ``.stl`` its
    triangle count; ``.obj`` its face lines, a polygon of n vertices n - 2 triangles (the fan
    tinyobjloader makes); ``.msh`` its header's face count; any other name the most of these
    and one face per 12 bytes."""
    ext = posixpath.splitext(name.lower())[1]
    if ext == ".stl":
        return struct.unpack("<I", data[80:84])[0] if len(data) >= 84 else 0
    text = sum(max(1, len(refs.split()) - 2) for refs in _OBJ_FACE.findall(data))
    if ext == ".obj":
        return text
    if ext == ".msh":
        return max(text, struct.unpack("<i", data[12:16])[0] if len(data) >= 16 else 0)
    return max(text, len(data) // 12)
