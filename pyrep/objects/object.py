"""PyRep's ``Object``: what every scene object has (pose, parent, properties, tree).

Each method is one or a few calls of simx's ``sim`` table (:mod:`pyrep.backend.sim`); poses in
m and rad, Euler angles as CoppeliaSim's alpha, beta, gamma, quaternions as ``[x, y, z, w]``,
``relative_to`` an :class:`Object` or None (the world).
"""

from __future__ import annotations

import warnings
from typing import Any, Union

import numpy as np

from pyrep.backend import sim
from pyrep.const import ObjectType
from pyrep.errors import ObjectAlreadyRemovedError, ObjectIsNotModelError, WrongObjectTypeError

#: Object type -> the PyRep class of that type (filled by each class's module).
object_type_to_class: dict[ObjectType, type] = {}

_PROP = {"collidable": 1, "measurable": 2, "detectable": 496, "renderable": 512}
_MODEL = {"collidable": 1, "measurable": 2, "renderable": 4, "detectable": 8, "dynamic": 32,
          "respondable": 64}
_NOT_MODEL = 0xF000  # sim_modelproperty_not_model


def _rel(relative_to: Any) -> int:
    return -1 if relative_to is None else relative_to.get_handle()


def _handle_of(name: str) -> int:
    """The handle of the object named ``name`` (CoppeliaSim 4.1's ``simGetObjectHandle``:
    ``name`` or ``name#n``)."""
    return int(sim.call("getObjectHandle", name))


class Object(sim.OnItsWorld):
    """An object of the scene, by name or handle, in the world of the PyRep current when it is
    made: its methods act on that world (:class:`pyrep.backend.sim.OnItsWorld`).

    Raises:
        RuntimeError: no object of that name.
        WrongObjectTypeError: the object is not of this class's type.
    """

    def __init__(self, name_or_handle: Union[str, int]):
        self._bind_world()
        self._handle = int(name_or_handle) if isinstance(name_or_handle, int) else _handle_of(name_or_handle)
        wanted = self._get_requested_type()
        actual = ObjectType(sim.call("getObjectType", self._handle))
        if not self._type_ok(actual):
            raise WrongObjectTypeError(
                f"You requested object of type {wanted.name}, but the actual type was {actual.name}")

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Object):
            raise NotImplementedError
        return self.get_handle() == other.get_handle()

    def __hash__(self) -> int:
        return hash(self._handle)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._handle})"

    # ------------------------------------------------------------ lookup
    @staticmethod
    def exists(name: str) -> bool:
        """Whether an object named ``name`` is in the scene."""
        try:
            _handle_of(name)
        except RuntimeError:
            return False
        return True

    @staticmethod
    def get_object_type(name: str) -> ObjectType:
        """The type of the object named ``name``."""
        return ObjectType(sim.call("getObjectType", _handle_of(name)))

    @staticmethod
    def get_object_name(name_or_handle: Union[str, int]) -> str:
        """The name of an object given by handle (a name is returned as is)."""
        if isinstance(name_or_handle, int):
            return str(sim.call("getObjectName", name_or_handle))
        return name_or_handle

    @staticmethod
    def get_object(name_or_handle: Union[str, int]) -> Object:
        """The object as an instance of the class of its type (Shape, Joint...).

        Raises:
            KeyError: a type PyRep has no class for.
        """
        handle = name_or_handle if isinstance(name_or_handle, int) else _handle_of(name_or_handle)
        cls = object_type_to_class[ObjectType(sim.call("getObjectType", handle))]
        return cls(handle)  # type: ignore[no-any-return]

    def _get_requested_type(self) -> ObjectType:
        raise NotImplementedError("Must be overridden.")

    def _type_ok(self, actual: ObjectType) -> bool:
        """Whether an object of type ``actual`` may be taken as this class."""
        return actual == self._get_requested_type()

    def get_type(self) -> ObjectType:
        """This object's type."""
        return ObjectType(sim.call("getObjectType", self._handle))

    def get_handle(self) -> int:
        """The object's handle."""
        return self._handle

    def still_exists(self) -> bool:
        """Whether the object is still in the scene."""
        return bool(sim.call("isHandle", self._handle))

    def get_name(self) -> str:
        """The object's name."""
        return str(sim.call("getObjectName", self._handle))

    def set_name(self, name: str) -> None:
        """Renames the object."""
        sim.call("setObjectName", self._handle, name)

    def scale_object(self, scale_x: float, scale_y: float, scale_z: float) -> None:
        """Scales the object (non-isometric scaling only on shapes that allow it)."""
        sim.call("scaleObject", self._handle, scale_x, scale_y, scale_z, 0)

    def get_size_factor(self) -> float:
        """The object's size factor."""
        return float(sim.call("getObjectSizeFactor", self._handle))

    # ------------------------------------------------------------- pose
    def get_position(self, relative_to: Any = None) -> np.ndarray:
        """Position (3,) in m."""
        return np.array(sim.call("getObjectPosition", self._handle, _rel(relative_to)), dtype=np.float64)

    def set_position(self, position: Any, relative_to: Any = None, reset_dynamics: bool = True) -> None:
        """Sets the position (3,) in m; ``reset_dynamics`` resets the dynamics of the tree."""
        if reset_dynamics:
            self._reset_tree_dynamics()
        sim.call("setObjectPosition", self._handle, _rel(relative_to), [float(v) for v in position])

    def get_orientation(self, relative_to: Any = None) -> np.ndarray:
        """Euler angles (3,) in rad (CoppeliaSim's alpha, beta, gamma)."""
        return np.array(sim.call("getObjectOrientation", self._handle, _rel(relative_to)), dtype=np.float64)

    def set_orientation(self, orientation: Any, relative_to: Any = None, reset_dynamics: bool = True) -> None:
        """Sets the Euler angles (3,) in rad."""
        if reset_dynamics:
            self._reset_tree_dynamics()
        sim.call("setObjectOrientation", self._handle, _rel(relative_to), [float(v) for v in orientation])

    def get_quaternion(self, relative_to: Any = None) -> np.ndarray:
        """Orientation as a quaternion (4,) ``[x, y, z, w]``."""
        return np.array(sim.call("getObjectQuaternion", self._handle, _rel(relative_to)), dtype=np.float64)

    def set_quaternion(self, quaternion: Any, relative_to: Any = None, reset_dynamics: bool = True) -> None:
        """Sets the orientation from a quaternion ``[x, y, z, w]`` (normalised here)."""
        q = np.asarray(quaternion, dtype=np.float64)
        q = q / np.linalg.norm(q)
        if reset_dynamics:
            self._reset_tree_dynamics()
        sim.call("setObjectQuaternion", self._handle, _rel(relative_to), q.tolist())

    def get_pose(self, relative_to: Any = None) -> np.ndarray:
        """Pose (7,): position (m) and quaternion ``[x, y, z, w]`` (``sim.getObjectPose``: the
        object's frame read once)."""
        return np.array(sim.call("getObjectPose", self._handle, _rel(relative_to)), dtype=np.float64)

    def set_pose(self, pose: Any, relative_to: Any = None, reset_dynamics: bool = True) -> None:
        """Sets the pose (7,): position (m) and quaternion ``[x, y, z, w]``."""
        self.set_position(pose[:3], relative_to, reset_dynamics)
        self.set_quaternion(pose[3:], relative_to, reset_dynamics)

    def get_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """Linear (m/s) and angular (rad/s) velocity, each (3,), in the world frame."""
        linear, angular = sim.call("getObjectVelocity", self._handle)
        return np.array(linear, dtype=np.float64), np.array(angular, dtype=np.float64)

    def get_matrix(self, relative_to: Any = None) -> np.ndarray:
        """The (4, 4) homogeneous transform of the object."""
        m = list(sim.call("getObjectMatrix", self._handle, _rel(relative_to)))
        return np.array([m[0:4], m[4:8], m[8:12], [0.0, 0.0, 0.0, 1.0]], dtype=np.float64)  # np.vstack's array, at half its cost

    def set_matrix(self, matrix: Any, relative_to: Any = None) -> None:
        """Sets the pose from a (4, 4) homogeneous transform.

        Raises:
            ValueError: not a (4, 4) matrix.
        """
        m = np.asarray(matrix, dtype=np.float64)
        if m.shape != (4, 4):
            raise ValueError("Expected a 4x4 matrix.")
        sim.call("setObjectMatrix", self._handle, _rel(relative_to), m[:3].flatten().tolist())

    def rotate(self, rotation: Any) -> None:
        """Rotates the object by ``rotation`` (3,) rad about its own z, then y, then x axis."""
        m = self.get_matrix()
        rx, ry, rz = (float(v) for v in rotation)
        local = _rot("x", rx) @ _rot("y", ry) @ _rot("z", rz)  # about the object's axes: z, then y, then x
        m[:3, :3] = m[:3, :3] @ local
        self.set_matrix(m)

    # ----------------------------------------------------------- parent
    def get_parent(self) -> Object | None:
        """The parent object, or None at the scene's root."""
        parent = int(sim.call("getObjectParent", self._handle))
        return None if parent == -1 else Object.get_object(parent)

    def set_parent(self, parent_object: Object | None, keep_in_place: bool = True) -> None:
        """Re-parents the object (None: to the world); ``keep_in_place`` keeps its world pose."""
        parent = -1 if parent_object is None else parent_object.get_handle()
        sim.call("setObjectParent", self._handle, parent, keep_in_place)

    # ------------------------------------------------------- properties
    def _get_property(self, bits: int) -> bool:
        return bool(int(sim.call("getObjectSpecialProperty", self._handle)) & bits)

    def _set_property(self, bits: int, value: bool) -> None:
        current = int(sim.call("getObjectSpecialProperty", self._handle))
        current = current | bits if value else current & ~bits
        sim.call("setObjectSpecialProperty", self._handle, current)

    def is_collidable(self) -> bool:
        return self._get_property(_PROP["collidable"])

    def set_collidable(self, value: bool) -> None:
        self._set_property(_PROP["collidable"], value)

    def is_measurable(self) -> bool:
        return self._get_property(_PROP["measurable"])

    def set_measurable(self, value: bool) -> None:
        self._set_property(_PROP["measurable"], value)

    def is_detectable(self) -> bool:
        return self._get_property(_PROP["detectable"])

    def set_detectable(self, value: bool) -> None:
        self._set_property(_PROP["detectable"], value)

    def is_renderable(self) -> bool:
        return self._get_property(_PROP["renderable"])

    def set_renderable(self, value: bool) -> None:
        self._set_property(_PROP["renderable"], value)

    def is_model(self) -> bool:
        """Whether the object is a model's base."""
        return not int(sim.call("getModelProperty", self._handle)) & _NOT_MODEL

    def set_model(self, value: bool) -> None:
        """Makes the object a model's base (True) or not."""
        current = int(sim.call("getModelProperty", self._handle))
        current = current & ~_NOT_MODEL if value else current | _NOT_MODEL
        sim.call("setModelProperty", self._handle, current)

    def _check_model(self) -> None:
        if not self.is_model():
            raise ObjectIsNotModelError(f"Object '{self.get_name()}' is not a model. Use 'set_model(True)'.")

    def _get_model_property(self, bits: int) -> bool:
        self._check_model()
        return not int(sim.call("getModelProperty", self._handle)) & bits

    def _set_model_property(self, bits: int, value: bool) -> None:
        self._check_model()
        current = int(sim.call("getModelProperty", self._handle))
        current = current & ~bits if value else current | bits
        sim.call("setModelProperty", self._handle, current)

    def is_model_collidable(self) -> bool:
        return self._get_model_property(_MODEL["collidable"])

    def set_model_collidable(self, value: bool) -> None:
        self._set_model_property(_MODEL["collidable"], value)

    def is_model_measurable(self) -> bool:
        return self._get_model_property(_MODEL["measurable"])

    def set_model_measurable(self, value: bool) -> None:
        self._set_model_property(_MODEL["measurable"], value)

    def is_model_detectable(self) -> bool:
        return self._get_model_property(_MODEL["detectable"])

    def set_model_detectable(self, value: bool) -> None:
        self._set_model_property(_MODEL["detectable"], value)

    def is_model_renderable(self) -> bool:
        return self._get_model_property(_MODEL["renderable"])

    def set_model_renderable(self, value: bool) -> None:
        self._set_model_property(_MODEL["renderable"], value)

    def is_model_dynamic(self) -> bool:
        return self._get_model_property(_MODEL["dynamic"])

    def set_model_dynamic(self, value: bool) -> None:
        self._set_model_property(_MODEL["dynamic"], value)

    def is_model_respondable(self) -> bool:
        return self._get_model_property(_MODEL["respondable"])

    def set_model_respondable(self, value: bool) -> None:
        self._set_model_property(_MODEL["respondable"], value)

    # ---------------------------------------------------- scene editing
    def remove(self) -> None:
        """Removes the object (a model: with its tree).

        Raises:
            ObjectAlreadyRemovedError: it was removed already.
        """
        try:
            if self.is_model():
                sim.call("removeModel", self._handle)
            else:
                sim.call("removeObjects", [self._handle])
        except RuntimeError as exc:
            raise ObjectAlreadyRemovedError("The object/model was already deleted.") from exc

    def copy(self) -> Object:
        """A copy of the object (with its tree when it is a model), of the same class."""
        return self.__class__(int(sim.call("copyPasteObjects", [self._handle], 0)[0]))

    def save_model(self, path: str) -> None:
        """Saves the model based at this object to a .ttm/.simmodel file (simx writes its own format)."""
        self._check_model()
        sim.call("saveModel", self._handle, path)

    def reset_dynamic_object(self) -> None:
        """Re-creates the object in the physics engine at its current pose."""
        sim.call("resetDynamicObject", self._handle)

    def _reset_tree_dynamics(self) -> None:
        with sim.one_change():  # one mj_forward for the tree, not one per object
            for h in sim.call("getObjectsInTree", self._handle, sim.sim_handle_all, 0):  # type: ignore[attr-defined]
                sim.call("resetDynamicObject", h)

    # ------------------------------------------------------- geometry
    def get_bounding_box(self) -> list[float]:
        """``[min_x, max_x, min_y, max_y, min_z, max_z]`` (m) in the object's frame."""
        return self._float_params(15, 18, 16, 19, 17, 20)  # sim_objfloatparam_objbbox_*

    def get_model_bounding_box(self) -> list[float]:
        """The model's bounding box, as :meth:`get_bounding_box`."""
        self._check_model()
        return self._float_params(21, 24, 22, 25, 23, 26)  # sim_objfloatparam_modelbbox_*

    def _float_params(self, *params: int) -> list[float]:
        return [float(sim.call("getObjectFloatParam", self._handle, p)) for p in params]

    def get_extension_string(self) -> str:
        """The object's extension string (additional properties written in the scene)."""
        return str(sim.call("getExtensionString", self._handle, -1, ""))

    def get_configuration_tree(self) -> bytes:
        """The poses and joint values of the object's tree, for :meth:`PyRep.set_configuration_tree`."""
        return bytes(sim.call("getConfigurationTree", self._handle))

    def check_collision(self, obj: Object | None = None) -> bool:
        """Whether this object collides with ``obj`` (None: with any collidable object)."""
        other = sim.sim_handle_all if obj is None else obj.get_handle()  # type: ignore[attr-defined]
        result = sim.call("checkCollision", self._handle, other)
        return bool(result[0] if isinstance(result, (list, tuple)) else result)

    def get_contact(self, contact_obj: Object | None = None, get_contact_normal: bool = True) -> list:
        """The contacts of this object: dicts with ``contact`` (position 3, force 3, normal 3 when
        ``get_contact_normal``) and ``contact_handles`` (the two objects); only those with
        ``contact_obj`` when given."""
        found = []
        index = 0
        while True:
            info = sim.call("getContactInfo", sim.sim_handle_all, self._handle, index)  # type: ignore[attr-defined]
            if not info or not info[0]:
                break
            handles, point, force = info[0], info[1], info[2]
            normal = info[3] if len(info) > 3 else [0.0, 0.0, 0.0]
            contact = list(point) + list(force) + (list(normal) if get_contact_normal else [])
            found.append({"contact": np.array(contact), "contact_handles": list(handles)[:2]})
            index += 1
        if contact_obj is None:
            return found
        other = contact_obj.get_handle()
        return [c for c in found if other in c["contact_handles"]]

    def check_distance(self, other: Object) -> float:
        """The minimum distance (m) between this object and ``other``."""
        result = sim.call("checkDistance", self._handle, other.get_handle(), 0)
        return float(result[1][6])

    def get_bullet_friction(self) -> float:
        """The friction coefficient of the shape (Bullet's parameter; MuJoCo's sliding friction)."""
        return float(sim.call("getEngineFloatParam", sim.sim_bullet_body_friction, self._handle))

    def set_bullet_friction(self, friction: float) -> None:
        """Sets the friction coefficient (MuJoCo's sliding friction of the shape's geoms)."""
        sim.call("setEngineFloatParam", sim.sim_bullet_body_friction, self._handle, float(friction))

    def get_explicit_handling(self) -> int:
        """The explicit-handling flags."""
        return int(sim.call("getExplicitHandling", self._handle))

    def set_explicit_handling(self, value: int) -> None:
        """Sets the explicit-handling flags (1: handled only by ``handle_explicitly``)."""
        sim.call("setExplicitHandling", self._handle, int(value))

    # ------------------------------------------------------------ tree
    @staticmethod
    def _get_objects_in_tree(root_object: Any = None, object_type: ObjectType = ObjectType.ALL,
                             exclude_base: bool = True, first_generation_only: bool = False) -> list[Object]:
        if root_object is None:
            root = sim.sim_handle_scene
        elif isinstance(root_object, Object):
            root = root_object.get_handle()
        elif isinstance(root_object, int):
            root = root_object
        else:
            raise ValueError("root_object must be None, int or Object")
        options = (1 if exclude_base else 0) | (2 if first_generation_only else 0)
        objects = []
        for handle in sim.call("getObjectsInTree", root, object_type.value, options):
            try:
                objects.append(Object.get_object(int(handle)))
            except (KeyError, ValueError):
                warnings.warn(f"Object ({handle}, '{Object.get_object_name(int(handle))}') has a type "
                              "PyRep does not support", stacklevel=2)
        return objects

    def get_objects_in_tree(self, *args: Any, **kwargs: Any) -> list[Object]:
        """The objects of this object's tree (``object_type``, ``exclude_base=True``,
        ``first_generation_only=False``)."""
        return self._get_objects_in_tree(self._handle, *args, **kwargs)


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
