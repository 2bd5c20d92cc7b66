"""Shapes made by scripts: ``sim.importShape`` (an .obj/.stl mesh through ``MjSpec``),
and ``sim.setShapeColor`` (``sim.setObjectName``: :mod:`simx_server.api.sim.objects`).

The imported shape is a new body of the world (V-REP's shape) holding one mesh geom; the
scene is edited through :class:`simx_server.scene.editor.Editor` (all or nothing, handles kept, the
simulation goes on). The ``sim`` functions here reach the scene's editor through the caller's
context (:meth:`CallContext.simulation <simx_server.api.context.CallContext.simulation>`), as the other
scene-editing calls do.
"""

from __future__ import annotations

import logging
import math
import weakref
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_wire.protocol import ArgumentError, RemoteError, UnsupportedError
from simx_server.base import limits as L
from simx_server.base import scene_guard as guard
from simx_server.base.arguments import quote
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text, as_vector as _vector
from simx_server.sim import friction, mechanisms, shape_looks
from simx_server.sim.spec_tools import _names, set_mesh_data, vrep_suffix
from simx_server.sim.state import SimulationView
from simx_server.sim.world import SHAPE, World

log = logging.getLogger("simx.shapes")

#: Handles of the shapes imported into each world (kept in place when the simulation stops).
_IMPORTED: "weakref.WeakKeyDictionary[World, set[int]]" = weakref.WeakKeyDictionary()
#: V-REP's importShape file formats MuJoCo reads: 0 OBJ, 4 binary STL (not 1 DXF, 2 3DS, 3 ASCII STL).
_FORMATS = {0: (".obj",), 4: (".stl",)}
#: Contact of imported shapes: elliptic-cone friction with torsion (condim 4), grippable.
_FRICTION = [1.0, 0.02, 0.001]



def obj_parts(data: bytes) -> list[bytes]:
    """An OBJ file's objects and groups (``o`` / ``g`` lines) as OBJ files of their own, each
    with every vertex line of the file and only its own faces. MuJoCo's reader takes the faces of
    a file's first object alone, where CoppeliaSim's importers give one mesh per object
    (RLBench's procedural objects: eight convex pieces in one ``_coll.obj``, of which MuJoCo
    read the first). A file of one part is returned as it is.

    Args:
        data: the OBJ file's bytes.

    Returns:
        One OBJ file per part with faces, in the file's order.
    """
    common: list[bytes] = []
    parts: list[list[bytes]] = [[]]
    for line in data.splitlines():
        word = line.split(None, 1)[0] if line.strip() else b""
        if word in (b"o", b"g"):
            if parts[-1]:
                parts.append([])
        elif word == b"f":
            parts[-1].append(line)
        else:
            common.append(line)
    parts = [p for p in parts if p]
    if len(parts) <= 1:
        return [data]
    return [b"\n".join(common + p) + b"\n" for p in parts]


def file_parts(data: bytes, suffix: str) -> list[bytes]:
    """The parts :func:`read_mesh` reads of a mesh file: an OBJ file's :func:`obj_parts`, or the
    file itself (``suffix``: ``.obj`` or ``.stl``)."""
    return obj_parts(data) if suffix == ".obj" else [data]


def read_mesh(pieces: list[bytes], suffix: str, scale: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """The meshes of a mesh file's parts (:func:`file_parts`) as MuJoCo reads them, one per part:
    vertices (n, 3) in the file's frame, times ``scale`` (m), and triangles (t, 3) of indices
    into them; of several parts, each with only the vertices its faces use.

    Args:
        pieces: the file's parts.
        suffix: ``.obj`` or ``.stl``.
        scale: factor on the vertices.

    Returns:
        ``[(vertices, faces), ...]``.

    Raises:
        UnsupportedError: MuJoCo cannot read a part.
    """
    out = []
    for piece in pieces:
        spec = mujoco.MjSpec()
        spec.assets = {"m" + suffix: piece}
        spec.add_mesh(name="m", file="m" + suffix).scale = [scale] * 3
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname="m", contype=0, conaffinity=0)
        try:
            m = spec.compile()
        except ValueError as exc:
            raise UnsupportedError(f"MuJoCo cannot read this mesh: {exc}") from None
        rot = np.empty(9)
        mujoco.mju_quat2Mat(rot, m.geom_quat[0])  # MuJoCo centres meshes: back to the file's frame
        v = m.mesh_vert[:m.mesh_vertnum[0]] @ rot.reshape(3, 3).T + m.geom_pos[0]
        f = np.asarray(m.mesh_face[:m.mesh_facenum[0]], dtype=np.int64)
        if len(pieces) > 1:  # every part holds the file's vertices: keep those its faces use
            used, f = np.unique(f, return_inverse=True)
            v, f = v[used], f.reshape(-1, 3)
        out.append((v, f))
    return out


def imported_poses(world: World) -> list[tuple[int, Any, Any]]:
    """``(handle, position, rotation)`` of the world's imported shapes, to :func:`restore_poses`
    after the simulation's reset: V-REP leaves objects made during a simulation where they are
    when it stops (their initial pose in the model is the origin, where they were imported)."""
    handles = _IMPORTED.get(world, ())
    return [(h, *world.frame(h)) for h in sorted(handles) if h in world.objects]


def restore_poses(world: World, poses: list[tuple[int, Any, Any]]) -> None:
    """Put imported shapes back where :func:`imported_poses` found them (at rest)."""
    for h, p, r in poses:
        if h in world.objects:
            try:
                world.set_pose(h, -1, position=p.tolist(), rotation=r)
            except Exception as exc:  # a pose out of bounds (after a blow-up): the origin then
                log.warning("imported shape %r left at its initial pose: %s", world.get(h).name, exc)



def _readable(sim: SimulationView, path: str, script: Any = None, what: str = "importShape") -> Path:
    """``path`` if the caller may read it (:meth:`ClientFiles.source
    <simx_server.scene.client_files.ClientFiles.source>`): the operator's scene folder and
    ``--scene-path`` folders, or the calling client's own folder (files it sent with
    simxTransferFile or wrote); relative names: the client's own file, else from the scene's
    folder. A scene's script may pass a client's path here (VPG's importShape does), so anything
    else is refused, with the same words whether or not such a file exists (docs/SECURITY.md).

    Args:
        sim: the simulation.
        path: the file name as given.
        script: the calling script (its file says whose scene it is), None for a ZMQ door's clients.
        what: the call, for the error.

    Raises:
        ArgumentError: outside those folders.
    """
    files = sim.editor.files
    key = files.writer(getattr(script, "path", None) if script is not None else None)
    try:
        return files.source(path, key, what, sim.world.scene_path.parent)
    except RemoteError as exc:
        raise ArgumentError(str(exc)) from None


def import_shape(sim: SimulationView, fileformat: int, path: str, scaling: float, script: Any = None) -> int:
    """Add the mesh of file ``path`` (.obj or binary .stl, at most limits.MAX_IMPORT_BYTES) as a new
    dynamic, respondable shape at the world origin, scaled by ``scaling``; returns its handle.

    Raises ArgumentError for a bad format, extension, scale or a file that cannot be read,
    UnsupportedError when MuJoCo cannot compile the mesh (the scene is then unchanged)."""
    suffixes = _FORMATS.get(fileformat)
    if suffixes is None:
        raise ArgumentError(f"importShape: file format {quote(fileformat)} is not one simx reads "
                            "(0 OBJ, 4 binary STL; MuJoCo reads no DXF, 3DS nor ASCII STL)")
    file = _readable(sim, path, script)
    if file.suffix.lower() not in suffixes:
        raise ArgumentError(f"importShape: {quote(path)} is not a {'/'.join(suffixes)} file (format {fileformat})")
    if not math.isfinite(scaling) or not 0 < scaling <= 1000:
        raise ArgumentError(f"importShape: scaling factor must be in (0, 1000], got {quote(scaling)}")
    try:
        if not file.is_file():
            raise ArgumentError(f"importShape: no file {quote(path)}")
        size = file.stat().st_size
        if size > L.MAX_IMPORT_BYTES:
            raise ArgumentError(f"importShape: {quote(path)} has {size} bytes, more than "
                                f"{L.MAX_IMPORT_BYTES} (simx_server.base.limits.MAX_IMPORT_BYTES)")
        data = file.read_bytes()
    except OSError as exc:
        raise ArgumentError(f"importShape: cannot read {quote(path)}: {quote(exc.strerror)}") from None
    vertices = guard.mesh_vertices(data, file.name)  # as MuJoCo's reader counts them, before it parses
    if vertices > L.MAX_MESH_VERTICES:
        raise ArgumentError(f"importShape: {quote(path)} has {vertices:,} vertices, more than "
                            f"{L.MAX_MESH_VERTICES:,} (simx_server.base.limits.MAX_MESH_VERTICES)")
    editor = sim.editor
    editor._asset_counter[0] += 1
    key = f"simx-asset-{editor._asset_counter[0]}-import{file.suffix.lower()}"
    # an OBJ file of several objects: one mesh each, as CoppeliaSim's importer makes them
    pieces = file_parts(data, file.suffix.lower())
    parts = read_mesh(pieces, ".obj", scaling) if len(pieces) > 1 else None

    def change(spec: mujoco.MjSpec):
        suffix = vrep_suffix({"Shape", "Shape_mesh", "Shape_geom"}, _names(spec))
        name = f"Shape{suffix}"
        meshes = []
        if parts is None:
            spec.assets = {**(spec.assets or {}), key: data}
            mesh = spec.add_mesh(name=f"Shape_mesh{suffix}", file=key)
            mesh.scale = [scaling] * 3
            meshes.append(mesh)
        for k, (v, f) in enumerate(parts or ()):
            mesh = spec.add_mesh(name=f"Shape_mesh{suffix}" + (f"_{k}" if k else ""))
            set_mesh_data(spec, mesh, v, f)
            meshes.append(mesh)
        body = spec.worldbody.add_body(name=name)
        body.add_freejoint()
        for k, mesh in enumerate(meshes):
            geom = body.add_geom(name=f"Shape_geom{suffix}" if k == 0 else "", type=mujoco.mjtGeom.mjGEOM_MESH,
                                 meshname=mesh.name, condim=4, friction=_FRICTION, rgba=[0.8, 0.8, 0.8, 1.0])
            mechanisms.rigid_contact(geom, spec.option.timestep, static=False)  # V-REP's, a dynamic shape's
            friction.new_shape(spec, geom)  # CoppeliaSim's default material in a V-REP scene
        return lambda: sim.world.resolve(name).handle

    handle = editor._edit(change)
    _IMPORTED.setdefault(sim.world, set()).add(handle)
    log.info("imported shape %r (handle %d) from %s", sim.world.get(handle).name, handle, file.name)
    return handle


@sim_function("importShape")
def importShape(ctx: CallContext, fileformat: Any, pathAndFilename: Any, options: Any = 0,  # noqa: N802, N803
                identicalVerticeTolerance: Any = 0.0, scalingFactor: Any = 1.0) -> int:  # noqa: N803
    """``sim.importShape(fileformat, pathAndFilename, options, identicalVerticeTolerance,
    scalingFactor)``: add a mesh file as a new shape at the world origin; returns its handle.

    ``fileformat``: 0 OBJ, 4 binary STL (V-REP's codes; 1 DXF, 2 3DS and 3 ASCII STL are
    refused: MuJoCo reads none of them).
    The path is read by the server (the scene's script decides what it imports). ``options``
    and ``identicalVerticeTolerance`` are accepted and ignored (MuJoCo merges nothing);
    ``scalingFactor`` (0 or absent: 1) scales the mesh. Unlike V-REP, whose imported shapes are
    static until made dynamic, the shape is dynamic and respondable (a free body: what programs
    that import objects then ask for). Its name is ``Shape`` (``Shape#0``... when taken):
    rename it with ``sim.setObjectName``. Raises ArgumentError (bad argument, unreadable or too
    large file) or UnsupportedError (MuJoCo cannot read the mesh); the scene is then unchanged.
    """
    fmt = _int(fileformat, "fileformat")
    path = _text(pathAndFilename, "pathAndFilename")
    _int(options, "options")
    _num(identicalVerticeTolerance, "identicalVerticeTolerance")
    scale = _num(scalingFactor, "scalingFactor") if scalingFactor is not None else 0.0
    return import_shape(ctx.simulation("importShape"), fmt, path, scale or 1.0, ctx.script)


#: The prefix V-REP 3.1.3's compatibility helper puts before a shape handle (``colorCorrectionFunction``).
_BACK1 = "@backCompatibility1:"


@sim_function("setShapeColor")
def setShapeColor(ctx: CallContext, shapeHandle: Any, colorName: Any, colorComponent: Any,  # noqa: N802, N803
                  rgbData: Any) -> int:  # noqa: N803
    """``sim.setShapeColor(shapeHandle, colorName, colorComponent, rgbData)``: colour of a
    shape's geoms (those named ``colorName``, every one for nil or ``""``).

    ``colorComponent`` 0 (``sim.colorcomponent_ambient_diffuse``) or 1 (diffuse) with
    ``rgbData`` = {r, g, b} in [0, 1] (the geom's material, if any, is dropped so that the
    colour shows; its specular, shininess and emission stay the geom's); 2
    (``sim.colorcomponent_specular``) and 3 (``_emission``): the geom's specular and emission
    colours, the others left as they are (``CColorObject::setColor``; drawn by the vision
    sensors as :mod:`simx_server.sim.shape_looks` says); 4 (``sim.colorcomponent_transparency``)
    with {t}, the opacity lost, as V-REP's transparency (alpha = 1 - t). Components outside
    [0, 1] (old scripts pass 0-255) are kept by CoppeliaSim and clamped by OpenGL when drawn:
    simx clamps them. Component 5 (auxiliary: temperature colours) is accepted and not drawn. ``shapeHandle`` ``'@backCompatibility1:H'`` (the helper
    V-REP 3.1.3 added to old scripts) is shape H with the ambient-diffuse colour corrected as
    coppeliaSimLib ``_simSetShapeColor`` does ((c + 0.25) / 0.85, scaled to a largest of 1).
    Returns 1. The colour lasts until the scene is reloaded (stopping the simulation keeps it).
    Raises UnknownObjectError / ObjectTypeError (not a shape), ArgumentError (bad colour)."""
    world = ctx.world
    correct = isinstance(shapeHandle, (str, bytes)) and _text(shapeHandle, "shapeHandle").startswith(_BACK1)
    if correct:
        try:
            shapeHandle = int(_text(shapeHandle, "shapeHandle")[len(_BACK1):])
        except ValueError:
            raise ArgumentError(f"shapeHandle {quote(shapeHandle)}: no handle after {_BACK1}") from None
    obj = world.get(ctx.h(shapeHandle, "shapeHandle"), SHAPE)
    name = None if colorName is None else _text(colorName, "colorName")
    component = _int(colorComponent, "colorComponent")
    values = _vector(rgbData, 1 if component == 4 else 3, "rgbData") if component in (0, 1, 2, 3, 4) else None
    if values is not None and correct and component == 0 and not (name or "").startswith("@"):
        values = [(v + 0.25) / 0.85 for v in values]
        values = [v / max(values) for v in values] if max(values) > 1.0 else values
    if values is not None:
        values = [min(max(float(v), 0.0), 1.0) for v in values]
    m = world.model
    geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] == obj.mj_id
             and (not name or mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) == name)]
    if values is None:
        return 1
    if component in (shape_looks.SPECULAR, shape_looks.EMISSION):
        for g in geoms:
            shape_looks.set_component(m, int(g), component, values)
        world.version += 1  # cached renders are stale
        return 1
    try:
        spec = ctx.simulation("setShapeColor").editor._live_spec()
    except UnsupportedError:
        spec = None
    for g in geoms:
        rgba = m.geom_rgba[g].copy()
        mat = int(m.geom_matid[g])
        untextured = mat >= 0 and not np.any(np.asarray(m.mat_texid[mat]) >= 0)
        if component == 4 and untextured:  # the material's colour shows: taken over with the new alpha
            rgba = m.mat_rgba[mat].copy()
            m.geom_matid[g] = -1
        if component == 4:
            rgba[3] = 1.0 - values[0]
        else:
            rgba[:3] = values
            shape_looks.keep_material(m, int(g))  # its specular, shininess and emission stay
            m.geom_matid[g] = -1
        m.geom_rgba[g] = rgba
        # the spec too, so that the colour survives later edits of the scene
        gname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g)
        el = spec.geom(gname) if spec is not None and gname else None
        if el is not None:
            el.rgba = rgba
            if component != 4 or untextured:
                el.material = ""
    world.version += 1  # cached renders are stale
    return 1
