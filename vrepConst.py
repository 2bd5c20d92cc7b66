"""Legacy module name ``vrepConst``: every constant of ``vrepConst.py`` with its value, and the few
that simx adds (:data:`simx_client.constants.VREP_CONSTANTS`)."""

from simx_client.constants import VREP_CONSTANTS as _CONSTANTS

globals().update(_CONSTANTS)
__all__ = sorted(_CONSTANTS)
del _CONSTANTS
