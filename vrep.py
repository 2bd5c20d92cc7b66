"""Legacy module name ``vrep``: everything of :mod:`simx_client`, for programs that ``import vrep``:
every ``simx*`` function and every constant of ``vrepConst.py`` (module ``vrepConst``).

Importing it also restores numpy's removed aliases (``np.int``, ``np.float``, ...) where
missing, because the programs written for V-REP use them
(see :func:`simx_client.legacy.restore_numpy_aliases`).
"""

import vrepConst as _constants
from simx_client import *  # noqa: F401,F403
from simx_client.legacy import legacy_names, restore_numpy_aliases
from vrepConst import *  # noqa: F401,F403 (vrepConst.py's values, where the two files would differ)

__all__ = legacy_names(_constants.__all__)
restore_numpy_aliases()
del legacy_names, restore_numpy_aliases
