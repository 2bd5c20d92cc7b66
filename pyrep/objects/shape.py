"""PyRep's ``Shape``: a mesh or primitive with colour, mass and contacts (m, kg, N)."""

from __future__ import annotations

from collections import namedtuple
from pathlib import Path
from typing import Any

import numpy as np

from pyrep.backend import sim
from pyrep.const import ObjectType, PrimitiveShape, TextureMappingMode
from pyrep.objects.object import Object, object_type_to_class
from pyrep.textures.texture import Texture

_STATIC = 3003  # sim_shapeintparam_static
_RESPONDABLE = 3004  # sim_shapeintparam_respondable

#: One item of a shape's visual (``Shape.get_shape_viz``), as PyRep's.
SShapeVizInfo = namedtuple("SShapeVizInfo", ["vertices", "indices", "normals", "shading_angle", "colors",
                                             "texture", "texture_id", "texture_coords", "texture_apply_mode",
                                             "texture_options"])


def _file_format(filename: str) -> int:
    return 4 if Path(filename).suffix.lower() == ".stl" else 0  # sim.importShape: 0 OBJ, 4 binary STL


class Shape(Object):
    """A shape."""

    @staticmethod
    def create(type: PrimitiveShape, size: list[float], mass: float = 1.0, backface_culling: bool = False,
               visible_edges: bool = False, smooth: bool = False, respondable: bool = True,
               static: bool = False, renderable: bool = True, position: Any = None, orientation: Any = None,
               color: Any = None) -> Shape:
        """A new primitive (``size`` x, y, z in m, ``mass`` kg), dynamic unless ``static``;
        neither collidable, measurable nor detectable (CoppeliaSim 4.1's ``simCreatePureShape``
        clears them: ``set_collidable`` and the like give them back).

        Raises:
            RuntimeError: a cone (MuJoCo has none), a bad size or mass.
        """
        options = (1 if backface_culling else 0) | (2 if visible_edges else 0) | (4 if smooth else 0) \
            | (8 if respondable else 0) | (16 if static else 0)
        shape = Shape(int(sim.call("createPureShape", type.value, options, [float(s) for s in size], float(mass))))
        shape.set_renderable(renderable)  # as PyRep: CoppeliaSim 4.1's new pure shape is not renderable
        if position is not None:
            shape.set_position(position)
        if orientation is not None:
            shape.set_orientation(orientation)
        if color is not None:
            shape.set_color(color)
        return shape

    @classmethod
    def import_shape(cls, filename: str, scaling_factor: float = 1.0, keep_identical_vertices: bool = False,
                     ignore_color: bool = False, ignore_texture: bool = False, reorient_bounding_box: bool = False,
                     ignore_up_vector: bool = False) -> Shape:
        """A new shape from an OBJ or binary STL file (m, times ``scaling_factor``).

        Raises:
            ValueError: no such file.
        """
        if not Path(filename).is_file():
            raise ValueError(f"Filename does not exist: {filename}")
        options = (1 if keep_identical_vertices else 0) | (8 if ignore_color else 0) \
            | (16 if ignore_texture else 0) | (128 if ignore_up_vector else 0)
        handle = sim.call("importShape", _file_format(filename), sim.program_file(filename), options, 0.0,
                          float(scaling_factor))
        return cls(int(handle))

    @staticmethod
    def import_mesh(filename: str, scaling_factor: float = 1.0, keep_identical_vertices: bool = False,
                    ignore_up_vector: bool = False) -> Shape:
        """A new mesh shape from an OBJ or binary STL file, without its colours and textures.

        Raises:
            ValueError: no such file.
        """
        if not Path(filename).is_file():
            raise ValueError(f"Filename does not exist: {filename}")
        vertices, indices = sim.call("importMesh", _file_format(filename), sim.program_file(filename), 0, 0.0,
                                     float(scaling_factor))
        if vertices and isinstance(vertices[0], (list, tuple)):  # one list per mesh of the file
            shapes = [Shape.create_mesh(v, i) for v, i in zip(vertices, indices)]
            if len(shapes) == 1:
                return shapes[0]
            return Shape(int(sim.call("groupShapes", [s.get_handle() for s in shapes])))
        return Shape.create_mesh(vertices, indices)

    @staticmethod
    def create_mesh(vertices: list[float], indices: list[int], shading_angle: float | None = None,
                    backface_culling: bool = False, visible_edges: bool = False) -> Shape:
        """A new mesh shape from ``vertices`` (3n, m) and ``indices`` (3t)."""
        options = (1 if backface_culling else 0) | (2 if visible_edges else 0)
        angle = 20.0 * np.pi / 180 if shading_angle is None else float(shading_angle)
        handle = sim.call("createShape", options, angle, [float(v) for v in vertices], [int(i) for i in indices])
        return Shape(int(handle))

    def _get_requested_type(self) -> ObjectType:
        return ObjectType.SHAPE

    def is_respondable(self) -> bool:
        """Whether the shape takes part in contacts."""
        return bool(sim.call("getObjectInt32Param", self._handle, _RESPONDABLE))

    def set_respondable(self, value: bool) -> None:
        sim.call("setObjectInt32Param", self._handle, _RESPONDABLE, int(value))
        self.reset_dynamic_object()

    def is_dynamic(self) -> bool:
        """Whether the shape is moved by physics (not static)."""
        return not sim.call("getObjectInt32Param", self._handle, _STATIC)

    def set_dynamic(self, value: bool) -> None:
        sim.call("setObjectInt32Param", self._handle, _STATIC, int(not value))
        self.reset_dynamic_object()

    def get_color(self) -> list[float]:
        """RGB (3, 0..1) of the shape's (first) visual."""
        return [float(c) for c in sim.call("getShapeColor", self._handle, None, 0)[1]]

    def set_color(self, color: list[float]) -> None:
        """Sets the RGB (3, 0..1) of every visual of the shape."""
        sim.call("setShapeColor", self._handle, None, 0, [float(c) for c in color])

    def get_transparency(self) -> float:
        """Transparency, 0 (opaque) .. 1."""
        return float(sim.call("getShapeColor", self._handle, None, 4)[1][0])

    def set_transparency(self, value: float) -> None:
        """Sets the transparency, 0 (opaque) .. 1.

        Raises:
            ValueError: out of 0..1.
        """
        if not 0.0 <= value <= 1.0:
            raise ValueError("Value must be between 0 and 1.")
        sim.call("setShapeColor", self._handle, None, 4, [float(value)])

    def get_mass(self) -> float:
        """Mass (kg)."""
        return float(sim.call("getShapeMass", self._handle))

    def set_mass(self, mass: float) -> None:
        """Sets the mass (kg)."""
        sim.call("setShapeMass", self._handle, float(mass))

    def compute_mass_and_inertia(self, density: float) -> None:
        """Mass and inertia from the shape's volume and ``density`` (kg/m³).

        Raises:
            RuntimeError: the computation failed.
        """
        if sim.call("computeMassAndInertia", self._handle, float(density)) != 1:
            raise RuntimeError("Failed to compute mass and inertia.")

    def get_mesh_data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``vertices`` (n, 3) m, ``indices`` (t, 3), ``normals`` (3t, 3), in the shape's frame."""
        vertices, indices, normals = sim.call("getShapeMesh", self._handle)
        return (np.array(vertices, dtype=np.float64).reshape(-1, 3), np.array(indices, dtype=np.int64).reshape(-1, 3),
                np.array(normals, dtype=np.float64).reshape(-1, 3))

    def decimate_mesh(self, percentage: float) -> Shape:
        """A new shape with about ``percentage`` (0.1-0.9) of this one's triangles, at this one's
        pose (``sim.getDecimatedMesh``, then ``create_mesh``).

        Raises:
            ValueError: ``percentage`` outside 0.1-0.9.
        """
        if percentage < 0.1 or percentage > 0.9:
            raise ValueError("percentage param must be between 0.1 and 0.9.")
        vertices, indices = sim.call("getDecimatedMesh", *[v.flatten().tolist() for v in self.get_mesh_data()[:2]],
                                     float(percentage))
        shape = Shape.create_mesh(vertices, indices)
        shape.set_matrix(self.get_matrix())
        return shape

    def get_convex_decomposition(self, morph: bool = False, same: bool = False, use_vhacd: bool = False,
                                 individual_meshes: bool = False, hacd_extra_points: bool = True,
                                 hacd_face_points: bool = True, hacd_min_clusters: int = 1,
                                 hacd_tri_target: int = 500, hacd_max_vertex: int = 200,
                                 hacd_max_iter: int = 4, hacd_max_concavity: int = 100,
                                 hacd_max_dist: int = 30, hacd_cluster_thresh: float = 0.25,
                                 vhacd_pca: bool = False, vhacd_tetrahedron: bool = False,
                                 vhacd_res: int = 100000, vhacd_depth: int = 20,
                                 vhacd_plane_downsample: int = 4, vhacd_hull_downsample: int = 4,
                                 vhacd_max_vertex: int = 64, vhacd_concavity: float = 0.0025,
                                 vhacd_alpha: float = 0.05, vhacd_beta: float = 0.05,
                                 vhacd_gamma: float = 0.00125, vhacd_min_vol: float = 0.0001) -> Shape:
        """The shape's convex decomposition (``sim.convexDecompose``, V-HACD in simx): a new
        shape, or this one changed when ``morph``. Options and parameters as PyRep passes them."""
        flags = (morph, False, same, hacd_extra_points, hacd_face_points, individual_meshes, False, use_vhacd,
                 vhacd_pca, vhacd_tetrahedron)
        options = sum(1 << i for i, on in enumerate(flags) if on)
        ints = [hacd_min_clusters, hacd_tri_target, hacd_max_vertex, hacd_max_iter, 0, vhacd_res, vhacd_depth,
                vhacd_plane_downsample, vhacd_hull_downsample, vhacd_max_vertex]
        floats = [hacd_max_concavity, hacd_max_dist, hacd_cluster_thresh, 0.0, 0.0, vhacd_concavity, vhacd_alpha,
                  vhacd_beta, vhacd_gamma, vhacd_min_vol]
        return Shape(int(sim.call("convexDecompose", self._handle, options, ints, [float(f) for f in floats])))

    def get_texture(self) -> Texture:
        """The shape's texture (id -1: none)."""
        return Texture(int(sim.call("getShapeTextureId", self._handle)))

    def remove_texture(self) -> None:
        """Takes the texture off."""
        sim.call("setShapeTexture", self._handle, -1, 0, 0, [1.0, 1.0])

    def set_texture(self, texture: Texture, mapping_mode: TextureMappingMode, interpolate: bool = True,
                    decal_mode: bool = False, repeat_along_u: bool = False, repeat_along_v: bool = False,
                    uv_scaling: Any = (1.0, 1.0), position: Any = None, orientation: Any = None) -> None:
        """Puts ``texture`` on the shape (MuJoCo maps it by the geom's type)."""
        options = (0 if interpolate else 1) | (2 if decal_mode else 0) | (4 if repeat_along_u else 0) \
            | (8 if repeat_along_v else 0)
        sim.call("setShapeTexture", self._handle, texture.get_texture_id(), mapping_mode.value, options,
                 [float(v) for v in uv_scaling], position, orientation)

    def ungroup(self) -> list[Shape]:
        """The shapes of a compound shape, which it no longer is."""
        return [Shape(int(h)) for h in sim.call("ungroupShape", self._handle)]

    def apply_texture(self, texture_coords: np.ndarray, texture: np.ndarray, interpolate: bool = True,
                      decal_mode: bool = False, is_rgba: bool = False, fliph: bool = False,
                      flipv: bool = False) -> None:
        """Puts an image on the shape (one mesh) with a (u, v) pair per triangle corner
        (``sim.applyTexture``): ``texture`` (h, w, 3) RGB or (h, w, 4) RGBA uint8.

        Raises:
            TypeError: ``texture`` is not a numpy array.
        """
        texture_coords = np.asarray(texture_coords)
        if not isinstance(texture, np.ndarray):
            raise TypeError("texture must be np.ndarray type")
        height, width = texture.shape[:2]
        options = ((0 if interpolate else 1) | (2 if decal_mode else 0) | (16 if is_rgba else 0)
                   | (32 if fliph else 0) | (64 if flipv else 0))
        sim.call("applyTexture", self._handle, texture_coords.flatten().tolist(),
                 np.ascontiguousarray(texture, dtype=np.uint8).tobytes(), [width, height], options)

    def get_shape_viz(self, index: int) -> SShapeVizInfo:
        """The ``index``-th visual item: vertices (n, 3), indices (t, 3), normals (3t, 3),
        shading angle (rad), colours (9,), texture (h, w, 4) uint8 and its coordinates (n, 2)."""
        info = sim.call("getShapeViz", self._handle, index)
        texture = info.get("texture") or {}
        resolution = texture.get("resolution", [0, 0])
        image = np.frombuffer(bytes(texture.get("texture", b"")), dtype=np.uint8)
        return SShapeVizInfo(
            vertices=np.array(info["vertices"], dtype=np.float64).reshape(-1, 3),
            indices=np.array(info["indices"], dtype=np.int64).reshape(-1, 3),
            normals=np.array(info["normals"], dtype=np.float64).reshape(-1, 3),
            shading_angle=float(info.get("shadingAngle", 0.0)),
            colors=np.array(info["colors"], dtype=np.float64),
            texture=image.reshape(int(resolution[1]), int(resolution[0]), 4) if image.size else image,
            texture_id=int(texture.get("id", -1)),
            texture_coords=np.array(texture.get("coordinates", []), dtype=np.float64).reshape(-1, 2),
            texture_apply_mode=int(texture.get("applyMode", 0)),
            texture_options=int(texture.get("options", 0)))

    def reorient_bounding_box(self, relative_to: Any = None) -> None:
        """Aligns the shape's bounding box with the world's axes (``relative_to`` None), with
        ``relative_to``'s, or with its mesh (``relative_to`` the shape itself), then puts its
        frame at the box's centre, as CoppeliaSim 4.1's ``simReorientShapeBoundingBox``
        (``sim.alignShapeBB``, then ``sim.relocateShapeFrame``; simx's box lies along the frame)."""
        if relative_to is None:
            quaternion = [0.0, 0.0, 0.0, 1.0]
        elif relative_to.get_handle() == self._handle:
            quaternion = [0.0, 0.0, 0.0, 0.0]
        else:
            quaternion = [float(q) for q in relative_to.get_quaternion()]
        if sim.call("alignShapeBB", self._handle, [0.0, 0.0, 0.0, *quaternion]):
            sim.call("relocateShapeFrame", self._handle, [0, 0, 0, 0, 0, 0, 0])

    def add_force(self, position: Any, force: Any, reset_force_torque: bool = False) -> None:
        """Adds ``force`` (N, world frame) at ``position`` (m, the shape's frame) for the next step."""
        sim.call("addForce", self._handle, [float(v) for v in position], [float(v) for v in force])

    def add_force_and_torque(self, force: Any, torque: Any, reset_force: bool = False,
                             reset_torque: bool = False) -> None:
        """Adds ``force`` (N) and ``torque`` (N·m) at the centre of mass for the next step."""
        sim.call("addForceAndTorque", self._handle, [float(v) for v in force], [float(v) for v in torque])


object_type_to_class[ObjectType.SHAPE] = Shape
