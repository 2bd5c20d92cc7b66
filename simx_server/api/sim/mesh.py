"""CoppeliaSim 4.x's mesh files and mesh shapes, and joint dependencies, through MjSpec
(``sim.importMesh``, ``sim.exportMesh``, ``sim.createShape``, ``sim.setJointDependency``).

``importMesh`` reads an OBJ or binary STL file (the confinement of ``sim.importShape``:
:func:`simx_server.api.sim.shape_import._readable`) through MuJoCo's mesh reader; ``exportMesh`` writes
OBJ text under ``saveScene``'s confinement; ``createShape`` adds a mesh body from vertices and
indices; ``setJointDependency`` adds an MJCF joint equality (``polycoef``).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from simx_server.api.context import CallContext
from simx_server.api.registry import sim_function
from simx_server.api.sim import file_writes, misc as _misc
from simx_wire.protocol import ArgumentError, UnsupportedError
from simx_server.base import limits as L
from simx_server.api.sim import shape_import as shapes
from simx_server.api.sim.meshops import box_axes
from simx_server.base.arguments import as_integer as _int, as_number as _num, as_text as _text
from simx_server.sim import friction, mechanisms
from simx_server.sim.objects import JOINT
from simx_server.sim.old_paths import matrix_to_quat
from simx_server.sim.spec_tools import _names, set_mesh_data, solid_mesh, vrep_suffix

_SUFFIX = {0: ".obj", 4: ".stl"}


def _array(values: Any, what: str, integer: bool) -> np.ndarray:
    """``values`` (numbers, as :func:`as_number` / :func:`as_integer` take them) as one array, at
    numpy's speed: a 200,000-triangle mesh's 1.8 million values one by one held the simulation
    thread a second or more; an element that is not a plain number is found and named by the
    checks one by one."""
    kinds = {int} if integer else {int, float}
    if isinstance(values, (list, tuple)) and set(map(type, values)) <= kinds:
        try:
            out = np.array(values, dtype=np.int64 if integer else float)
        except OverflowError:  # an integer past 64 bits: refused below, by the indices' range
            out = None
        if out is not None and (integer or np.isfinite(out).all()):
            return out
    return np.array([(_int if integer else _num)(x, f"{what}[i]") for x in values])


def _mesh(vertices: Any, indices: Any) -> tuple[np.ndarray, np.ndarray]:
    v = _array(vertices, "vertices", False).reshape(-1, 3) if len(vertices) % 3 == 0 else None
    f = _array(indices, "indices", True).reshape(-1, 3) if len(indices) % 3 == 0 else None
    if v is None or f is None or len(v) < 3 or len(f) < 1:
        raise ArgumentError("vertices (3 numbers each, at least 3) and indices (3 per triangle) must fit")
    if len(v) > L.MAX_MESH_VERTICES:
        raise ArgumentError(f"more than {L.MAX_MESH_VERTICES} vertices (limits.MAX_MESH_VERTICES)")
    if f.min() < 0 or f.max() >= len(v):
        raise ArgumentError("indices must name vertices")
    return v, f


# ``importMesh``, ``exportMesh``, ``createShape``, ``setJointDependency``.

@sim_function("importMesh")
def importMesh(ctx: CallContext, fileformat: Any, pathAndFilename: Any, options: Any = 0,  # noqa: N802, N803
               identicalVerticeTolerance: Any = 0.0, scalingFactor: Any = 1.0) -> tuple[list, list]:  # noqa: N803
    """``vertices, indices`` of an OBJ (0) or binary STL (4) file: one table of each per mesh
    (an OBJ file's objects and groups, as CoppeliaSim's importer gives them:
    :func:`~simx_server.api.sim.shape_import.obj_parts`), as MuJoCo reads them (vertices in m,
    scaled by ``scalingFactor``).

    ``sim.importMesh``.

    Args:
        fileformat: 0 (OBJ) or 4 (binary STL).
        pathAndFilename: a file the server may read.
        options: checked.
        identicalVerticeTolerance: ignored.
        scalingFactor: factor on the vertices.

    Returns:
        ``([vertices, ...], [indices, ...])``: per mesh, 3n floats (m) and 3t ints.

    Raises:
        UnsupportedError: another format, or no simulation behind the script.
        ArgumentError: no such file, or one MuJoCo cannot read.
        RemoteError: a file outside the folders the server reads.
    """
    fmt = _int(fileformat, "fileformat")
    if fmt not in _SUFFIX:
        raise UnsupportedError("importMesh formats: 0 OBJ, 4 binary STL (what MuJoCo reads)")
    sim = ctx.simulation("importMesh")
    file = shapes._readable(sim, _text(pathAndFilename, "pathAndFilename"), ctx.script, "importMesh")
    if file.suffix.lower() != _SUFFIX[fmt] or not file.is_file():
        raise ArgumentError(f"importMesh: no {_SUFFIX[fmt]} file {file.name!r}")
    if file.stat().st_size > L.MAX_IMPORT_BYTES:
        raise ArgumentError(f"importMesh: more than {L.MAX_IMPORT_BYTES} bytes")
    scale = _num(scalingFactor, "scalingFactor") or 1.0
    suffix = file.suffix.lower()
    meshes = shapes.read_mesh(shapes.file_parts(file.read_bytes(), suffix), suffix, scale)
    return [v.reshape(-1).tolist() for v, _ in meshes], [f.reshape(-1).astype(int).tolist() for _, f in meshes]


@sim_function("exportMesh")
def exportMesh(ctx: CallContext, fileformat: Any, pathAndFilename: Any, options: Any, scalingFactor: Any,  # noqa: N802, N803
               vertices: Any, indices: Any) -> None:
    """Write meshes (tables of vertex tables and index tables) as one OBJ file (format 0),
    where ``saveScene`` writes (a client: into its own folder, within its budget).

    ``sim.exportMesh``.

    Args:
        fileformat: 0 (OBJ).
        pathAndFilename: a file name (a client: relative, in its own folder).
        options: ignored.
        scalingFactor: factor on the vertices (0: 1).
        vertices: list of 3n-number tables, m.
        indices: list of 3t-integer tables.

    Raises:
        UnsupportedError: another format.
        ArgumentError: meshes that do not fit; a client's name outside its folder.
        RemoteError: the operator's file outside the scene folders; past the client's budget.
    """
    if _int(fileformat, "fileformat") != 0:
        raise UnsupportedError("exportMesh writes OBJ (format 0) only")
    name = _text(pathAndFilename, "pathAndFilename")
    file, key = _misc.target_file(ctx, name[:-4] + ".xml" if name.lower().endswith(".obj") else name + ".xml",
                                  "exportMesh")
    file = file.with_suffix(".obj")
    scale = _num(scalingFactor, "scalingFactor") or 1.0
    meshes = [_mesh(vs, fs) for vs, fs in zip(vertices, indices)]

    def text() -> bytes:  # OBJ's lines: on the files' thread for a ZMQ client (_misc.write_files)
        lines, base = [], 0
        for v, f in meshes:
            lines += [f"v {x * scale:.9g} {y * scale:.9g} {z * scale:.9g}" for x, y, z in v.tolist()]
            lines += [f"f {a + base + 1} {b + base + 1} {c + base + 1}" for a, b, c in f.tolist()]
            base += len(v)
        return ("\n".join(lines) + "\n").encode("utf-8")

    return file_writes.write_files(ctx, key, lambda: [(file, text(), name)])  # type: ignore[no-any-return]


@sim_function("createShape")
def createShape(ctx: CallContext, options: Any, shadingAngle: Any, vertices: Any, indices: Any, normals: Any = None,  # noqa: N802, N803
                textureCoordinates: Any = None, texture: Any = None, textureResolution: Any = None) -> int:  # noqa: N803
    """A static, non-respondable mesh shape from ``vertices`` (m, world) and ``indices``, its
    frame along the mesh's main axes (:func:`simx_server.api.sim.meshops.box_axes`: x the
    smallest extent, z the largest) at the centre of its box in those axes (CoppeliaSim's
    ``CShape::_acceptNewGeometry``), as CoppeliaSim's new shapes are (coppeliaSimLib 4.1 ``CShape``'s constructor:
    ``_shapeIsDynamicallyStatic`` true, ``_shapeIsDynamicallyRespondable`` false; PyRep's
    ``import_mesh`` and RLBench's procedural objects then set what they need); its handle. Made
    dynamic and respondable, MuJoCo uses the mesh's convex hull for contacts. Textures: refused. A
    flat mesh (one triangle and up: CoppeliaSim's ``simCreateMeshShape_internal`` takes 3
    vertices, MuJoCo needs a volume) gets a back face 0.1 mm behind it
    (:func:`simx_server.sim.spec_tools.solid_mesh`), its mass and inertia those of a shell, as
    the ``.ttt`` converter's flat meshes; ``sim.getShapeMesh`` then reads both faces.

    ``sim.createShape`` (and 4.1's ``simCreateMeshShape``).

    Args:
        options: checked.
        shadingAngle: ignored (rad).
        vertices: 3n numbers, m.
        indices: 3t integers.
        normals: ignored.
        textureCoordinates: ignored.
        texture: must be empty.
        textureResolution: ignored.

    Returns:
        The shape's handle.

    Raises:
        UnsupportedError: a texture, or no simulation behind the script.
        ArgumentError: a bad mesh (points on a line included).
    """
    if texture:
        raise UnsupportedError("createShape with a texture: no run-time textures in simx")
    v, f = _mesh(vertices, indices)
    solid = solid_mesh(v, f)
    if solid is None:
        raise ArgumentError("createShape: the vertices lie on a line")
    flat = len(solid[0]) != len(v)
    # the shape's frame along the mesh's main axes at their box's centre, as CoppeliaSim's
    # CShape::_acceptNewGeometry (alignAndCenterGeometryAndGetTransformation) puts it
    axes = box_axes(v)
    local = v @ axes
    centre = axes @ ((local.min(axis=0) + local.max(axis=0)) / 2)
    v, f = (solid[0] - centre) @ axes, solid[1]
    quat = matrix_to_quat(axes)
    sim = ctx.simulation("createShape")

    def change(spec: mujoco.MjSpec):
        suffix = vrep_suffix({"Shape", "Shape_mesh"}, _names(spec) | set(sim.world.by_name))
        mesh = spec.add_mesh(name=f"Shape_mesh{suffix}")
        set_mesh_data(spec, mesh, v, f)  # a file of MuJoCo's cache: later compiles reuse it
        if flat:
            mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        body = spec.worldbody.add_body(name=f"Shape{suffix}", pos=centre.tolist(), quat=quat.tolist())
        geom = body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=mesh.name, rgba=[0.8, 0.8, 0.8, 1],
                             contype=0, conaffinity=0)
        mechanisms.rigid_contact(geom, spec.option.timestep)  # static: V-REP's rigid contact once respondable
        friction.new_shape(spec, geom)  # CoppeliaSim's default material in a V-REP scene
        return lambda: sim.world.resolve(f"Shape{suffix}").handle

    return sim.editor._edit(change)


@sim_function("setJointDependency")
def setJointDependency(ctx: CallContext, jointHandle: Any, masterJointHandle: Any, offset: Any, multCoeff: Any) -> None:  # noqa: N802, N803
    """Make the joint follow ``masterJointHandle``: q = offset + multCoeff · q_master, on the
    joints' positions (an MJCF joint equality relative to their ``ref``); -1 as master removes
    the joint's dependency; a joint of the master's chain that depended on this one loses its
    dependency, as V-REP breaks the loop (:func:`simx_server.sim.mechanisms.set_dependency`).

    ``sim.setJointDependency``.

    Args:
        jointHandle: the dependent joint.
        masterJointHandle: the master joint, or -1.
        offset: rad or m.
        multCoeff: factor.

    Raises:
        UnknownObjectError: no such object.
        ObjectTypeError: not a joint.
        ArgumentError: the joint as its own master.
        UnsupportedError: no simulation behind the script.
    """
    w = ctx.world
    joint = w.get(ctx.h(jointHandle, "jointHandle"), JOINT)
    master = ctx.h(masterJointHandle, "masterJointHandle")
    mname = None if master == -1 else w.get(master, JOINT).name
    off, k = _num(offset, "offset"), _num(multCoeff, "multCoeff")
    sim = ctx.simulation("setJointDependency")

    if mname == joint.name:
        raise ArgumentError(f"setJointDependency: joint {joint.name!r} cannot depend on itself")

    m = w.model
    qpos0 = tuple(float(m.qpos0[m.jnt_qposadr[w.get(h).mj_id]]) for h in (joint.handle, master if mname else joint.handle))

    def change(spec: mujoco.MjSpec):  # a stiff equality on positions (sim/mechanisms.py)
        mechanisms.set_dependency(spec, joint.name, mname, off, k, qpos0)

    sim.editor._edit(change)


@sim_function("scaleObject")
def scaleObject(ctx: CallContext, objectHandle: Any, xScale: Any, yScale: Any, zScale: Any, options: Any = 0) -> None:  # noqa: N802, N803
    """Scale a shape's geoms (sizes and positions in its frame) by x, y, z (0.001..1000):
    boxes and ellipsoids along each axis, meshes by their scale; spheres, cylinders and
    capsules need equal x and y (and z for spheres). Its mass scales with the volume.

    ``sim.scaleObject``.

    Args:
        objectHandle: a shape's handle, or ``sim.handle_self``.
        xScale: factor.
        yScale: factor.
        zScale: factor.
        options: checked.

    Raises:
        UnknownObjectError: no such object.
        UnsupportedError: not a shape, unequal factors a geom cannot take, or no simulation.
        ArgumentError: factors out of range.
    """
    obj = ctx.world.get(ctx.h(objectHandle))
    if obj.type != 0:  # sim.object_shape_type
        raise UnsupportedError("scaleObject: simx scales shapes (bodies) only")
    f = np.array([_num(v, n) for v, n in ((xScale, "xScale"), (yScale, "yScale"), (zScale, "zScale"))])
    if not np.all((f >= 1e-3) & (f <= 1e3)):
        raise ArgumentError("scale factors must lie in [0.001, 1000]")
    _int(options, "options")
    sim = ctx.simulation("scaleObject")
    G = mujoco.mjtGeom

    def change(spec: mujoco.MjSpec):
        body = spec.body(obj.name)
        for geom in body.geoms:
            kind = geom.type
            if kind in (G.mjGEOM_BOX, G.mjGEOM_ELLIPSOID):
                geom.size = np.asarray(geom.size) * f
            elif kind == G.mjGEOM_MESH:
                mesh = spec.mesh(geom.meshname)
                mesh.scale = np.asarray(mesh.scale) * f
            elif kind in (G.mjGEOM_SPHERE, G.mjGEOM_CYLINDER, G.mjGEOM_CAPSULE) and f[0] == f[1] and (
                    kind != G.mjGEOM_SPHERE or f[0] == f[2]):
                size = np.asarray(geom.size, float)
                geom.size = [size[0] * f[0], size[1] * (f[2] if kind != G.mjGEOM_SPHERE else 1), size[2]]
            else:
                raise ValueError(f"a {G(kind).name} geom cannot be scaled by {f.tolist()}")
            geom.pos = np.asarray(geom.pos) * f
        if body.explicitinertial:
            body.mass = body.mass * float(np.prod(f))

    sim.editor._edit(change)


