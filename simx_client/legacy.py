"""What importing the legacy module names (``vrep``, ``sim``) does besides re-exporting."""

from __future__ import annotations

import numpy as np

#: numpy aliases removed in numpy 1.24 that legacy programs still use (``np.int`` ...).
NUMPY_ALIASES = {"int": int, "float": float, "bool": bool, "object": object, "str": str}


def restore_numpy_aliases() -> None:
    """Define ``np.int``, ``np.float``, ``np.bool``, ``np.object`` and ``np.str`` where missing,
    as the builtins they aliased, so programs written for V-REP run on a current numpy.

    ``np.bool`` exists again since numpy 2 (as ``np.bool_``) and is left as it is.
    """
    namespace = vars(np)  # not getattr: numpy's module __getattr__ warns about these names
    for name, value in NUMPY_ALIASES.items():
        if name not in namespace:
            setattr(np, name, value)
