"""CoppeliaSim's ``simIK`` API on MuJoCo: environments and groups (:mod:`.environments`), the
calls over them (:mod:`.calls`), joints' transforms, dependencies and chain Jacobians
(:mod:`.chains`), an environment's own dummies (:mod:`.dummies`), saving and loading an
environment (:mod:`.storage`); importing this package registers every ``simIK.NAME`` in :data:`simx_server.api.registry.SIMIK`."""

from __future__ import annotations

from simx_server.api.registry import SIMIK
from simx_server.api.simik import calls, chains, dummies, environments, search, storage  # noqa: F401 (each module registers its functions)
from simx_server.api.simik.environments import CONSTANTS

SIMIK.constants.update(CONSTANTS)

#: Names of every ``simIK`` function.
FUNCTIONS: tuple[str, ...] = SIMIK.names()
