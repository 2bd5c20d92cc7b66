"""What the legacy module names (``vrep``, ``sim``) share: their ``__all__`` and numpy's old aliases."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

#: numpy aliases removed in numpy 1.24 that legacy programs still use (``np.int`` ...).
NUMPY_ALIASES = {"int": int, "float": float, "bool": bool, "object": object, "str": str}


def legacy_names(constants: Iterable[str]) -> list[str]:
    """``__all__`` of a legacy module: every ``simx*`` function of :mod:`simx_client.api` and
    the names ``constants`` (those of vrepConst.py or simConst.py), sorted.

    Args:
        constants: the constants' names.

    Returns:
        The names.
    """
    from simx_client import api

    functions = [n for n in vars(api) if n.startswith("simx") and callable(getattr(api, n))]
    return sorted({*functions, *constants})


def restore_numpy_aliases() -> None:
    """Define ``np.int``, ``np.float``, ``np.bool``, ``np.object`` and ``np.str`` where missing,
    as the builtins they aliased, so programs written for V-REP run on a current numpy.

    ``np.bool`` exists again since numpy 2 (as ``np.bool_``) and is left as it is.
    """
    namespace = vars(np)  # not getattr: numpy's module __getattr__ warns about these names
    for name, value in NUMPY_ALIASES.items():
        if name not in namespace:
            setattr(np, name, value)
