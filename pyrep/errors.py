"""PyRep's exceptions (``pyrep.errors``), raised by simx's ``pyrep`` where PyRep raises them."""


class PyRepError(Exception):
    """A PyRep call that cannot be done (PyRep's base error)."""


class WrongObjectTypeError(Exception):
    """An object asked for as one type (``Shape('name')``) is of another."""


class ObjectAlreadyRemovedError(Exception):
    """The object was removed from the scene already."""


class ObjectIsNotModelError(Exception):
    """A model operation on an object that is not a model."""


class ConfigurationError(Exception):
    """No joint configuration reaches the asked pose (IK failed)."""


class ConfigurationPathError(Exception):
    """No collision-free path to the asked configuration was found."""


class GripperError(Exception):
    """A gripper operation failed."""


class IKError(Exception):
    """Inverse kinematics failed."""


class CoppeliaSimError(RuntimeError):
    """A call refused by the simulation (bad handle, bad argument): PyRep's backend raises it as
    a RuntimeError, so ``except RuntimeError`` keeps working."""
