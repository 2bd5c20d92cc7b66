"""Shapes to MJCF geoms: primitives as MuJoCo primitives, other meshes as mesh assets (binary
STL files in ``meshes/``), colours, collision filtering and friction."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from simx_server.scene.ttt.geometry import compose
from simx_server.scene.ttt.looks import Look, Materials, texture_colour
from simx_server.scene.ttt.model import Mesh, Pose, ShapeData
from simx_server.sim.mechanisms import rigid_contact
from simx_server.sim.spec_tools import solid_mesh

# V-REP primitive type -> how it becomes a geom (the others are meshes)
PLANE, DISC, CUBOID, SPHEROID, CYLINDER, CONE, HEIGHTFIELD, CAPSULE = 1, 2, 3, 4, 5, 6, 7, 8
_THIN = 0.0005  # half-thickness of a plane or disc, m
#: Bullet's cap on two shapes' combined friction (btManifoldResult.cpp, MAX_FRICTION): a material
#: of 100 (RLBench's chairs, Robotiq fingers, wheels) on any other meets it at 10.
BULLET_MAX_FRICTION = 10.0


def write_stl(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    """A binary STL of the triangles (vertices (N, 3) m, faces (M, 3))."""
    tri = vertices[faces].astype("<f4")  # (M, 3, 3)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    normal = np.cross(e1, e2)
    rec = np.zeros(len(faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"] = normal
    rec["v"] = tri
    with open(path, "wb") as fh:
        fh.write(b"simx ttt mesh".ljust(80, b"\0"))
        fh.write(np.uint32(len(faces)).tobytes())
        fh.write(rec.tobytes())


def write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray, uv: np.ndarray, n_front: int) -> None:
    """An OBJ with texture coordinates per triangle corner (``uv`` (3 x n_front, 2)); faces past
    ``n_front`` are the back faces :func:`usable_mesh` added, reusing their front's corners."""
    lines = ["# simx ttt mesh"]
    lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices]
    lines += [f"vt {u:.7g} {v:.7g}" for u, v in uv]
    for i, (a, b, c) in enumerate(faces + 1):
        k = 3 * (i % n_front) + 1
        ta, tb, tc = (k, k + 1, k + 2) if i < n_front else (k + 2, k + 1, k)
        lines.append(f"f {a}/{ta} {b}/{tb} {c}/{tc}")
    path.write_text("\n".join(lines) + "\n")


def usable_mesh(mesh: Mesh) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and faces MuJoCo can compile, or None: a flat mesh (a wall, a floor tile) gets a
    back face 0.1 mm behind it so that it has a volume (:func:`simx_server.sim.spec_tools.solid_mesh`);
    fewer than 3 points are left out."""
    return solid_mesh(mesh.vertices, mesh.faces)


class GeomMaker:
    """Adds a shape's geoms to bodies; writes mesh files under ``out/meshes``.

    Args:
        spec: the MjSpec being built; out: the output folder (None: meshes inline).
        friction_scale: how a V-REP friction coefficient becomes MuJoCo's sliding friction.
    """

    def __init__(self, spec: mujoco.MjSpec, out: Path | None, report, textures: dict | None = None):
        self.spec, self.out, self.report = spec, out, report
        self.textures = textures or {}
        self.materials: dict[int, str] = {}  # texture id -> texture name
        self.looks = Materials(spec, report)
        self.count = 0
        self._shared: dict[tuple, str] = {}  # (vertices, faces) ids -> mesh asset name
        # shape name -> how V-REP computes the coordinates of its first textured mesh (a
        # ``texture_map=`` setting: MODE,SX,SY,PX,PY,PZ,QW,QX,QY,QZ; sim/texture_motion.py)
        self.texture_maps: dict[str, str] = {}
        self._textured = False  # whether the last geom made is a textured mesh
        if out is not None:
            (out / "meshes").mkdir(parents=True, exist_ok=True)

    def add(self, body, frame_pos, frame_quat, name: str, shape: ShapeData, contype: int, conaffinity: int,
            visible: bool = True, ground: bool = False):
        """Geoms of ``shape`` in ``body``; the shape's frame is (frame_pos, frame_quat) in it.
        A shape in no shown layer (V-REP's hidden collision shapes) and the wireframe meshes of a
        shape that is not respondable (V-REP draws their edges; RLBench's spawn boundaries) go
        to geom group 3, which neither the viewer nor the vision sensors draw by default.
        Every geom gets V-REP's rigid contact (:func:`simx_server.sim.mechanisms.rigid_contact`),
        in its static form where ``ground``: a static shape fixed to the world."""
        base = Pose(np.asarray(frame_pos, float), np.asarray(frame_quat, float))
        for i, mesh in enumerate(shape.meshes):
            lines = mesh.wireframe and contype == 0  # V-REP draws it as lines: MuJoCo cannot
            if lines:  # kept, not drawn, for its pose, bounding box and collision checks
                self.report.add("wireframe meshes (not drawn: MuJoCo draws no lines)", approximated=True)
            pose = compose(base, mesh.frame)
            self._textured = False
            g = self._geom(body, mesh, name, i)
            if g is None:
                continue
            g.pos, g.quat = pose.pos, pose.quat
            look = mesh.look or Look(diffuse=tuple(mesh.color))
            g.rgba = [*mesh.color, look.opacity]
            g.contype, g.conaffinity = contype, conaffinity
            rigid_contact(g, self.spec.option.timestep, ground)  # Bullet's rigid contacts (mechanisms.py)
            if not visible or lines:
                g.group = 3
            g.density = 0.0  # bodies get the file's mass and inertia, not the geoms'
            if shape.friction is not None:
                # Bullet multiplies the two shapes' coefficients, MuJoCo takes the larger:
                # mu^2 gives Bullet's value for two equal materials; Bullet caps the product
                # (btManifoldResult::calculateCombinedFriction, MAX_FRICTION)
                g.friction = [min(shape.friction ** 2, BULLET_MAX_FRICTION), 0.005, 0.0001]
            if g.material:  # the texture over the shape's colour as V-REP applies it (looks.py)
                g.rgba = texture_colour(look, mesh.texture_mode)
            elif mesh.texture >= 0 and visible and not lines and g.type != mujoco.mjtGeom.mjGEOM_MESH and \
                    self._skin(body, mesh, pose):
                g.group = 3  # the primitive collides; its textured mesh (the skin) is what is seen
            elif mesh.texture >= 0:
                self.report.add("textures without their coordinates (shown as the shape's colour)", approximated=True)
            if not g.material and g.group != 3:  # V-REP's specular, shininess, emission (looks.py)
                g.material = self.looks.material(look, owner=body.name) or ""
            if self._textured and mesh.texture_map is not None and name not in self.texture_maps:
                mode, (sx, sy), tf = mesh.texture_map
                self.texture_maps[name] = ",".join([str(mode)] + [repr(float(v)) for v in (sx, sy, *tf.pos, *tf.quat)])

    def _skin(self, body, mesh: Mesh, pose: Pose) -> bool:
        """A textured primitive's look: MuJoCo's primitives take no texture coordinates, so the
        triangles the file keeps for it, with its coordinates, become a visual-only mesh geom
        beside the primitive (which still collides). False (nothing added) where the file's
        coordinates or texture are not usable."""
        if self.out is None or self._texture(mesh) is None:
            return False
        g = self._mesh_geom(body, mesh, visual=True)
        if g is None:
            return False
        g.pos, g.quat = pose.pos, pose.quat
        g.rgba = texture_colour(mesh.look or Look(diffuse=tuple(mesh.color)), mesh.texture_mode)
        g.contype = g.conaffinity = 0
        g.density = 0.0
        return True

    def _geom(self, body, mesh: Mesh, name: str, index: int):
        s = np.abs(mesh.sizes)
        p = mesh.primitive
        G = mujoco.mjtGeom
        if p == CUBOID and np.all(s > 0):
            return self._new(body, G.mjGEOM_BOX, np.maximum(s / 2, 1e-5))
        if p == SPHEROID and np.all(s > 0):
            if np.ptp(s) < 1e-6 * s.max():
                return self._new(body, G.mjGEOM_SPHERE, [s[0] / 2, 0, 0])
            return self._new(body, G.mjGEOM_ELLIPSOID, s / 2)
        if p == CYLINDER and s[0] > 0 and s[2] > 0:
            return self._new(body, G.mjGEOM_CYLINDER, [s[0] / 2, s[2] / 2, 0])
        if p == DISC and s[0] > 0:
            return self._new(body, G.mjGEOM_CYLINDER, [s[0] / 2, _THIN, 0])
        if p == PLANE and s[0] > 0 and s[1] > 0:
            return self._new(body, G.mjGEOM_BOX, [s[0] / 2, s[1] / 2, _THIN])
        if p == CAPSULE and s[0] > 0:
            r = s[0] / 2
            return self._new(body, G.mjGEOM_CAPSULE, [r, max(s[2] / 2 - r, 1e-4), 0])
        return self._mesh_geom(body, mesh)

    def _mesh_geom(self, body, mesh: Mesh, visual: bool = False):
        """A mesh geom of ``mesh``'s triangles (with its texture where the file gives
        coordinates); None for a degenerate mesh. ``visual``: it does not collide (no report of
        its convex hull). Shapes that point at the same pool arrays (``reader.MeshPool``) share
        one mesh asset (an untextured mesh's asset depends on its arrays only)."""
        G = mujoco.mjtGeom
        key = (id(mesh.vertices), id(mesh.faces)) if mesh.uv is None else None
        mname = self._shared.get(key) if key is not None else None
        material = None
        if mname is None:
            usable = usable_mesh(mesh)
            if usable is None:
                if len(mesh.vertices):
                    self.report.add("degenerate meshes (left out)")
                return None
            texture = self._texture(mesh) if self.out is not None else None
            look = mesh.look or Look(diffuse=tuple(mesh.color))
            material = self.looks.material(look, texture, body.name, mesh.texture_mode) if texture is not None else None
            mname = self._mesh_asset(mesh, *usable, material)
            if key is not None:
                self._shared[key] = mname
            self._textured = material is not None
        if not mesh.convex and not visual:
            self.report.add("non-convex meshes (collide as their convex hull)", approximated=True)
        g = body.add_geom()
        g.type = G.mjGEOM_MESH
        g.meshname = mname
        if material is not None:
            g.material = material
        return g

    def _mesh_asset(self, mesh: Mesh, vertices: np.ndarray, faces: np.ndarray, material: str | None) -> str:
        """A new mesh asset of ``vertices`` (N, 3) and ``faces`` (M, 3), its file written
        (OBJ with the texture coordinates where ``material`` shows a texture); its name."""
        self.count += 1
        mname = f"ttt_mesh{self.count}"
        m = self.spec.add_mesh()
        m.name = mname
        m.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        if material is not None:
            write_obj(self.out / "meshes" / f"{mname}.obj", vertices, faces, mesh.uv, len(mesh.faces))
            m.file = f"{mname}.obj"
        elif self.out is not None:
            write_stl(self.out / "meshes" / f"{mname}.stl", vertices, faces)
            m.file = f"{mname}.stl"
        else:
            m.uservert = vertices.astype(np.float32).ravel()
            m.userface = faces.astype(np.int32).ravel()
        return mname

    def _texture(self, mesh: Mesh) -> str | None:
        """The MJCF texture of the mesh's texture (a PNG in ``textures/``), when the file gives
        texture coordinates per triangle corner; None otherwise."""
        tex = self.textures.get(mesh.texture)
        if tex is None or mesh.uv is None or len(mesh.uv) != 3 * len(mesh.faces) or not len(mesh.faces):
            return None
        if mesh.texture not in self.materials:
            import cv2

            folder = self.out / "textures"
            folder.mkdir(exist_ok=True)
            rgb = tex.rgb[::-1]  # V-REP's rows go bottom-up (OpenGL's order)
            bgr = cv2.cvtColor(rgb, cv2.COLOR_RGBA2BGRA if rgb.shape[2] == 4 else cv2.COLOR_RGB2BGR)
            cv2.imwrite(str(folder / f"tex{mesh.texture}.png"), bgr)
            t = self.spec.add_texture()
            t.name = f"ttt_tex{mesh.texture}"
            t.type = mujoco.mjtTexture.mjTEXTURE_2D
            t.file = f"tex{mesh.texture}.png"
            self.materials[mesh.texture] = t.name
        return self.materials[mesh.texture]

    @staticmethod
    def _new(body, kind, size):
        g = body.add_geom()
        g.type = kind
        g.size = np.asarray(size, dtype=float)
        return g


#: The ``contype`` of a respondable shape whose two respondable masks are empty: a bit no geom's
#: ``conaffinity`` has (V-REP's masks use the low eight), so it meets nothing, as in V-REP.
NO_PARTNER_BIT = 1 << 30


def collision_bits(shape: ShapeData) -> tuple[int, int]:
    """contype/conaffinity of a shape's geoms: V-REP's global respondable mask (high byte of
    ``Dc2``) for a respondable shape, 0/0 (visual only) otherwise. The local mask (low byte,
    shapes of one model) becomes ``<exclude>`` pairs (see :mod:`.convert`). A respondable shape
    with both masks empty collides with nothing in V-REP (its engines pair two shapes only when
    their masks share a bit: the TurtleBot's wheel-drop bodies): ``(NO_PARTNER_BIT, 0)``, which
    MuJoCo pairs with no geom while the shape stays respondable (it has contact bits)."""
    if not shape.respondable:
        return 0, 0
    if not shape.respondable_mask & 0xFFFF:
        return NO_PARTNER_BIT, 0
    bits = (shape.respondable_mask >> 8) & 0xFF or 1
    return bits, bits
