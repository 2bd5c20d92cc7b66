"""``simIK`` over the ZMQ remote API, as far as it maps onto the scene's IK groups.

CoppeliaSim 4.x's ``simIK`` builds IK environments from the scene; simx solves the groups the
scene declares (``simx:ik:NAME``, README "Inverse kinematics", :mod:`simx_server.sim.ik`) every
step, and child scripts reach them through ``sim.handleIkGroup``. A remote program gets the
same mapping Lua child scripts get: one environment (0) that is the scene, groups by the names
the scene gives them, ``handleGroup`` solving one now. Every other ``simIK`` function answers an
error that names it (:mod:`simx_server.zmq.names` lists them).
"""

from __future__ import annotations

from typing import Any

from simx_wire.protocol import ArgumentError
from simx_server.base.arguments import as_integer as _int, as_text as _text

#: The one IK environment: the scene.
SCENE_ENVIRONMENT = 0


class RemoteSimIK:
    """``simIK.*`` on top of a :class:`~simx_server.zmq.remote_sim.RemoteSim` (its IK calls)."""

    def __init__(self, sim: Any):
        self._sim = sim

    @staticmethod
    def _env(environment: Any) -> None:
        if _int(environment, "environmentHandle") != SCENE_ENVIRONMENT:
            raise ArgumentError(f"simx has one IK environment, {SCENE_ENVIRONMENT} (the scene's IK groups)")

    def createEnvironment(self, flags: Any = 0) -> int:  # noqa: N802 (CoppeliaSim's names)
        """The scene's IK environment (0): its groups are the scene's ``simx:ik:NAME``."""
        return SCENE_ENVIRONMENT

    def eraseEnvironment(self, environmentHandle: Any) -> None:  # noqa: N802, N803
        """Nothing to erase: the scene's environment lives as long as the scene."""
        self._env(environmentHandle)

    def getGroupHandle(self, environmentHandle: Any, ikGroupName: Any) -> int:  # noqa: N802, N803
        """The handle of the scene's IK group ``ikGroupName``; an error when it has none."""
        self._env(environmentHandle)
        return self._sim.getIkGroupHandle(_text(ikGroupName, "ikGroupName"))

    def doesGroupExist(self, environmentHandle: Any, ikGroupName: Any) -> bool:  # noqa: N802, N803
        self._env(environmentHandle)
        try:
            self._sim.getIkGroupHandle(_text(ikGroupName, "ikGroupName"))
        except Exception:
            return False
        return True

    def handleGroup(self, environmentHandle: Any, ikGroupHandle: Any, options: Any = None) -> int:  # noqa: N802, N803
        """Solve the group now (its joints' target positions move; the physics follows at the
        next step): ``simIK.result_success`` (1) or ``result_fail`` (2). ``options`` ignored."""
        self._env(environmentHandle)
        return self._sim.handleIkGroup(ikGroupHandle)

    def applySceneToIkEnvironment(self, environmentHandle: Any, ikGroupHandle: Any = None) -> None:  # noqa: N802, N803
        """Nothing to copy: the environment is the scene."""
        self._env(environmentHandle)

    def applyIkEnvironmentToScene(self, environmentHandle: Any, ikGroupHandle: Any,  # noqa: N802, N803
                                  applyOnlyWhenSuccessful: Any = False) -> int:  # noqa: N803
        """Solve the group (as :meth:`handleGroup`)."""
        return self.handleGroup(environmentHandle, ikGroupHandle)
