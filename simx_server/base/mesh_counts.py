"""What a client's mesh and texture files hold, counted on their bytes before MuJoCo reads them
(scene_guard measures client files with these): vertices and faces as MuJoCo's readers take
them, a PNG's pixels from its header."""

from __future__ import annotations

import posixpath
import re
import struct
import threading
from collections import OrderedDict
from typing import Any


def png_pixels(head: bytes) -> int | None:
    """Pixels of a PNG by its header (width x height), None when ``head`` is no PNG's."""
    if head[:8] == b"\x89PNG\r\n\x1a\n" and len(head) >= 24 and head[12:16] == b"IHDR":
        w, h = struct.unpack(">II", head[16:24])
        return w * h
    return None


#: An OBJ vertex line as MuJoCo's reader (tinyobjloader) takes one: after \n, \r or \r\n (or at
#: the start), optional blanks (space, tab), ``v``, a blank.
_OBJ_VERTEX = re.compile(rb"(?:^|[\r\n])[ \t]*v[ \t]")
#: Bytes of text one regular-expression call reads: ``re`` holds the GIL for a whole call, and a
#: client's 12 MiB OBJ read in one call held every other thread (the simulation's included)
#: 0.6-0.9 s while the conversions' thread measured it.
_PIECE = 1 << 18


def _lines(data: bytes) -> list[bytes]:
    """``data`` in pieces of about :data:`_PIECE` bytes, each ending with a line's end (or the
    data's): a line-anchored pattern finds in the pieces what it finds in the whole."""
    pieces, start, n = [], 0, len(data)
    while start < n:
        end = start + _PIECE
        if end < n:
            cut = max(data.rfind(b"\n", start, end), data.rfind(b"\r", start, end))
            if cut < start:  # a line longer than a piece: up to its end
                ends = [i for i in (data.find(b"\n", end), data.find(b"\r", end)) if i >= 0]
                cut = min(ends) if ends else n - 1
            end = cut + 1
        pieces.append(data[start:end])
        start = end
    return pieces


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
    text = sum(len(_OBJ_VERTEX.findall(piece)) for piece in _lines(data))
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
    text = sum(max(1, len(refs.split()) - 2) for piece in _lines(data) for refs in _OBJ_FACE.findall(piece))
    if ext == ".obj":
        return text
    if ext == ".msh":
        return max(text, struct.unpack("<i", data[12:16])[0] if len(data) >= 16 else 0)
    return max(text, len(data) // 12)


#: (vertices, faces) of mesh files read into memory, by their asset name and content (``hash`` of
#: a bytes object is computed once and kept in it; the spec hands back the same objects), counted
#: once, on the conversions' thread where it can be (``Editor.prepare_model``), and looked up when
#: an edit's growth is checked on the simulation thread.
_KEPT: OrderedDict[tuple[str, int, int], tuple[int, int]] = OrderedDict()
_KEPT_MOST = 4096
_KEPT_LOCK = threading.Lock()


def spec_mesh_counts(mesh: Any, assets: dict[str, bytes] | None) -> tuple[int, int]:
    """``(vertices, faces)`` of an ``MjsMesh``: its vertex and face lists and its file among
    ``assets`` (a spec's files in memory; a file not there counts nothing), as MuJoCo's readers
    take them (:func:`mesh_vertices`, :func:`mesh_faces`)."""
    vertices, faces = len(mesh.uservert) // 3, len(mesh.userface) // 3
    name = mesh.file
    data = (assets or {}).get(name) if name else None
    if data:
        key = (name, len(data), hash(data))
        with _KEPT_LOCK:
            counts = _KEPT.get(key)
        if counts is None:
            counts = (mesh_vertices(data, name), mesh_faces(data, name))
            with _KEPT_LOCK:
                _KEPT[key] = counts
                while len(_KEPT) > _KEPT_MOST:
                    _KEPT.popitem(last=False)
        vertices, faces = vertices + counts[0], faces + counts[1]
    return vertices, faces
