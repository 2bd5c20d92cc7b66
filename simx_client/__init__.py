"""simx client: a drop-in replacement for V-REP's ``vrep.py`` / CoppeliaSim's ``sim.py``.

``import simx_client as vrep`` (or plain ``import vrep`` / ``import sim`` once simx is
installed) gives every legacy ``simx*`` function and ``simx_*`` / ``sim_*`` constant
(every constant of ``vrepConst.py`` / ``simConst.py``: see :mod:`simx_client.constants`).
The client needs only zenoh, msgpack and numpy (no MuJoCo).
"""

from simx_client import constants as _constants
from simx_client.api import *  # noqa: F401,F403
from simx_client.constants import *  # noqa: F401,F403
from simx_client.legacy import legacy_names as _legacy_names

__all__ = _legacy_names(_constants.__all__)
