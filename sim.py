"""Legacy module name ``sim``: everything of :mod:`simx_client`, for programs that ``import sim``.

Importing it also restores numpy's removed aliases (``np.int``, ``np.float``, ...) where
missing, because the programs written for V-REP use them
(see :func:`simx_client.legacy.restore_numpy_aliases`).
"""

from simx_client import *  # noqa: F401,F403
from simx_client import __all__  # noqa: F401
from simx_client.legacy import restore_numpy_aliases

restore_numpy_aliases()
del restore_numpy_aliases
