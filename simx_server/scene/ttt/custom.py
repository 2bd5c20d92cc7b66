"""An object's custom data and script simulation parameters as a ``.ttt``/``.ttm`` stores them.

Custom data (what ``sim.writeCustomDataBlock`` wrote; scripts read it back with
``sim.readCustomDataBlock``), in the object's common part:

* ``Cda`` (CoppeliaSim 4.3+): a list of ``Cdt`` records, each i32 tag length, tag, i32 data
  length, data.
* ``Cod`` (V-REP 3.x, still written by 4.x for older readers): one ``Dat`` record, a run of
  ``(i32 header, i32 length, bytes)`` blocks. The block of header 356248756 (the one
  ``simWriteCustomDataBlock`` uses) is a run of ``(i32 entry length, i32 tag length, tag with its
  NUL, data)`` entries, the entry length counting its 8 header bytes, the tag and the data.
  Blocks of other headers are V-REP 2.x/3.x developer data (``simAddObjectCustomData``).

Script simulation parameters: the script's ``Prm`` (up to 4.2) or the object's ``Lsp`` (4.3+)
hold one ``Par`` record: i32 count, then per parameter three i32-length strings (name, unit,
value) and i32 properties.

Referenced handles (``sim.setReferencedHandles``; coppeliaSimLib ``CSceneObject::serialize``):
``Crh`` the untagged list (i32 count, then per entry i32 object type, i32 handle, i32 0) and one
``Cr2`` per tag (i32-length tag, i32 count, i32 handles).
"""

from __future__ import annotations

import struct

from simx_server.scene.ttt import errors as E
from simx_server.scene.ttt.records import Records, read_string

DEVELOPER_DATA_HEADER = 356248756  # the header of simWriteCustomDataBlock's blocks in ``Cod``/``Dat``
_MAX_PARAMETERS = 10_000


def _raw_string(payload: memoryview, p: int, where: Records, tag: str) -> tuple[bytes, int]:
    """An i32-length-prefixed byte string at ``p``, bytes unchanged; and the position after it."""
    if p + 4 > len(payload):
        raise where.error(tag, "string truncated")
    n, = struct.unpack_from("<i", payload, p)
    if n < 0 or n > E.MAX_STRING_BYTES or p + 4 + n > len(payload):
        raise where.error(tag, f"string of declared size {n:,} beyond its record")
    return bytes(payload[p + 4:p + 4 + n]), p + 4 + n


def read_custom_data(common: Records) -> tuple[dict[str, bytes], int]:
    """The custom data blocks of an object (``{tag: data}``) from its common records, the newer
    ``Cda`` preferred, and the count of developer data blocks of other headers (not modelled).

    Raises:
        SceneFileError: a block or entry whose sizes run beyond its record.
    """
    if common.get("Cda") is not None:
        cda = common.sub("Cda")
        out: dict[str, bytes] = {}
        for tag, payload in cda:
            if tag != "Cdt":
                continue
            name, p = read_string(payload, 0, cda, "Cdt")
            if p + 4 > len(payload):
                raise cda.error("Cdt", "data size truncated")
            n, = struct.unpack_from("<i", payload, p)
            if n < 0 or p + 4 + n > len(payload):
                raise cda.error("Cdt", f"data of declared size {n:,} beyond its record")
            out[name] = bytes(payload[p + 4:p + 4 + n])
        return out, 0
    cod = common.sub("Cod")
    dat = cod.get("Dat")
    if dat is None:
        return {}, 0
    out, others, p = {}, 0, 0
    while p + 8 <= len(dat):
        header, n = struct.unpack_from("<ii", dat, p)
        p += 8
        if n < 0 or p + n > len(dat):
            raise cod.error("Dat", f"block of declared size {n:,} beyond its record")
        if header == DEVELOPER_DATA_HEADER:
            out.update(_tagged_entries(dat[p:p + n], cod))
        else:
            others += 1
        p += n
    return out, others


def _tagged_entries(block: memoryview, where: Records) -> dict[str, bytes]:
    out: dict[str, bytes] = {}
    p = 0
    while p + 8 <= len(block):
        size, tag_size = struct.unpack_from("<ii", block, p)
        if size < 8 or p + size > len(block) or not 0 <= tag_size <= min(size - 8, E.MAX_STRING_BYTES):
            raise where.error("Dat", f"custom data entry of declared size {size:,} (tag {tag_size:,}) beyond its block")
        tag = bytes(block[p + 8:p + 8 + tag_size]).split(b"\x00", 1)[0].decode("utf-8", "replace")
        out[tag] = bytes(block[p + 8 + tag_size:p + size])
        p += size
    return out


def read_parameters(holder: Records, tag: str) -> list[dict]:
    """The script simulation parameters in ``holder``'s ``tag`` record (``Prm`` of a script,
    ``Lsp`` of an object) as ``{name, value, unit}``, the value the stored bytes unchanged (V-REP
    keeps any bytes there: a recorded trajectory, a packed table); [] when absent.

    Raises:
        SceneFileError: a string whose size runs beyond its record.
    """
    sub = holder.sub(tag)
    par = sub.get("Par")
    params: list[dict] = []
    if par is None or len(par) < 4:
        return params
    count, = struct.unpack_from("<i", par, 0)
    p = 4
    for _ in range(max(0, min(count, _MAX_PARAMETERS))):
        name, p = read_string(par, p, sub, "Par")
        unit, p = read_string(par, p, sub, "Par")
        value, p = _raw_string(par, p, sub, "Par")
        p += 4  # properties
        params.append({"name": name, "value": value, "unit": unit})
    return params


_MAX_REFERENCES = 10_000


def read_references(common: Records) -> dict[str, list[int]]:
    """An object's referenced handles, tag -> handles in the file's numbering (``Crh``: tag
    ``""``; ``Cr2``: one tag each), as coppeliaSimLib ``CSceneObject::serialize`` loads them.
    A truncated record raises SceneFileError naming it."""
    refs: dict[str, list[int]] = {}
    for tag, payload in common:
        if tag == "Crh":
            if len(payload) < 4:
                raise common.error(tag, "truncated")
            n = struct.unpack_from("<i", payload, 0)[0]
            if not 0 <= n <= _MAX_REFERENCES or len(payload) < 4 + 12 * n:
                raise common.error(tag, f"{n} references in {len(payload)} bytes")
            refs[""] = [struct.unpack_from("<i", payload, 4 + 12 * i + 4)[0] for i in range(n)]
        elif tag == "Cr2":
            key, p = read_string(payload, 0, common, tag)
            n = struct.unpack_from("<i", payload, p)[0] if p + 4 <= len(payload) else -1
            if not 0 <= n <= _MAX_REFERENCES or len(payload) < p + 4 + 4 * n:
                raise common.error(tag, f"references of tag {key!r} truncated")
            refs[key] = list(struct.unpack_from(f"<{n}i", payload, p + 4))
    return refs
