"""PyRep's enumerations (``pyrep.const``), with CoppeliaSim's values."""

from enum import Enum

from pyrep.backend import sim


class PrimitiveShape(Enum):
    CUBOID = 0
    SPHERE = 1
    CYLINDER = 2
    CONE = 3


class ObjectType(Enum):
    ALL = sim.sim_handle_all  # type: ignore[attr-defined]
    SHAPE = sim.sim_object_shape_type  # type: ignore[attr-defined]
    JOINT = sim.sim_object_joint_type  # type: ignore[attr-defined]
    DUMMY = sim.sim_object_dummy_type  # type: ignore[attr-defined]
    PROXIMITY_SENSOR = sim.sim_object_proximitysensor_type  # type: ignore[attr-defined]
    GRAPH = sim.sim_object_graph_type  # type: ignore[attr-defined]
    CAMERA = sim.sim_object_camera_type  # type: ignore[attr-defined]
    PATH = sim.sim_object_path_type  # type: ignore[attr-defined]
    VISION_SENSOR = sim.sim_object_visionsensor_type  # type: ignore[attr-defined]
    VOLUME = sim.sim_object_volume_type  # type: ignore[attr-defined]
    MILl = sim.sim_object_mill_type  # type: ignore[attr-defined]
    FORCE_SENSOR = sim.sim_object_forcesensor_type  # type: ignore[attr-defined]
    LIGHT = sim.sim_object_light_type  # type: ignore[attr-defined]
    MIRROR = sim.sim_object_mirror_type  # type: ignore[attr-defined]
    OCTREE = sim.sim_object_octree_type


class JointType(Enum):
    REVOLUTE = sim.sim_joint_revolute_subtype  # type: ignore[attr-defined]
    PRISMATIC = sim.sim_joint_prismatic_subtype  # type: ignore[attr-defined]
    SPHERICAL = sim.sim_joint_spherical_subtype  # type: ignore[attr-defined]


class JointMode(Enum):
    PASSIVE = sim.sim_jointmode_passive  # type: ignore[attr-defined]
    IK = sim.sim_jointmode_ik  # type: ignore[attr-defined]
    IK_DEPENDENT = sim.sim_jointmode_ikdependent  # type: ignore[attr-defined]
    DEPENDENT = sim.sim_jointmode_dependent  # type: ignore[attr-defined]
    FORCE = sim.sim_jointmode_force  # type: ignore[attr-defined]


class ConfigurationPathAlgorithms(Enum):
    BiTRRT = "BiTRRT"
    BITstar = "BITstar"
    BKPIECE1 = "BKPIECE1"
    CForest = "CForest"
    EST = "EST"
    FMT = "FMT"
    KPIECE1 = "KPIECE1"
    LazyPRM = "LazyPRM"
    LazyPRMstar = "LazyPRMstar"
    LazyRRT = "LazyRRT"
    LBKPIECE1 = "LBKPIECE1"
    LBTRRT = "LBTRRT"
    PDST = "PDST"
    PRM = "PRM"
    PRMstar = "PRMstar"
    pRRT = "pRRT"
    pSBL = "pSBL"
    RRT = "RRT"
    RRTConnect = "RRTConnect"
    RRTstar = "RRTstar"
    SBL = "SBL"
    SPARS = "SPARS"
    SPARStwo = "SPARStwo"
    STRIDE = "STRIDE"
    TRRT = "TRRT"


class TextureMappingMode(Enum):
    PLANE = sim.sim_texturemap_plane
    CYLINDER = sim.sim_texturemap_cylinder
    SPHERE = sim.sim_texturemap_sphere
    CUBE = sim.sim_texturemap_cube


class PerspectiveMode(Enum):
    ORTHOGRAPHIC = 0
    PERSPECTIVE = 1


class RenderMode(Enum):
    OPENGL = sim.sim_rendermode_opengl  # type: ignore[attr-defined]
    OPENGL_AUXILIARY = sim.sim_rendermode_auxchannels  # type: ignore[attr-defined]
    OPENGL_COLOR_CODED = sim.sim_rendermode_colorcoded  # type: ignore[attr-defined]
    POV_RAY = sim.sim_rendermode_povray  # type: ignore[attr-defined]
    EXTERNAL = sim.sim_rendermode_extrenderer  # type: ignore[attr-defined]
    EXTERNAL_WINDOWED = sim.sim_rendermode_extrendererwindowed  # type: ignore[attr-defined]
    OPENGL3 = sim.sim_rendermode_opengl3  # type: ignore[attr-defined]
    OPENGL3_WINDOWED = sim.sim_rendermode_opengl3windowed  # type: ignore[attr-defined]


class Verbosity(Enum):
    NONE = "none"
    ERRORS = "errors"
    WARNINGS = "warnings"
    LOAD_INFOS = "loadinfos"
    SCRIPT_ERRORS = "scripterrors"
    SCRIPT_WARNINGS = "scriptwarnings"
    SCRIPT_INFOS = "scriptinfos"
    INFOS = "infos"
    DEBUG = "debug"
    TRACE = "trace"
    TRACE_LUA = "tracelua"
    TYRACE_ALL = "traceall"


PYREP_SCRIPT_TYPE = sim.sim_scripttype_addonscript
