"""simx client: a drop-in replacement for V-REP's ``vrep.py`` / CoppeliaSim's ``sim.py``.

``import simx_client as vrep`` (or plain ``import vrep`` / ``import sim`` once simx is
installed) gives every legacy ``simx*`` function and ``simx_*`` / ``sim_*`` constant
(every constant of ``vrepConst.py`` / ``simConst.py``: see :mod:`simx_client.constants`).
The client needs only zenoh, msgpack and numpy (no MuJoCo).
"""

from simx_client import constants as _constants
from simx_client.constants import *  # noqa: F401,F403

_SUBMODULES = {p.stem for p in __import__("pathlib").Path(__file__).parent.iterdir()
               if p.suffix == ".py" or (p / "__init__.py").exists()}


def __getattr__(name: str):
    """The ``simx*`` functions (and ``__all__``, which lists them) on first use (PEP 562):
    :mod:`simx_client.api` is imported then, not with the package. ``simx-server`` imports
    :mod:`simx_client.protocol`, and so this package, at every start; the client's connection,
    images and refusal probe (ssl) are not its to import (the test suite starts about 140
    servers). ``import simx_client as vrep; vrep.simxStart(...)``, ``from simx_client import *``
    and ``from simx_client import simxStart`` all come here the first time."""
    if (name.startswith("__") and name != "__all__") or name in _SUBMODULES:
        raise AttributeError(name)  # a submodule not imported yet: the import system imports it
    from simx_client import api
    from simx_client.legacy import legacy_names

    names = globals()
    for key, value in vars(api).items():  # as `from simx_client.api import *` did, constants kept
        if not key.startswith("_") and key not in names:
            names[key] = value
    names.setdefault("__all__", legacy_names(_constants.__all__))
    if name not in names:
        raise AttributeError(f"module 'simx_client' has no attribute {name!r}")
    return names[name]
