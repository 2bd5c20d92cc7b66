"""``PyRep``: a simx simulation in the calling process, with PyRep's interface.

PyRep starts CoppeliaSim inside the Python process; here :meth:`PyRep.launch` makes a
:class:`simx_server.scene.simulation.Simulation` of the scene (a CoppeliaSim ``.ttt``, a MuJoCo
MJCF ``.xml``) in this process, with no server, port or display (vision sensors render with
EGL or OSMesa, ``MUJOCO_GL``). Every PyRep call goes through simx's API table
(:mod:`pyrep.backend.sim`), as the ZMQ door's do. Several ``PyRep`` instances may live in one
process, each with its own world: an object acts on the world of the instance current when it
was made (:class:`pyrep.backend.sim.OnItsWorld`); lookups and ``create`` calls act on the
instance whose method, or whose object's, was called last (``make_current`` switches
explicitly).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from simx_server.api import CallContext, Callers
from simx_server.scene.simulation import Simulation
from simx_server.sim.state import RunState
from simx_wire.protocol import SimxError

from pyrep.backend import sim
from pyrep.errors import CoppeliaSimError, PyRepError
from pyrep.objects import vision_sensor
from pyrep.objects.object import Object
from pyrep.objects.shape import Shape
from pyrep.textures.texture import Texture

#: The scene ``launch()`` loads without a scene file: a floor and a light.
EMPTY_SCENE = Path(__file__).resolve().parent / "assets" / "empty.xml"


class _InProcessContext(CallContext):
    """The context of a PyRep in this process: a remote API client's (as ZMQ's, see
    :func:`simx_server.api.client_context`) whose image calls wait for their frame, as a
    script's do, rather than answering a deferred reply."""

    @property
    def defer_renders(self) -> bool:
        return False


def _pyreps_error(exc: SimxError) -> CoppeliaSimError:
    """PyRep's error for one of simx's own (a physics blow-up, a script's error...) raised by
    the simulation's start, step or stop: a ``CoppeliaSimError``, the ``RuntimeError`` PyRep's
    backend raises when CoppeliaSim refuses a call, so that a program's ``except`` clauses
    catch it as on CoppeliaSim."""
    return CoppeliaSimError(f"simx: {exc}")


class PyRep:
    """One simulation in this process (see the module docstring)."""

    def __init__(self) -> None:
        self._simulation: Simulation | None = None
        self._ctx: Any = None
        self._remote: Any = None  # a RemoteContext when connected to a simx-server
        self.running = False

    # ----------------------------------------------------------- life
    def launch(self, scene_file: str = "", headless: bool = False, responsive_ui: bool = False,
               blocking: bool = False, write_coppeliasim_stdout_to_file: bool = False,
               verbosity: Any = None) -> None:
        """Loads ``scene_file`` (a ``.ttt``, MJCF or URDF, told by its content whatever its name:
        ``export_scene("x.ttt")``'s MJCF launches again; ``""``: an empty scene) into a new
        in-process simulation, stopped. ``headless`` and the UI options are accepted and ignored:
        simx has no window.

        Raises:
            PyRepError: the file does not exist, its content is no scene (the message says what it
                begins with), or this instance runs one already.
        """
        if self._simulation is not None:
            raise PyRepError("This PyRep instance has launched a scene already: shutdown() first")
        path = Path(scene_file) if scene_file else EMPTY_SCENE
        if not path.is_file():
            raise PyRepError(f"PyRep could not locate the scene file: {scene_file}")
        os.environ.setdefault("MUJOCO_GL", "egl")
        try:
            self._simulation = Simulation(path.resolve())
        except ValueError as exc:
            raise PyRepError(f"PyRep could not load the scene {scene_file}: {exc}") from exc
        simulation = self._simulation
        self._ctx = _InProcessContext(None, -1, simulation.signals, "pyrep", caller=Callers.CLIENTS,
                                      live=lambda: simulation)
        sim.push(self._ctx)

    def connect(self, host: str = "127.0.0.1", port: int = 23000) -> None:
        """Instead of ``launch``: drive the scene of a running ``simx-server`` over its ZMQ remote
        API (the official client, :mod:`pyrep.backend.remote`); ``start()`` puts this client in
        stepping mode, so that ``step()`` advances the server's simulation by one step.

        Raises:
            PyRepError: this instance runs a scene already, or the official client is missing.
        """
        from pyrep.backend.remote import RemoteContext

        if self._simulation is not None or self._remote is not None:
            raise PyRepError("This PyRep instance has a scene already: shutdown() first")
        self._remote = self._ctx = RemoteContext(host, port)
        sim.push(self._ctx)

    def make_current(self) -> None:
        """Makes the objects made from now on act on this instance's world."""
        sim.push(self._require())

    def _require(self) -> Any:
        if self._simulation is None and self._remote is None:
            raise PyRepError("PyRep is not launched: call launch(scene) first")
        sim.push(self._ctx)
        return self._ctx

    @property
    def simulation(self) -> Simulation:
        """The simx simulation behind this instance."""
        self._require()
        assert self._simulation is not None
        return self._simulation

    def shutdown(self) -> None:
        """Stops the simulation and frees it (renderers, scripts); connected: stops the server's
        simulation and closes the client."""
        if self._remote is not None:
            self.stop()
            sim.pop(self._ctx)
            self._remote.close()
            self._remote = self._ctx = None
            return
        if self._simulation is None:
            return
        if self._simulation.state is not RunState.STOPPED:
            self._simulation.stop()
        self._simulation.close()
        sim.pop(self._ctx)
        self._simulation = None
        self._ctx = None
        self.running = False

    def start(self) -> None:
        """Starts the simulation (child scripts' init); ``step()`` then advances it."""
        if self._remote is not None:
            self._require()
            sim.call("setStepping", True)
            sim.call("startSimulation")
            self.running = True
            return
        s = self.simulation
        try:
            s.start()
        except SimxError as exc:
            raise _pyreps_error(exc) from exc
        self.running = True

    def stop(self) -> None:
        """Stops the simulation: scripts' cleanup, the scene back to its state at start."""
        if self._remote is not None:
            self._require()
            sim.call("stopSimulation")
            self.running = False
            return
        s = self.simulation
        self.running = False
        if s.state is not RunState.STOPPED:
            try:
                s.stop()
            except SimxError as exc:
                raise _pyreps_error(exc) from exc

    def step(self) -> None:
        """One simulation step (scripts, IK groups, physics, sensors) while started; nothing
        while stopped (as PyRep, whose step only refreshes the UI then).

        Raises:
            CoppeliaSimError: (a RuntimeError) simx could not step: the physics blew up (MuJoCo
                found NaN or huge values; the simulation is then stopped and reset to the
                scene's initial state), or a script failed.
        """
        if self._remote is not None:
            self._require()
            if self.running:
                sim.call("step")
            return
        s = self.simulation
        if s.state is RunState.RUNNING:
            try:
                s.step()
            except SimxError as exc:  # a physics blow-up stops and resets the simulation
                self.running = s.state is not RunState.STOPPED
                raise _pyreps_error(exc) from exc
            pending = vision_sensor.unhandled()
            if pending:  # the step handled the sensors made since that are not explicitly handled
                pending -= {h for h in pending if not sim.call("getExplicitHandling", h)}

    def step_ui(self) -> None:
        """PyRep's UI refresh: nothing to do without a window."""
        self._require()

    def set_simulation_timestep(self, dt: float) -> None:
        """Sets the step (s).

        Raises:
            ValueError: ``dt`` not positive.
        """
        if not dt > 0:
            raise ValueError("dt must be > 0")
        self._require()
        sim.call("setFloatParam", sim.sim_floatparam_simulation_time_step, float(dt))  # type: ignore[attr-defined]

    def get_simulation_timestep(self) -> float:
        """The step (s)."""
        self._require()
        return float(sim.call("getSimulationTimeStep"))

    # --------------------------------------------------------- scene
    def script_call(self, function_name_at_script_name: str, script_handle_or_type: int,
                    ints: Any = (), floats: Any = (), strings: Any = (), bytes: str = "") -> tuple:
        """Calls ``function@scriptName`` with PyRep's four argument lists; returns the script's
        ``(ints, floats, strings, bytes)``."""
        self._require()
        result = sim.call("callScriptFunction", function_name_at_script_name, script_handle_or_type,
                          list(ints), list(floats), list(strings), bytes)
        values = list(result) if isinstance(result, (list, tuple)) else [result]
        values += [[]] * (4 - len(values))
        return tuple(values[:4])

    def set_configuration_tree(self, config_tree: bytes) -> None:
        """Restores poses and joint values saved by ``Object.get_configuration_tree``."""
        self._require()
        sim.call("setConfigurationTree", config_tree)

    def group_objects(self, objects: list[Shape]) -> Shape:
        """Groups shapes into one compound shape (the shapes themselves become part of it)."""
        self._require()
        return Shape(int(sim.call("groupShapes", [o.get_handle() for o in objects])))

    def merge_objects(self, objects: list[Shape]) -> Shape:
        """Merges shapes into one mesh shape."""
        self._require()
        return Shape(int(sim.call("groupShapes", [o.get_handle() for o in objects], True)))

    def export_scene(self, filename: str) -> None:
        """Saves the scene as it is now: MJCF (``sim.saveScene``), whatever the extension (a
        ``.ttt`` name gets MJCF too; simx writes no CoppeliaSim file)."""
        self._require()
        target = sim.program_file(filename)
        if target.lower().endswith(".xml"):
            sim.call("saveScene", target)
            return
        # saved beside it as <name>.xml, so the files it names (<name>_...) lie beside it too
        sim.call("saveScene", target + ".xml")
        os.replace(target + ".xml", target)

    def import_model(self, filename: str) -> Object:
        """Adds a model file (a ``.ttm``, MJCF or URDF, told by its content whatever its name) to
        the scene; returns its base object.

        Raises:
            CoppeliaSimError: the file cannot be loaded, or its content is no model.
        """
        self._require()
        handle = sim.call("loadModel", sim.program_file(filename))
        return Object.get_object(int(handle))

    def create_texture(self, filename: str, interpolate: bool = True, decal_mode: bool = False,
                       repeat_along_u: bool = False, repeat_along_v: bool = False) -> tuple[Shape, Texture]:
        """Loads an image as a texture, on a new plane shape; returns the plane and the texture.
        A relative ``filename`` is the program's working folder's, as in CoppeliaSim
        (:func:`pyrep.backend.sim.program_file`)."""
        self._require()
        options = (0 if interpolate else 1) | (2 if decal_mode else 0) | (4 if repeat_along_u else 0) \
            | (8 if repeat_along_v else 0)
        shape, texture_id, _ = sim.call("createTexture", sim.program_file(filename), options)
        return Shape(int(shape)), Texture(int(texture_id))

    def get_objects_in_tree(self, root_object: Any = None, *args: Any, **kwargs: Any) -> list[Object]:
        """The objects under ``root_object`` (None: the whole scene), as ``Object.get_objects_in_tree``."""
        self._require()
        return Object._get_objects_in_tree(root_object, *args, **kwargs)

    def get_collection_handle_by_name(self, collection_name: str) -> int:
        """The handle of the collection named ``collection_name``."""
        self._require()
        return int(sim.call("getCollectionHandle", collection_name))
