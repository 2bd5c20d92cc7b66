"""The typed content of a ``.ttt``/``.ttm`` file: what the converter needs, in V-REP's terms.

Poses are ``(pos, quat)``: position in m, unit quaternion ``w x y z``; every local pose is
relative to the parent object's frame (for children of joints: the joint's *displaced* frame).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from simx_server.scene.ttt.looks import Look


@dataclass
class Pose:
    pos: np.ndarray = field(default_factory=lambda: np.zeros(3))
    quat: np.ndarray = field(default_factory=lambda: np.array([1.0, 0, 0, 0]))


@dataclass
class Mesh:
    """One mesh of a shape (a compound shape has several).

    Attributes:
        name: the mesh's name in the file.
        vertices: (N, 3) float64 in the mesh frame ``frame`` (m); faces (M, 3) int64.
        frame: the vertices' frame relative to the shape (``Ppf``/``_pf``).
        primitive: 0 mesh, 1 plane, 2 disc, 3 cuboid, 4 spheroid, 5 cylinder, 6 cone,
            7 heightfield, 8 capsule; ``sizes`` its x/diameter, y, z/height (m).
        color: ambient-diffuse RGB (0-1); texture: texture id or -1, uv: (K, 2) coordinates.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    frame: Pose
    primitive: int = 0
    sizes: np.ndarray = field(default_factory=lambda: np.zeros(3))
    color: np.ndarray = field(default_factory=lambda: np.array([0.7, 0.7, 0.7]))
    texture: int = -1
    uv: np.ndarray | None = None
    convex: bool = False
    wireframe: bool = False  # drawn as edges only in V-REP
    look: Look | None = None  # the colour object (specular, emission, shininess, opacity)
    texture_mode: int = 0  # how the texture meets the colour: 0 modulate, 1 decal, 2 add, 3 blend
    # where V-REP computes the coordinates from (``uv`` made so): mapping, scale (m), texture frame
    texture_map: tuple[int, tuple[float, float], Pose] | None = None


@dataclass
class ShapeData:
    """A shape: meshes, mass (kg), inertia (principal moments, kg·m², already times the mass)
    at ``inertia_frame``; V-REP's dynamic flags; material friction: ``bullet_friction`` the
    material's two Bullet coefficients (Bullet 2.78's, 2.83's), ``friction`` the one the scene's
    engine uses (:func:`simx_server.scene.ttt.reader.read` picks it)."""

    meshes: list[Mesh]
    compound: bool
    mass: float = 1.0
    inertia: np.ndarray = field(default_factory=lambda: np.full(3, 1e-3))
    inertia_frame: Pose = field(default_factory=Pose)
    static: bool = True
    respondable: bool = False
    respondable_mask: int = 0xFFFF
    friction: float | None = None
    bullet_friction: tuple[float | None, float | None] = (None, None)


@dataclass
class JointData:
    """A joint: type 10 revolute, 11 prismatic, 12 spherical; mode 0 passive, 1 motion (old),
    2 IK (old), 3 IK-dependent (old), 4 dependent, 5 force/torque. Angles rad, lengths m."""

    type: int
    mode: int
    minimum: float
    range: float
    position: float
    cyclic: bool
    motor: bool
    control_loop: bool
    target_velocity: float = 0.0
    max_force: float = 0.0
    target_position: float | None = None  # None: the file does not say (Dtp / _tp)
    pid: tuple[float, float, float] | None = None
    spring: tuple[float, float] | None = None
    dependency: tuple[int, float, float] | None = None  # master handle, multiplier, offset
    max_velocity: float | None = None
    spherical_quat: np.ndarray | None = None
    control_mode: int | None = None  # 4.4+'s Dcm: 0 free, 1 force, 4 velocity, 8 position, 12 spring (<= 4.3: 12 or None)
    size: tuple[float, float] | None = None  # length, diameter as drawn (``Arg`` / ``_rg``), m
    velocity_lock: bool = False  # ``Vaa`` bit 1: lock the motor when its target velocity is 0


@dataclass
class DummyData:
    size: float
    linked: int       # handle of the linked dummy, -1 none
    link_type: int    # 0 dynamics loop closure, 5 IK tip-target (sim_dummy_linktype_*)


@dataclass
class ProximityData:
    type: int          # 30 pyramid, 31 cylinder, 32 disc, 33 cone, 34 ray
    offset: float
    range: float
    angle: float       # cone/disc opening angle, rad (0 when not applicable)
    max_angle: float | None  # limited angle detection, rad
    #: pyramid sizes at the offset and at the far end (x, y, x far, y far), cylinder radii (near,
    #: far), m (``Ss3`` / ``_s3`` values 2-7)
    sizes: tuple[float, ...] = ()
    sensable: int = 16  # ``Sst``: the detectable bit it senses (16 ultrasonic ... 256 capacitive)
    faces: int = 32     # ``Ssi`` faceNumber: the sides of a cylinder volume (CConvexVolume's default 32)


@dataclass
class VisionData:
    resolution: tuple[int, int]
    view_angle: float   # rad, of the longer image side
    ortho_size: float   # m
    near: float
    far: float
    perspective: bool
    explicit: bool
    #: filter components (simx_server.scene.ttt.filters.FilterComponent), in order
    filters: list = field(default_factory=list)
    ignore_rgb: bool = False
    ignore_depth: bool = False
    basic_stats: bool = True  # V-REP's default packet (``Va2`` bit 4 clear)
    background: np.ndarray | None = None  # default background colour ``Db2`` (RGB 0-1)
    same_background: bool = False  # the environment's background instead (``Va3`` bit 7)
    render_mode: int = 0  # sim_rendermode_*: 0 OpenGL, 1 auxiliary channels, 2 colour-coded handles


@dataclass
class ForceSensorData:
    size: float


@dataclass
class TttObject:
    """A scene object. ``kind``: shape, joint, dummy, proximity_sensor, vision_sensor,
    force_sensor, camera, light, graph, path, point_cloud, octree, mill, mirror, other."""

    tag: str
    kind: str
    handle: int
    parent: int
    name: str
    alias: str
    pose: Pose
    model_base: bool = False
    layers: int = 1  # V-REP's visibility layers (bits; layers 1-8 are shown by default)
    data: object | None = None
    children: list["TttObject"] = field(default_factory=list)
    custom_data: dict[str, bytes] = field(default_factory=dict)  # sim.readCustomDataBlock's blocks: tag -> data
    developer_data: int = 0  # custom data blocks of other headers (V-REP's simAddObjectCustomData), not kept
    script_parameters: list[dict] = field(default_factory=list)  # 4.3+: kept with the object (``Lsp``)
    references: dict[str, list[int]] = field(default_factory=dict)  # sim.setReferencedHandles: tag -> handles
    extension: str = ""  # sim.getExtensionString's text (``Rst``)
    special: int | None = None  # V-REP's object special property bits (``Omp``), None: not in the file
    model_property: int = 0xF000  # ``Mpo``: a model base's override bits (sim.modelproperty_not_*)
    object_property: int = 0  # ``Op2``: sim.objectproperty_* bits (dontshowasinsidemodel 256 ...)


@dataclass
class Script:
    """A script: type 0 main, 1 child, 6 customization (4/5/7 retired callbacks). In 4.6+ files
    a script is also a scene object (``SCT``): ``handle`` and ``object`` are then that object's."""

    handle: int
    object: int
    type: int
    threaded: bool
    disabled: bool
    text: str
    language: str = "lua"
    parameters: list[dict] = field(default_factory=list)
    proxy: bool = False  # 4.6+ script object whose parent stands for it (``Va3`` bit 2, _parentIsProxy)


@dataclass
class Collection:
    """A collection (``GRP``): its name and elements in order, each (object handle or -1,
    V-REP's element type ``Gty``: 0 loose, 1 tree from base, 2 the same without it, 3 chain from
    tip, 4 the same without it, 5 everything; additive ``Var``)."""

    name: str
    elements: list[tuple[int, int, bool]]
    handle: int = -1  # the collection's handle in the file (``Gix``: what COL/DST entities name)

    @property
    def objects(self) -> list[int]:
        return [h for h, _, _ in self.elements]


@dataclass
class IkElement:
    """One element of an old IK group (coppeliaSimLib ``CIkElement_old``)."""

    tip: int  # the tip dummy's handle (its linked dummy is the target)
    base: int  # the chain's base (-1: the world)
    constraints: int = 7  # V-REP's bits: x 1, y 2, z 4, alpha-beta 8, gamma 16
    precision: tuple[float, float] = (0.0005, 0.1 * np.pi / 180)  # linear m, angular rad
    weights: tuple[float, float] = (1.0, 1.0)  # position, orientation
    enabled: bool = True


@dataclass
class IkGroup:
    """An old (V-REP 3.x) IK group (coppeliaSimLib ``CIkGroup_old``): its elements and how it is
    solved (defaults: ``_CIkGroup_old``'s)."""

    name: str
    elements: list[IkElement]
    explicit: bool = False
    enabled: bool = True
    iterations: int = 3
    damping: float = 0.1
    method: int = 0  # sim_ik_pseudo_inverse_method 0, damped_least_squares 1, jacobian_transpose 2
    max_steps: bool = False  # False: the joints' max step sizes are ignored (Var bit 5 clear)


@dataclass
class Texture:
    id: int
    name: str
    width: int
    height: int
    rgb: np.ndarray  # (height, width, 3 or 4) uint8


@dataclass
class TttScene:
    """Everything read from one file (:func:`simx_server.scene.ttt.reader.read`)."""

    file: str
    serialization: int
    program_version: int
    is_model: bool
    objects: dict[int, TttObject]
    roots: list[TttObject]
    scripts: list[Script]
    collections: list[Collection]
    ik_groups: list[IkGroup]
    textures: dict[int, Texture]
    engine: int = 0          # 0 Bullet, 1 ODE, 2 Vortex, 3 Newton, 4 MuJoCo
    engine_version: int = 0  # Bullet's: 0 for 2.78 (CoppeliaSim 4.1's default), 283 for 2.83 (``DYN``/``Ver``)
    gravity: np.ndarray = field(default_factory=lambda: np.array([0, 0, -9.81]))
    time_step: float = 0.05  # s
    background: tuple[np.ndarray, np.ndarray] | None = None  # environment colours: up, down (RGB 0-1)
    ambient: np.ndarray | None = None  # ambient light (RGB 0-1)
    fog_background: np.ndarray | None = None  # the environment's fog/sensor background ``Fbg`` (RGB 0-1)
    skipped: dict[str, int] = field(default_factory=dict)  # what was read but is not modelled: count
    saved_settings: object | None = None  # settings.SavedSettings: the SIM/DYN records' settings
    measurements: list = field(default_factory=list)  # measurements.Measurement: COL/DST objects
