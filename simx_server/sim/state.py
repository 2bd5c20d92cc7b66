"""The run state of a simulation, and what the lower layers may read of a simulation.

:class:`RunState` is V-REP's stopped / running / paused state, decided by
:class:`simx_server.scene.simulation.Simulation` (``simxStartSimulation``, ``simxPauseSimulation``,
``simxStopSimulation``). :class:`SimulationView` is the part of that simulation that the sensor,
parameter and script code below the scene layer reads: they receive the simulation as an argument
and type it with this protocol, so that no lower module imports the scene layer.
"""

from __future__ import annotations

import enum
from typing import Any, Protocol

from simx_wire import protocol as P
from simx_server.sim.vision import VisionSensors
from simx_server.sim.world import World


class RunState(enum.Enum):
    """Run state of the simulation. Each value is the state's V-REP server-state bits
    (``simx_headeroffset_server_state``), so that stamping a reply reads no table."""
    STOPPED = 0
    RUNNING = P.STATE_SIM_NOT_STOPPED
    PAUSED = P.STATE_SIM_NOT_STOPPED | P.STATE_SIM_PAUSED


class SimulationView(Protocol):
    """What code below the scene layer reads of the running simulation.

    Attributes:
        world: the MuJoCo model and data with V-REP's object registry.
        vision: the vision sensors' renderers.
        sensors: sensor state kept between reads (broken force sensors, passive images):
            a :class:`simx_server.sim.sensors.SensorState` (whose module reads this one).
        state: the run state.
        scripts: the scene's child scripts (:class:`simx_server.scripts.scene_scripts.Scripts`).
        editor: the scene editor (:class:`simx_server.scene.editor.Editor`).
        selection: the object selection (``simxGetObjectSelection``), handles.
    """
    world: World
    vision: VisionSensors
    sensors: Any
    state: RunState
    scripts: Any
    editor: Any
    selection: list[int]

    def request(self, state: RunState) -> int:
        """A script's stop or pause, carried out once the current pass is over
        (``Simulation.request``).

        Args:
            state: ``RunState.STOPPED`` or ``RunState.PAUSED``.

        Returns:
            1 when requested, 0 when it cannot be.
        """
        ...

    def apply_requests(self) -> None:
        """Carry out a script's stop or pause request, if one is due."""
        ...

    def legacy_parameter(self, kind: str, pid: int, *value: Any) -> Any:
        """The legacy API's parameter ``pid`` (``simxGetIntegerParameter``...), or set it.

        Args:
            kind: ``"integer"``, ``"float"``, ``"boolean"``, ``"string"`` or ``"array"``.
            pid: the parameter's id.
            value: the new value, to set it.

        Returns:
            The value (None when set).
        """
