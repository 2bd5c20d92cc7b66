"""The simulation's run state: world, vision sensors and child scripts behind V-REP's
start / pause / stop and synchronous (stepped) mode. No transport in here.
"""

from __future__ import annotations

import logging
import zlib
from typing import Any, Callable
from pathlib import Path

from simx_wire import protocol as P
from simx_server.base import limits
from simx_server.base.scene_guard import transfer_folders
from simx_server.scene import custom_data, parameters
from simx_server.scene.editor import Editor
from simx_server.scene.ttt import cache as ttt_cache
from simx_server.api.sim import shape_import as shapes
from simx_server.api.signals import Signals
from simx_server.api.sim.legacy_data import RemoteApiPorts
from simx_server.scripts.scene_scripts import Scripts
from simx_server.sim import ik, kept_objects, scene_collections
from simx_server.sim.physics import PhysicsError
from simx_server.sim.sensors import SensorState
from simx_server.sim.state import RunState
from simx_server.sim.vision import VisionSensors
from simx_server.sim.world import World

log = logging.getLogger("simx.simulation")


#: Kind -> (getter, setter) of the legacy API's parameters.
_LEGACY_PARAMETERS = {"integer": (parameters.get_integer, parameters.set_integer),
                      "float": (parameters.get_floating, parameters.set_floating),
                      "boolean": (parameters.get_boolean, parameters.set_boolean),
                      "string": (parameters.get_string, parameters.set_string),
                      "array": (parameters.get_array, parameters.set_array)}


class Simulation:
    """A scene and its run state.

    Args:
        scene: MJCF file.
        dt: simulation step in s; None: the scene's saved step (a .ttt's), else 0.05 (``--dt``).
        realtime: whether asynchronous mode paces steps to wall time (the server's --speed > 0);
            None: the scene's saved real-time mode, else True.
        allow_remote_code: let child scripts run code sent by clients (--allow-remote-code).
        allow_unsafe_lua: give Lua child scripts files, processes and the environment (--allow-unsafe-lua).
        allow_python_scripts: run the scene's Python scripts, with the server's rights
            (--allow-python-scripts); off: each is refused with one log line, the rest loads.
        scene_paths: folders server-side scenes and models may be loaded from, besides the
            scene's own folder (--scene-path).
        renderers_at_load: make the vision sensors' renderers at load, so that the first image
            is fast (False: at the first image, 0.4-0.5 s of CPU saved per start; --renderers).

    Raises:
        ValueError: the scene or one of its scripts cannot be loaded.
    """

    def __init__(self, scene: str | Path, dt: float | None = None, realtime: bool | None = None,
                 allow_remote_code: bool = False, allow_unsafe_lua: bool = False, scene_paths=(),
                 renderers_at_load: bool = True, allow_python_scripts: bool = False):
        name = None
        if ttt_cache.is_vrep_file(scene):  # a V-REP .ttt/.ttm: its (cached) MJCF conversion
            name = Path(scene).name  # messages name the user's file, not the cache's
            scene = ttt_cache.mjcf_for(scene)
        #: The step the server was told (``--dt``), None: each scene's own (its saved step).
        self.dt_override = dt
        self.world = World(scene, dt, name=name)
        scene_collections.of(self.world)  # the scene's collections: a wrong declaration is logged now
        self.vision = VisionSensors(self.world, at_load=renderers_at_load)
        self.signals = Signals()  # shared by every client and child script
        # The operator's scene is trusted, but no file that came through a transfer folder is.
        self.scripts = Scripts(self.world, self.signals, allow_remote_code=allow_remote_code,
                               allow_unsafe_lua=allow_unsafe_lua, untrusted=transfer_folders(), simulation=self,
                               allow_python_scripts=allow_python_scripts)
        self.sensors = SensorState()
        self.editor = Editor(self, scene_paths)  # scene editing (MjSpec) and the transfer folder
        self.state = RunState.STOPPED
        self.realtime = realtime if realtime is not None else self.speed() > 0
        #: s of wall time between two asynchronous passes when not real time: a display frame
        #: (limits.DISPLAY_FRAME_RATE) for a scene saved not real time and no ``--speed``, else 0
        #: (as fast as possible).
        self.frame_interval = (1.0 / limits.DISPLAY_FRAME_RATE
                               if realtime is None and self.world.scene_settings.speed == 0 else 0.0)
        #: Stepped mode: some client enabled it, so a step runs only when every such client
        #: has triggered (:meth:`enable_sync`, :meth:`trigger`). Read it, never set it.
        self.synchronous = False
        self._sync: dict[str, bool] = {}  # synchronous client -> triggered since the last step
        self.steps = 0
        self._scene_id: tuple[World | None, int] = (None, 0)
        self.stop_requests = 0  # sim_intparam_stop_request_counter
        self._requested: RunState | None = None  # a script's stop or pause, due at the end of its pass
        self._phase = ""  # "starting" (scripts' init) or "stopping" (their cleanup), else ""
        #: ``post(job)``: run ``job()`` on the simulation thread (thread-safe), given by the loop
        #: that serves it (simx_server.loop.tasks.attach); None in-process: .ttt loads then wait.
        self.post: Callable[[Callable[[], Any]], None] | None = None
        self.selection: list[int] = []  # simxGetObjectSelection (no GUI: only what clients set)
        #: Why the simulation last stopped by itself (a physics blow-up), None after a start.
        self.stop_reason: str | None = None
        self.remote_api = RemoteApiPorts()  # ports scripts ask the legacy remote API to serve
        #: Custom data blocks, ``{handle: {tag: bytes}}``: the scene's own, then what scripts and
        #: clients write (sim.writeCustomDataBlock and co.)
        self.custom_data: dict[int, dict[str, bytes]] = {}
        custom_data.install(self, custom_data.load(self.world))
        self.scripts.open()  # customization scripts run from the scene's load

    def speed(self, given: float | None = None) -> float:
        """The asynchronous real-time factor: ``given`` (``--speed``) when not None, else the
        scene's saved real-time mode (its multiplier, 0 when off: not paced to wall time, see
        :attr:`frame_interval`), else 1."""
        if given is not None:
            return given
        saved = self.world.scene_settings.speed
        return 1.0 if saved is None else saved

    def pacing_text(self, dt: float | None, speed: float | None) -> str:
        """The ready line's part about the step and the pacing, given ``--dt`` / ``--speed``
        (None: not given): ``dt 0.01 s (the scene's)``, and ``real time x2 (the scene's)`` or
        ``a pass per 60 Hz display frame (the scene's not real time ...)`` where the scene's saved
        real-time mode applies."""
        saved = self.world.scene_settings
        text = f"dt {self.world.dt:g} s" + (" (the scene's)" if dt is None and saved.dt is not None else "")
        if speed is None and saved.speed is not None:
            text += ", " + (f"real time x{saved.speed:g} (the scene's)" if saved.speed > 0 else
                            f"a pass per {limits.DISPLAY_FRAME_RATE:g} Hz display frame (the scene's not real "
                            "time, as CoppeliaSim's window runs it; --speed 0: as fast as possible)")
        return text

    @property
    def scene_id(self) -> int:
        """Identifies the loaded scene (simx_headeroffset_scene_id): 16 bits of its path's hash."""
        if self._scene_id[0] is not self.world:  # scene editing may have loaded another scene
            self._scene_id = (self.world, zlib.crc32(str(self.world.scene_path).encode()) & 0xFFFF)
        return self._scene_id[1]

    @property
    def sim_time_ms(self) -> int:
        """Simulation time in ms, 0 while stopped (as V-REP stamps its replies)."""
        return self.stamp()[0]

    @property
    def server_state(self) -> int:
        """V-REP's server-state bits: 1 not stopped, 2 paused, 4 real time."""
        return self.stamp()[1]

    def stamp(self) -> tuple[int, int, int]:
        """``(sim_time_ms, server_state, scene_id)``: the stamp of every reply.

        Hot path (every reply): one read of the state's bits, of the clock and of the scene id.
        """
        bits = self.state._value_  # the not-stopped and paused bits
        time_ms = round(self.world.time * 1000) if bits else 0
        if self.realtime:
            bits |= P.STATE_REALTIME
        return time_ms, bits, self.scene_id

    def legacy_parameter(self, kind: str, pid: int, *value: Any) -> Any:
        """The legacy API's parameter ``pid`` (``simxGetIntegerParameter``...: the headless mouse,
        the stop counter; :mod:`simx_server.scene.parameters`), or set it when ``value`` is given.

        Args:
            kind: ``"integer"``, ``"float"``, ``"boolean"``, ``"string"`` or ``"array"``.
            pid: the parameter's id.
            value: the new value, to set it.

        Returns:
            The value (None when set).

        Raises:
            UnsupportedError: an id the legacy API does not answer.
        """
        get, set_ = _LEGACY_PARAMETERS[kind]
        return set_(self, pid, *value) if value else get(self, pid)

    def start(self) -> None:
        """``simxStartSimulation``: from stopped, run the scripts' init; from paused, resume."""
        if self.state is RunState.STOPPED:
            self.stop_reason = None
            self._requested = None
            self._phase = "starting"  # a stop asked in sysCall_init comes after the first pass
            kept_objects.simulation_started(self.world)  # paths' positions, cameras' optics
            try:
                self.scripts.start()
            finally:
                self._phase = ""
        self.state = RunState.RUNNING

    def request(self, state: RunState) -> int:
        """A script's ``sim.stopSimulation`` (``state`` STOPPED) or ``sim.pauseSimulation``
        (PAUSED): as in CoppeliaSim, a request that takes effect once the current pass is over
        (the end of this step, or of the client's call into a script that made it), never in
        the middle of the script that asks; a stop outranks a pause.

        Args:
            state: ``RunState.STOPPED`` or ``RunState.PAUSED``.

        Returns:
            1 when requested, 0 when it cannot be (stopped already; a pause when not running).
        """
        if self._phase == "stopping":  # asked in sysCall_cleanup: stopping already
            return 0
        running = self.state is RunState.RUNNING or self._phase == "starting"
        if not running and (self.state is RunState.STOPPED or state is RunState.PAUSED):
            return 0
        if self._requested is not RunState.STOPPED:
            self._requested = state
        return 1

    def apply_requests(self) -> None:
        """Carry out a script's stop or pause request (:meth:`request`), if one is due."""
        requested, self._requested = self._requested, None
        if requested is RunState.STOPPED:
            self.stop()
        elif requested is RunState.PAUSED:
            self.pause()

    def pause(self) -> None:
        """``simxPauseSimulation``: keeps the state; ignored while stopped (as V-REP)."""
        if self.state is RunState.RUNNING:
            self.state = RunState.PAUSED

    def stop(self) -> None:
        """``simxStopSimulation``: scripts' cleanup, then the scene back to its initial state."""
        self.stop_requests += 1
        self._halt()

    def _halt(self) -> None:
        if self.state is RunState.STOPPED:
            return
        self._phase = "stopping"
        try:
            self.scripts.stop()
        finally:
            self._phase = ""
        imported = shapes.imported_poses(self.world)  # shapes imported while running stay in place
        self.world.reset()
        shapes.restore_poses(self.world, imported)
        self.vision.reset()  # clipping planes changed by clients
        kept_objects.simulation_ended(self.world)  # paths' positions, cameras' optics
        self.state = RunState.STOPPED
        self._requested = None  # asked during the cleanup: stopped already
        for client in self._sync:  # triggers given before the stop do not count for the next run
            self._sync[client] = False

    def step(self) -> None:
        """One simulation step of dt: actuation scripts, IK groups, physics, sensing scripts;
        then a stop or pause a script asked for in it (:meth:`request`).

        Raises:
            physics.PhysicsError: the physics blew up (MuJoCo found NaN, infinite or huge
                values). The simulation is then already stopped as on ``simxStopSimulation``
                (scripts' cleanup, the scene's initial state) and ``stop_reason`` says why; the
                server logs it once and tells each client (``simxStartSimulation`` runs again).
        """
        self.scripts.actuation()
        ik.step(self.world)  # IK groups, after the scripts' actuation, before physics (V-REP's main script)
        try:
            self.world.step()
        except PhysicsError as exc:
            self._halt()
            self.stop_reason = f"{exc}; simulation stopped and reset to the scene's initial state " \
                               "(simxStartSimulation starts it again)"
            raise
        self.scripts.sensing()
        self.steps += 1
        if self._requested is not None:  # a script's sim.stopSimulation / pauseSimulation in this pass
            self.apply_requests()

    # ------------------------------------------------ synchronous mode (a barrier)
    def enable_sync(self, client: str, enable: bool) -> bool:
        """``simxSynchronous(client, enable)``: ``client`` joins (True) or leaves (False) the
        set of synchronous clients; True when its leaving releases a step every remaining
        synchronous client has triggered (the caller then steps, see :meth:`trigger`).

        V-REP's rule (simExtRemoteApi ``CSimxConnections::thereWasARequestToCallTheMainScript``):
        the main script runs only when no connection with synchronous mode enabled is still
        waiting for its trigger; enabling arms the client's trigger (not yet triggered).
        """
        if enable:
            self._sync[client] = False
            self.synchronous = True
            return False
        return self.leave_sync(client)

    def leave_sync(self, client: str) -> bool:
        """A client leaves the barrier (``simxSynchronous(False)``, ``simxFinish``, lost token,
        expiry); True when that releases a step the remaining clients all triggered. With no
        synchronous client left the simulation runs asynchronously again, as on V-REP, whose
        server stops waiting for a disconnected client's trigger."""
        if self._sync.pop(client, None) is None:
            return False
        self.synchronous = bool(self._sync)
        return self._barrier_open()

    def trigger(self, client: str) -> bool:
        """``simxSynchronousTrigger`` of ``client``: marks it triggered; True when every
        synchronous client has now triggered, i.e. one step is due (the triggers are then
        re-armed). Triggering again before that step changes nothing (V-REP's flag, not a count).

        Raises:
            KeyError: ``client`` did not enable synchronous mode.
        """
        if client not in self._sync:
            raise KeyError(client)
        self._sync[client] = True
        return self._barrier_open()

    def _barrier_open(self) -> bool:
        if not self._sync or not all(self._sync.values()):
            return False
        for client in self._sync:
            self._sync[client] = False
        return True

    def is_synchronous(self, client: str) -> bool:
        """Whether ``client`` enabled synchronous mode (is part of the barrier)."""
        return client in self._sync

    def waiting_for(self) -> list[str]:
        """The synchronous clients whose trigger the next step waits for."""
        return [client for client, triggered in self._sync.items() if not triggered]

    def close(self) -> None:
        """Customization scripts' cleanup, release GL contexts and the transfer folder; idempotent."""
        self.scripts.close()
        self.vision.close()
        self.editor.close()
