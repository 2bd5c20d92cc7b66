"""Legacy module name ``simConst``: every constant of ``simConst.py`` with its value, and the few
that simx adds (:data:`simx_client.constants.SIM_CONSTANTS`)."""

from simx_client.constants import SIM_CONSTANTS as _CONSTANTS

globals().update(_CONSTANTS)
__all__ = sorted(_CONSTANTS)
del _CONSTANTS
