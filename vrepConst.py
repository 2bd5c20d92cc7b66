"""Legacy module name ``vrepConst``: the remote API constants (see :mod:`simx_client.constants`)."""

from simx_client.constants import *  # noqa: F401,F403
