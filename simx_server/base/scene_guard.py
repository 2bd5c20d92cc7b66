"""Files and scenes sent by clients: where they live, what they may name, how big they may be.

Trust (docs/SECURITY.md, "Files and scenes sent by clients"):

* Trusted: the operator's scene (command line), its folder and ``--scene-path`` folders.
* Untrusted: everything that arrived through a transfer folder (``simxTransferFile``) of any
  simx-server. A transfer folder is ``<tmp>/simx-<pid>-<start>-<random>``, created 0700 by
  :func:`make_transfer_folder`, marked with a :data:`MARKER` file, removed when its server exits;
  folders whose server is gone (``kill -9``) are removed by the next server's
  :func:`sweep_stale`.

A scene or model sent by a client (MJCF, or URDF: its ``<link>``\\ s are bodies, its ``<mesh
filename>``\\ s files) is checked twice before MuJoCo compiles it:
:func:`check_client_file` reads its XML (and ``<include>``\\ d files) before MuJoCo parses it:
every file it names must lie inside its transfer folder, and its bodies and elements, with
``<replicate>``, ``<composite>`` and ``<flexcomp>`` counts multiplied out, must stay within
:mod:`simx_server.base.limits`; :func:`check_spec` then measures the parsed ``MjSpec`` (exact
counts, texture pixels, mesh vertices, height fields, ``<size>``, solver iterations, offscreen
buffers). Refusals raise ``RemoteError`` naming the bound; a refusal never says whether a
server path exists. Nothing here runs on a per-call hot path.
"""

from __future__ import annotations

import logging
import math
import os
import posixpath
import re
import shutil
import struct
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Iterable

import mujoco

from simx_wire.protocol import RemoteError
from simx_server.base import limits
from simx_server.base.arguments import quote
from simx_server.base.mesh_counts import mesh_faces, mesh_vertices, spec_mesh_counts
from simx_server.base.mesh_counts import png_pixels as _png_pixels

log = logging.getLogger("simx.files")

#: File that marks a transfer folder (any folder holding it, and all below, is untrusted).
MARKER = ".simx-transfer-folder"
PREFIX = "simx-"
_OURS = re.compile(r"simx-(\d+)-(\d+)-[A-Za-z0-9_]+")
#: XML attributes that name files, and folders that files are looked up in.
_FILE_ATTRS = ("file", "fileback", "filedown", "filefront", "fileleft", "fileright", "fileup",
               "filename")  # filename: URDF's <mesh>
_DIR_ATTRS = ("meshdir", "texturedir", "assetdir")
#: Elements a client-sent file may not hold (they load other files or native code).
_REFUSED = {"model": "<model> assets", "extension": "plugins", "plugin": "plugins",
            "instance": "plugins"}
_LISTS = ("bodies", "joints", "geoms", "sites", "cameras", "lights", "frames", "materials", "textures",
          "meshes", "hfields", "skins", "actuators", "sensors", "equalities", "tendons", "excludes", "pairs",
          "texts", "numerics", "tuples", "keys", "flexes")
_SIZE_FIELDS = ("nuserdata", "nkey", "nuser_body", "nuser_jnt", "nuser_geom", "nuser_site", "nuser_cam",
                "nuser_tendon", "nuser_actuator", "nuser_sensor", "njmax", "nconmax", "nstack")
_ITERATIONS = ("iterations", "ls_iterations", "noslip_iterations", "ccd_iterations", "sdf_iterations")


def temp_root() -> Path:
    return Path(tempfile.gettempdir()).resolve()


# ----------------------------------------------------------------- transfer folders
def _start_time(pid: int) -> int:
    """The process's start time in clock ticks since boot (Linux), 0 where unknown."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        return int(stat[stat.rindex(")") + 2:].split()[19])
    except (OSError, ValueError, IndexError):
        return 0


def _alive(pid: int, start: int) -> bool:
    """Whether the process that made a folder still runs (a reused PID does not count)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    now = _start_time(pid)
    return not (start and now and now != start)


def sweep_stale(tmp: Path | None = None) -> list[Path]:
    """Remove the transfer folders of simx-servers that are gone; returns them.

    Only folders that are ours are touched: named ``simx-<pid>-<start>-*``, owned by this user,
    real folders (not links) holding :data:`MARKER`, whose process is not alive (or whose PID
    now belongs to a process started at another time).
    """
    tmp = tmp or temp_root()
    removed = []
    try:
        entries = list(os.scandir(tmp))
    except OSError:
        return removed
    for entry in entries:
        m = _OURS.fullmatch(entry.name)
        try:
            if (not m or not entry.is_dir(follow_symlinks=False)
                    or entry.stat(follow_symlinks=False).st_uid != os.getuid()
                    or not os.path.isfile(os.path.join(entry.path, MARKER))):
                continue
        except OSError:
            continue
        if _alive(int(m.group(1)), int(m.group(2))):
            continue
        shutil.rmtree(entry.path, ignore_errors=True)
        removed.append(Path(entry.path))
        log.info("swept stale transfer folder %s", entry.path)
    return removed


def make_transfer_folder() -> Path:
    """A fresh transfer folder for this process (0700, marked); stale ones are swept first."""
    sweep_stale()
    pid = os.getpid()
    folder = Path(tempfile.mkdtemp(prefix=f"{PREFIX}{pid}-{_start_time(pid)}-")).resolve()
    os.chmod(folder, 0o700)  # mkdtemp makes it so; say it
    (folder / MARKER).write_text(f"transfer folder of simx-server process {pid}\n")
    return folder


def is_transferred(path: Path) -> bool:
    """Whether ``path`` lies in a transfer folder of any simx-server (or is one): a folder named
    as a server names its own (``simx-<pid>-<start>-*``) directly in the temporary folder, or any
    folder holding :data:`MARKER`. Other ``simx-*`` folders (a checkout cloned to
    ``/tmp/simx-demo``, a ``--scene-path`` folder) are not."""
    path = Path(os.path.realpath(path))
    tmp = temp_root()
    for folder in (path, *path.parents):
        if folder.parent == tmp and _OURS.fullmatch(folder.name):
            return True
        if (folder / MARKER).is_file():
            return True
    return False


def transfer_folders(*extra: Path) -> list[Path]:
    """Every transfer folder there is now (for ``Scripts(untrusted=...)``), plus ``extra``."""
    tmp = temp_root()
    try:
        found = [tmp / e.name for e in os.scandir(tmp) if _OURS.fullmatch(e.name)]
    except OSError:
        found = []
    return [*found, *(Path(p) for p in extra)]


def inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


# ----------------------------------------------------------------- measuring files
def _refuse(what: str, detail: str) -> RemoteError:
    return RemoteError(f"{what} refused: {detail}")


def _over(what: str, count: float, bound_name: str) -> None:
    bound = getattr(limits, bound_name)
    if count > bound:
        raise _refuse(what, f"{count:,.0f} {_UNITS.get(bound_name, '')}, more than {bound_name} = {bound:,}")


_UNITS = {"MAX_SCENE_BODIES": "bodies", "MAX_SCENE_ELEMENTS": "elements", "MAX_TEXTURE_PIXELS": "texture pixels",
          "MAX_SCENE_TEXTURE_PIXELS": "texture pixels in all", "MAX_HFIELD_CELLS": "height-field cells",
          "MAX_SCENE_HFIELD_CELLS": "height-field cells in all", "MAX_SCENE_MESH_VERTICES": "mesh vertices in all",
          "MAX_MESH_VERTICES": "mesh vertices", "MAX_MESH_FACES": "mesh faces",
          "MAX_SCENE_MESH_FACES": "mesh faces in all", "MAX_SCENE_FILE_BYTES": "bytes", "MAX_ASSET_FILE_BYTES": "bytes",
          "MAX_XML_DEPTH": "levels of nesting", "MAX_ARENA_BYTES": "bytes of arena",
          "MAX_SIZE_ENTRIES": "entries", "MAX_SOLVER_ITERATIONS": "iterations", "MAX_VISUAL_SIZE": "pixels",
          "MAX_VISUAL_DETAIL": "", "MAX_RESOLUTION": "pixels"}


def _number(el: ET.Element, attr: str, what: str, default: str = "1") -> list[int]:
    text = el.get(attr, default)
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        raise _refuse(what, f"<{el.tag} {attr}={quote(text)}> is not a list of numbers") from None
    if not all(math.isfinite(v) and v >= 0 for v in values):
        raise _refuse(what, f"<{el.tag} {attr}={quote(text)}> must be finite and not negative")
    return [int(v) for v in values] or [0]


def _relative(base: str, name: str) -> str | None:
    """``name`` (a path in a file) relative to the transfer folder, or None if it leaves it
    (as written, or with surrounding white space stripped, whichever way MuJoCo reads it)."""
    if not name or not name.strip() or "\x00" in name:
        return None
    out = None
    for n in (name.strip(), name):
        joined = posixpath.normpath(posixpath.join(base, n))
        if posixpath.isabs(n) or posixpath.isabs(joined) or joined == ".." or joined.startswith("../"):
            return None
        out = joined
    return out


def _local_names(tree: ET.Element) -> ET.Element:
    """Drop XML namespaces from tags and attribute names: MuJoCo's parser ignores them, so
    ``<include xmlns="x" file=...>`` is an include all the same."""
    for el in tree.iter():
        if isinstance(el.tag, str) and "}" in el.tag:
            el.tag = el.tag.rsplit("}", 1)[1]
        if any("}" in k for k in el.attrib):
            el.attrib = {k.rsplit("}", 1)[-1]: v for k, v in el.attrib.items()}
    return tree


class _Walk:
    """One client-sent MJCF file and its includes, measured before MuJoCo parses them."""

    def __init__(self, root: Path, main: Path, what: str):
        self.root, self.what = root, what
        self.base = posixpath.relpath(str(main.parent), str(root))  # main file's folder in root
        self.bodies = self.elements = 0
        self.files: list[str] = []  # asset file names as written
        self.dirs: set[str] = {""}
        self.trees: dict[str, ET.Element] = {}  # each file read and parsed once
        self.bytes = 0  # of XML read, includes with it

    def outside(self, name: str) -> RemoteError:
        # One message whether or not such a server file exists: nothing is looked up.
        return _refuse(self.what, f"it names the file {quote(name)}; a scene or model sent by a client "
                                  "may only use files sent with it (simxTransferFile), by relative paths "
                                  "inside the transfer folder")

    def read(self, rel: str) -> ET.Element:
        if rel in self.trees:
            return self.trees[rel]
        path = self.root / rel
        try:
            size = path.stat().st_size
            self.bytes += size
            _over(f"{self.what} ({quote(rel)} and the files before it)", self.bytes, "MAX_SCENE_FILE_BYTES")
            text = path.read_bytes()
        except OSError:
            raise _refuse(self.what, f"no transferred file {quote(rel)}") from None
        try:  # checked as text: the bytes of UTF-16 or UTF-32 XML hide a DOCTYPE from a byte search
            decoded = text.decode("utf-8")
        except UnicodeDecodeError:
            decoded = None
        if decoded is None or "\x00" in decoded:
            raise _refuse(self.what, f"{quote(rel)} is not UTF-8 text (UTF-16 or UTF-32?): MuJoCo reads UTF-8 XML only")
        if re.search(r"<!(DOCTYPE|ENTITY)", decoded, re.IGNORECASE):
            raise _refuse(self.what, f"{quote(rel)} declares a DOCTYPE or entities")
        try:
            tree = self.trees[rel] = _local_names(ET.fromstring(text))
        except (ET.ParseError, LookupError, ValueError) as exc:  # LookupError: unknown encoding
            raise _refuse(self.what, f"{quote(rel)} is not well-formed XML: {quote(str(exc))}") from None
        return tree

    def file(self, rel: str, depth: int) -> None:
        if depth > limits.MAX_XML_DEPTH:
            _over(self.what, depth, "MAX_XML_DEPTH")
        self.visit(self.read(rel), 1, depth, posixpath.dirname(rel))

    def visit(self, el: ET.Element, mult: int, depth: int, here: str) -> None:
        if depth > limits.MAX_XML_DEPTH:
            _over(self.what, depth, "MAX_XML_DEPTH")
        tag = el.tag if isinstance(el.tag, str) else ""
        if tag in _REFUSED:
            raise _refuse(self.what, f"{_REFUSED[tag]} (<{tag}>) are not allowed in files sent by clients")
        for attr in _DIR_ATTRS:
            if attr in el.attrib:
                if _relative(self.base, el.get(attr)) is None:
                    raise self.outside(el.get(attr))
                self.dirs.add(el.get(attr))
        for attr in _FILE_ATTRS:
            name = el.get(attr)
            if name is None:
                continue
            if _relative(self.base, name) is None or (tag == "include" and _relative(here, name) is None):
                raise self.outside(name)
            if tag != "include":
                self.files.append(name)
        self.elements += mult  # <include>s too: a file that includes itself twice ends here
        if tag == "include":
            _over(self.what, self.elements, "MAX_SCENE_ELEMENTS")
            self.file(_relative(self.base, el.get("file", "")), depth + 1)
            return
        if tag == "replicate":
            mult *= _number(el, "count", self.what)[0]
        elif tag in ("composite", "flexcomp"):
            n = math.prod(_number(el, "count", self.what, "1 1 1"))
            self.bodies += mult * n
            self.elements += mult * n * 4  # joints, geoms, sites... per point
            if tag == "flexcomp" and el.get("file"):
                self.flex_file(el.get("file"))
        elif tag == "hfield":  # MuJoCo allocates the cells while parsing
            rows, cols = _number(el, "nrow", self.what, "0")[0], _number(el, "ncol", self.what, "0")[0]
            _over(f"{self.what} (hfield {quote(el.get('name', ''))})", rows * cols, "MAX_HFIELD_CELLS")
        elif tag == "texture" and el.get("builtin", "none") != "none":
            w, h = _number(el, "width", self.what, "0")[0], _number(el, "height", self.what, "0")[0]
            px = w * h if el.get("type", "cube") == "2d" else 6 * w * w
            _over(f"{self.what} (texture {quote(el.get('name', ''))})", px, "MAX_TEXTURE_PIXELS")
        elif tag == "mesh" and el.get("builtin"):
            for v in _number(el, "params", self.what, "0"):
                _over(f"{self.what} (mesh {quote(el.get('name', ''))})", v, "MAX_VISUAL_DETAIL")
        if tag in ("body", "link"):  # link: a URDF's (simx_server.sim.urdf keeps every link a body)
            self.bodies += mult
        _over(self.what, self.bodies, "MAX_SCENE_BODIES")
        _over(self.what, self.elements, "MAX_SCENE_ELEMENTS")
        for child in el:
            self.visit(child, mult, depth + 1, here)

    def flex_file(self, name: str) -> None:
        """A <flexcomp file> is read while parsing: measure it now."""
        for d in self.dirs:
            rel = _relative(self.base, posixpath.join(d, name))
            path = self.root / rel if rel else None
            try:
                if not (path and path.is_file()):
                    continue
                _over(f"{self.what} ({quote(name)})", path.stat().st_size, "MAX_ASSET_FILE_BYTES")
                data = path.read_bytes()
            except OSError:
                raise _refuse(self.what, f"cannot read {quote(name)}") from None
            _over(f"{self.what} ({quote(name)})", mesh_vertices(data, name), "MAX_MESH_VERTICES")

    def check_combinations(self) -> None:
        """Every asset file under every folder the scene sets must stay in the transfer folder."""
        for name in self.files:
            for d in self.dirs:
                if _relative(self.base, posixpath.join(d, name) if d else name) is None:
                    raise self.outside(name)


def check_client_file(file: Path, root: Path, what: str) -> None:
    """Measure a client-sent MJCF file (in transfer folder ``root``) before MuJoCo parses it.

    Raises:
        RemoteError: a file named outside ``root`` (absolute, or climbing out with ``..``), an
            ``<include>`` missing or too big, a DOCTYPE, refused elements (``<model>``, plugins),
            or more bodies/elements than the bounds once ``<replicate>``, ``<composite>`` and
            ``<flexcomp>`` are multiplied out.
    """
    walk = _Walk(root, file, what)
    walk.file(posixpath.relpath(str(file), str(root)), 0)
    walk.check_combinations()


def _asset_path(spec: mujoco.MjSpec, el, folder_attr: str, name: str) -> str:
    if spec.strippath:
        name = posixpath.basename(name)
    compiler = getattr(el, "compiler", None)
    folder = getattr(compiler, folder_attr, "") if compiler is not None else ""
    folder = folder or getattr(spec, folder_attr)
    return posixpath.join(spec.modelfiledir or "", folder or "", name)


def check_spec(spec: mujoco.MjSpec, what: str, root: Path | None = None, dt: float | None = None) -> None:
    """Measure a parsed client-sent ``MjSpec`` before it is compiled.

    Args:
        spec: the parsed scene or model (files not read yet).
        what: names it in errors (``"scene 'x.xml'"``).
        root: its transfer folder: every asset file must resolve inside it (None: not checked).
        dt: the server's simulation step in s: the model's timestep may not need more than
            ``MAX_SUBSTEPS`` substeps per step (None: not checked, for models).

    Raises:
        RemoteError: naming the first bound passed.
    """
    counts = element_counts(spec)
    _over(what, counts[0], "MAX_SCENE_BODIES")
    _over(what, counts[1], "MAX_SCENE_ELEMENTS")
    total = verts_total = cells_total = faces_total = 0
    files = [(t, "texturedir") for t in spec.textures] + [(e, "meshdir") for e in
                                                        (*spec.meshes, *spec.hfields, *spec.skins)]
    for el, folder_attr in files:
        kind = type(el).__name__[3:].lower()  # MjsTexture -> texture
        label = f"{what} ({kind} {quote(el.name or el.file)})"
        data = b""
        names = [n for n in ([el.file] + list(getattr(el, "cubefiles", []) or [])) if n]
        for name in names:
            if root is None:
                break
            path = Path(os.path.realpath(_asset_path(spec, el, folder_attr, name)))
            if posixpath.isabs(name) or not inside(path, root):
                raise _refuse(what, f"it names the file {quote(name)}; a scene or model sent by a client may "
                                    "only use files sent with it (simxTransferFile), by relative paths inside "
                                    "the transfer folder")
            try:
                if path.is_file():
                    _over(label, path.stat().st_size, "MAX_ASSET_FILE_BYTES")
                    data = path.read_bytes()  # at most MAX_ASSET_FILE_BYTES
            except OSError:  # its text would name the transfer folder; MuJoCo reports it below
                data = b""
        if isinstance(el, mujoco.MjsTexture):
            if el.builtin != mujoco.mjtBuiltin.mjBUILTIN_NONE and not names:
                px = el.width * el.height if el.type == mujoco.mjtTexture.mjTEXTURE_2D else 6 * el.width ** 2
            else:
                px = (_png_pixels(data) or 0) * max(1, len(names))
            _over(label, px, "MAX_TEXTURE_PIXELS")
            total += px
        elif isinstance(el, mujoco.MjsHField):
            cells = max(el.nrow * el.ncol, _png_pixels(data) or 0, len(data) // 4)
            _over(label, cells, "MAX_HFIELD_CELLS")
            _over(label, len(el.userdata), "MAX_HFIELD_CELLS")  # converted only when nrow x ncol passed
            cells_total += cells
        elif isinstance(el, mujoco.MjsMesh):
            verts = len(el.uservert) // 3 + (mesh_vertices(data, el.file) if data else 0)
            _over(label, verts, "MAX_MESH_VERTICES")
            verts_total += verts
            faces = len(el.userface) // 3 + (mesh_faces(data, el.file) if data else 0)
            _over(label, faces, "MAX_MESH_FACES")
            faces_total += faces
        elif isinstance(el, mujoco.MjsSkin):  # a .skn file starts with its vertex count
            verts = len(el.vert) // 3 + (max(struct.unpack("<i", data[:4])[0], 0) if len(data) >= 4 else 0)
            _over(label, verts, "MAX_MESH_VERTICES")
            verts_total += verts
    for flex in spec.flexes:
        _over(f"{what} (flex {quote(flex.name)})", len(flex.vert) // 3, "MAX_MESH_VERTICES")
        verts_total += len(flex.vert) // 3
    _over(what, total, "MAX_SCENE_TEXTURE_PIXELS")
    _over(what, verts_total, "MAX_SCENE_MESH_VERTICES")
    _over(what, faces_total, "MAX_SCENE_MESH_FACES")
    _over(what, cells_total, "MAX_SCENE_HFIELD_CELLS")
    for n in spec.numerics:
        _over(f"{what} (numeric {quote(n.name)})", max(n.size, len(n.data)), "MAX_SIZE_ENTRIES")
    _over(f"{what} (<size memory>)", spec.memory, "MAX_ARENA_BYTES")
    for f in _SIZE_FIELDS:
        _over(f"{what} (<size {f}>)", getattr(spec, f), "MAX_SIZE_ENTRIES")
    for cam in spec.cameras:  # a vision sensor's offscreen buffer has the camera's resolution
        _over(f"{what} (camera {quote(cam.name)} resolution)", max(cam.resolution), "MAX_RESOLUTION")
    for f in _ITERATIONS:
        _over(f"{what} (<option {f}>)", getattr(spec.option, f), "MAX_SOLVER_ITERATIONS")
    g, q = spec.visual.global_, spec.visual.quality
    for label, v in (("offwidth", g.offwidth), ("offheight", g.offheight), ("shadowsize", q.shadowsize)):
        _over(f"{what} (<visual {label}>)", v, "MAX_VISUAL_SIZE")
    for label, v in (("offsamples", q.offsamples), ("numslices", q.numslices), ("numstacks", q.numstacks),
                     ("numquads", q.numquads)):
        _over(f"{what} (<visual {label}>)", v, "MAX_VISUAL_DETAIL")
    if dt is not None:
        ts = spec.option.timestep
        if not (ts > 0 and dt / ts <= limits.MAX_SUBSTEPS):
            raise _refuse(what, f"its timestep {ts:g} s would need more than MAX_SUBSTEPS = "
                                f"{limits.MAX_SUBSTEPS:,} substeps per simulation step of {dt:g} s")


def element_counts(spec: mujoco.MjSpec) -> tuple[int, int]:
    """``(bodies and flexes, elements of every kind)`` of a spec (the world body not counted)."""
    bodies = len(spec.bodies) - 1 + len(spec.flexes)
    return bodies, sum(len(getattr(spec, name)) for name in _LISTS) - 1


def check_growth(before: tuple[int, int], spec: mujoco.MjSpec) -> None:
    """An edit by a client may not grow a scene past ``MAX_SCENE_BODIES``/``MAX_SCENE_ELEMENTS``
    (a scene of the operator's that is bigger already may still shrink)."""
    after = element_counts(spec)
    for i, name in enumerate(("MAX_SCENE_BODIES", "MAX_SCENE_ELEMENTS")):
        bound = getattr(limits, name)
        if after[i] > bound and after[i] > before[i]:
            raise RemoteError(f"edit refused: the scene would hold {after[i]:,} {_UNITS[name]}, more than "
                              f"{name} = {bound:,}")


def check_mesh_growth(model: mujoco.MjModel, live: mujoco.MjSpec, spec: mujoco.MjSpec) -> None:
    """An edit may not add meshes past ``MAX_SCENE_MESH_VERTICES``/``MAX_SCENE_MESH_FACES`` in the
    scene (``model``, compiled from ``live``): a client loading one in-bounds model again and again
    grew a scene's compile on the simulation thread to 5 s and the server by 1.4 GB in five loads."""
    names = {m.name for m in live.meshes}
    added = [spec_mesh_counts(m, spec.assets) for m in spec.meshes if m.name not in names]
    check_mesh_totals((model.nmeshvert, model.nmeshface), (sum(a[0] for a in added), sum(a[1] for a in added)),
                      "edit refused: the scene")


def check_mesh_totals(now: tuple[int, int], grown: tuple[int, int], what: str) -> None:
    """Raises RemoteError when ``grown`` (vertices, faces) more would put a scene holding ``now``
    past ``MAX_SCENE_MESH_VERTICES``/``MAX_SCENE_MESH_FACES`` (a scene that holds more may shrink)."""
    for name, n, more in (("MAX_SCENE_MESH_VERTICES", *(v[0] for v in (now, grown))),
                          ("MAX_SCENE_MESH_FACES", *(v[1] for v in (now, grown)))):
        if more and n + more > getattr(limits, name):
            raise RemoteError(f"{what} would hold {n + more:,} {_UNITS[name][:-7]}, more than "
                              f"{name} = {getattr(limits, name):,}")


def folder_usage(folder: Path, skip: Iterable[Path] = ()) -> tuple[int, int]:
    """``(entries, bytes)`` in a transfer folder (its own bookkeeping files not counted)."""
    skip = set(skip)
    entries = size = 0
    for dirpath, dirnames, filenames in os.walk(folder):
        dirnames[:] = [d for d in dirnames if not d.startswith(".simx")]
        entries += len(dirnames)
        for f in filenames:
            p = Path(dirpath) / f
            if p in skip or f.startswith(".simx"):
                continue
            entries += 1
            try:
                size += p.lstat().st_size
            except OSError:
                pass
    return entries, size
