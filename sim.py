"""Legacy module name ``sim``: everything of :mod:`simx_client`, for programs that ``import sim``:
every ``simx*`` function and every constant of ``simConst.py`` (module ``simConst``).

Importing it also restores numpy's removed aliases (``np.int``, ``np.float``, ...) where
missing, because the programs written for V-REP use them
(see :func:`simx_client.legacy.restore_numpy_aliases`).
"""

import simConst as _constants
from simx_client import *  # noqa: F401,F403
from simx_client.legacy import legacy_names, restore_numpy_aliases
from simConst import *  # noqa: F401,F403 (simConst.py's values, where the two files would differ)

__all__ = legacy_names(_constants.__all__)
restore_numpy_aliases()
del legacy_names, restore_numpy_aliases
