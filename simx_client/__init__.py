"""simx client: a drop-in replacement for V-REP's ``vrep.py`` / CoppeliaSim's ``sim.py``.

``import simx_client as vrep`` (or plain ``import vrep`` / ``import sim`` once simx is
installed) gives every legacy ``simx*`` function and ``simx_*`` / ``sim_*`` constant.
The client needs only zenoh, msgpack and numpy (no MuJoCo).
"""

from simx_client import api as _api
from simx_client import constants as _constants
from simx_client.api import *  # noqa: F401,F403
from simx_client.constants import *  # noqa: F401,F403

__all__ = sorted(
    [n for n in vars(_api) if n.startswith("simx") and callable(getattr(_api, n))]
    + [n for n in vars(_constants) if n.startswith(("simx_", "sim_", "SIMX_"))]
)
