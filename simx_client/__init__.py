"""simx client: a drop-in replacement for V-REP's ``vrep.py`` / CoppeliaSim's ``sim.py``.

``import simx_client as vrep`` (or plain ``import vrep`` / ``import sim`` once simx is
installed) gives every legacy ``simx*`` function and ``simx_*`` / ``sim_*`` constant
(every constant of ``vrepConst.py`` / ``simConst.py``: see :mod:`simx_wire.constants`).
The client needs only zenoh, msgpack and numpy (no MuJoCo).

The wire schema that client and server share lives in the neutral package :mod:`simx_wire`.
Its modules stay importable under their old names, ``simx_client.protocol``,
``simx_client.constants``, ``simx_client.decoded_size`` and ``simx_client.legacy_constants``:
each of those names is the :mod:`simx_wire` module itself (the same module object, so a
monkeypatch through either name is seen by both sides), registered in :data:`sys.modules` here.
The client starts local servers through one place only, :mod:`simx_client.servers`.
"""

import sys as _sys

from simx_wire import constants, decoded_size, legacy_constants, protocol

# The old module names, before anything below imports them.
for _module in (constants, decoded_size, legacy_constants, protocol):
    _sys.modules[f"{__name__}.{_module.__name__.rpartition('.')[2]}"] = _module
del _module

from simx_client.api import *  # noqa: E402,F401,F403
from simx_wire.constants import *  # noqa: E402,F401,F403
from simx_client.legacy import legacy_names as _legacy_names  # noqa: E402

__all__ = _legacy_names(constants.__all__)
